"""The Python API validates what it is given (issue 17): motions that describe no clip are
refused at construction and by ``save``, huge quaternions are normalised, filter parameters
of the wrong type or beyond what can be computed give TypeError/ValueError naming them, and
no numpy RuntimeWarning escapes."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from helpers import SAMPLE

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import InvalidMotion, MotionError
from motionclean.filters import (
    auto,
    bilateral,
    bilateral_positions,
    despike,
    fairing,
    lee_shin,
    lee_shin_positions,
)
from motionclean.filters.masks import binomial
from motionclean.steps.pipeline import Pipeline


@pytest.fixture(autouse=True)
def warnings_are_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


def test_rigid_csv_quaternion_of_large_norm_is_the_rotation_it_describes(tmp_path):
    """The largest value the reader takes (1e12, 1e12, 0, 0) is 90 degrees; beyond that the
    reader refuses the value (1e200 used to become the identity)."""
    path = tmp_path / "large.csv"
    for big in ("1e12", "1e200"):
        rows = ["time,b.px,b.py,b.pz,b.qw,b.qx,b.qy,b.qz"]
        rows += [f"{f / 100},0,0,0,{big},{big},0,0" for f in range(3)]
        path.write_text("\n".join(rows) + "\n")
        if big == "1e200":
            with pytest.raises(MotionError, match="out of range"):
                mc.load(path)
            continue
        motion = mc.load(path)
        np.testing.assert_allclose(motion.rotations[:, 0], [[0.5**0.5, 0.5**0.5, 0, 0]] * 3)
        assert np.degrees(quat.angle(motion.rotations[0, 0])) == pytest.approx(90.0)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ((2.0, 0.0, 0.0, 0.0), r"joint '\w+' at frame 5 is not a unit quaternion \(norm 2\)"),
        ((0.0, 0.0, 0.0, 0.0), r"at frame 5 is not a unit quaternion \(norm 0\)"),
        ((1e200, 1e200, 0.0, 0.0), r"at frame 5 is not a unit quaternion \(norm 1.41421e\+200\)"),
        ((np.nan, 0.0, 0.0, 0.0), r"joint '\w+' has a non-finite value at frame 5"),
        ((1.0, np.inf, 0.0, 0.0), r"has a non-finite value at frame 5"),
    ],
)
def test_motion_of_invalid_rotations_is_refused_and_not_saved(value, message, tmp_path):
    clip = mc.load(SAMPLE)
    rotations = clip.rotations.copy()
    rotations[5, 2] = value
    with pytest.raises(ValueError, match=message):
        clip.replace(rotations=rotations)
    clip.rotations[5, 2] = value  # changed in place after construction: save refuses it
    for suffix in (".bvh", ".csv"):
        target = tmp_path / f"out{suffix}"
        with pytest.raises(InvalidMotion, match=message) as error:
            mc.save(clip, target)
        assert isinstance(error.value, ValueError) and isinstance(error.value, MotionError)
        assert error.value.path == str(target)  # the command line's one-line form
        assert not target.exists()


def test_rotations_slightly_off_unit_are_accepted_and_written():
    clip = mc.load(SAMPLE)
    nearly = clip.rotations * (1.0 + 5e-7)  # within checks.UNIT_TOLERANCE
    assert clip.replace(rotations=nearly).n_frames == clip.n_frames


@pytest.mark.parametrize("off", [5e-7, 9e-7])
def test_multires_takes_rotations_a_hair_off_unit_as_the_checks_do(off):
    """``multires`` continues the clip past its end by a product of three quaternions,
    which tripled the hair: it refused what every other filter takes, naming frame 200
    of 0-199 and 'norm 1'. Now it runs, and agrees with the unit input."""
    clip = mc.load(SAMPLE)
    nearly = clip.replace(rotations=clip.rotations * (1.0 + off))
    pipeline = Pipeline.from_inline(["multires:levels=3,gains=[0.5]"])
    out, exact = pipeline.run(nearly)[0], pipeline.run(clip)[0]
    assert np.degrees(quat.angle_between(out.rotations, exact.rotations)).max() < 1e-4
    with pytest.raises(ValueError, match=r"\(norm 1\.000002\)"):  # its digits, not "1"
        mc.lee_shin(clip.rotations[:, 0] * 1.000002, binomial(1))


def test_a_rotation_on_a_joint_without_rotation_channels_is_refused_not_dropped(tmp_path):
    """As a translation on a joint without position channels is: the writer writes a
    joint's rotation from its channels, so it would have been lost without a word."""
    clip = mc.load(SAMPLE)
    joint = 1
    channels = list(clip.channels)
    channels[joint] = ("Xposition", "Yposition", "Zposition")
    turned = clip.rotations.copy()
    turned[:, joint] = [np.cos(0.3), np.sin(0.3), 0.0, 0.0]  # 34 degrees about x
    offsets = clip.translations.copy()
    offsets[:, joint] = clip.offsets[joint]
    no_turn = clip.replace(channels=channels, translations=offsets, rotations=clip.rotations.copy())
    no_turn.rotations[:, joint] = [1.0, 0.0, 0.0, 0.0]
    mc.save(no_turn, tmp_path / "ok.bvh")  # unturned: written
    with pytest.raises(ValueError, match=rf"joint {clip.names[joint]!r} has no rotation channels"):
        mc.save(no_turn.replace(rotations=turned), tmp_path / "lost.bvh")
    assert not (tmp_path / "lost.bvh").exists()


def test_shape_errors_say_how_many_frames_and_joints_were_expected():
    clip = mc.load(SAMPLE)
    with pytest.raises(ValueError, match=r"translations: expected shape \(F, 31, 3\) with F = 10 "):
        clip.replace(rotations=clip.rotations[:10])
    with pytest.raises(ValueError, match=r"noise: shape \(7,\) does not broadcast"):
        mc.filters.auto(clip.rotations, clip.frame_time, noise=np.ones(7))


@pytest.mark.parametrize(
    ("changes", "error", "message"),
    [
        (
            {"rotations": np.zeros((4, 2, 4))},
            ValueError,
            r"rotations: expected shape \(F, \d+, 4\)",
        ),
        ({"translations": np.zeros((3, 1, 3))}, ValueError, r"translations: expected shape"),
        ({"rotations": "identity"}, TypeError, "rotations: expected an array of numbers, got str"),
        ({"translations": None}, TypeError, "translations: expected an array of numbers"),
    ],
)
def test_motion_arrays_of_the_wrong_shape_or_type(changes, error, message):
    with pytest.raises(error, match=message):
        mc.load(SAMPLE).replace(**changes)


@pytest.fixture
def q():
    return quat.normalize(np.random.default_rng(3).normal(size=(40, 2, 4)))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda q: bilateral(None, 1.0, 0.1), "q: expected an array of numbers, got NoneType"),
        (lambda q: bilateral(q, "1", 0.1), "sigma_t: expected a number, got str"),
        (lambda q: bilateral(q, 1.0, "wide"), "sigma_g: expected a number, got str"),
        (lambda q: bilateral(q, 1.0, 0.1, radius="3"), "radius: expected a number, got str"),
        (lambda q: bilateral(q, 1.0, 0.1, iterations=[2]), "iterations: expected a number"),
        (lambda q: lee_shin(q, binomial(1), iterations=None), "iterations: expected a number"),
        (lambda q: fairing(q, order="3"), "order: expected a number, got str"),
        (lambda q: fairing(q, lam_r=None), "lam_r: expected a number, got NoneType"),
        (lambda q: fairing(q, max_iterations="9"), "max_iterations: expected a number"),
        (lambda q: despike(q, "0.01"), "frame_time: expected a number, got str"),
        (lambda q: auto(q, 0.01, strength="high"), "strength: expected a number, got str"),
        (lambda q: quat.from_euler(np.zeros(3), 123), "order: expected a string"),
    ],
)
def test_bad_parameter_types_are_type_errors_naming_them(q, call, message):
    with pytest.raises(TypeError, match=message):
        call(q)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda q: bilateral(q, 1e308, 0.1), "sigma_t must be at most 1000 frames"),
        (lambda q: bilateral(q, 1.0, 0.1, radius=10**12), r"radius: .* <= 3000"),
        (lambda q: bilateral(q, 1.0, 0.1, iterations=10**30), r"iterations: .* <= 10000"),
        (lambda q: lee_shin(q, binomial(1), iterations=2.5), "iterations: expected a whole"),
        (lambda q: fairing(q, max_iterations=1e300), r"max_iterations: .* <= 10000"),
        (lambda q: despike(q, 1e-320), "frame_time must be a positive number of seconds"),
        (lambda q: despike(q, 1e308), "frame_time must be a positive number of seconds"),
        (lambda q: auto(q, 5e-324), "frame_time must be a positive number of seconds"),
        (lambda q: auto(q, 1e308), "frame_time must be a positive number of seconds"),
    ],
)
def test_parameters_beyond_what_can_be_computed_are_refused(q, call, message):
    """Before: OverflowError, numpy's "array is too big", a pass loop of 1e30 iterations."""
    with pytest.raises(ValueError, match=message):
        call(q)


def test_huge_max_seconds_is_capped_by_the_clip(q):
    out = auto(q, 0.01, max_seconds=1e308)  # was OverflowError
    assert np.all(np.isfinite(out.values))


@pytest.mark.parametrize(
    "filt",
    [
        lambda p: lee_shin_positions(p, binomial(1)),
        lambda p: bilateral_positions(p, 1.0, 1.0),
        lambda p: mc.filters.despike_positions(p, 0.01),
        lambda p: mc.filters.auto_positions(p, 0.01),
    ],
)
def test_positions_too_large_to_square_are_refused_without_warnings(filt):
    p = np.random.default_rng(4).normal(size=(30, 2, 3))
    p[6, 1, 2] = 1e300  # squares overflow: was a RuntimeWarning and NaN/inf results
    with pytest.raises(ValueError, match=r"value 1e\+300 at index \(6, 1, 2\) is beyond"):
        filt(p)


def test_masks_of_the_wrong_type_and_uninvertible_quaternions():
    with pytest.raises(TypeError, match="mask: expected an array of numbers, got str"):
        lee_shin(quat.identity((5,)), "binomial")
    with pytest.raises(ValueError, match="sum to 1"):
        lee_shin_positions(np.zeros((5, 3)), [1e308, 1e308, 1e308])  # sum overflows: no warning
    with pytest.raises(ValueError, match="no inverse"):
        quat.inverse(np.array([[1.0, 0, 0, 0], [0.0, 0, 0, 0]]))
    with pytest.raises(ValueError, match="no inverse"):
        quat.inverse(np.array([1e200, 0, 0, 0]))
    q = np.array([0.6, -0.4, 1.8, 0.2])  # not unit: the inverse still undoes it
    np.testing.assert_allclose(quat.multiply(q, quat.inverse(q)), [1, 0, 0, 0], atol=1e-15)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: quat.normalize(np.array([np.inf, 0, 0, 0])), ValueError, "NaN or infinite"),
        (lambda: quat.normalize(np.array([np.nan, 0, 0, 0])), ValueError, "NaN or infinite"),
        (lambda: quat.normalize(np.array([1j, 0, 0, 0])), TypeError, "got complex values"),
        (lambda: lee_shin(np.ones((5, 1, 4)) + 0j, [1.0]), TypeError, "got complex values"),
        (lambda: mc.filters.masks.gaussian(np.nan), ValueError, "sigma_t must be a positive"),
        (lambda: mc.filters.masks.gaussian(1e9), ValueError, "at most 5000"),
        (lambda: mc.filters.masks.smoothing(np.nan), ValueError, "lam must be a finite"),
        (lambda: mc.Pipeline.default().run("abc"), TypeError, "motion: expected a Motion, got str"),
        (lambda: mc.filters.masks.binomial("2"), TypeError, "^k: expected a number, got str$"),
        (
            lambda: mc.load(SAMPLE).replace(frame_time="0.01"),
            InvalidMotion,
            "frame_time: expected seconds as a number, got str",
        ),
    ],
)
def test_more_of_what_no_clip_is_gets_a_clear_error(call, error, message):
    """Each had given numpy's warning and a wrong value (complex parts dropped, NaN), an
    allocation of 45 GiB, or an AttributeError or TypeError that named nothing."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(error, match=message):
            call()


def test_numpy_scalars_are_parameters_like_pythons_and_a_clip_without_frames_no_gltf(tmp_path):
    as_numpy = [{"filter": "lee-shin", "k": np.int64(2), "positions": np.bool_(True)}]
    as_python = [{"filter": "lee-shin", "k": 2, "positions": True}]
    assert (
        mc.Pipeline.from_tables(as_numpy, "x").describe()
        == mc.Pipeline.from_tables(as_python, "x").describe()
    )
    clip = mc.load(SAMPLE)
    empty = clip.replace(rotations=clip.rotations[:0], translations=clip.translations[:0])
    with pytest.raises(MotionError, match="glTF needs at least one frame"):
        mc.save(empty.replace(source_values=None), tmp_path / "e.glb")


def test_the_package_exposes_the_filters_and_world_space_as_design_says():
    """DESIGN's public API: load, save, Motion, Pipeline and the filter functions at the
    top level, and ``motionclean.kinematics.forward``."""
    import motionclean as mc
    from motionclean import filters

    for name in filters.__all__:
        assert getattr(mc, name) is getattr(filters, name)
    motion = mc.load(SAMPLE)
    positions, rotations = mc.kinematics.forward(motion)
    assert positions.shape == (motion.n_frames, motion.n_joints, 3)
    assert rotations.shape == (motion.n_frames, motion.n_joints, 4)


def test_auto_names_its_arguments_as_its_signature_does():
    """auto(q, ...) and auto_positions(p, ...) name q and p in their errors (they had said
    'rotations' and 'positions', no parameter of theirs)."""
    import motionclean as mc

    with pytest.raises(ValueError, match=r"^q: expected shape"):
        mc.auto(np.zeros((10, 3)), 0.01)
    with pytest.raises(ValueError, match=r"^p: expected shape"):
        mc.auto_positions(np.zeros((10, 4)), 0.01)
