"""The command line as a user runs it: outputs, reports, exit codes, one-line errors."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import REPORT_KEYS, ROOT, SAMPLE, degrees_between, run_cli, with_t_pose

import motionclean as mc
from motionclean.cli.options import one_line
from motionclean.core import quat
from motionclean.filters import multires
from motionclean.io.csv import format_csv
from motionclean.steps.pipeline import REGISTRY, Pipeline


def run(args, capsys):
    """Run the console entry point with ``args``; return (exit code, stdout, stderr)."""
    return run_cli(capsys, *args)


def test_version(capsys):
    code, out, _ = run(["--version"], capsys)
    assert code == 0 and mc.__version__ in out


def test_python_dash_m_runs_the_command_line():
    """``python -m motionclean`` is the same program, named ``motionclean`` in its messages."""
    done = subprocess.run(
        [sys.executable, "-m", "motionclean", "info", "missing.bvh"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.startswith("motionclean: error: missing.bvh")
    assert done.stderr.count("\n") == 1


def test_clean_writes_clip_and_json_report(noisy_path, tmp_path, capsys):
    out, report = tmp_path / "clean.bvh", tmp_path / "report.json"
    code, stdout, err = run(
        [
            "clean",
            noisy_path,
            "-o",
            out,
            "-f",
            "lee-shin:mask=binomial,k=2,iterations=5",
            "--report",
            report,
        ],
        capsys,
    )
    assert code == 0, err
    assert "all joints" in stdout
    data = json.loads(report.read_text())
    assert set(data) == REPORT_KEYS
    assert data["pipeline"][0]["filter"] == "lee-shin" and data["pipeline"][0]["iterations"] == 5
    knee = data["joints"]["LeftKnee"]
    assert set(knee) >= {"angular_accel_rms", "angular_accel_max", "deviation_deg"}
    assert knee["angular_accel_rms"]["after"] < knee["angular_accel_rms"]["before"]
    summary = data["summary"]
    assert 0.0 < summary["noise_reduction"] < 1.0
    assert summary["deviation_deg_max"] > 0.0
    cleaned = mc.load(out)
    assert cleaned.n_frames == data["frames"]


def test_clean_refuses_to_overwrite_its_input(sample_path, tmp_path, capsys):
    target = tmp_path / "clip.bvh"
    target.write_bytes(sample_path.read_bytes())
    code, _, err = run(["clean", target, "-o", target], capsys)
    assert code == 2
    assert err.count("\n") == 1 and "refusing to overwrite the input" in err
    assert target.read_bytes() == sample_path.read_bytes()
    code, _, err = run(["clean", target, "--in-place", "-q"], capsys)
    assert code == 0, err
    assert target.read_bytes() != sample_path.read_bytes()


def test_invalid_pipeline_exits_2_before_reading_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out.bvh"
    code, _, err = run(["clean", tmp_path / "missing.bvh", "-o", out, "-f", "lee-shin:k=x"], capsys)
    assert code == 2
    assert err.startswith("motionclean: error: -f: step 1 (lee-shin): k must be an integer")
    assert err.count("\n") == 1
    assert not out.exists()


def test_pipeline_file_and_inline_steps_are_exclusive(sample_path, tmp_path, capsys):
    pipe = tmp_path / "p.toml"
    pipe.write_text('[[step]]\nfilter = "lee-shin"\n')
    code, _, err = run(
        ["clean", sample_path, "-o", tmp_path / "o.bvh", "-p", pipe, "-f", "lee-shin"], capsys
    )
    assert code == 2 and "either -p" in err


def test_bad_clip_is_one_line_with_exit_1_and_no_output(tmp_path, capsys):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation\n")
    out = tmp_path / "out.bvh"
    code, _, err = run(["clean", bad, "-o", out], capsys)
    assert code == 1
    assert err == f"motionclean: error: {bad}:5: CHANNELS says 3 but names 2\n"
    assert not out.exists()
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize(
    "option",
    [
        ("--animation", "Walk", "glTF"),
        ("--input-fps", "30", "SMPL"),
        ("--exclude", "*_force", "OpenSim"),
        ("--skeleton", SAMPLE, "CSV and SMPL"),
    ],
    ids=lambda option: option[0],
)
def test_a_read_option_the_clips_format_does_not_use_is_refused(option, tmp_path, capsys):
    """``clean walk.bvh --input-fps 30`` would otherwise run at the file's own rate, the
    option silently dropped: a usage error naming the option and what it is for, nothing
    written. A command reading two clips takes it when one of them uses it; ``batch``
    (folders of mixed formats) lets each file take what applies to it, and refuses an
    option none of its clips uses."""
    flag, value, kind = option
    out = tmp_path / "out.bvh"
    code, _, err = run(["clean", SAMPLE, "-o", out, flag, value], capsys)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith(f"motionclean: error: {SAMPLE}: {flag} applies to {kind}")
    assert err.rstrip().endswith("not to a .bvh file") and not out.exists()
    code, _, err = run(["info", SAMPLE, flag, value], capsys)
    assert code == 2 and flag in err
    if flag == "--skeleton":  # a channel CSV beside the BVH: it reads the CSV
        channels = tmp_path / "clip.csv"
        mc.save(mc.load(SAMPLE), channels)
        code, _, err = run(["report", SAMPLE, channels, flag, value], capsys)
        assert code == 0, err
        motive = ROOT / "sample_data" / "131_02_motive.csv"  # a CSV by suffix, not by kind
        code, _, err = run(["info", motive, flag, value], capsys)
        assert code == 2 and "not to an OptiTrack Motive export" in err
        rigid = tmp_path / "bodies.csv"  # a rigid-body CSV: its bodies carry their poses
        rigid.write_bytes(format_csv(mc.load(motive), layout="rigid"))
        code, _, err = run(["convert", rigid, tmp_path / "bodies.bvh", flag, value], capsys)
        assert code == 2 and "not to a rigid-body CSV" in err, err
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "a.bvh").write_bytes(SAMPLE.read_bytes())
    code, _, err = run(["batch", folder, "-o", tmp_path / "cleaned", "-q", flag, value], capsys)
    assert code == 2 and not (tmp_path / "cleaned").exists()
    assert err.startswith(f"motionclean: error: {folder / 'a.bvh'}: {flag} applies to"), err
    if flag == "--skeleton":  # a folder of both: each file takes what applies to it
        mc.save(mc.load(SAMPLE), folder / "b.csv")
        code, _, err = run(["batch", folder, "-o", tmp_path / "cleaned", "-q", flag, value], capsys)
        assert code == 0, err
        assert (tmp_path / "cleaned" / "a.bvh").is_file()
        assert (tmp_path / "cleaned" / "b.csv").is_file()


def test_unknown_command_is_a_one_line_usage_error(capsys):
    code, _, err = run(["frobnicate"], capsys)
    assert code == 2 and err.count("\n") == 1 and err.startswith("motionclean: error:")


def test_an_error_naming_a_file_with_a_line_break_stays_one_line(tmp_path, capsys):
    """A file named with a line break (a shell makes one easily): the error line shows it
    escaped, so a log or CI step reading one line per error still reads one."""
    broken = tmp_path / "in" / "take\n2.bvh"
    broken.parent.mkdir()
    broken.write_text("HIERARCHY\nROOT Hips\n{\n")
    for args in (["info", broken], ["batch", broken.parent, "-o", tmp_path / "out", "-q"]):
        code, _, err = run(args, capsys)
        assert code == 1 and err.count("\n") == 1, err
        assert err.startswith(f"motionclean: error: {one_line(str(broken))}:"), err
        assert "\\n" in one_line(str(broken))
    named = tmp_path / "in" / "walk\n1.bvh"  # and a warning about it
    named.write_bytes(SAMPLE.read_bytes())
    code, _, err = run(
        ["clean", named, "-o", tmp_path / "o.bvh", "-q", "-f", "lee-shin:joints=[Nope]"], capsys
    )
    assert code == 0 and err.count("\n") == 1, err
    assert err.startswith(f"motionclean: warning: {one_line(str(named))}: step 1"), err


def test_info_finds_the_rthumb_flip(sample_path, capsys):
    code, out, _ = run(["info", sample_path], capsys)
    assert code == 0
    assert "frames: 300" in out and "rate: 120 fps" in out
    motion = mc.load(sample_path)
    steps = np.degrees(quat.angle_between(motion.rotations[:-1], motion.rotations[1:]))
    thumb = motion.names.index("RThumb")
    line = next(row for row in out.splitlines() if row.strip().startswith("RThumb "))
    assert f"{steps[:, thumb].max():.2f}" in line
    assert str(int(np.argmax(steps[:, thumb])) + 1) in line.split()


@pytest.mark.parametrize("clip", ["dropout", "t-pose"])
def test_info_gives_the_reports_acceleration_figures(clip, tmp_path, capsys):
    """info's accel rms, per joint and over all, is the report's: the rows next to a
    dropout (131_02_motive.csv: hand_l, frames 40-47) and a rest pose are left out, not
    counted as zeros."""
    if clip == "dropout":
        source = ROOT / "sample_data" / "131_02_motive.csv"
    else:
        source = with_t_pose(SAMPLE, tmp_path / "t.bvh")
    code, out, _ = run(["info", source], capsys)
    assert code == 0
    code, _, _ = run(["report", source, "--json", tmp_path / "r.json"], capsys)
    report = json.loads((tmp_path / "r.json").read_text())
    rows = {cells[0]: cells for cells in map(str.split, out.splitlines()) if cells}
    for name, entry in report["joints"].items():
        if "angular_accel_rms" in entry:
            assert rows[name][-2] == f"{entry['angular_accel_rms']['before']:,.0f}", name
    total = report["summary"]["angular_accel_rms"]["before"]
    assert f"RMS angular acceleration {total:,.0f} deg/s^2" in out


@pytest.mark.parametrize("given", [(), ("--source", "video")], ids=["auto", "video"])
@pytest.mark.parametrize("name", ["131_02_noisy.bvh", "131_02_motive.csv"])
def test_report_finds_the_capture_source_as_clean_does(name, given, tmp_path, capsys):
    """`report IN` measures the clip's motion slope where the default clean's auto step
    does, after despike (the noisy sample's flips) and fill-gaps (the tracker CSV's
    dropout): the same line, the same slope, a source given or not (the slope had been
    null in `report`'s JSON where a source was given)."""
    source = ROOT / "sample_data" / name
    cleaned, found = tmp_path / f"c{source.suffix}", tmp_path / "c.json"
    code, out, _ = run(["clean", source, "-o", cleaned, "--report", found, *given], capsys)
    line = next(row for row in out.splitlines() if row.startswith("capture source:"))
    code, text, _ = run(["report", source, "--json", tmp_path / "r.json", *given], capsys)
    assert code == 0 and line in text.splitlines()
    joints = json.loads(found.read_text())["joints"].values()
    notes = {(j["auto"]["motion_slope"], j["auto"]["source_measured"]) for j in joints}
    said = json.loads((tmp_path / "r.json").read_text())["capture_source"]
    assert notes == {(said["motion_slope"], said["source_measured"])}


def test_filters_catalogue_lists_every_filter_with_parameters(capsys):
    code, out, _ = run(["filters"], capsys)
    assert code == 0
    assert max(len(line) for line in out.splitlines()) < 200  # (auto's summary was 205)
    flat = " ".join(out.split())
    for spec in REGISTRY.values():
        assert f"{spec.name}: " in out
        assert " ".join(spec.paper.split()) in flat
        for param in spec.params:
            assert param.name in out


def test_report_before_and_after_pair(noisy_path, tmp_path, capsys):
    cleaned = tmp_path / "c.bvh"
    assert run(["clean", noisy_path, "-o", cleaned, "-q"], capsys)[0] == 0
    js = tmp_path / "r.json"
    code, out, _ = run(["report", noisy_path, cleaned, "--json", js], capsys)
    assert code == 0 and "removed" in out
    data = json.loads(js.read_text())
    assert data["summary"]["noise_reduction"] > 0.3
    code, _, err = run(["report", noisy_path, tmp_path / "nope.bvh"], capsys)
    assert code == 1 and "no such file" in err


def test_stitch_and_blend_commands(sample_path, tmp_path, capsys):
    motion = mc.load(sample_path)
    first, second = tmp_path / "a.bvh", tmp_path / "b.bvh"
    mc.save(
        motion.replace(
            rotations=motion.rotations[:120],
            translations=motion.translations[:120],
            source_values=None,
            source_rotations=None,
        ),
        first,
    )
    mc.save(
        motion.replace(
            rotations=motion.rotations[150:],
            translations=motion.translations[150:],
            source_values=None,
            source_rotations=None,
        ),
        second,
    )
    out = tmp_path / "s.bvh"
    code, _, err = run(["stitch", first, second, "-o", out, "--levels", "3"], capsys)
    assert code == 0, err
    stitched = mc.load(out)
    assert stitched.n_frames == 120 + 150 - 1
    a = mc.load(first)
    unchanged = 120 - 3 * (2**3 - 1) - 1
    gap = quat.angle_between(stitched.rotations[:unchanged], a.rotations[:unchanged])
    assert np.degrees(gap).max() < 1e-5
    code, _, err = run(["blend", first, second, "-o", tmp_path / "x.bvh"], capsys)
    assert code == 1 and "frames" in err and err.count("\n") == 1
    code, _, err = run(["blend", first, first, "-o", tmp_path / "x.bvh", "--weight", "0.3"], capsys)
    assert code == 0, err
    blended = mc.load(tmp_path / "x.bvh")
    assert np.degrees(quat.angle_between(blended.rotations, a.rotations)).max() < 1e-5


def test_blend_says_which_joints_flip_across_the_blend(tmp_path, capsys):
    """A joint that flips by half turns nothing repaired is blended across its flips (a
    tester's RThumb swung 169 degrees from both inputs): the command names it and what to
    do; a clip without such a step gets no note."""
    noisy = ROOT / "sample_data" / "131_02_noisy.bvh"
    code, out, err = run(["blend", noisy, noisy, "-o", tmp_path / "b.bvh"], capsys)
    assert code == 0 and not err
    notes = [line for line in out.splitlines() if line.startswith("note: ")]
    # (one note per file: the same file given twice had been told twice)
    assert len(notes) == 1 and "RThumb steps by more than 90 degrees" in notes[0]
    assert notes[0].endswith("the blend crosses them; despike the clip first (clean -f despike)")
    calm = ROOT / "tests" / "data" / "exporters" / "mocapbank_walk.bvh"
    code, out, err = run(["blend", calm, calm, "-o", tmp_path / "c.bvh"], capsys)
    assert code == 0 and not err and "note:" not in out


def stitched_notes(tmp_path, capsys, seam: int) -> tuple[Path, list[str]]:
    """The noisy sample cut at ``seam`` (the halves share that frame) and stitched back:
    the first half's path and the command's notes."""
    noisy = mc.load(ROOT / "sample_data" / "131_02_noisy.bvh")
    first, second = tmp_path / "a.bvh", tmp_path / "b.bvh"
    mc.save(noisy.at_frames(slice(0, seam + 1)), first)
    mc.save(noisy.at_frames(slice(seam, None)), second)
    code, out, err = run(["stitch", first, second, "-o", tmp_path / "s.bvh"], capsys)
    assert code == 0 and not err
    return first, [line for line in out.splitlines() if line.startswith("note: ")]


def test_stitch_says_which_joints_flip_within_the_transition(tmp_path, capsys):
    """RThumb's flips (frames 48-70, 233-255 of the noisy sample) within the 45 frames
    either side of a seam at 100 are blended across, and said (stitch had said nothing
    where blend notes it)."""
    first, notes = stitched_notes(tmp_path, capsys, 100)
    assert notes == [
        f"note: {first}: RThumb steps by more than 90 degrees between frames (flips or "
        "glitches): the transition crosses them; despike the clip first (clean -f despike)"
    ]


def test_stitch_says_nothing_of_flips_outside_the_transition(tmp_path, capsys):
    assert stitched_notes(tmp_path, capsys, 150)[1] == []


def test_stitch_of_a_clip_with_itself_notes_flips_at_either_end(tmp_path, capsys):
    """The same file as both clips: its end (the first clip's side) and its start (the
    second's) are each looked at (keyed by path, the start's look had replaced the end's)."""
    noisy = mc.load(ROOT / "sample_data" / "131_02_noisy.bvh")
    loop = tmp_path / "loop.bvh"
    mc.save(noisy.at_frames(slice(0, 76)), loop)  # flips at 48-51, 64-70: near its end
    code, out, err = run(["stitch", loop, loop, "-o", tmp_path / "s.bvh", "--levels", "3"], capsys)
    assert code == 0 and not err
    assert [line for line in out.splitlines() if line.startswith("note: ")] == [
        f"note: {loop}: RThumb steps by more than 90 degrees between frames (flips or "
        "glitches): the transition crosses them; despike the clip first (clean -f despike)"
    ]


def test_stitch_refuses_different_skeletons(sample_path, tmp_path, capsys):
    other = tmp_path / "other.bvh"
    other.write_bytes(sample_path.read_bytes().replace(b"LeftKnee", b"LeftKnee2"))
    code, _, err = run(["stitch", sample_path, other, "-o", tmp_path / "s.bvh"], capsys)
    assert code == 1 and "skeleton differs" in err
    assert not (tmp_path / "s.bvh").exists()


@pytest.mark.parametrize("empty_first", [False, True])
def test_stitch_refuses_a_clip_without_frames(sample_path, tmp_path, capsys, empty_first):
    text = sample_path.read_text()
    head, motion = text.split("MOTION\n", 1)
    frame_time = motion.splitlines()[1]
    empty = tmp_path / "empty.bvh"
    empty.write_text(f"{head}MOTION\nFrames: 0\n{frame_time}\n")
    pair = [empty, sample_path] if empty_first else [sample_path, empty]
    code, _, err = run(["stitch", *pair, "-o", tmp_path / "s.bvh"], capsys)
    assert (
        code == 1 and err == f"motionclean: error: {empty}: cannot stitch a clip without frames\n"
    )
    assert not (tmp_path / "s.bvh").exists()


def test_default_clean_repairs_flips_and_reports_where(sample_path, tmp_path, capsys):
    report = tmp_path / "r.json"
    code, out, err = run(
        ["clean", sample_path, "-o", tmp_path / "c.bvh", "--report", report], capsys
    )
    assert code == 0, err
    data = json.loads(report.read_text())
    assert [step["filter"] for step in data["pipeline"]] == [
        "despike",
        "fill-gaps",
        "auto",
        "footlock",
    ]
    thumb = data["joints"]["RThumb"]["despike"]
    assert thumb["frames_repaired"] > 0 and thumb["max_step"]["after"] < 30.0
    assert "repaired RThumb:" in out
    cleaned = mc.load(tmp_path / "c.bvh")
    steps = np.degrees(quat.angle_between(cleaned.rotations[:-1], cleaned.rotations[1:]))
    assert steps.max() < 30.0


def test_stitch_says_when_the_clips_are_too_short_for_the_levels_asked(
    sample_path, tmp_path, capsys
):
    """A take cut in two and stitched back with --levels 9: the transition would have
    reached both clips' far ends (a joint 999 frames from the seam had turned 176 degrees);
    the levels that fit are used, and said, and the far ends are the clips' own."""
    clip = mc.load(sample_path)
    half = clip.n_frames // 2
    first, second = tmp_path / "a.bvh", tmp_path / "b.bvh"
    mc.save(clip.at_frames(slice(0, half + 1)), first)
    mc.save(clip.at_frames(slice(half, None)), second)
    out = tmp_path / "s.bvh"
    code, stdout, err = run(["stitch", first, second, "-o", out, "--levels", "9"], capsys)
    assert code == 0 and not err
    used = multires.stitch_levels(half + 1, clip.n_frames - half, 9)
    assert used == 5  # 150 and 151 frames: 4 x 2^5 + 1 = 129 fit, 4 x 2^6 + 1 do not
    assert stdout.startswith("stitched on 5 levels, not 9: ")
    stitched, width = mc.load(out), 3 * (2**used - 1)
    # (the halves are written afresh: their text is theirs, the rotations the clip's)
    far = np.r_[0 : half - width, half + width + 1 : clip.n_frames]
    assert degrees_between(stitched.rotations[far], clip.rotations[far]).max() < 1e-4
    a_text, b_text = mc.load(first).source_values, mc.load(second).source_values
    assert np.array_equal(stitched.source_values[: half - width], a_text[: half - width])
    tail = b_text[width + 1 :, 6:]  # (the root moved: aligned)
    assert np.array_equal(stitched.source_values[half + width + 1 :, 6:], tail)


def test_stitch_keeps_every_frame_outside_the_transition(sample_path, tmp_path, capsys):
    out = tmp_path / "s.bvh"
    code, _, err = run(["stitch", sample_path, sample_path, "-o", out, "--levels", "4"], capsys)
    assert code == 0, err
    clip, stitched = mc.load(sample_path), mc.load(out)
    width = 3 * (2**4 - 1)
    seam = clip.n_frames - 1
    # channel values, Euler branch included, are the input's away from the seam
    assert np.array_equal(
        stitched.source_values[: seam - width], clip.source_values[: seam - width]
    )
    # the second clip's root is moved to where the first ends; without alignment every
    # channel is the input's, with it every channel but the root's
    assert not np.array_equal(
        stitched.source_values[seam + width + 1 :, :6], clip.source_values[width + 1 :, :6]
    )
    assert np.array_equal(
        stitched.source_values[seam + width + 1 :, 6:], clip.source_values[width + 1 :, 6:]
    )
    run(["stitch", sample_path, sample_path, "-o", out, "--no-align"], capsys)
    unaligned = mc.load(out)
    assert np.array_equal(
        unaligned.source_values[seam + width + 1 :], clip.source_values[width + 1 :]
    )


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--report", "r.txt"], "a report must end in .json or .html"),
        (["--report", "nowhere/r.json"], "no folder"),
    ],
)
def test_bad_report_path_is_refused_before_anything_is_written(
    sample_path, tmp_path, capsys, extra, message
):
    out = tmp_path / "c.bvh"
    args = [a if not a.startswith(("r.", "nowhere")) else tmp_path / a for a in extra]
    code, _, err = run(["clean", sample_path, "-o", out, *args], capsys)
    assert code == 2 and message in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize(
    ("option", "name", "message"),
    [
        ("--json", "r.html", "--json {}: the file name must end in .json"),
        ("--html", "r.json", "--html {}: the file name must end in .html or .htm"),
    ],
)
def test_report_options_write_their_own_format_or_refuse(
    sample_path, tmp_path, capsys, option, name, message
):
    """`report --json r.html` had written the page (the suffix decided, the option was
    ignored): a name of the other format is a usage error, before any work."""
    target = tmp_path / name
    code, _, err = run(["report", sample_path, option, target], capsys)
    assert code == 2 and message.format(target) in err and err.count("\n") == 1
    assert not target.exists()
    code, _, err = run(["report", sample_path, "--html", tmp_path / "r.htm"], capsys)
    assert code == 0 and (tmp_path / "r.htm").read_text().startswith("<!DOCTYPE html>")


def test_clip_output_must_have_a_known_suffix(sample_path, tmp_path, capsys):
    code, _, err = run(["clean", sample_path, "-o", tmp_path / "c.json"], capsys)
    assert code == 2 and "a clip must end in .bvh or .csv" in err


def test_a_joint_pattern_that_matches_nothing_is_warned_about(sample_path, tmp_path, capsys):
    code, _, err = run(
        [
            "clean",
            sample_path,
            "-o",
            tmp_path / "c.bvh",
            "-q",
            "-f",
            "lee-shin:joints=['LeftKnee','LeftKnea']",
        ],
        capsys,
    )
    assert code == 0
    assert "warning" in err and "'LeftKnea' matches no joint" in err
    assert "LeftKnee'" not in err


def test_bare_command_shows_help(capsys):
    code, out, _ = run([], capsys)
    assert code == 0 and "Commands:" in out and "clean" in out


def test_single_clip_report_has_the_full_summary_schema(sample_path, tmp_path, capsys):
    js = tmp_path / "r.json"
    code, _, _ = run(["report", sample_path, "--json", js], capsys)
    assert code == 0
    summary = json.loads(js.read_text())["summary"]
    assert summary["noise_reduction"] is None and summary["deviation_deg_max"] is None
    assert summary["angular_accel_rms"]["after"] is None


def test_info_cuts_very_long_joint_names_so_every_line_stays_short(tmp_path, capsys):
    """A 100,000-character joint name (as fuzzed files have) is printed cut to 40
    characters (its start and end kept), in its own row and its child's parent column: the
    table does not pad every row to it (it was 6 MB of output here, 320 MB for a 5 MB
    name)."""
    text = SAMPLE.read_text()
    long_name = "L" * 100_000
    clip = tmp_path / "long.bvh"
    clip.write_text(text.replace("JOINT LeftHip", f"JOINT {long_name}", 1))
    code, out, err = run_cli(capsys, "info", clip)
    assert code == 0 and not err
    assert max(map(len, out.splitlines())) < 200
    shown = "L" * 19 + "..." + "L" * 18
    assert sum(line.count(shown) for line in out.splitlines()) == 2  # its row, its child's


def test_report_compares_clips_whose_offsets_moved_by_a_round_trip(tmp_path, capsys):
    """A clip through Blender's FBX comes back with a finger's offset 1.3e-4 off (of a 24
    unit figure): report compares it with its source (it refused: "another OFFSET"); blend,
    which joins the two skeletons' motion, still refuses."""
    text = SAMPLE.read_text()
    moved = text.replace("OFFSET 0 -0.657810 0.000000", "OFFSET 0.000126 -0.657814 -0.000003", 1)
    assert moved != text
    (tmp_path / "moved.bvh").write_text(moved)
    code, _, err = run_cli(capsys, "report", SAMPLE, tmp_path / "moved.bvh")
    assert code == 0, err
    code, _, err = run_cli(
        capsys, "blend", SAMPLE, tmp_path / "moved.bvh", "-o", tmp_path / "b.bvh"
    )
    assert code == 1 and "has another OFFSET" in err


def test_fill_gaps_with_no_longest_gap_fills_every_gap(tmp_path, capsys):
    """max_gap=inf, which the catalogue allows, had ended in an internal error on a clip with
    a gap (an infinity turned into a frame count)."""
    dropouts = ROOT / "sample_data" / "131_02_motive.csv"
    code, _, err = run_cli(
        capsys, "clean", dropouts, "-o", tmp_path / "f.csv", "-q", "-f", "fill-gaps:max_gap=inf"
    )
    assert code == 0, err
    assert mc.load(tmp_path / "f.csv").missing is None


def test_debug_is_taken_after_the_command_too(tmp_path, capsys):
    """`clean ... --debug` had been click's "No such option" with a traceback of its own:
    the option is the group's, and is now taken wherever it is given."""
    code, out, err = run_cli(capsys, "info", SAMPLE, "--debug")
    assert code == 0 and "frames: 300" in out and err == ""


def test_batch_and_check_warn_of_a_joints_pattern_that_matches_nothing(tmp_path, capsys):
    """As clean does (a likely typo): batch and check had said nothing."""
    (tmp_path / "in").mkdir()
    clip = tmp_path / "in" / "a.bvh"
    clip.write_bytes(SAMPLE.read_bytes())
    warning = (
        f"motionclean: warning: {clip}: step 1 (lee-shin): joints pattern 'Nope' matches no joint\n"
    )
    step = ["-f", "lee-shin:joints=[Nope]"]
    code, _, err = run_cli(capsys, "batch", tmp_path / "in", "-o", tmp_path / "out", "-q", *step)
    assert code == 0 and err == warning
    code, _, err = run_cli(
        capsys, "check", clip, "--baseline", tmp_path / "b.json", "--update", *step
    )
    assert code == 0 and err == warning


def test_an_exclusion_that_matches_nothing_is_warned_of(tmp_path, capsys):
    """``!Rthumb`` (RThumb meant) excluded nothing and filtered the joint it was to keep,
    without a word: warned of as an include pattern is; one that matches keeps quiet."""
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(
        capsys, "clean", SAMPLE, "-o", out, "-q", "-f", "lee-shin:joints=['*','!Rthumb']"
    )
    assert code == 0 and err == (
        f"motionclean: warning: {SAMPLE}: step 1 (lee-shin): joints pattern '!Rthumb' "
        "matches no joint\n"
    )
    code, _, err = run_cli(
        capsys, "clean", SAMPLE, "-o", out, "-q", "-f", "lee-shin:joints=['*','!RThumb']"
    )
    assert code == 0 and err == ""


def test_a_feet_pattern_that_matches_nothing_is_warned_of(tmp_path, capsys):
    """footlock's ``feet`` names joints as ``joints`` does: a typo had locked no foot and
    said nothing. A pattern that matches keeps quiet."""
    out = tmp_path / "o.bvh"
    code, _, err = run_cli(
        capsys, "clean", SAMPLE, "-o", out, "-q", "-f", "footlock:feet=[LeftAnkle,LeftFoot]"
    )
    assert code == 0
    assert err == (
        f"motionclean: warning: {SAMPLE}: step 1 (footlock): feet pattern 'LeftFoot' "
        "matches no joint\n"
    )


def strict_json(text: str):
    """``text`` read as strict JSON: no ``Infinity`` / ``NaN`` token, no number as text."""

    def refuse(token: str):
        raise ValueError(f"not strict JSON: {token}")

    data = json.loads(text, parse_constant=refuse)
    assert not re.search(r'"-?(inf|nan)"', text, re.IGNORECASE)  # (a number written as text)
    return data


def test_the_json_report_is_strict_and_its_pipeline_reads_back(noisy_path, tmp_path, capsys):
    """despike's max_units_per_s (inf by default: none given) had been the string "inf" among
    JSON numbers; it is null, and the pipeline reads back as the one that ran."""
    report = tmp_path / "r.json"
    steps = ["-f", "despike", "-f", "bilateral:sigma_g=inf,sigma_p=inf"]
    code, _, err = run(
        ["clean", noisy_path, "-o", tmp_path / "c.bvh", "--report", report, *steps], capsys
    )
    assert code == 0, err
    pipeline = strict_json(report.read_text())["pipeline"]
    assert pipeline[0]["max_units_per_s"] is None and pipeline[1]["sigma_g"] is None
    ran = Pipeline.from_inline(steps[1::2])
    tables = [{k: v for k, v in step.items() if k != "touched"} for step in pipeline]
    assert Pipeline.from_tables(tables, "r.json").describe() == ran.describe()


def test_report_of_a_resampled_clean_says_how_to_compare_it(tmp_path, capsys):
    """`report IN OUT` where OUT was resampled by its cleaning: refused (the frames are
    not the input's), the line saying what compares them (`clean --report`)."""
    out = tmp_path / "half.bvh"
    code, _, err = run_cli(capsys, "clean", SAMPLE, "-o", out, "-f", "resample:fps=60", "-q")
    assert code == 0, err
    code, _, err = run_cli(capsys, "report", SAMPLE, out)
    assert code == 1 and err.count("\n") == 1
    assert "frame time 0.0166667 s differs" in err and "`clean --report` compares it" in err
