"""Resampling to a new frame rate: the interpolant, the step, the command and the report."""

from __future__ import annotations

import json

import numpy as np
import pytest
from helpers import (
    NOISY,
    ROOT,
    SAMPLE,
    corpus_clip,
    cut_bvh,
    degrees_between,
    max_degrees,
    run_cli,
    with_t_pose,
)
from hypothesis import given, settings
from hypothesis import strategies as st

import motionclean as mc
from motionclean.core import quat
from motionclean.core.errors import MotionError
from motionclean.core.motion import hold_missing
from motionclean.filters.interpolate import catmull_rom_tangents, end_tangent, hermite_rotations
from motionclean.filters.resample import (
    resample_positions,
    resample_rotations,
    resampled_length,
    sample_positions,
)
from motionclean.io.csv import RIGID_SUFFIXES
from motionclean.steps.pipeline import Pipeline
from motionclean.steps.resampling import on_input_frames, resample_motion

RNG = np.random.default_rng(21)


def constant_velocity(frames: int, joints: int = 3, speed: float = 0.06):
    """``q0 exp(i w)`` per joint: constant angular velocity (half-angle ``w`` per frame)."""
    w = RNG.normal(size=(1, joints, 3))
    w *= speed / np.linalg.norm(w, axis=-1, keepdims=True)
    q0 = quat.normalize(RNG.normal(size=(joints, 4)))
    return q0, w, quat.multiply(q0[None], quat.exp(np.arange(frames)[:, None, None] * w))


@settings(max_examples=30, deadline=None)
@given(ratio=st.floats(0.13, 7.0), frames=st.integers(12, 80))
def test_constant_angular_velocity_stays_constant_at_any_ratio(ratio, frames):
    """The interpolant is exact on constant angular velocity, and so is the anti-aliasing
    low-pass (its mask sums to one and is symmetric), up or down."""
    q0, w, q = constant_velocity(frames)
    out = resample_rotations(q, ratio)
    index, u = sample_positions(out.shape[0], ratio)
    times = index + u
    truth = quat.multiply(q0[None], quat.exp(times[:, None, None] * w))
    assert max_degrees(out, truth) < 1e-9
    p = np.cumsum(np.broadcast_to(w, q.shape[:-1] + (3,)), axis=0)
    np.testing.assert_allclose(
        resample_positions(p, ratio), w * (times[:, None, None] + 1), atol=1e-9
    )


def test_angular_velocity_is_continuous_at_the_samples():
    """C1: the angular velocity at the end of one piece equals the one at the start of the
    next (finite differences), on an irregular signal where slerp would jump."""
    q = quat.make_continuous(quat.normalize(RNG.normal(size=(8, 4)) * 0.4 + [1, 0, 0, 0]))
    steps = np.concatenate([quat.displacements(q), quat.displacements(q)[-1:]])
    tangents = catmull_rom_tangents(steps)

    def piece(i: int, u: float) -> np.ndarray:
        m1 = end_tangent(steps[i], tangents[i + 1])
        return hermite_rotations(q[i], steps[i], tangents[i], m1, np.array(u))

    eps = 1e-6
    for i in range(1, 6):
        assert max_degrees(piece(i, 1.0), q[i + 1]) < 1e-10  # reaches the next sample
        left = quat.log(quat.multiply(quat.conjugate(piece(i, 1.0 - eps)), piece(i, 1.0))) / eps
        right = quat.log(quat.multiply(quat.conjugate(piece(i + 1, 0.0)), piece(i + 1, eps))) / eps
        np.testing.assert_allclose(left, right, atol=1e-5)
        slerp_left, slerp_right = steps[i], steps[i + 1]
        assert np.abs(slerp_left - slerp_right).max() > 1e-2  # the test has teeth


@settings(max_examples=20, deadline=None)
@given(ratio=st.sampled_from([0.25, 0.4, 0.5, 0.8, 1.25, 2.0, 2.5, 4.0]), seed=st.integers(0, 99))
def test_resampling_is_coordinate_invariant(ratio, seed):
    """A fixed rotation on either side of every sample commutes with resampling (003
    Sec. 4); rotated positions with rotation-equivariant positions."""
    rng = np.random.default_rng(seed)
    q = quat.make_continuous(
        quat.normalize(rng.normal(size=(40, 2, 4)) * 0.15 + [1, 0, 0, 0]), axis=0
    )
    a, b = quat.normalize(rng.normal(size=(2, 4)))
    out = resample_rotations(q, ratio)
    # exact but for the control points' solve, which stops at 1e-9 rad (spline.TOLERANCE)
    assert max_degrees(resample_rotations(quat.multiply(a, q), ratio), quat.multiply(a, out)) < 1e-6
    assert max_degrees(resample_rotations(quat.multiply(q, b), ratio), quat.multiply(out, b)) < 1e-6
    p = rng.normal(size=(40, 2, 3))
    np.testing.assert_allclose(
        resample_positions(quat.rotate(a, p), ratio),
        quat.rotate(a, resample_positions(p, ratio)),
        atol=1e-12,
    )


def test_new_grid_lengths_and_positions():
    assert resampled_length(300, 4.0) == 75  # 120 -> 30 fps
    assert resampled_length(300, 0.5) == 600
    assert resampled_length(5, 2.0) == 3  # 2.5 frames of duration: rounded half up
    index, u = sample_positions(6, 1.2)  # 120 -> 100 fps: 6/5, hits every fifth frame
    np.testing.assert_array_equal(index, [0, 1, 2, 3, 4, 6])
    np.testing.assert_allclose(u, [0, 0.2, 0.4, 0.6, 0.8, 0])
    # A file's rounded Frame Time (0.008333 s) resampled to 60 fps hits every other frame.
    index, u = sample_positions(4, (1 / 60) / 0.008333)
    np.testing.assert_array_equal(index, [0, 2, 4, 6])
    assert not u.any()


def test_same_rate_is_the_identity_byte_for_byte(tmp_path, capsys):
    for fps in ("120", "120.0048", "119.95"):  # 0.008333 s per frame is 120 fps
        out = tmp_path / f"same_{fps}.bvh"
        code, _, err = run_cli(capsys, "resample", SAMPLE, out, "--fps", fps)
        assert code == 0, err
        assert out.read_bytes() == SAMPLE.read_bytes()


def test_two_times_up_hits_every_sample_and_down_again_returns_the_clip(tmp_path, capsys):
    clip = mc.load(NOISY)
    up = resample_motion(clip, clip.frame_time / 2)
    assert up.n_frames == 2 * clip.n_frames
    assert max_degrees(up.rotations[::2], clip.rotations) < 1e-12
    np.testing.assert_array_equal(up.translations[::2], clip.translations)
    down = resample_motion(up, clip.frame_time)
    assert down.n_frames == clip.n_frames
    # Up 2.5x and down again low-passes at 0.7 x 60 Hz: a smooth joint comes back within a
    # small angle (the sample's RThumb flips by ~180 degrees: no smooth joint, left out).
    smooth = mc.load(SAMPLE)
    back = resample_motion(resample_motion(smooth, smooth.frame_time / 2.5), smooth.frame_time)
    assert back.n_frames == smooth.n_frames
    kept = [j for j, name in enumerate(smooth.names) if name != "RThumb"]
    angles = degrees_between(back.rotations[:, kept], smooth.rotations[:, kept])
    assert np.sqrt(np.mean(angles**2)) < 0.02 and angles.max() < 0.2


def test_frame_count_time_and_duration_follow(tmp_path, capsys):
    for fps, suffix in ((30.0, ".bvh"), (100.0, ".bvh"), (24.0, ".csv"), (73.5, ".csv")):
        out = tmp_path / f"out{suffix}"
        code, stdout, err = run_cli(capsys, "resample", SAMPLE, out, "--fps", str(fps))
        assert code == 0, err
        clip, new = mc.load(SAMPLE), mc.load(out)
        assert abs(new.frame_rate - fps) < 1e-6 * fps
        assert abs(new.duration - clip.duration) <= 0.5 * new.frame_time + 1e-9
        assert f"{new.n_frames} frames at {fps:g} fps" in stdout
        assert max_degrees(new.rotations[0], clip.rotations[0]) < 1.0  # the first frame kept
        if suffix == ".bvh":  # the hierarchy text stays byte for byte
            head = SAMPLE.read_bytes().split(b"MOTION")[0]
            assert out.read_bytes().split(b"MOTION")[0] == head
        else:  # CSV time column regenerated on the new grid
            times = np.loadtxt(out, delimiter=",", skiprows=1, usecols=1)
            np.testing.assert_allclose(np.diff(times), 1 / fps, rtol=1e-9)


def test_steps_after_resample_see_the_new_rate_and_frames():
    clip = mc.load(NOISY)
    pipeline = Pipeline.from_inline(["resample:fps=60", "lee-shin:frames=[10,40],blend=0"])
    out, logs = pipeline.run(clip)
    assert out.n_frames == 150 and abs(out.frame_rate - 60.0) < 1e-9
    assert logs[1].touched == (10, 41)
    alone = resample_motion(clip, 1 / 60)
    assert max_degrees(out.rotations[41:], alone.rotations[41:]) < 1e-9
    assert max_degrees(out.rotations[10:41], alone.rotations[10:41]) > 0.0
    with pytest.raises(MotionError, match=r"ends at frame 200, but the clip has 150 frames"):
        Pipeline.from_inline(["resample:fps=60", "lee-shin:frames=[10,200]"]).run(clip)


def test_a_t_pose_keeps_its_time_and_the_motion_is_not_late_or_stretched(tmp_path, capsys):
    """A T-pose frame before the motion stays a T-pose (never blended in) and takes the new
    frames that fall within its own frame time; the motion keeps its times: every new frame
    samples the motion where it is in the file, and the clip keeps its duration."""
    motion = mc.load(SAMPLE)
    for frames in (1, 2):
        source = with_t_pose(SAMPLE, tmp_path / f"tpose{frames}.bvh", frames)
        clip = mc.load(source)
        # 2x up: the new grid hits every old frame, the motion's included, where it was
        up = resample_motion(clip, clip.frame_time / 2)
        assert up.n_frames == 2 * clip.n_frames
        assert max_degrees(up.rotations[: 2 * frames], clip.rotations[:1]) == 0.0
        assert max_degrees(up.rotations[2 * frames :: 2], motion.rotations) < 1e-12
    # 2x down with two T-pose frames: they take new frame 0, the motion new frames from 1 on,
    # each at its own time (new frame k at old frame 2k, motion frame 2k - 2)
    clip = mc.load(source)
    down = resample_motion(clip, clip.frame_time * 2)
    assert down.n_frames == resampled_length(clip.n_frames, 2.0) == 151
    alone = resample_motion(motion, motion.frame_time * 2)
    assert max_degrees(down.rotations[1:], alone.rotations) < 1e-9
    # the clip: 75 frames with a T-pose first, 120 -> 30 fps
    short = cut_bvh(with_t_pose(SAMPLE, tmp_path / "t.bvh"), tmp_path / "short.bvh", 75)
    out = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, "resample", short, out, "--fps", "30")
    assert code == 0, err
    clip, new = mc.load(short), mc.load(out)
    assert abs(new.duration - clip.duration) <= 0.5 * new.frame_time  # 0.625 s -> 0.633 s
    rows_in = short.read_text().split("Frame Time:")[1].splitlines()[1:]
    rows_out = out.read_text().split("Frame Time:")[1].splitlines()[1:]
    tpose_in, tpose_out = (np.array(row.split(), dtype=float) for row in (rows_in[0], rows_out[0]))
    np.testing.assert_array_equal(tpose_out, tpose_in)  # the T-pose frame, value for value
    # new frame 1 is at 33.3 ms: the motion there (file frame 4), not its first frame (8.3 ms)
    first = degrees_between(new.rotations[1], clip.rotations[4])
    late = degrees_between(new.rotations[1], clip.rotations[1])
    assert first.max() < 0.5 * late.max()
    # the report compares on the input's frames: the T-pose frame and the motion in place
    code, _, err = run_cli(
        capsys,
        "clean",
        short,
        "-o",
        tmp_path / "c.bvh",
        "-f",
        "resample:fps=30",
        "--report",
        tmp_path / "r.json",
    )
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["rest_frames"] == {"leading": 1, "trailing": 0}
    plain = cut_bvh(SAMPLE, tmp_path / "plain.bvh", 74)  # the same motion without it
    code, _, err = run_cli(
        capsys,
        "clean",
        plain,
        "-o",
        tmp_path / "p.bvh",
        "-f",
        "resample:fps=30",
        "--report",
        tmp_path / "p.json",
    )
    assert code == 0, err
    alone = json.loads((tmp_path / "p.json").read_text())

    def largest(figures: dict) -> float:  # RThumb's half-turn flips left out
        return max(j["deviation_deg"]["max"] for n, j in figures["joints"].items() if n != "RThumb")

    assert largest(report) < 1.5 * largest(alone) < 20.0


def test_a_flip_repaired_by_despike_is_not_smeared_by_resampling():
    """The noisy sample's RThumb flips by ~180 degrees for a few frames: resampled as it is
    the flip is smeared over its neighbours; despike first and the result stays on the
    repaired curve."""
    clip = mc.load(NOISY)
    thumb = clip.names.index("RThumb")
    repaired, _ = Pipeline.from_inline(["despike"]).run(clip)
    both, _ = Pipeline.from_inline(["despike", "resample:fps=40"]).run(clip)
    raw, _ = Pipeline.from_inline(["resample:fps=40"]).run(clip)
    on_grid = on_input_frames(clip, both)
    smeared = on_input_frames(clip, raw)
    step = degrees_between(repaired.rotations[:, thumb], on_grid.rotations[:, thumb])
    assert step.max() < 10.0
    assert degrees_between(repaired.rotations[:, thumb], smeared.rotations[:, thumb]).max() > 40


@pytest.mark.parametrize("fps", [60.0, 30.0])
def test_a_flip_left_in_the_clip_stays_a_flip_at_a_lower_rate(fps):
    """RThumb's half-turn flips, not repaired: the anti-alias low-pass is cut at them as the
    spline is, so each new frame is the input's rotation at its time (it had smeared a flip
    into rotations of neither side: 71 and 108 degrees from the frames beside it)."""
    clip = mc.load(SAMPLE)
    thumb = clip.names.index("RThumb")
    steps = degrees_between(clip.rotations[1:, thumb], clip.rotations[:-1, thumb])
    assert (steps > 150.0).sum() >= 4  # the flips are there
    out = resample_motion(clip, 1.0 / fps)
    every = round(1.0 / (fps * clip.frame_time))
    hit = clip.rotations[::every][: out.n_frames]
    assert degrees_between(out.rotations[:, thumb], hit[:, thumb]).max() < 5.0


def test_beats_per_channel_euler_cubic_where_channels_wrap():
    """4x subsampled and restored: on a clip turned to face backwards (its root's Z and X
    channels wrap at +-180 degrees as a DCC tool writes them) the per-channel Euler cubic
    spins the root through wrong rotations; ours does not. On the clip itself it is not
    worse (bench/resample.py has the full table)."""
    import sys

    sys.path.insert(0, str(SAMPLE.parents[1] / "bench"))
    from resample import restore_errors, turned  # the bench's own peer and measure

    clip = mc.load(corpus_clip("131_01.bvh"))
    ours, euler = restore_errors(clip)
    assert ours <= 1.05 * euler
    back = turned(clip, quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), np.pi))
    ours, euler = restore_errors(back, np.array([0]))
    assert ours < 0.1 * euler


def test_missing_samples_stay_missing_after_resampling():
    clip = mc.load(SAMPLE)
    missing = np.zeros((clip.n_frames, clip.n_joints), dtype=bool)
    missing[100:110, 4] = True
    out = resample_motion(clip.replace(missing=missing), clip.frame_time * 2)
    assert out.missing is not None
    np.testing.assert_array_equal(np.flatnonzero(out.missing[:, 4]), np.arange(50, 55))
    assert out.missing.sum() == 5


@pytest.mark.parametrize(
    ("args", "message", "code"),
    [
        (["--fps", "0"], "fps must be a number >= ", 2),
        (["--fps", "nan"], "fps must be a number", 2),
        (["--fps", "-30"], "fps must be a number", 2),
        (["--fps", "inf"], "fps must be a number", 2),
        ([], "error: give the new rate as either --fps or --frame-time", 2),
        (["--fps", "30", "--frame-time", "0.1"], "either --fps or --frame-time", 2),
        (["--frame-time", "2"], "leaves 1 frame; at least two are needed", 1),
    ],
)
def test_bad_rates_get_one_line(tmp_path, capsys, args, message, code):
    out = tmp_path / "out.bvh"
    got, stdout, err = run_cli(capsys, "resample", SAMPLE, out, *args)
    assert got == code and message in err and err.count("\n") == 1 and not stdout
    assert "step" not in err  # (the command's own options, not a pipeline's step 1)
    assert not out.exists()


def test_a_length_beyond_memory_is_refused_saying_how_many_frames(tmp_path, capsys):
    """1,000,000 fps makes 2.5 million frames of a 2.5 s clip: more than fit in half of any
    machine's memory this suite runs on? Not necessarily, so the limit is asked for."""
    from motionclean.steps.resampling import BYTES_PER_VALUE, _memory_bytes

    clip = mc.load(SAMPLE)
    per_frame = (clip.n_joints * 7 + clip.layout.n_channels) * BYTES_PER_VALUE
    fits = _memory_bytes() // 2 // per_frame
    fps = (fits + 10) / clip.duration
    if fps > 1e6:
        pytest.skip(f"this machine fits {fits:,} frames, more than 1e6 fps gives")
    out = tmp_path / "out.bvh"
    code, _, err = run_cli(capsys, "resample", SAMPLE, out, "--fps", repr(fps))
    assert code == 1 and f"at most {fits:,} fit in memory" in err and not out.exists()


def test_the_memory_bound_covers_what_resampling_holds():
    """The bound's bytes per new frame and value keep a margin over what resampling holds:
    its peak (tracemalloc) grows by about 13 bytes per value from 10,000 to 20,000 new frames
    of the sample clip, under half of BYTES_PER_VALUE and over a quarter of it (96 had been
    7.6 times as much, refusing lengths that fit), and the longest length accepted, at that
    growth, peaks within the half of the machine's memory the bound allows."""
    import tracemalloc

    from motionclean.steps.resampling import BYTES_PER_VALUE, _memory_bytes

    clip = mc.load(SAMPLE)
    values = clip.n_joints * 7 + clip.layout.n_channels
    span = clip.frame_time * (clip.n_frames - 1)
    peaks = []
    for n_new in (10_000, 20_000):
        tracemalloc.start()
        try:
            frames = resample_motion(clip, span / (n_new - 1)).n_frames
            peaks.append((frames, tracemalloc.get_traced_memory()[1]))
        finally:
            tracemalloc.stop()
    (n1, p1), (n2, p2) = peaks
    growth = (p2 - p1) / (n2 - n1) / values
    assert 2.0 * growth <= BYTES_PER_VALUE <= 4.0 * growth
    fits = _memory_bytes() // 2 // (values * BYTES_PER_VALUE)
    assert p1 + (fits - n1) * values * growth <= _memory_bytes() // 2


def test_clean_report_compares_on_the_input_frames_and_says_what_was_written(tmp_path, capsys):
    out, report = tmp_path / "out.bvh", tmp_path / "r.json"
    code, stdout, err = run_cli(
        capsys, "clean", NOISY, "-o", out, "-f", "resample:fps=30", "--report", report
    )
    assert code == 0, err
    data = json.loads(report.read_text())
    assert data["frames"] == 300 and data["output"] == {"frames": 75, "frame_time": 1 / 30}
    assert "written as 75 frames at 30 fps" in stdout
    assert data["joints"]["Hips"]["resample"]["frames"] == [300, 75]
    rms = data["joints"]["Head"]["deviation_deg"]["rms"]
    assert 0.0 < rms < 5.0  # compared frame by frame on the input's grid


def test_resample_takes_no_range_joints_or_positions():
    for text in ("resample:fps=30,frames=[0,10]", "resample:fps=30,joints=Hips"):
        with pytest.raises(MotionError, match="changes the whole clip"):
            Pipeline.from_inline([text])


def test_a_single_frame_clip_cannot_be_resampled(tmp_path, capsys):
    one = tmp_path / "one.bvh"
    cut_bvh(SAMPLE, one, 1)
    code, _, err = run_cli(capsys, "resample", one, tmp_path / "out.bvh", "--fps", "240")
    assert code == 1 and "a clip of 1 frame cannot be resampled" in err
    none = tmp_path / "none.bvh"
    cut_bvh(SAMPLE, none, 0)
    code, _, err = run_cli(capsys, "resample", none, tmp_path / "out.bvh", "--fps", "240")
    assert code == 1 and "a clip of 0 frames cannot be resampled" in err  # ("0 frame")


def rigid_csv(path, frames: int, bodies: int = 2):
    head = ",".join(f"b{k}.{s}" for k in range(bodies) for s in RIGID_SUFFIXES)
    rows = [f"time,{head}"]
    for f in range(frames):
        body = f"{0.01 * f:.4f},1,0,{np.cos(0.02 * f):.6f},{np.sin(0.02 * f):.6f},0,0"
        rows.append(f"{f / 120:.6f}," + ",".join([body] * bodies))
    path.write_text("\n".join(rows) + "\n")
    return path


def opensim_mot(path, frames: int):
    rows = "".join(
        f"{f / 120:.8f}\t{10 + f * 0.5:.8f}\t{0.1 + f * 0.001:.8f}\n" for f in range(frames)
    )
    head = f"Coordinates\nversion=1\nnRows={frames}\nnColumns=3\ninDegrees=yes\nendheader\n"
    path.write_text(head + "time\tpelvis_rotation\tpelvis_tx\n" + rows)
    return path


@pytest.mark.parametrize(
    "kind", ["bvh", "channel csv", "rigid csv", "motive csv", "glb", "opensim mot"]
)
def test_every_format_refuses_an_absurd_rate_up_front(tmp_path, capsys, kind):
    """1e6 fps of a 240-frame clip: 2 million frames. The BVH path refused it by memory; a
    tracker CSV of two bodies 'fit' and wrote a gigabyte for minutes. Every format now
    refuses more than MAX_UPSAMPLING frames per frame read, before any work."""
    from motionclean.steps.resampling import MAX_UPSAMPLING

    if kind == "bvh":
        clip = cut_bvh(SAMPLE, tmp_path / "c.bvh", 240)
    elif kind == "channel csv":
        mc.save(mc.load(cut_bvh(SAMPLE, tmp_path / "c.bvh", 240)), tmp_path / "c.csv")
        clip = tmp_path / "c.csv"
    elif kind == "rigid csv":
        clip = rigid_csv(tmp_path / "c.csv", 240)
    elif kind == "glb":
        mc.save(mc.load(cut_bvh(SAMPLE, tmp_path / "c.bvh", 240)), tmp_path / "c.glb")
        clip = tmp_path / "c.glb"
    elif kind == "opensim mot":
        clip = opensim_mot(tmp_path / "c.mot", 240)
    else:
        clip = ROOT / "sample_data" / "131_02_motive.csv"
    frames = mc.load(clip).n_frames
    out = tmp_path / f"out{clip.suffix}"
    code, stdout, err = run_cli(capsys, "resample", clip, out, "--fps", "1e6")
    assert code == 1 and not stdout and err.count("\n") == 1 and not out.exists()
    bound = f"at most {MAX_UPSAMPLING:,} per frame read ({MAX_UPSAMPLING * frames:,})"
    if kind in ("rigid csv", "motive csv", "opensim mot"):  # few values: memory would do
        assert bound in err
    else:  # a BVH skeleton's frames may pass the memory bound first
        assert bound in err or "fit in memory" in err
    code, _, err = run_cli(capsys, "clean", clip, "-o", out, "-f", "resample:fps=1e6", "-q")
    assert code == 1 and err.count("\n") == 1 and not out.exists()


def test_a_high_rate_within_the_bound_is_made(tmp_path, capsys):
    clip = rigid_csv(tmp_path / "c.csv", 10, bodies=1)
    out = tmp_path / "out.csv"
    code, _, err = run_cli(capsys, "resample", clip, out, "--fps", "96000")  # 800x
    assert code == 0, err
    assert mc.load(out).n_frames == 8000


@pytest.mark.parametrize(("fps", "largest"), [(240, 0.05), (60, 0.2)])
def test_a_dropout_left_missing_does_not_spread_into_the_frames_beside_it(fps, largest):
    """A 61-frame dropout of one body, held as placeholders: resampled, the known frames
    within 0.1 s after it are what the clip without the dropout gives (the spline and the
    anti-alias low-pass had run across the held value and the step at its end: 8.0 and 4.9
    degrees off), and the frames it covers stay missing."""
    clip = mc.load(ROOT / "sample_data" / "131_02_motive.csv")
    hand = clip.names.index("hand_l")
    missing = clip.missing.copy()
    missing[40:101, hand] = True
    dropout = clip.replace(
        missing=missing,
        rotations=quat.make_continuous(hold_missing(clip.rotations, missing), axis=0),
        translations=hold_missing(clip.translations, missing),
    )
    step = Pipeline.from_inline([f"resample:fps={fps}"])
    out, _ = step.run(dropout)
    whole, _ = step.run(clip.replace(missing=None))
    times = np.arange(out.n_frames) * out.frame_time
    beside = ~out.missing[:, hand] & (np.abs(times - 101 * clip.frame_time) < 0.1)
    assert beside.sum() >= 3
    moved = np.degrees(
        quat.angle_between(out.rotations[beside, hand], whole.rotations[beside, hand])
    )
    assert moved.max() < largest
    assert out.missing[(times > 45 * clip.frame_time) & (times < 95 * clip.frame_time), hand].all()


@pytest.mark.parametrize(
    ("frame_time", "error", "message"),
    [
        (0, ValueError, "frame_time must be a positive number of seconds .* got 0$"),
        (-1, ValueError, "frame_time must be a positive number of seconds .* got -1$"),
        (float("nan"), ValueError, "frame_time must be a positive number of seconds .* got nan$"),
        ("0.1", TypeError, "^frame_time: expected a number, got str$"),
    ],
)
def test_resample_motion_checks_the_frame_time_it_is_given(frame_time, error, message):
    """They had raised ZeroDivisionError, "cannot convert float NaN to integer", a
    MotionError about "-1 fps", and a TypeError from arithmetic on a str."""
    clip = mc.load(SAMPLE)
    with pytest.raises(error, match=message):
        resample_motion(clip, frame_time)
    with pytest.raises(TypeError, match="^motion: expected a Motion, got NoneType$"):
        resample_motion(None, 1 / 60)


LEE_SHIN_RANGED = "lee-shin:k=3,iterations=3,seconds=[0.5,1.5],blend=6"


@pytest.mark.parametrize("fps", [25.0, 30.0, 47.0, 60.0])
def test_resampled_channels_neither_spin_nor_jump_across_unrepaired_flips(tmp_path, fps):
    """New frames restart on the principal angles where the rotation leaps (RThumb's flips,
    not repaired): a channel had then stepped up to 331 degrees where 29 would do; then,
    unwrapped across every flip, RThumb's Z spiralled to -1002.6 degrees at 30 fps (read
    within -124..84). Away from the leaps each channel stays on the whole turns nearest the
    frame before; at a leap that jumps either way no turn is carried past it."""
    target = tmp_path / "r.bvh"
    resampled = resample_motion(mc.load(NOISY), 1.0 / fps)
    mc.save(resampled, target)
    text = target.read_text().split("Frame Time:")[1].splitlines()[1:]
    values = np.array([row.split() for row in text if row.strip()], dtype=float)
    clip = mc.load(target)
    columns = clip.layout.rotation_columns
    rotation = columns[columns[:, 0] >= 0].ravel()
    assert max_degrees(clip.rotations, resampled.rotations) < 1e-4
    turned = np.degrees(quat.angle_between(clip.rotations[1:], clip.rotations[:-1]))  # (F-1, J)
    step = np.abs(np.diff(values, axis=0))
    joint_of = np.repeat(np.arange(clip.n_joints), 3)[columns.ravel() >= 0]
    leap = turned[:, joint_of] > 90.0
    assert step[:, rotation][~leap].max() < 180.0  # (no frame that turns little jumps)
    thumb = clip.names.index("RThumb")
    assert leap[:, joint_of == thumb].any()  # (the flips are there, turned in one frame)
    assert np.abs(values[:, rotation]).max() < 360.0  # (no turns gathered flip after flip)


def test_a_ranged_step_after_a_resample_leaves_the_text_outside_its_range(tmp_path):
    """After resample to 60 fps, lee-shin on 0.5-1.5 s touched frames [24, 97), but RThumb
    was written a whole turn off from frame 97 to the clip's end (75.07 as 435.07): the
    turns its flips carried changed with the range. Outside it every row is as before."""
    clip = mc.load(NOISY)
    rows = []
    for steps in (["resample:fps=60"], ["resample:fps=60", LEE_SHIN_RANGED]):
        target = tmp_path / f"{len(steps)}.bvh"
        cleaned, logs = Pipeline.from_inline(steps).run(clip)
        mc.save(cleaned, target)
        rows.append(target.read_text().split("Frame Time:")[1].splitlines()[1:])
    first, stop = logs[-1].touched
    changed = [i for i, (a, b) in enumerate(zip(*rows, strict=True)) if a != b]
    assert changed and first <= min(changed) and max(changed) < stop, (first, stop, changed)
