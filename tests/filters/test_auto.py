"""Automatic cleaning: noise estimate, SURE choice per joint, no over-smoothing."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest
from helpers import (
    SAMPLE,
    corpus_clip,
    low_passed_noise,
    needs_corpus,
    plant,
    run_cli,
    smooth_synthetic,
    wander_noise,
)

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.auto import (
    NEAR_LEAST_RISK,
    _smoothest_near_least,
    auto,
    auto_positions,
    candidates,
    estimate_noise,
    estimate_position_noise,
    noise_source,
)
from motionclean.filters.design import lowpass, savgol
from motionclean.filters.linear import lee_shin, lee_shin_positions
from motionclean.filters.masks import binomial


def rms_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.degrees(quat.angle_between(a, b)) ** 2)))


@pytest.fixture(scope="module")
def smooth_clip():
    """A real walk (131_02, 600 frames at 120 fps, no RThumb) smoothed by 20 B^3 passes."""
    m = mc.load(corpus_clip("131_02.bvh"))
    keep = [i for i, n in enumerate(m.names) if n != "RThumb"]
    return lee_shin(m.rotations[200:800, keep], binomial(1), 20), m.frame_time


# ----------------------------------------------------------------------------- estimate


@pytest.mark.parametrize("noise", [0.5, 2.0, 6.0])
def test_noise_estimate_recovers_planted_noise_on_synthetic_motion(noise):
    q = plant(smooth_synthetic(), noise, seed=int(noise * 10))
    est = estimate_noise(q, 1 / 120)
    assert est.shape == (6,)
    assert np.all(np.abs(est / noise - 1.0) < 0.12)


def test_noise_estimate_is_zero_for_constant_angular_velocity():
    i = np.arange(50, dtype=np.float64)[:, None, None]
    q = quat.exp(i * np.array([[0.02, -0.05, 0.01]]))
    assert estimate_noise(q, 1 / 120).max() < 1e-6
    assert estimate_noise(q[:3], 1 / 120).tolist() == [0.0]  # too short to tell


@needs_corpus
def test_noise_estimate_recovers_planted_levels_on_a_smooth_real_clip(smooth_clip):
    q, frame_time = smooth_clip
    for noise in (1.0, 3.0, 6.0):
        est = estimate_noise(plant(q, noise, seed=int(noise)), frame_time)
        assert np.all(np.abs(est / noise - 1.0) < 0.25), est
        assert abs(np.median(est) / noise - 1.0) < 0.05


def test_noise_estimate_is_per_joint_and_coordinate_invariant():
    q = plant(smooth_synthetic(joints=3), [0.5, 2.0, 5.0], seed=3)
    a = quat.normalize(np.array([0.2, 0.9, -0.3, 0.1]))
    b = quat.normalize(np.array([-0.5, 0.1, 0.6, 0.6]))
    est = estimate_noise(q, 1 / 120)
    np.testing.assert_allclose(
        est, estimate_noise(quat.multiply(a, quat.multiply(q, b)), 1 / 120), rtol=1e-9
    )
    np.testing.assert_allclose(est / np.array([0.5, 2.0, 5.0]), 1.0, atol=0.15)


def test_position_noise_estimate_recovers_planted_noise():
    t = np.arange(500)[:, None, None] / 120.0
    p = np.concatenate(
        [
            np.sin(2 * np.pi * 0.7 * t) * [3.0, 1.0, 2.0],
            np.cos(2 * np.pi * 0.3 * t) * [1.0, 4.0, 0.5],
        ],
        axis=1,
    )  # (500, 2, 3)
    noise = np.array([0.05, 0.3])  # RMS length of the noise vector
    rng = np.random.default_rng(4)
    noisy = p + rng.normal(size=p.shape) * (noise / math.sqrt(3))[:, None]
    np.testing.assert_allclose(estimate_position_noise(noisy, 1 / 120) / noise, 1.0, atol=0.12)


# ----------------------------------------------------------------------------- choice


def test_candidates_ladder():
    cands = candidates(1 / 120)
    for family in ("binomial", "savgol", "lowpass"):
        values = [value for fam, value, _ in cands if fam == family]
        assert values == sorted(set(values))
        assert np.all(np.diff(values) / np.array(values[:-1]) <= 1.5)
    assert [v for f, v, _ in cands if f == "savgol"][-1] == 120  # 1 s at 120 fps
    cutoffs = [v for f, v, _ in cands if f == "lowpass"]
    assert cutoffs[0] == 2.0 and cutoffs[-1] == 54.0  # 2 / max_seconds .. 0.45 x 120 Hz
    assert all(abs(mask.sum() - 1) < 1e-12 for _, _, mask in cands)
    assert max(mask.size // 2 for _, _, mask in cands) <= 121
    short = candidates(1 / 30, max_seconds=0.5)
    assert max(mask.size // 2 for _, _, mask in short) == 15
    assert {fam for fam, _, _ in candidates(1 / 30, families=("savgol",))} == {"savgol"}
    for bad in (
        {"frame_time": 0.0},
        {"frame_time": 0.01, "max_seconds": -1},
        {"frame_time": 0.01, "families": ("gaussian",)},
    ):
        with pytest.raises(ValueError):
            candidates(**bad)


def test_auto_adapts_per_joint_and_beats_every_fixed_setting():
    truth = np.repeat(smooth_synthetic(frames=500, joints=1, seed=7), 4, axis=1)
    levels = np.array([0.0, 1.0, 3.0, 6.0])
    noisy = plant(truth, levels, seed=8)
    values, noise, choices = auto(noisy, 1 / 120)
    assert values.shape == noisy.shape and noise.shape == (4,) and len(choices) == 4
    assert rms_deg(values[:, 0], noisy[:, 0]) < 0.01  # the clean joint stays as it is
    # More noise on the same motion: a mask that passes less white noise (sum a^2).
    table = {(family, value): mask for family, value, mask in candidates(1 / 120)}
    gains = [float(np.sum(table[c.mask, c.value] ** 2)) for c in choices[1:]]
    assert gains[0] > gains[1] >= gains[2]
    for j in (1, 2, 3):
        ours = rms_deg(values[:, j], truth[:, j])
        fixed = [rms_deg(lee_shin(noisy[:, j], binomial(1), p), truth[:, j]) for p in (1, 4, 16)]
        assert ours < min(fixed), (j, ours, fixed)


def test_expected_error_predicts_the_actual_error():
    truth = smooth_synthetic(frames=800, joints=3, seed=11)
    noisy = plant(truth, [1.0, 3.0, 6.0], seed=12)
    values, _, choices = auto(noisy, 1 / 120)
    for j, (choice, noise) in enumerate(zip(choices, (1.0, 3.0, 6.0), strict=True)):
        # SURE estimates the mean squared error; its spread is a few % of the noise power.
        actual = rms_deg(values[:, j], truth[:, j])
        assert abs(choice.expected_error**2 - actual**2) < 0.1 * noise**2
        assert actual < 0.5 * noise
        assert choice.params()["mask"] in ("binomial", "savgol", "lowpass")


def test_auto_is_coordinate_invariant():
    noisy = plant(smooth_synthetic(frames=200, joints=2, seed=2), 2.0, seed=5)
    a = quat.normalize(np.array([0.4, -0.2, 0.8, 0.1]))
    b = quat.normalize(np.array([0.1, 0.7, 0.2, -0.6]))
    out = auto(noisy, 1 / 120).values
    moved = auto(quat.multiply(a, quat.multiply(noisy, b)), 1 / 120).values
    assert rms_deg(moved, quat.multiply(a, quat.multiply(out, b))) < 1e-9


def test_strength_and_given_noise():
    truth = smooth_synthetic(frames=300, joints=2, seed=9)
    noisy = plant(truth, 3.0, seed=10)
    unchanged = auto(noisy, 1 / 120, strength=0.0)
    assert rms_deg(unchanged.values, noisy) < 1e-12
    assert [c.mask for c in unchanged.choices] == ["none", "none"]
    assert rms_deg(auto(noisy, 1 / 120, noise=0.0).values, noisy) < 1e-12
    given = auto(noisy, 1 / 120, noise=[3.0, 3.0])
    np.testing.assert_array_equal(given.noise, [3.0, 3.0])
    default, strong = auto(noisy, 1 / 120), auto(noisy, 1 / 120, strength=3.0)
    assert rms_deg(strong.values, noisy) > rms_deg(default.values, noisy)
    for bad in ({"strength": -1.0}, {"noise": -2.0}, {"strength": math.nan}):
        with pytest.raises(ValueError):
            auto(noisy, 1 / 120, **bad)


def test_auto_keeps_any_trailing_shape():
    noisy = plant(smooth_synthetic(frames=120, joints=6, seed=1), 2.0, seed=2)
    out = auto(noisy.reshape(120, 2, 3, 4), 1 / 120)
    assert out.values.shape == (120, 2, 3, 4) and out.noise.shape == (2, 3)
    assert len(out.choices) == 6
    np.testing.assert_allclose(out.values.reshape(120, 6, 4), auto(noisy, 1 / 120).values)
    single = auto(noisy[:, 0], 1 / 120)
    assert single.values.shape == (120, 4) and single.noise.shape == ()


@pytest.mark.parametrize("frames", [0, 1, 2, 3])
def test_short_clips_are_returned_unchanged(frames):
    q = quat.exp(np.random.default_rng(frames).normal(scale=0.1, size=(frames, 2, 3)))
    result = auto(q, 1 / 120)
    np.testing.assert_array_equal(result.noise, [0.0, 0.0])
    np.testing.assert_allclose(result.values, quat.make_continuous(q, axis=0))
    assert [c.mask for c in result.choices] == ["none", "none"]
    p = np.arange(frames * 3, dtype=float).reshape(frames, 1, 3) ** 2
    np.testing.assert_array_equal(auto_positions(p, 1 / 120).values, p)


def test_auto_positions_cleans_translations():
    t = np.arange(600)[:, None, None] / 120.0
    p = np.sin(2 * np.pi * np.array([0.5, 0.9])[:, None] * t + [0.0, 1.0, 2.0]) * 2.0
    rng = np.random.default_rng(6)
    noisy = p + rng.normal(scale=0.2 / math.sqrt(3), size=p.shape)
    values, noise, choices = auto_positions(noisy, 1 / 120)

    def err(x, ref=p):
        return float(np.sqrt(np.mean(np.sum((x - ref) ** 2, axis=-1))))

    np.testing.assert_allclose(noise, 0.2, rtol=0.15)
    assert err(values) < min(err(lee_shin_positions(noisy, binomial(1), n)) for n in (1, 4, 16))
    for j, choice in enumerate(choices):
        actual = err(values[:, j], p[:, j])
        assert abs(choice.expected_error**2 - actual**2) < 0.1 * 0.2**2
    assert np.array_equal(auto_positions(noisy, 1 / 120, strength=0).values, noisy)


def test_a_fixed_offset_written_with_float_rounding_is_left_as_it_is():
    """A glTF's bone translations are fixed offsets whose float32 arithmetic wobbles by a
    few millionths of their size (a fox's 7-45 units by 2e-5): no signal to clean, while a
    moving root beside them is cleaned."""
    rng = np.random.default_rng(9)
    offsets = rng.uniform(7.0, 45.0, (1, 4, 3))
    wobble = offsets * (1.0 + rng.normal(0.0, 3e-7, (500, 4, 3)))
    fixed = wobble.astype(np.float32).astype(np.float64)
    walk = np.arange(500)[:, None, None] / 120.0 * [[[1.0, 0.0, 0.5]]]
    moving = 50.0 * walk + rng.normal(0.0, 0.1, walk.shape)
    p = np.concatenate([fixed, moving], axis=1)
    values, noise, choices = auto_positions(p, 1 / 120)
    assert np.all(noise[:4] > 1e-6)  # above the absolute floor: the offsets' own size says
    assert np.array_equal(values[:, :4], fixed)
    assert choices[4].mask != "none" and not np.array_equal(values[:, 4], moving[:, 0])


def test_a_marker_sliding_on_the_floor_is_cleaned_though_its_height_never_changes():
    """A channel constant along one axis (height exactly 0: a marker sliding on the floor,
    a planar rig) is no fixed offset: its noisy x and z are smoothed."""
    t = np.arange(600) / 120.0
    truth = np.stack([30 * np.sin(t), np.zeros_like(t), 20 * np.cos(0.7 * t)], axis=-1)
    noisy = truth + np.random.default_rng(0).normal(0.0, 0.3, truth.shape) * [1.0, 0.0, 1.0]
    values, _, choices = auto_positions(noisy[:, None], 1 / 120)

    def err(x):
        return float(np.sqrt(np.mean((x - truth) ** 2)))

    assert choices[0].mask != "none"
    assert err(values[:, 0]) < err(noisy) / 2


# ----------------------------------------------------------------------------- real clip


@needs_corpus
def test_auto_leaves_a_smooth_real_clip_alone(smooth_clip):
    q, frame_time = smooth_clip
    assert rms_deg(auto(q, frame_time).values, q) < 0.05


@needs_corpus
def test_auto_beats_fixed_binomial_passes_on_a_noisy_real_clip(smooth_clip):
    q, frame_time = smooth_clip
    for noise in (1.0, 6.0):
        noisy = plant(q, noise, seed=20 + int(noise))
        ours = rms_deg(auto(noisy, frame_time).values, q)
        for passes in (1, 4, 16):
            assert ours < rms_deg(lee_shin(noisy, binomial(1), passes), q), (noise, passes)


def test_work_follows_the_clip_not_the_frame_time():
    """A 1 microsecond frame time on a short clip: masks no wider than the clip, little memory."""
    import tracemalloc

    noisy = plant(smooth_synthetic(frames=300, joints=4, seed=3), 2.0, seed=4)
    assert max(mask.size // 2 for _, _, mask in candidates(1e-6, n_frames=300)) <= 300
    tracemalloc.start()
    try:
        result = auto(noisy, 1e-6)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, peak  # the clip is 38 kB; a mask per microsecond would need GBs
    assert rms_deg(result.values, noisy) > 0.1  # the noise is still smoothed


def ar1_log_noise(shape, rho: float, noise_deg: float, seed: int) -> np.ndarray:
    """Stationary AR(1) noise in log units along axis 0, RMS rotation angle ``noise_deg``."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=shape) * math.sqrt(1 - rho**2)
    e = np.empty(shape)
    e[0] = rng.normal(size=shape[1:])
    for i in range(1, shape[0]):  # the recursion defines the process (test data only)
        e[i] = rho * e[i - 1] + u[i]
    return e * math.radians(noise_deg) / (2 * math.sqrt(3))


def test_loud_stretch_is_smoothed_more_than_the_quiet_one():
    truth = smooth_synthetic(frames=1200, joints=2, seed=21)
    level = np.where(np.arange(1200) < 600, 0.3, 5.0)[:, None]
    noisy = plant(truth, level, seed=22)
    result = auto(noisy, 1 / 120)
    quiet, loud = slice(0, 480), slice(720, 1200)  # away from the change at 5 s

    def roughness(q, part):  # RMS second difference of the rotation vectors, degrees
        r = quat.log(quat.make_continuous(q[part], axis=0))
        return float(np.degrees(np.sqrt(np.mean(np.sum(np.diff(r, 2, axis=0) ** 2, -1)))))

    kept_quiet = roughness(result.values, quiet) / roughness(noisy, quiet)
    kept_loud = roughness(result.values, loud) / roughness(noisy, loud)
    assert kept_loud < 0.5 * kept_quiet, (kept_loud, kept_quiet)
    assert rms_deg(result.values[loud], truth[loud]) < 0.4 * 5.0
    assert rms_deg(result.values[quiet], truth[quiet]) < 0.3  # the quiet part is not worse
    for choice in result.choices:  # the report says where it is loud
        assert choice.loud and 4.0 <= choice.loud[0][0] <= 6.0 and choice.loud[-1][1] >= 9.9
        assert choice.share < 1.0  # the mask changes along the clip


def test_correlated_noise_is_modelled_and_its_error_predicted():
    truth = smooth_synthetic(frames=1200, joints=3, seed=23)
    noisy = quat.multiply(truth, quat.exp(ar1_log_noise((1200, 3, 3), 0.8, 3.0, seed=24)))
    result = auto(noisy, 1 / 120)
    assert all(abs(c.rho - 0.8) <= 0.2 for c in result.choices)
    white = auto(noisy, 1 / 120, noise=result.noise)  # same level, assumed white
    for j, choice in enumerate(result.choices):
        actual = rms_deg(result.values[:, j], truth[:, j])
        assert actual < rms_deg(white.values[:, j], truth[:, j])
        assert abs(choice.expected_error**2 - actual**2) < 0.15 * 3.0**2


def test_whole_auto_is_coordinate_invariant_with_choices_that_vary_along_the_clip():
    truth = smooth_synthetic(frames=900, joints=2, seed=25)
    noisy = plant(truth, np.where(np.arange(900) < 450, 0.5, 4.0)[:, None], seed=26)
    a = quat.normalize(np.array([0.3, -0.5, 0.2, 0.7]))
    b = quat.normalize(np.array([-0.6, 0.1, 0.4, 0.3]))
    out = auto(noisy, 1 / 120)
    assert all(c.share < 1.0 for c in out.choices)
    moved = auto(quat.multiply(a, quat.multiply(noisy, b)), 1 / 120)
    assert rms_deg(moved.values, quat.multiply(a, quat.multiply(out.values, b))) < 1e-9
    np.testing.assert_allclose(moved.noise, out.noise, rtol=1e-9)


@pytest.mark.parametrize("windows", [1, 2, 7])
def test_moves_do_not_depend_on_how_many_windows_are_built_together(monkeypatch, windows):
    """Frames are moved as soon as no later window covers them; every frame gets at most
    two windows' moves, whose sum does not depend on the order: the same bits. Written
    into the input itself, frames a later group still reads are moved only after it."""
    import importlib

    auto_module = importlib.import_module("motionclean.filters.auto")
    truth = smooth_synthetic(frames=1500, joints=3, seed=31)
    noisy = plant(truth, np.where(np.arange(1500) < 700, 0.5, 3.0)[:, None], seed=32)
    whole = auto(noisy, 1 / 120)
    assert any(c.share < 1.0 for c in whole.choices)  # several masks along the clip
    monkeypatch.setattr(auto_module, "APPLY_WINDOWS", windows)
    assert np.array_equal(auto(noisy, 1 / 120).values, whole.values)
    assert np.array_equal(auto(noisy.copy(), 1 / 120, overwrite=True).values, whole.values)


def test_overwrite_writes_into_the_input_and_otherwise_leaves_it():
    noisy = plant(smooth_synthetic(frames=600, joints=2, seed=33), 2.0, seed=34)
    kept = noisy.copy()
    fresh = auto(noisy, 1 / 120)
    assert np.array_equal(noisy, kept) and not np.shares_memory(fresh.values, noisy)
    inplace = auto(noisy, 1 / 120, overwrite=True)
    assert np.shares_memory(inplace.values, noisy)
    assert np.array_equal(inplace.values, fresh.values) and not np.array_equal(noisy, kept)
    p = np.cumsum(np.random.default_rng(35).normal(size=(600, 2, 3)), axis=0)
    given = p.copy()
    moved = auto_positions(p, 1 / 120)
    assert np.array_equal(p, given)
    assert np.array_equal(auto_positions(p, 1 / 120, overwrite=True).values, moved.values)
    assert np.array_equal(p, moved.values)
    # a read-only array is never written, overwrite or not (numpy's 'assignment
    # destination is read-only' had come out of the filter's depths)
    frozen = kept.copy()
    frozen.setflags(write=False)
    result = auto(frozen, 1 / 120, overwrite=True)
    assert np.array_equal(result.values, fresh.values) and np.array_equal(frozen, kept)


def test_auto_cleans_band_limited_noise_it_would_leave_without_the_band_limited_model(
    monkeypatch,
):

    # real motion (131_02, the joints without flips): the band-limited term is kept only
    # where the clip's motion slope is flatter than clean motion's (-1.7), which noise
    # low-passed at 6 Hz makes it (pure sinusoids below 1.5 Hz would not: their spectrum
    # is all the noise's cliff from 2 Hz up)
    motion = mc.load(corpus_clip("131_02.bvh"))
    q = quat.make_continuous(motion.rotations, axis=0)
    steps = np.degrees(quat.angle_between(q[:-1], q[1:])).max(axis=0)
    truth = q[:, (steps < 30.0) & (np.array(motion.names) != "RThumb")]
    e = low_passed_noise(truth.shape[0], truth.shape[1], 6.0, 3.0, seed=66)
    noisy = quat.multiply(truth, quat.exp(e))
    with_model = auto(noisy, motion.frame_time)
    assert with_model.choices[0].band_hz is not None
    assert with_model.choices[0].model == "optical"
    assert rms_deg(with_model.values, truth) < 0.8 * rms_deg(noisy, truth)
    np.testing.assert_allclose(np.median(with_model.noise), 3.0, rtol=0.35)  # counted
    monkeypatch.setattr("motionclean.filters.noise.fit_band_limited", lambda *a: None)
    without = auto(noisy, motion.frame_time)
    assert rms_deg(with_model.values, truth) < 0.85 * rms_deg(without.values, truth)


def test_a_given_noise_beyond_any_clip_picks_the_strongest_without_warnings(tmp_path, capsys):
    import warnings

    outs = {}
    for value in ("1e10", "1e308"):
        outs[value] = tmp_path / f"{value}.bvh"
        step = f"auto:position_noise={value}"
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", outs[value], "-f", step, "-q")
        assert (code, err) == (0, "")
    assert outs["1e10"].read_bytes() == outs["1e308"].read_bytes()


# ----------------------------------------------------------------------------- sources


def test_the_source_is_found_from_the_motion_slope_unless_given():
    assert noise_source("auto", -0.5) == "markerless"  # flat: a wander over the band
    assert noise_source("auto", -1.5) == "optical"  # falls like clean motion
    assert noise_source("auto", math.nan) == "optical"  # the clip cannot tell
    assert noise_source("video", -3.0) == "markerless"
    assert noise_source("markerless") == "markerless"
    assert noise_source("optical", 0.5) == "optical"
    assert noise_source("inertial", 0.5) == "optical"
    with pytest.raises(ValueError, match="source must be one of"):
        auto(smooth_synthetic(200, 2), 1 / 60, source="kinect")


@pytest.mark.parametrize("step", [1, 2, 4, 5])
def test_a_clean_capture_is_taken_for_optical_at_any_rate(step):
    """131_02 at 120, 60, 30 and 24 fps: found optical from the clip, and all but left alone
    (on branch realnoise the frame rate made it markerless at 60 fps and below: 3.5-4.5
    degrees RMS changed)."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    keep = [i for i, n in enumerate(motion.names) if n != "RThumb"]
    q = quat.make_continuous(motion.rotations[::step, keep], axis=0)
    result = auto(q, motion.frame_time * step)
    assert {c.model for c in result.choices} == {"optical"}
    assert result.choices[0].motion_slope < -1.3
    assert rms_deg(result.values, q) < 0.2


@needs_corpus
@pytest.mark.parametrize("step", [1, 2, 4, 5])
def test_a_clean_captures_own_jitter_is_left_as_captured(step):
    """131_02 at 120, 60, 30 and 24 fps: no filter promises to take off a tenth of its own
    jitter, so every joint comes back bit for bit (a light low-pass on toes, wrists and
    shoulders changed the accelerations by up to 1.3 % without it); the same clip with half
    a degree of planted noise is cleaned, each filtered joint promising at least that tenth."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    keep = [i for i, n in enumerate(motion.names) if n != "RThumb"]
    q = quat.make_continuous(motion.rotations[::step, keep], axis=0)
    frame_time = motion.frame_time * step
    assert np.array_equal(auto(q, frame_time).values, q)
    noisy = plant(q, 0.5, seed=step)
    result = auto(noisy, frame_time)
    filtered = [c for c in result.choices if c.mask != "none"]
    assert len(filtered) > len(keep) // 2
    assert rms_deg(result.values, q) < rms_deg(noisy, q)
    for choice, level in zip(result.choices, result.noise, strict=True):
        if choice.mask != "none":
            assert choice.expected_error <= 0.9 * level + 1e-12


@pytest.fixture(scope="module")
def wandering():
    """(truth, noisy): slow motion at 60 fps with a markerless-like wander below 6 Hz (white
    displacements from about 5 Hz up)."""
    truth = smooth_synthetic(frames=1200, joints=6, seed=11)
    e = wander_noise(1200, 6, 6.0, 2.0, seed=11, rho=0.5)
    return truth, quat.multiply(truth, quat.exp(e))


def test_the_markerless_model_cleans_a_wander_the_optical_model_leaves(wandering):
    truth, noisy = wandering
    before = rms_deg(noisy, truth)
    markerless = auto(noisy, 1 / 60, source="markerless")
    optical = auto(noisy, 1 / 60, source="optical")
    hindsight = min(rms_deg(lee_shin(noisy, lowpass(c, 60.0)), truth) for c in (1, 1.5, 2, 3))
    assert rms_deg(markerless.values, truth) < min(0.65 * before, 1.1 * hindsight)
    assert rms_deg(optical.values, truth) > 0.85 * before
    assert all(c.model == "markerless" and c.wander > 0.5 for c in markerless.choices)
    assert all(c.model == "optical" and c.wander == 0 for c in optical.choices)
    # one choice per column over the clip, and its error predicted within a factor 2
    assert all(c.share == 1.0 for c in markerless.choices)
    actual = np.sqrt(np.mean(np.degrees(quat.angle_between(markerless.values, truth)) ** 2, 0))
    expected = np.array([c.expected_error for c in markerless.choices])
    np.testing.assert_array_less(expected, 2.0 * actual)
    np.testing.assert_array_less(actual, 2.0 * expected)


def test_the_markerless_model_is_coordinate_invariant(wandering):
    _, noisy = wandering
    turn = quat.exp(np.array([0.3, -0.2, 0.5]))
    a = auto(quat.multiply(turn, noisy), 1 / 60, source="markerless").values
    b = quat.multiply(turn, auto(noisy, 1 / 60, source="markerless").values)
    assert np.degrees(quat.angle_between(a, b)).max() < 1e-6


def test_the_markerless_model_leaves_smooth_motion_alone():
    truth = smooth_synthetic(frames=1200, joints=6, seed=12)
    assert rms_deg(auto(truth, 1 / 60, source="markerless").values, truth) < 0.05


def test_the_source_found_and_said_is_the_one_auto_uses_on_a_short_clip():
    """Two seconds of a markerless-like wander read flat (slope above the limit), but are
    too short to fit the wandering noise: auto keeps the optical model, and found_source
    (what `report IN` prints) had said markerless; both now say optical, and why."""
    import importlib

    found = importlib.import_module("motionclean.filters.auto")
    truth = smooth_synthetic(frames=120, joints=6, seed=11)
    noisy = quat.multiply(truth, quat.exp(wander_noise(120, 6, 10.0, 4.0, seed=11, rho=0.5)))
    result = auto(noisy, 1 / 60)
    model, slope = found.found_source(noisy, 1 / 60)[:2]
    assert slope > found.MARKERLESS_SLOPE  # the premise: flat
    assert model == result.choices[0].model == "optical"
    assert "too short" in found.describe_source(model, "auto", slope)
    given = auto(noisy, 1 / 60, source="video").choices[0].model
    said = found.describe_source(given, "video", slope)
    assert given == "optical" and "source=video was given, but the clip is too short" in said


@pytest.mark.parametrize("seconds", [4, 6])
def test_a_flat_clip_under_five_seconds_is_not_taken_for_markerless_unasked(seconds):
    """A wander read flat on a clip of 4 s, long enough to fit it (a clean 2.4 s run at 30
    fps had read flat by chance and been smoothed by 2.7 degrees RMS): `source=auto` keeps
    the optical model under MARKERLESS_MIN_SECONDS and says why; from 5 s on it takes the
    markerless one; given, the source is used at 4 s."""
    import importlib

    found = importlib.import_module("motionclean.filters.auto")
    frames = 60 * seconds
    truth = smooth_synthetic(frames=frames, joints=6, seed=13)
    noisy = quat.multiply(truth, quat.exp(wander_noise(frames, 6, 10.0, 4.0, seed=13, rho=0.5)))
    model, slope = found.found_source(noisy, 1 / 60)[:2]
    assert slope > found.MARKERLESS_SLOPE  # the premise: flat
    expected = "optical" if seconds < found.MARKERLESS_MIN_SECONDS else "markerless"
    assert model == auto(noisy, 1 / 60).choices[0].model == expected
    if expected == "optical":
        said = found.describe_source(model, "auto", slope, seconds)
        assert f"too short ({seconds:.3g} s, under 5 s) to tell that from motion" in said
        assert auto(noisy, 1 / 60, source="video").choices[0].model == "markerless"


def test_five_seconds_written_with_a_rounded_frame_time_are_five_seconds():
    """600 frames of "Frame Time: .0083333" are 4.99998 s by the header's rounding: long
    enough for a flat clip to be taken for markerless (it had been kept optical as "too
    short (5 s, under 5 s)")."""
    import importlib

    found = importlib.import_module("motionclean.filters.auto")
    truth = smooth_synthetic(frames=600, joints=6, seed=13)
    noisy = quat.multiply(truth, quat.exp(wander_noise(600, 6, 10.0, 4.0, seed=13, rho=0.5)))
    model, slope = found.found_source(noisy, 0.0083333)[:2]
    assert slope > found.MARKERLESS_SLOPE and model == "markerless"


def test_the_markerless_choice_is_the_smoothest_of_the_candidates_near_the_least_risk():
    """Under the markerless model every candidate's expected error may lie within a few
    percent of the others' (the noise wanders where no filter takes it out): of those
    within NEAR_LEAST_RISK of the least, the one passing the least white noise is chosen
    (a video estimate's knees had been given a near pass-through); none further off."""
    masks = [binomial(1), binomial(4), binomial(16)]  # lighter to heavier
    least = 1.0
    near = least * (1.0 + 0.9 * NEAR_LEAST_RISK)
    far = least * (1.0 + 1.1 * NEAR_LEAST_RISK)
    risk = np.array(
        [
            [1.2, 1.2, 1.2],  # the identity
            [least, least, near],  # binomial(1)
            [near, near, least],  # binomial(4)
            [near, far, far],  # binomial(16)
        ]
    )
    assert _smoothest_near_least(risk, masks).tolist() == [3, 2, 2]
    gains = [np.sum(m**2) for m in masks]
    assert gains[0] > gains[1] > gains[2]  # (the premise: heavier masks pass less noise)


# ----------------------------------------------------------------------------- held still


def still_and_moving(frames: int, noise_deg: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(truth, noisy) ``(frames, 3, 4)``: a joint that never turns (a dummy root's
    rotation, held at an arbitrary pose), a slow joint and a joint turning by one noise
    level at 0.3 Hz, each with white noise of ``noise_deg`` at 30 fps."""
    rng = np.random.default_rng(seed)
    fixed = np.broadcast_to(quat.normalize(rng.normal(size=4)), (frames, 1, 4))
    moving = smooth_synthetic(frames * 4, joints=1, seed=seed)[::4]  # (its 120 fps, every 4th)
    t = np.arange(frames)[:, None] / 30.0
    axis = np.array([0.0, 0.6, 0.8])
    slight = quat.exp(math.radians(noise_deg) / 2 * np.sin(2 * np.pi * 0.3 * t)[..., None] * axis)
    truth = np.concatenate([fixed, moving, slight], axis=1)
    return truth, plant(truth, noise_deg, seed + 1)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_joint_whose_motion_the_noise_hides_is_held_at_its_mean(seed):
    """A joint that never turns, with 3 degrees of white noise (a dummy root far from the
    body, a rig's fixed joint): its mean over the clip is far closer to the truth than any
    mask, and it is held there, the same rotation on every frame; the joints that move are
    filtered as masks filter them, even one turning by no more than the noise."""
    truth, noisy = still_and_moving(300, 3.0, seed)
    values, _, choices = auto(noisy, 1 / 30)
    assert [c.mask for c in choices][0] == "mean"
    assert all(c.mask in ("binomial", "savgol", "lowpass") for c in choices[1:])
    assert np.degrees(quat.angle_between(values[1:, 0], values[:-1, 0])).max() < 1e-9
    held = rms_deg(values[:, 0], truth[:, 0])
    assert held < 0.4  # the mean of 300 samples of 3 degrees: about 0.17
    widest = max(h for family, h, _ in candidates(1 / 30) if family == "savgol")
    masked = rms_deg(lee_shin(noisy[:, :1], savgol(widest, 2), 1), truth[:, :1])
    assert held < 0.5 * masked
    # the note's expected error is the mean's (its motion estimate is noisy: 0 here)
    assert abs(choices[0].expected_error ** 2 - held**2) < 0.1 * 3.0**2
    assert choices[0].params() == {"mask": "mean"} and choices[0].share == 1.0
    # asked to smooth more, it is held all the more (its risk is estimated as the masks')
    for strength in (1.5, 2.0):
        assert auto(noisy, 1 / 30, strength=strength).choices[0].mask == "mean"


def test_a_clip_under_four_seconds_holds_no_joint_at_its_mean():
    """Over a short clip the scatter about the mean is read too roughly to tell a joint
    that never turns from one that turns by the noise's size: the masks filter it."""
    _, noisy = still_and_moving(300, 3.0, 1)
    assert auto(noisy[:120], 1 / 30).choices[0].mask == "mean"  # 4 s
    assert auto(noisy[:119], 1 / 30).choices[0].mask in ("binomial", "savgol", "lowpass")


def test_holding_at_the_mean_is_coordinate_invariant_and_keeps_the_signs():
    _, noisy = still_and_moving(300, 3.0, 4)
    a = quat.normalize(np.array([0.4, -0.2, 0.8, 0.1]))
    b = quat.normalize(np.array([0.1, 0.7, 0.2, -0.6]))
    out = auto(noisy, 1 / 30)
    moved = auto(quat.multiply(a, quat.multiply(noisy, b)), 1 / 30)
    assert [c.mask for c in moved.choices] == [c.mask for c in out.choices]
    assert out.choices[0].mask == "mean"
    assert rms_deg(moved.values, quat.multiply(a, quat.multiply(out.values, b))) < 1e-9
    # each held frame on its input sample's hemisphere, whichever the input's is
    for q in (noisy, -noisy):
        held = auto(q, 1 / 30).values[:, 0]
        assert np.all(np.sum(held * q[:, 0], axis=-1) > 0.0)


@pytest.mark.parametrize("rotations", [True, False])
def test_the_means_summed_in_blocks_are_the_clips(monkeypatch, rotations):
    """The mean and its risk summed a few frames at a time (blocks of 1-7 frames, the
    step out of each block counted once) are those of the whole clip at once."""
    module = importlib.import_module("motionclean.filters.auto")  # (not the function)
    rng = np.random.default_rng(3)
    x = rng.normal(size=(23, 3, 4 if rotations else 3))
    if rotations:
        x = quat.continuous(quat.normalize(x * 0.1 + [1.0, 0.0, 0.0, 0.0]))
    whole = module._clip_means(x, rotations, None, 1.0)
    for rows in (1, 2, 7):
        monkeypatch.setattr(module, "APPLY_BLOCK", rows * x.shape[1] * x.shape[-1])
        parts = module._clip_means(x, rotations, None, 1.0)
        np.testing.assert_allclose(parts[0], whole[0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(parts[1], whole[1], rtol=0, atol=1e-12)
    if not rotations:  # against the formula written out
        noise = np.mean(np.sum(np.diff(x, axis=0) ** 2, axis=-1), axis=0) / 2
        spread = np.mean(np.sum((x - x.mean(axis=0)) ** 2, axis=-1), axis=0)
        np.testing.assert_allclose(whole[1], spread - noise + 2 * noise / 23, atol=1e-12)


def test_noise_that_wanders_is_not_taken_for_a_still_joint():
    """The noise is read from the steps between frames, which a wander (AR(1), rho 0.8)
    makes small: its slow swings read as motion, and the masks filter it."""
    frames = 400
    truth = np.broadcast_to(quat.normalize(np.array([0.9, 0.1, -0.3, 0.2])), (frames, 1, 4))
    rng = np.random.default_rng(5)
    e = np.zeros((frames, 1, 3))
    for i in range(1, frames):
        e[i] = 0.8 * e[i - 1] + rng.normal(scale=0.02, size=(1, 3))
    out = auto(quat.multiply(truth, quat.exp(e)), 1 / 30)
    assert out.choices[0].mask in ("binomial", "savgol", "lowpass")


def test_a_still_position_channel_is_held_at_its_mean():
    """A translation that never moves (a joint's position channel carrying its offset) with
    noise: held at its mean; a moving root beside it is filtered."""
    rng = np.random.default_rng(8)
    frames = 400
    still = np.broadcast_to([[[12.0, 94.0, -450.0]]], (frames, 1, 3))
    t = np.arange(frames)[:, None, None] / 30.0
    walk = np.concatenate([40.0 * t, 2.0 * np.sin(2 * np.pi * 1.8 * t), 0.0 * t], axis=-1)
    truth = np.concatenate([still, walk], axis=1)
    noisy = truth + rng.normal(scale=0.3, size=truth.shape)
    values, _, choices = auto_positions(noisy, 1 / 30)
    assert [c.mask for c in choices][0] == "mean" and choices[1].mask != "mean"
    assert np.ptp(values[:, 0], axis=0).max() == 0.0
    assert np.linalg.norm(values[0, 0] - still[0, 0]) < 0.1  # 0.3 * sqrt(3 / 400) = 0.026
