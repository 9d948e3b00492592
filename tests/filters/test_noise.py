"""The noise model: AR(1) shape and level along the clip, fitted on the displacements."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import (
    ROOT,
    corpus_clip,
    low_passed_noise,
    needs_corpus,
    plant,
    smooth_synthetic,
    wander_noise,
)

import motionclean as mc
from motionclean.core import quat
from motionclean.filters.linear import lee_shin
from motionclean.filters.masks import binomial
from motionclean.filters.noise import (
    fast_length,
    fit,
    fit_band_limited,
    fit_coloured,
    hann_windows,
    motion_slope,
    window_frames,
)
from motionclean.steps.resampling import resample_motion


def ar1_noise(frames: int, columns: int, rho: float, noise_deg: float, seed: int) -> np.ndarray:
    """(frames, columns, 3) stationary AR(1) noise, RMS rotation angle ``noise_deg``."""
    rng = np.random.default_rng(seed)
    sigma = math.radians(noise_deg) / (2 * math.sqrt(3))
    u = rng.normal(size=(frames, columns, 3)) * math.sqrt(1 - rho**2)
    e = np.empty_like(u)
    e[0] = rng.normal(size=(columns, 3))
    for i in range(1, frames):  # the recursion defines the process (test data only)
        e[i] = rho * e[i - 1] + u[i]
    return e * sigma


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_fit_recovers_a_planted_ar1_coefficient_and_level(rho):
    truth = smooth_synthetic(frames=1200, joints=3, seed=4)
    e = ar1_noise(1200, 3, rho, 3.0, seed=int(10 * rho))
    noisy = quat.multiply(truth, quat.exp(e))
    planted = np.degrees(2 * np.sqrt(np.mean(np.sum(e**2, axis=-1), axis=0)))  # this sample's
    model = fit(quat.displacements(noisy), 1 / 120)
    np.testing.assert_allclose(model.rho, rho, atol=0.2)  # each joint: 3,600 noisy values
    assert abs(np.mean(model.rho) - rho) < 0.1
    level = np.degrees(2 * math.sqrt(3) * np.sqrt(model.clip_sigma2()))
    np.testing.assert_allclose(level, planted, rtol=0.25)
    assert abs(np.mean(level / planted) - 1) < 0.1


def test_fit_follows_a_level_that_changes_along_the_clip():
    truth = smooth_synthetic(frames=1200, joints=2, seed=5)
    level = np.where(np.arange(1200) < 600, 0.5, 5.0)[:, None]
    model = fit(quat.displacements(plant(truth, level, seed=6)), 1 / 120)
    local = np.degrees(2 * math.sqrt(3) * np.sqrt(model.sigma2))  # (W, C)
    centre = model.starts + model.window // 2
    np.testing.assert_allclose(local[centre < 480], 0.5, rtol=0.3)
    np.testing.assert_allclose(local[centre > 720], 5.0, rtol=0.2)


def test_windows_tile_the_clip_and_stay_within_its_length():
    for frames, frame_time in ((1247, 1 / 120), (300, 1e-6), (50, 1 / 30), (9, 1.0)):
        window = window_frames(frames, frame_time, 2.0)
        assert window % 2 == 0 and window <= max(8, fast_length(frames + 1) + 1)
        starts, taper = hann_windows(frames, window)
        total = np.zeros(frames + 2 * window)
        for s in starts:  # the tapers of all windows sum to one on every frame
            total[s + window : s + 2 * window] += taper
        np.testing.assert_allclose(total[window : window + frames], 1.0, atol=1e-12)


def test_fast_length_has_only_small_prime_factors():
    for n in (1, 7, 97, 241, 1247, 100_003):
        length = fast_length(n)
        assert n <= length < 1.25 * n + 2
        rest = length
        for p in (2, 3, 5):
            while rest % p == 0:
                rest //= p
        assert rest == 1


def test_at_30_fps_the_noise_is_taken_as_white_and_its_level_found():
    truth = smooth_synthetic(frames=400, joints=3, seed=7)
    model = fit(quat.displacements(plant(truth, 2.0, seed=8)), 1 / 30)
    assert np.all(model.rho == 0.0)
    level = np.degrees(2 * math.sqrt(3) * np.sqrt(model.clip_sigma2()))
    np.testing.assert_allclose(level, 2.0, rtol=0.2)


@pytest.mark.parametrize("block", [1, 5000, 1 << 18])
def test_the_fit_does_not_depend_on_its_block_size(monkeypatch, block):
    """Periodograms, band medians, quartiles and the Whittle deviance go a block of
    windows at a time (no clip-long temporaries): the model is the same for any block size
    (the deviance is summed block by block, so only its last bits may move)."""
    import importlib

    noise_module = importlib.import_module("motionclean.filters.noise")
    truth = smooth_synthetic(frames=1500, joints=4, seed=8)
    disp = quat.displacements(quat.multiply(truth, quat.exp(ar1_noise(1500, 4, 0.6, 2.0, 9))))
    whole = fit(disp, 1 / 120)
    monkeypatch.setattr(noise_module, "BLOCK_VALUES", block)
    blocked = fit(disp, 1 / 120)
    assert np.array_equal(blocked.rho, whole.rho)
    assert np.array_equal(blocked.power, whole.power)
    assert np.array_equal(blocked.sigma2, whole.sigma2)


# ----------------------------------------------------------------------------- band-limited


def band_limited(noisy, frame_time=1 / 120):
    return fit_band_limited(fit(quat.displacements(noisy), frame_time), frame_time)


@pytest.mark.parametrize(("edge", "seed", "frames"), [(6.0, 61, 2880), (8.0, 83, 1440)])
def test_band_limited_noise_is_found_with_its_edge_and_level(edge, seed, frames):
    """A lower edge needs a longer clip: noise of 3 degrees low-passed at 6 Hz is found on
    9 of seeds 1-15 at 12 s, 14 of them at 24 s (at 8 Hz: all 15 at 12 s)."""
    truth = smooth_synthetic(frames=frames, joints=12, seed=seed)
    e = low_passed_noise(frames, 12, edge, 3.0, seed)
    found = band_limited(quat.multiply(truth, quat.exp(e)))
    assert found is not None
    assert abs(found.edge_hz - edge) <= 0.5
    level = np.degrees(2 * math.sqrt(3) * np.sqrt(found.sigma2))
    np.testing.assert_allclose(level, 3.0, rtol=0.35)


def test_joints_held_still_beside_band_limited_noise_fit_without_overflow():
    """A joint that never moves has no power to fit, or only rounding at 0 Hz: its motion
    and noise shapes fit as one (the determinant of its fit had been clamped to the
    smallest float and the levels overflowed, a RuntimeWarning on stderr of a glTF with
    such a joint); its level is 0 and the others' fit is as without it."""
    frames, seed, fps = 1309, 83, 50.0
    truth = smooth_synthetic(frames=frames, joints=12, seed=seed)
    e = wander_noise(frames, 12, 5.0, 3.0, seed, fps=fps, rho=0.5)
    noisy = quat.multiply(truth, quat.exp(e))
    still = np.broadcast_to(quat.identity((frames, 4)), (frames, 4, 4)).copy()
    # held at a float32 glTF's rotation: its displacements are 2.5e-30 rad of rounding on
    # every frame, all their power at 0 Hz
    still[:, 2:] = [-1.0, 1.86264504e-09, -3.72530007e-09, -2.98022993e-08]
    found = band_limited(np.concatenate([noisy, still], axis=1), 1 / fps)  # (warnings: errors)
    alone = band_limited(noisy, 1 / fps)
    assert found is not None and alone is not None and found.edge_hz == alone.edge_hz
    assert np.array_equal(found.sigma2[12:], np.zeros(4))
    np.testing.assert_allclose(found.sigma2[:12], alone.sigma2, rtol=0.05)


def test_band_limited_gate_stays_off_for_other_noise():
    truth = smooth_synthetic(frames=1440, joints=12, seed=5)
    white = ar1_noise(1440, 12, 0.0, 3.0, seed=50)
    loud = np.where(np.arange(12) % 3 == 0, 3.0, 1.0)[:, None]  # extremities 3x
    outliers = white.copy()
    hit = np.random.default_rng(52).random((1440, 12)) < 0.01
    outliers[hit] = np.radians(30.0) / 2 / math.sqrt(3)
    cases = {
        "white": white,
        "AR(1) 0.5": ar1_noise(1440, 12, 0.5, 3.0, seed=51),
        "AR(1) 0.8": ar1_noise(1440, 12, 0.8, 3.0, seed=53),
        "extremities": white * loud,
        "outliers": outliers,
        "6 Hz, for contrast": low_passed_noise(1440, 12, 6.0, 3.0, seed=54),
    }
    found = {k: band_limited(quat.multiply(truth, quat.exp(e))) for k, e in cases.items()}
    assert found.pop("6 Hz, for contrast") is not None
    assert found == dict.fromkeys(found)


@needs_corpus
def test_band_limited_gate_stays_off_for_clean_captures():
    m = mc.load(corpus_clip("131_02.bvh"))
    for q, ft in ((m.rotations, m.frame_time), (m.rotations[::4], 4 * m.frame_time)):
        q = quat.make_continuous(q, axis=0)
        assert band_limited(q, ft) is None  # as captured
        assert band_limited(lee_shin(q, binomial(1), 20), ft) is None  # pre-smoothed


def coloured(noisy, frame_time=1 / 60):
    return fit_coloured(fit(quat.displacements(noisy), frame_time), frame_time)


@pytest.mark.parametrize(("edge", "seed"), [(6.0, 7), (9.0, 9)])
def test_coloured_noise_is_found_with_its_edge_and_spectrum(edge, seed):
    truth = smooth_synthetic(frames=1200, joints=6, seed=seed)
    e = wander_noise(1200, 6, edge, 2.0, seed)
    model = fit(quat.displacements(quat.multiply(truth, quat.exp(e))), 1 / 60)
    found = fit_coloured(model, 1 / 60)
    assert found is not None
    assert abs(found.edge_hz - edge) <= 1.5
    assert found.slope <= 0.5  # flat or nearly: a wander
    # its spectrum (of the rotation) against the planted noise's, from 1.5 Hz to the edge
    alone = fit(quat.displacements(quat.exp(e)), 1 / 60)
    gain = 4.0 * np.sin(np.pi * model.freqs) ** 2
    band = (model.freqs * 60 >= 1.5) & (model.freqs * 60 <= edge - 1.0)
    planted = alone.power.mean(axis=0)[band] / gain[band, None]
    fitted = found.level * found.shape[band, None]
    ratio = np.median(fitted / planted, axis=0)
    np.testing.assert_allclose(ratio, 1.0, rtol=0.4)


def test_coloured_noise_is_nil_on_smooth_motion_and_white_noise_stays_white():
    truth = smooth_synthetic(frames=1200, joints=6, seed=3)
    assert np.all(np.degrees(2 * np.sqrt(coloured(truth).level)) < 0.05)
    white = ar1_noise(1200, 6, 0.0, 2.0, seed=30)
    found = coloured(quat.multiply(truth, quat.exp(white)))
    level = np.degrees(2 * np.sqrt(found.level))
    white_level = np.degrees(2 * math.sqrt(3) * np.sqrt(found.white))
    np.testing.assert_allclose(white_level, 2.0, rtol=0.25)
    assert np.all(level < 0.5 * white_level)


def test_coloured_noise_needs_a_few_windows():
    truth = smooth_synthetic(frames=100, joints=2, seed=3)
    assert coloured(truth) is None  # 1.7 s: three windows


# ----------------------------------------------------------------------------- motion slope


def slope_of(q: np.ndarray, frame_time: float):
    return motion_slope(
        fit(quat.Displacements(quat.make_continuous(q, axis=0)), frame_time), frame_time
    )


@needs_corpus
@pytest.mark.parametrize("step", [1, 2, 4, 5])
def test_clean_motion_falls_across_the_band_at_any_frame_rate(step):
    """The corpus clips at 120, 60, 30 and 24 fps: the median joint's motion slope over
    2-8 Hz is -1.46 or steeper (what the markerless limit of -1 is set against)."""
    for name in ("131_01.bvh", "131_02.bvh", "131_03.bvh"):
        motion = mc.load(corpus_clip(name))
        found = slope_of(motion.rotations[::step], motion.frame_time * step)
        assert found.columns >= 20
        assert -2.5 < found.slope < -1.4


@needs_corpus
def test_joints_held_still_have_no_say_in_the_slope():
    """An AMASS clip's SMPL-H fingers hold one pose to the last bit but for float64
    rounding: 40 such joints beside a capture's 31 leave its slope as it was (their
    rounding alone read flat and outvoted the moving joints: a still-standing optical
    take was taken for markerless)."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    alone = slope_of(motion.rotations, motion.frame_time)
    rng = np.random.default_rng(5)
    still = quat.exp(np.full((motion.n_frames, 40, 3), 0.3) + rng.normal(0, 1e-15, (1, 40, 3)))
    still = quat.multiply(still, quat.exp(rng.normal(0.0, 1e-16, (motion.n_frames, 40, 3))))
    both = slope_of(np.concatenate([motion.rotations, still], axis=1), motion.frame_time)
    assert both.slope == pytest.approx(alone.slope, abs=1e-9)
    assert both.columns == alone.columns


def test_joints_that_vary_by_their_files_rounding_alone_have_no_say_when_resampled(tmp_path):
    """Mixamo's T-pose export: 22 finger columns vary by the file's 4-decimal text
    rounding alone. Resampled to 60 or 120 fps, that rounding holds nothing above the old
    Nyquist frequency and reads as flat as a pose estimator's noise: the clip had been
    taken for markerless (slope +0.39) and its feet smoothed by 5.9 degrees. Their power,
    a billionth of the body's, leaves them out of the vote: optical at every rate, and the
    default leaves the clip as it was."""
    from motionclean.steps.pipeline import Pipeline

    clip = mc.load(ROOT / "tests" / "data" / "exporters" / "mixamo_tpose.bvh")
    for fps in (60, 120):
        faster = resample_motion(clip, 1.0 / fps)
        found = slope_of(faster.rotations, faster.frame_time)
        assert found.slope < -1.4
        out, _ = Pipeline.default().run(faster)
        moved = np.degrees(quat.angle_between(out.rotations, faster.rotations))
        assert moved.max() < 1.0


def test_a_wander_over_the_band_reads_flat_and_planted_white_noise_never_does():
    truth = smooth_synthetic(frames=1200, joints=8, seed=21)
    wander = wander_noise(1200, 8, 10.0, 2.0, seed=21, rho=0.5)  # flat up to a 10 Hz cliff
    assert slope_of(quat.multiply(truth, quat.exp(wander)), 1 / 60).slope > -0.5
    # white noise is the fitted noise itself: it hides motion (no slope) but is never flat
    for fps in (30.0, 60.0, 120.0):
        noisy = plant(smooth_synthetic(frames=int(10 * fps), joints=8, seed=22), 3.0, seed=23)
        found = slope_of(noisy, 1.0 / fps)
        assert not found.slope > -1.0


@needs_corpus
def test_a_clean_capture_at_30_fps_keeps_a_noise_level_far_below_its_band_median():
    """At 30 fps the band above 9 Hz still holds the motion of 131_02: the level is the
    noise seen beside a falling motion (nearly none), not the band's median ratio; planted
    white noise fills the band and keeps its level."""
    motion = mc.load(corpus_clip("131_02.bvh"))
    keep = [i for i, n in enumerate(motion.names) if n != "RThumb"]
    q = quat.make_continuous(motion.rotations[::4, keep], axis=0)
    level = np.degrees(2 * math.sqrt(3) * np.sqrt(fit(quat.displacements(q), 1 / 30).clip_sigma2()))
    assert np.median(level) < 0.05
    noisy = plant(q, 2.0, seed=24)
    level = np.degrees(
        2 * math.sqrt(3) * np.sqrt(fit(quat.displacements(noisy), 1 / 30).clip_sigma2())
    )
    np.testing.assert_allclose(np.median(level), 2.0, rtol=0.1)
