"""The default pipeline (despike, then auto) on a clip with known planted noise: auto reads
the planted level per joint and does the cleaning.

The truth is the sample clip smoothed by a few Lee-Shin passes (RThumb, whose real flips
are left to despike, is excluded from smoothing, noise and figures). The noise follows the
model of motionclean/filters/auto.py: ``y_i = s_i exp(e_i)`` with ``e_i`` normal of
per-component deviation ``sigma`` in log units, level ``N = 2 sqrt(3) sigma`` (RMS rotation
angle of one sample's noise); positions ``y_i = s_i + n_i`` with ``N = sqrt(3) sigma``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from helpers import ROOT, SAMPLE, run_cli

import motionclean as mc
from motionclean.core import quat
from motionclean.filters import lee_shin, lee_shin_positions
from motionclean.filters.masks import binomial

NOISE_DEG = 0.5  # planted rotation noise level N, degrees
NOISE_LENGTH = 0.05  # planted root translation noise level, length units
SMOOTHING_PASSES = 8


@pytest.fixture(scope="module")
def planted(tmp_path_factory):
    """(truth Motion, path of the noisy clip, mask of the joints with noise)."""
    motion = mc.load(SAMPLE)
    keep = np.array([n != "RThumb" for n in motion.names])
    truth_r = motion.rotations.copy()
    truth_r[:, keep] = lee_shin(truth_r[:, keep], binomial(1), SMOOTHING_PASSES)
    truth_p = lee_shin_positions(motion.translations, binomial(1), SMOOTHING_PASSES)
    truth = motion.replace(rotations=truth_r, translations=truth_p)

    rng = np.random.default_rng(20240611)
    sigma = math.radians(NOISE_DEG) / (2.0 * math.sqrt(3.0))
    noisy_r = truth_r.copy()
    e = rng.normal(scale=sigma, size=(motion.n_frames, int(keep.sum()), 3))
    noisy_r[:, keep] = quat.multiply(truth_r[:, keep], quat.exp(e))
    noisy_p = truth_p.copy()
    noisy_p[:, 0] += rng.normal(scale=NOISE_LENGTH / math.sqrt(3.0), size=(motion.n_frames, 3))
    path = tmp_path_factory.mktemp("planted") / "noisy.bvh"
    mc.save(motion.replace(rotations=noisy_r, translations=noisy_p), path)
    return truth, path, keep


def rms_error_deg(motion: mc.Motion, truth: mc.Motion, keep: np.ndarray) -> np.ndarray:
    """Per joint RMS rotation angle to the truth, degrees."""
    dev = np.degrees(quat.angle_between(motion.rotations[:, keep], truth.rotations[:, keep]))
    return np.sqrt(np.mean(dev**2, axis=0))


def clean(capsys, source, out, *options) -> mc.Motion:
    code, _, err = run_cli(capsys, "clean", source, "-o", out, "-q", *options)
    assert code == 0, err
    return mc.load(out)


def test_planted_noise_has_the_intended_level(planted):
    truth, path, keep = planted
    noisy = mc.load(path)
    # the RMS rotation angle of the planted noise is N (printing adds 1e-6 degrees)
    overall = math.sqrt(np.mean(rms_error_deg(noisy, truth, keep) ** 2))
    assert overall == pytest.approx(NOISE_DEG, rel=0.03)


def test_default_clean_estimates_the_planted_noise_and_removes_it(planted, tmp_path, capsys):
    truth, path, keep = planted
    report_path = tmp_path / "r.json"
    cleaned = clean(capsys, path, tmp_path / "c.bvh", "--report", report_path)
    report = json.loads(report_path.read_text())
    assert [step["filter"] for step in report["pipeline"]] == [
        "despike",
        "fill-gaps",
        "auto",
        "footlock",
    ]

    names = [n for n, k in zip(truth.names, keep, strict=True) if k]
    for name in names:
        note = report["joints"][name]["auto"]
        assert note["unit"] == "deg"
        assert note["noise"] == pytest.approx(NOISE_DEG, rel=0.25), name
        assert note["filter"]["mask"] != "none", name
        assert "despike" not in report["joints"][name], name  # Gaussian noise is no spike
    root = report["joints"]["Hips"]["position_auto"]
    assert root["noise"] == pytest.approx(NOISE_LENGTH, rel=0.25)

    noisy = mc.load(path)
    despiked = clean(capsys, path, tmp_path / "d.bvh", "-f", "despike")
    error_in = rms_error_deg(noisy, truth, keep)
    error_despike = rms_error_deg(despiked, truth, keep)
    error_out = rms_error_deg(cleaned, truth, keep)
    assert np.all(error_out < error_in), [
        n for n, e, i in zip(names, error_out, error_in, strict=True) if e >= i
    ]
    total = {
        name: math.sqrt(np.mean(e**2))
        for name, e in (("in", error_in), ("despike", error_despike), ("out", error_out))
    }
    assert total["out"] < 0.6 * total["in"]
    assert total["out"] < 0.6 * total["despike"]
    # most of the angular acceleration was the noise
    assert report["summary"]["noise_reduction"] > 0.5

    def position_error(m: mc.Motion) -> float:
        return float(
            np.sqrt(
                np.mean(np.sum((m.translations[:, 0] - truth.translations[:, 0]) ** 2, axis=-1))
            )
        )

    assert position_error(cleaned) < 0.6 * position_error(noisy)
    assert position_error(cleaned) < 0.6 * position_error(despiked)


def test_auto_at_strength_zero_adds_nothing_to_despike(planted, tmp_path, capsys):
    _, path, _ = planted
    clean(capsys, path, tmp_path / "d.bvh", "-f", "despike")
    clean(capsys, path, tmp_path / "z.bvh", "-f", "despike", "-f", "auto:strength=0")
    assert (tmp_path / "z.bvh").read_bytes() == (tmp_path / "d.bvh").read_bytes()
    clean(capsys, SAMPLE, tmp_path / "ds.bvh", "-f", "despike")
    clean(capsys, SAMPLE, tmp_path / "zs.bvh", "-f", "despike", "-f", "auto:strength=0")
    assert (tmp_path / "zs.bvh").read_bytes() == (tmp_path / "ds.bvh").read_bytes()
    assert (tmp_path / "ds.bvh").read_bytes() != SAMPLE.read_bytes()  # RThumb un-flipped


def test_a_lower_strength_smooths_less_not_suddenly_nothing(planted):
    """``auto:strength`` scales the noise the filters are chosen for: on the noisy sample,
    higher strengths change the clip more, lower ones less and less, and 0.65 still
    smooths (every joint had fallen under the worthwhile gain there and been left as it
    was, from 73 % of the jitter removed at 0.75)."""
    motion = mc.load(planted[1])
    despiked, _ = mc.Pipeline.from_inline(["despike"]).run(motion)
    changes = []
    for strength in (4.0, 2.0, 1.0, 0.75, 0.65, 0.5):
        out, _ = mc.Pipeline.from_inline(["despike", f"auto:strength={strength}"]).run(motion)
        angle = quat.angle_between(out.rotations, despiked.rotations)
        changes.append(float(np.sqrt(np.mean(angle**2))))
    assert all(a >= b for a, b in zip(changes, changes[1:], strict=False))
    assert changes[4] > 0.2 * changes[2] and changes[5] > 0.0


def test_a_higher_strength_smooths_noise_too_faint_for_the_default():
    """Noise of 0.05 degrees is not worth smoothing at the noise found, but strength 2 asks
    for smoothing as if it were twice as loud: joints the default leaves are smoothed."""
    motion = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")  # a clean capture
    rng = np.random.default_rng(5)
    turn = rng.normal(scale=np.radians(0.05) / np.sqrt(3.0), size=(*motion.rotations.shape[:2], 3))
    noisy = motion.replace(rotations=quat.multiply(motion.rotations, quat.exp(turn / 2.0)))
    moved = []
    for strength in (1.0, 2.0):
        out, _ = mc.Pipeline.from_inline(["despike", f"auto:strength={strength}"]).run(noisy)
        base, _ = mc.Pipeline.from_inline(["despike"]).run(noisy)
        moved.append(int((quat.angle_between(out.rotations, base.rotations).max(0) > 1e-9).sum()))
    assert moved[1] > moved[0] + 3


def test_garbage_root_frames_far_beyond_any_body_speed_are_repaired():
    """A decoder's garbage: the root 800 body heights away for 10 frames (longer than a
    spike at 120 fps) is repaired by the default on a body (100 body heights per second at
    most); a cap given in the file's units replaces it."""
    from motionclean.core import kinematics
    from motionclean.steps.pipeline import Pipeline

    clip = mc.load(SAMPLE)
    height = kinematics.body_height(clip)
    translations = clip.translations.copy()
    truth = translations[:, 0].copy()
    translations[100:110, 0] += 800.0 * height * np.array([1.0, -1.0, 1.0]) / math.sqrt(3)
    broken = clip.replace(translations=translations)
    out, _ = Pipeline.default().run(broken)
    assert np.linalg.norm(out.translations[:, 0] - truth, axis=-1).max() < 0.05 * height
    custom, _ = Pipeline.from_inline(["despike:max_units_per_s=1e9"]).run(broken)
    np.testing.assert_array_equal(custom.translations[100:110, 0], translations[100:110, 0])
