"""Lone outliers: single samples leaving a joint's noise and coming straight back are found
against the noise level, impacts and noise are not, the same on a turned or reversed clip;
in the default pipeline auto takes them out before smoothing and says so."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import ROOT, corpus_clip, degrees_between, every, plant, run_cli, smooth_synthetic

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.outliers import LONE_SIGMAS, lone_outliers, replaced

NOISE_DEG = 2.0
#: One-frame spikes on the sample's legs: under despike's jump threshold at that noise
#: (most of them), over the lone outliers' (12.2 degrees from the chord).
SPIKE_DEG = 18.0


def _spiked(seed: int, spike_deg: float = 25.0):
    """Slow motion with 2 degrees of noise and one-frame spikes of ``spike_deg`` about a
    random axis on every joint, 40 frames apart (frames, joints)."""
    rng = np.random.default_rng(seed)
    truth = smooth_synthetic(600, 4, seed)
    noisy = plant(truth, NOISE_DEG, seed)
    frames = np.arange(20, 580, 40)
    axis = rng.normal(size=(frames.size, 4, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    kick = quat.exp(axis * np.radians(spike_deg) / 2.0)
    noisy[frames] = quat.multiply(noisy[frames], kick)
    spikes = np.zeros(noisy.shape[:2], dtype=bool)
    spikes[frames] = True
    return truth, noisy, spikes


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_spikes_of_a_noisy_clip_are_found_and_its_noise_is_not(seed):
    _, noisy, spikes = _spiked(seed)
    found = lone_outliers(noisy, np.full(4, NOISE_DEG))
    assert np.array_equal(found, spikes)
    # spikes within the noise's reach are left to the smoothing
    _, small, _ = _spiked(seed, spike_deg=LONE_SIGMAS * NOISE_DEG * 0.5)
    assert not lone_outliers(small, np.full(4, NOISE_DEG)).any()


def test_an_impact_is_no_outlier():
    """A turn that stops dead at one frame (a foot striking) leaves its neighbours on
    their chords: however large, no lone outlier; nor is a column without noise judged."""
    angle = np.r_[np.linspace(0.0, 1.2, 60), np.full(60, 1.2)]  # radians, stopping at 59
    q = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), angle)[:, None]
    assert not lone_outliers(q, np.array([0.01])).any()
    q[30] = quat.multiply(q[30], quat.from_axis_angle(np.array([1.0, 0, 0]), 0.5))
    assert lone_outliers(q, np.array([0.01]))[30, 0]
    assert not lone_outliers(q, np.array([0.0])).any()


def test_the_same_outliers_on_a_turned_and_a_reversed_clip():
    _, noisy, spikes = _spiked(3)
    turn = quat.from_axis_angle(np.array([0.3, 0.9, -0.2]) / np.linalg.norm([0.3, 0.9, -0.2]), 2.0)
    noise = np.full(4, NOISE_DEG)
    for copy in (quat.multiply(turn, noisy), quat.multiply(noisy, turn)):
        assert np.array_equal(lone_outliers(copy, noise), spikes)
    assert np.array_equal(lone_outliers(noisy[::-1], noise)[::-1], spikes)


def test_unknown_samples_and_two_in_a_row_are_not_judged():
    """A spike beside a dropout is not judged (the chord there is a bridge); a spike held
    two frames is no lone sample."""
    _, noisy, spikes = _spiked(4)
    first = int(np.flatnonzero(spikes[:, 0])[0])
    known = np.ones(spikes.shape, dtype=bool)
    known[first + 2, 0] = False  # (a dropout two frames on: the chord there is a bridge)
    found = lone_outliers(noisy, np.full(4, NOISE_DEG), known)
    assert not found[first, 0] and found[first, 1]
    twice = noisy.copy()
    twice[first + 1, 1] = twice[first, 1]
    assert not lone_outliers(twice, np.full(4, NOISE_DEG))[first : first + 2, 1].any()


def test_a_replaced_outlier_lies_on_its_neighbours_chord():
    _, noisy, spikes = _spiked(5)
    out = replaced(noisy, spikes)
    f, c = np.nonzero(spikes)
    np.testing.assert_allclose(
        degrees_between(out[f, c], noisy[f - 1, c]), degrees_between(out[f, c], noisy[f + 1, c])
    )
    np.testing.assert_array_equal(out[~spikes], noisy[~spikes])


def test_the_default_takes_lone_outliers_out_before_smoothing(tmp_path, capsys):
    """The sample's clean cut with 2 degrees of noise and 18-degree one-frame spikes on
    its legs: each spike is repaired, by despike or by auto (whose notes list it), the
    verdict counts them with the spikes, and the spike frames end within the noise of the
    capture (smoothed in, a binomial k=1 had kept half of each)."""
    clip = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    legs = [clip.names.index(n) for n in ("LeftHip", "LeftKnee", "RightHip", "RightKnee")]
    rng = np.random.default_rng(7)
    noisy = plant(clip.rotations, NOISE_DEG, 7)
    frames = np.arange(30, clip.n_frames - 30, 50)
    axis = rng.normal(size=(frames.size, len(legs), 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    kick = quat.exp(axis * np.radians(SPIKE_DEG) / 2.0)
    noisy[frames[:, None], legs] = quat.multiply(noisy[frames[:, None], legs], kick)
    source, target, page = tmp_path / "spiked.bvh", tmp_path / "out.bvh", tmp_path / "r.json"
    mc.save(clip.replace(rotations=noisy, source_values=None), source)
    code, _, _ = run_cli(capsys, "clean", source, "-o", target, "--report", page)
    assert code == 0
    report = json.loads(page.read_text())
    lone = 0
    for joint in legs:
        notes = report["joints"][clip.names[joint]]
        runs = (notes.get("despike") or {}).get("interpolated", []) + notes["auto"].get(
            "outliers", []
        )
        assert all(any(a <= f < b for a, b in runs) for f in frames), clip.names[joint]
        lone += len(notes["auto"].get("outliers", []))
    assert lone > 0
    repairs = report["verdict"]["repairs"]
    assert sum(repairs[clip.names[j]]["spikes"] for j in legs) >= frames.size * len(legs)
    cleaned = mc.load(target)
    error = degrees_between(
        cleaned.rotations[frames[:, None], legs], clip.rotations[frames[:, None], legs]
    )
    assert error.max() < 2.5 * NOISE_DEG


def test_a_good_sample_between_two_outliers_is_none():
    """Spikes at two frames with one good sample between: the good sample's chord runs
    through both spikes and its neighbours' deviations point back by all of its own, not
    half; it had been put onto the spikes' chord, 20 degrees off."""
    twin = plant(smooth_synthetic(600, 4, 6), NOISE_DEG, 6)
    kick = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(25.0))
    twin[[100, 102], 0] = quat.multiply(twin[[100, 102], 0], kick)
    found = lone_outliers(twin, np.full(4, NOISE_DEG))
    assert not found[99:104, 0].any()


def test_the_default_keeps_big_outliers_out_of_a_joint_it_then_leaves_alone():
    """CMU 131_01 at 30 fps with a degree of noise and 20-degree one-frame spikes on four
    joints (600 deg/s: despike's floor): with them in, auto reads noise and filters; without
    them it leaves joints unfiltered, and had put every spike it found back (17.6 degrees
    left at LeftShoulder's). Now those over KEPT_BELOW_DEG stay repaired: every spike frame
    ends within a few degrees of the capture."""
    clip = every(mc.load(corpus_clip("131_01.bvh")), 4)
    joints = [clip.names.index(n) for n in ("LeftShoulder", "RightKnee", "Neck", "Hips")]
    spiked = plant(clip.rotations, 1.0, 9)
    frames = np.array([60, 150, 240])
    kick = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(20.0))
    spiked[frames[:, None], joints] = quat.multiply(spiked[frames[:, None], joints], kick)
    out, _ = mc.Pipeline.from_inline(["despike", "fill-gaps", "auto"]).run(
        clip.replace(rotations=spiked, source_values=None)
    )
    at = (frames[:, None], joints)
    assert degrees_between(out.rotations[at], clip.rotations[at]).max() < 5.0


def test_the_lone_outliers_of_every_take_are_noted_and_listed(tmp_path, capsys):
    """Two takes joined end to end (the second, shorter, its root turned and moved) with
    14-degree spikes on its right knee, one under despike's jump threshold: auto's outlier
    had been dropped from the joint's note, which took the longest take's; now noted, and
    listed with the repairs in the terminal."""
    clip = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    noisy = plant(clip.rotations, NOISE_DEG, 8)
    knee = clip.names.index("RightKnee")
    kick = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(14.0))
    turn = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.radians(170.0))
    first, second = noisy[:150], noisy[200:300].copy()
    second[:, 0] = quat.multiply(turn, second[:, 0])
    second[[40, 70], knee] = quat.multiply(second[[40, 70], knee], kick)
    moved = clip.translations[200:300].copy()
    moved[:, 0, 0] += 50.0
    joined = clip.replace(
        rotations=np.concatenate([first, second]),
        translations=np.concatenate([clip.translations[:150], moved]),
        source_values=None,
    )
    source, page = tmp_path / "two.bvh", tmp_path / "r.json"
    mc.save(joined, source)
    code, out, _ = run_cli(capsys, "clean", source, "-o", tmp_path / "c.bvh", "--report", page)
    assert code == 0 and "takes: 2 joined end to end, the second at frame 150" in out
    note = json.loads(page.read_text())["joints"]["RightKnee"]
    assert [190, 191] in note["auto"]["outliers"]
    assert any(
        line.startswith("repaired RightKnee") and "took out 1 lone outlier: 190" in line
        for line in out.splitlines()
    )


def test_a_long_clip_is_judged_a_block_at_a_time_as_at_once(monkeypatch):
    """Blocks of 7 frames (their chords read across the cuts) find what one block finds;
    columns without noise are not read."""
    from motionclean.filters import outliers

    _, noisy, spikes = _spiked(10)
    noise = np.array([NOISE_DEG, 0.0, NOISE_DEG, NOISE_DEG])
    whole = lone_outliers(noisy, noise)
    monkeypatch.setattr(outliers, "BLOCK_FRAMES", 7)
    np.testing.assert_array_equal(lone_outliers(noisy, noise), whole)
    assert np.array_equal(whole[:, [0, 2, 3]], spikes[:, [0, 2, 3]]) and not whole[:, 1].any()


def test_the_chords_give_the_noise_that_spikes_do_not_raise():
    """The median chord deviation over 2 s stretches gives the noise within half of it above
    (noise of three degrees of freedom; within a quarter for one), spikes or not; where a
    joint's spectral estimate is raised by its own spikes (here five times the noise),
    judging against the smaller of the two finds them."""
    from motionclean.filters.outliers import chord_noise

    truth, noisy, spikes = _spiked(11)
    level = chord_noise(noisy, 1.0 / 120.0)
    assert np.all((level > NOISE_DEG) & (level < 1.5 * NOISE_DEG)), level
    about_z = quat.from_axis_angle(
        np.array([0.0, 0.0, 1.0]),
        np.random.default_rng(1).normal(size=(600, 4)) * np.radians(NOISE_DEG),
    )
    assert np.all(
        np.abs(chord_noise(quat.multiply(truth, about_z), 1.0 / 120.0) / NOISE_DEG - 1.0) < 0.25
    )
    raised = np.full(4, 5.0 * NOISE_DEG)
    assert not lone_outliers(noisy, raised).any()
    assert np.array_equal(lone_outliers(noisy, np.minimum(raised, level)), spikes)


def test_a_joint_auto_leaves_as_captured_keeps_its_glitches_whatever_the_rounding(tmp_path):
    """CMU 131_01 at 60 fps cut to 158 frames: every joint's windows choose no filter, and
    the sum of their tapers over the frames is 1 - 2e-16, so the share of none had read
    0.9999999999999998: "filtered somewhere", and auto took lone outliers out of joints it
    left as captured (three samples of a Bandai Namco run's forearm moved by 3-7
    degrees). The share is 1 exactly, and an 8-degree glitch planted on such a joint
    stays as captured (README: a clean capture's own glitches stay)."""
    clip = every(mc.load(corpus_clip("131_01.bvh")), 2).at_frames(slice(0, 158))
    result = mc.filters.auto(clip.rotations, clip.frame_time)
    left = [c for c in result.choices if c.mask == "none"]
    assert left and all(c.share == 1.0 for c in left)
    knee = clip.names.index("LeftKnee")
    assert result.choices[knee].mask == "none"
    glitched = clip.rotations.copy()
    glitched[80, knee] = quat.multiply(
        glitched[80, knee], quat.from_axis_angle([0.0, 0.0, 1.0], np.radians(8.0))
    )
    source = clip.replace(rotations=glitched, source_values=None)
    cleaned, logs = mc.Pipeline.from_inline(["auto"]).run(source)
    assert not any(n.get("outliers") for log in logs for n in log.notes.values())
    assert degrees_between(cleaned.rotations[:, knee], glitched[:, knee]).max() < 1e-9


def test_a_still_joint_and_a_joint_whose_noise_hides_are_told_apart(tmp_path, capsys):
    """The default on CMU 131_02 at 30 fps with 1.5 degrees of noise on the right wrist: a
    joint that holds one value throughout is "still throughout" (JSON `still`), and a
    moving joint whose noise reads 0 says no noise is measurable beside its motion, not
    "estimated noise 0 deg ... expected error < 0.01 deg"."""
    clip = every(mc.load(corpus_clip("131_02.bvh")), 4)
    wrist = clip.names.index("RightWrist")
    q = clip.rotations.copy()
    q[:, wrist] = plant(q[:, wrist][:, None], 1.5, 3)[:, 0]
    source = tmp_path / "w.bvh"
    mc.save(clip.replace(rotations=q, source_values=None), source)
    code, _, err = run_cli(
        capsys, "clean", source, "-o", tmp_path / "c.bvh", "--report", tmp_path / "r.json"
    )
    assert code == 0, err
    joints = json.loads((tmp_path / "r.json").read_text())["joints"]
    still = [name for name, joint in joints.items() if joint["auto"].get("still")]
    assert "lhand" in still and "RightWrist" not in still
    assert all(np.ptp(clip.rotations[:, clip.names.index(n)], axis=0).max() == 0 for n in still)
    hidden = [n for n, j in joints.items() if j["auto"]["noise"] == 0 and n not in still]
    page = tmp_path / "p.html"
    code, _, err = run_cli(capsys, "clean", source, "-o", tmp_path / "c.bvh", "--report", page)
    text = page.read_text()
    assert code == 0 and "estimated noise 0 deg" not in text
    assert hidden and "no noise measurable beside its motion" in text


def test_a_still_joint_is_told_as_still_under_the_markerless_model_too():
    """A video estimate's toe held fixed, cleaned with `source=video`: its note says still
    (it had read "estimated noise 8.11e-34 deg, 8.11e-34 of it a wander ...")."""
    from motionclean.steps.auto import STEP

    clip = mc.load(ROOT / "sample_data" / "131_02_noisy.bvh")
    toe = clip.names.index("LeftToe")
    q = clip.rotations.copy()
    q[:, toe] = q[0, toe]
    _, logs = mc.Pipeline.from_inline(["auto:source=video"]).run(
        clip.replace(rotations=q, source_values=None)
    )
    note = logs[0].notes["LeftToe"]["auto"]
    assert note["still"] and note["model"] == "markerless"
    assert STEP.format_note(note, False) == "still throughout: nothing to filter"
