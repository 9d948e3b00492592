"""`motionclean check`: a fresh baseline passes; a noisier clip fails, named; clear errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from helpers import SAMPLE, cut_bvh, run_cli

import motionclean as mc
from motionclean.cli.check import (
    ABSOLUTE,
    DEFAULT_TOLERANCE,
    FORMAT,
    JOINT_FIGURES,
    compare,
    compare_joints,
)
from motionclean.core import quat
from motionclean.report.summary import json_safe
from motionclean.steps.pipeline import Pipeline


@pytest.fixture
def clips(tmp_path, monkeypatch) -> list[str]:
    monkeypatch.chdir(tmp_path)  # baseline keys are paths relative to the current folder
    Path("clips").mkdir()
    return [
        cut_bvh(SAMPLE, Path("clips") / f"{name}.bvh", 80).as_posix() for name in ("calm", "busy")
    ]


def make_noisier(path: str) -> None:
    motion = mc.load(path)
    rng = np.random.default_rng(7)
    noise = quat.exp(rng.normal(scale=0.02, size=motion.rotations.shape[:-1] + (3,)))
    mc.save(motion.replace(rotations=quat.multiply(motion.rotations, noise)), path)


def test_fresh_baseline_passes_then_a_noisier_clip_fails(clips, capsys):
    code, stdout, _ = run_cli(capsys, "check", *clips, "--baseline", "base.json", "--update")
    assert code == 0 and "baseline written" in stdout
    recorded = json.loads(Path("base.json").read_text())
    assert sorted(recorded["clips"]) == sorted(clips)
    assert recorded["pipeline"] == json_safe(Pipeline.default().describe())

    code, stdout, stderr = run_cli(capsys, "check", *clips, "--baseline", "base.json")
    assert code == 0, stderr
    assert "check passed" in stdout and "WORSE" not in stdout

    make_noisier("clips/busy.bvh")
    code, stdout, stderr = run_cli(capsys, "check", *clips, "--baseline", "base.json")
    assert code == 1
    assert "clips/busy.bvh" in stderr and "clips/calm.bvh" not in stderr
    assert "noise after got worse" in stderr
    assert all(
        line.startswith("motionclean: error: clips/busy.bvh: ")
        for line in stderr.strip().splitlines()
    )
    worse = [line for line in stdout.splitlines() if line.rstrip().endswith("WORSE")]
    assert worse and "noise after" in worse[0]


def test_a_weaker_pipeline_fails_and_a_looser_tolerance_does_not(clips, capsys):
    assert (
        run_cli(
            capsys,
            "check",
            *clips,
            "--baseline",
            "b.json",
            "--update",
            "-f",
            "lee-shin:k=2,iterations=3",
        )[0]
        == 0
    )
    code, _, stderr = run_cli(
        capsys, "check", *clips, "--baseline", "b.json", "-f", "lee-shin:k=2,iterations=2"
    )
    # (each clip's joints got noisier; the clip's own figure is its RThumb's flips, which
    # lee-shin leaves as they are)
    lines = stderr.strip().splitlines()
    worse = re.compile(r"\d+ figures? of \d+ joints got worse")
    assert code == 1 and len(lines) == 2 and all(worse.search(line) for line in lines)
    assert all("noise after" in line for line in lines)
    code, _, _ = run_cli(
        capsys,
        "check",
        *clips,
        "--baseline",
        "b.json",
        "-f",
        "lee-shin:k=2,iterations=2",
        "--tolerance",
        "100",
    )
    assert code == 0
    for tolerance in ("nan", "inf"):  # would pass any regression: refused as usage
        code, stdout, stderr = run_cli(
            capsys, "check", *clips, "--baseline", "b.json", "--tolerance", tolerance
        )
        assert code == 2 and not stdout
        assert stderr.strip().splitlines() == [
            f"motionclean: error: Invalid value for '--tolerance': {tolerance} is not a "
            "finite number."
        ]


def test_missing_baseline_is_a_clear_error(clips, capsys):
    code, stdout, stderr = run_cli(capsys, "check", *clips, "--baseline", "none.json")
    assert code == 2 and stdout == ""
    assert stderr.strip() == (
        "motionclean: error: none.json: no such baseline; create it with --update"
    )
    assert not Path("none.json").exists()
    Path("d.json").mkdir()
    code, stdout, stderr = run_cli(capsys, "check", *clips, "--baseline", "d.json")
    assert (code, stdout) == (2, "")
    assert stderr == "motionclean: error: d.json: is a directory, not a baseline\n"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda e: e.update(frames="x"), "frames 'x' is not a whole number"),
        (lambda e: e.update(noise_after=-5), "noise_after '-5' is not a number of at least 0"),
        (lambda e: e.update(noise_after=10**400), "noise_after '10000000000000000000' is not a"),
        (lambda e: e.update(joints=[]), "joints is not a table"),
        (lambda e: e["joints"].update(Hips=3), "joint 'Hips': not a table of figures"),
        (lambda e: e.clear(), "frames 'None' is not a whole number"),
        (lambda e: e.update(content="abc"), "content 'abc' is not a SHA-256 digest"),
    ],
)
def test_a_baseline_edited_by_hand_is_refused_naming_the_clip(clips, capsys, edit, message):
    """Figures that are no figures had ended in internal errors (a text where a number
    was formatted, a list taken for a table) or printed -100228.5 %."""
    assert run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--update")[0] == 0
    document = json.loads(Path("b.json").read_text())
    edit(document["clips"][clips[0]])
    Path("b.json").write_text(json.dumps(document))
    code, stdout, stderr = run_cli(capsys, "check", clips[0], "--baseline", "b.json")
    assert code == 1 and stdout == "" and stderr.count("\n") == 1
    assert stderr.startswith(
        f"motionclean: error: b.json: not a motionclean baseline: clip {clips[0]!r}: "
    )
    assert message in stderr


def test_a_clip_named_twice_is_checked_and_recorded_once(clips, capsys):
    code, stdout, _ = run_cli(
        capsys, "check", clips[0], clips[0], "--baseline", "b.json", "--update"
    )
    assert code == 0 and "(1 clip recorded)" in stdout
    assert list(json.loads(Path("b.json").read_text())["clips"]) == [clips[0]]


def test_update_with_a_broken_clip_writes_nothing(clips, capsys):
    Path("clips/broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    code, _, stderr = run_cli(
        capsys, "check", *clips, "clips/broken.bvh", "--baseline", "b.json", "--update"
    )
    assert code == 1 and "clips/broken.bvh" in stderr
    assert not Path("b.json").exists()


def test_update_into_a_missing_folder_is_refused_before_any_clip(clips, capsys):
    Path(clips[0]).write_text("not a clip: never read")
    code, stdout, stderr = run_cli(
        capsys, "check", *clips, "--baseline", "nodir/b.json", "--update"
    )
    assert (code, stdout) == (2, "")
    assert stderr == "motionclean: error: nodir/b.json: no folder 'nodir' to write into\n"
    assert not Path("nodir").exists()
    code, _, stderr = run_cli(capsys, "check", *clips, "--baseline", "b.txt", "--update")
    assert code == 2 and stderr == "motionclean: error: b.txt: a baseline must end in .json\n"
    assert not Path("b.txt").exists()


def test_clip_missing_from_the_baseline_fails(clips, capsys):
    assert run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--update")[0] == 0
    code, _, stderr = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert code == 1 and f"{clips[1]}: not in the baseline" in stderr


def test_a_recorded_clip_that_is_not_checked_fails_until_the_baseline_drops_it(clips, capsys):
    """A clip deleted from the test set had passed silently ('check passed: 1 clip'): the
    check now fails naming it, until a baseline is recorded without it."""
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    Path(clips[1]).unlink()
    code, out, err = run_cli(capsys, "check", clips[0], "--baseline", "b.json")
    assert code == 1 and "check passed" not in out and f"{clips[0]} " in out
    assert err == (
        f"motionclean: error: b.json: 1 recorded clip not checked: {clips[1]}; check it too, "
        "or record the baseline without it (--update --replace with the clips to keep)\n"
    )
    args = ("check", clips[0], "--baseline", "b.json")
    assert run_cli(capsys, *args, "--update", "--replace")[0] == 0
    code, out, err = run_cli(capsys, *args)
    assert (code, err) == (0, "") and "check passed: 1 clip " in out


def test_compare_limits():
    base = {
        "frames": 10,
        "noise_before": 100.0,
        "noise_after": 10.0,
        "deviation_max": 2.0,
        "deviation_rms": 1.0,
    }
    t = DEFAULT_TOLERANCE

    def verdicts(**now):
        return {label: v for label, _, _, v in compare(dict(base, **now), base, t)}

    assert set(verdicts().values()) == {"ok"}
    assert set(verdicts(noise_after=10.0 * (1 + t) * (1 - 1e-9)).values()) == {"ok"}
    assert verdicts(noise_after=10.0 * (1 + 2 * t))["noise after, deg/s^2"] == "WORSE"
    assert verdicts(deviation_max=1.0)["deviation max, deg"] == "better"
    assert verdicts(noise_before=90.0)["noise before, deg/s^2"] == "CHANGED"
    assert verdicts(frames=11)["frames"] == "CHANGED"
    zero = dict(base, deviation_max=0.0)
    assert compare(dict(zero, deviation_max=1e-12), zero, t)[2][3] == "ok"


def test_compare_joints_flags_a_rise_just_above_the_tolerance_and_not_one_just_below():
    """One joint's figure rising by more than the tolerance is a regression of its own,
    whatever the other joints do; a rise within it is not."""
    t = DEFAULT_TOLERANCE
    key, label = JOINT_FIGURES[0]
    base = {"joints": {"LeftHand": {key: 10.0}, "Hips": {key: 50.0}}}
    limit = 10.0 * (1 + t) + ABSOLUTE

    def rows(value):
        return compare_joints({"joints": {"LeftHand": {key: value}, "Hips": {key: 50.0}}}, base, t)

    assert rows(limit * (1 - 1e-9)) == []
    assert rows(limit * (1 + 1e-9)) == [("LeftHand", label, 10.0, limit * (1 + 1e-9))]


def test_update_of_a_subset_keeps_the_other_clips_and_replace_starts_anew(clips, capsys):
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    calm_before = json.loads(Path("b.json").read_text())["clips"]["clips/calm.bvh"]
    make_noisier(clips[1])
    code, stdout, _ = run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update")
    assert code == 0 and "1 others kept" in stdout
    recorded = json.loads(Path("b.json").read_text())["clips"]
    assert sorted(recorded) == sorted(clips) and recorded["clips/calm.bvh"] == calm_before
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json")[0] == 0
    code, _, _ = run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--update", "--replace")
    assert code == 0 and list(json.loads(Path("b.json").read_text())["clips"]) == [clips[0]]
    code, _, err = run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--replace")
    assert code == 2 and "--replace goes with --update" in err


def test_an_update_that_changes_the_pipeline_must_cover_every_recorded_clip(clips, capsys):
    """An --update with another pipeline on some of the baseline's clips had overwritten
    its one "pipeline" and kept the others' figures of the old one: a mixed baseline that
    failed them under the new pipeline with no word of why. It is refused, nothing written;
    updating every clip, or a new baseline, changes the pipeline."""
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    recorded = Path("b.json").read_bytes()
    other = ("-f", "lee-shin:k=2,iterations=3")
    code, out, err = run_cli(capsys, "check", clips[1], *other, "--baseline", "b.json", "--update")
    assert (code, out) == (2, "") and Path("b.json").read_bytes() == recorded
    assert err == (
        "motionclean: error: b.json: recorded with another pipeline, which 1 clip not given "
        f"would keep ({clips[0]}); to change the pipeline, update every clip in it, or start "
        "a new baseline (--replace, or another file)\n"
    )
    assert run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update")[0] == 0
    code, out, _ = run_cli(capsys, "check", *clips, *other, "--baseline", "b.json", "--update")
    assert code == 0 and "(2 clips recorded)" in out
    code, out, err = run_cli(capsys, "check", *clips, *other, "--baseline", "b.json")
    assert (code, err) == (0, "") and "pipeline differs" not in out
    args = ("check", clips[0], "--baseline", "b.json", "--update", "--replace")
    assert run_cli(capsys, *args)[0] == 0  # (a new baseline: the default pipeline's)


def test_a_baseline_holds_inf_as_null_and_one_written_as_text_is_the_same_pipeline(clips, capsys):
    """The default despike's max_units_per_s (inf: none given) is null in the baseline, which
    reads back as the pipeline; a baseline that holds it as the string "inf" (as they were
    written before) is of the same pipeline: no note, and an update of some clips is no
    change of pipeline."""
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    text = Path("b.json").read_text()
    pipeline = json.loads(text, parse_constant=pytest.fail)["pipeline"]
    assert '"inf"' not in text and pipeline[0]["max_units_per_s"] is None
    assert Pipeline.from_tables(pipeline, "b.json").describe() == Pipeline.default().describe()
    Path("b.json").write_text(text.replace('"max_units_per_s": null', '"max_units_per_s": "inf"'))
    code, out, err = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert (code, err) == (0, "") and "pipeline differs" not in out
    assert run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--update")[0] == 0


def test_keys_are_relative_to_the_baseline_folder_and_links_are_not_followed(
    clips, tmp_path, capsys
):
    Path("ci").mkdir()
    Path("elsewhere").mkdir()
    target = Path("elsewhere/real.bvh")
    target.write_bytes(Path(clips[0]).read_bytes())
    Path("clips/linked.bvh").symlink_to(target.resolve())
    code, _, err = run_cli(
        capsys, "check", "clips/linked.bvh", "--baseline", "ci/b.json", "--update"
    )
    assert code == 0, err
    assert list(json.loads(Path("ci/b.json").read_text())["clips"]) == ["../clips/linked.bvh"]
    # the same baseline read from another working folder
    import os

    os.chdir("ci")
    assert run_cli(capsys, "check", "../clips/linked.bvh", "--baseline", "b.json")[0] == 0


def test_errors_name_a_clip_as_given_when_the_baseline_is_in_another_folder(clips, capsys):
    """The baseline's keys are relative to its folder (``../clips/busy.bvh``), a path that
    does not exist from where the command runs: the error lines name the clip as given."""
    Path("ci").mkdir()
    assert run_cli(capsys, "check", *clips, "--baseline", "ci/b.json", "--update")[0] == 0
    make_noisier(clips[1])
    code, _, err = run_cli(capsys, "check", *clips, "--baseline", "ci/b.json")
    assert code == 1 and err.startswith(f"motionclean: error: {clips[1]}: ")
    assert "../clips" not in err and Path(clips[1]).exists()


def test_a_regression_on_one_joint_fails_although_the_clip_maximum_is_unchanged(clips, capsys):
    """The clip's largest deviation is RThumb's repaired flip; a weaker smoothing of the
    other joints leaves it alone but is caught joint by joint."""
    base = ["-f", "despike", "-f", "lee-shin:k=3,iterations=3,joints=['*','!LeftKnee']"]
    weak = [
        "-f",
        "despike",
        "-f",
        "lee-shin:k=3,iterations=3,joints=['*','!LeftKnee','!RightKnee']",
    ]
    assert run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update", *base)[0] == 0
    code, out, err = run_cli(capsys, "check", clips[1], "--baseline", "b.json", *weak)
    assert code == 1 and "1 figure of 1 joint got worse" in err and "RightKnee noise after" in err
    assert "deviation max got worse" not in err  # the clip maximum (RThumb) is unchanged
    worse = [line.split() for line in out.splitlines() if line.rstrip().endswith("WORSE")]
    assert ["RightKnee:", "noise", "after,"] in [row[:3] for row in worse]  # in the table too
    assert_columns_line_up(out)


def assert_columns_line_up(table: str) -> None:
    """Every row's figure and result start under their heads (a joint's label had run into
    the baseline column: 'LeftHip: deviation max, deg')."""
    head, _, *rows = table.splitlines()
    rows = [row for row in rows if not row.startswith(("note:", "check passed"))]
    figure, result = head.index("figure"), head.index("result")
    for row in rows:
        assert row[figure - 2 : figure] == "  " and row[figure] != " ", row
        assert row[result - 2 : result] == "  ", row
        assert row[result:] in ("ok", "better", "WORSE", "CHANGED"), row


def edit_value(path: str, frame: int, column: int, change: float) -> None:
    """Add ``change`` to one value of a BVH clip's motion block."""
    lines = Path(path).read_text().splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1 + frame
    values = lines[row].split()
    values[column] = f"{float(values[column]) + change:.6f}"
    lines[row] = " ".join(values)
    Path(path).write_text("\n".join(lines) + "\n")


def test_a_clip_edited_by_half_a_degree_on_one_frame_is_another_clip(clips, capsys):
    """The clip's own figure (the noise before cleaning) is compared to rounding, not to the
    tolerance: a half-degree edit of one value had passed as 'ok'."""
    assert run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update")[0] == 0
    edit_value(clips[1], frame=40, column=5, change=0.5)
    code, out, err = run_cli(capsys, "check", clips[1], "--baseline", "b.json")
    assert code == 1 and "not the one of the baseline" in err
    assert "got worse" not in err  # another clip: its joints are not judged
    # (a change of 3e-6 of the figure: six digits had printed "147,966 to 147,966")
    base, now = re.search(r"noise before changed from (\S+) to (\S+):", err).groups()
    assert base != now and float(base.replace(",", "")) < float(now.replace(",", ""))
    row = next(line.split() for line in out.splitlines() if "noise before" in line)
    assert row[-1] == "CHANGED" and row[-2] not in ("+0.0%", "-0.0%") and row[-4] != row[-3]


def test_a_clip_whose_root_moved_on_one_frame_is_another_clip(clips, capsys):
    """+5 units on the root's Xposition of one frame had passed ('check passed ... +0.0%
    ok'): only rotation figures were compared. The baseline records a digest of the
    clip's values as read, positions too."""
    assert run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update")[0] == 0
    recorded = json.loads(Path("b.json").read_text())
    assert recorded["format"] == FORMAT and len(recorded["clips"][clips[1]]["content"]) == 64
    edit_value(clips[1], frame=40, column=0, change=5.0)
    code, out, err = run_cli(capsys, "check", clips[1], "--baseline", "b.json")
    assert code == 1 and "check passed" not in out
    assert f"motionclean: error: {clips[1]}: content digest changed from " in err
    assert "the clip is not the one of the baseline" in err
    assert [line.split()[-1] for line in out.splitlines() if "content digest" in line] == [
        "CHANGED"
    ]


def set_value(path: str, frame: int, column: int, text: str) -> None:
    """Write ``text`` as one value of a BVH clip's motion block."""
    lines = Path(path).read_text().splitlines()
    row = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1 + frame
    values = lines[row].split()
    values[column] = text
    lines[row] = " ".join(values)
    Path(path).write_text("\n".join(lines) + "\n")


def test_an_edit_in_the_last_written_digit_is_another_clip(clips, capsys):
    """The root's height on frame 0 from 117.056789 to 117.056787: one float32 both (the
    digest had hashed the values so, and the clip passed), two values as parsed."""
    assert np.float32(117.056789) == np.float32(117.056787)
    set_value(clips[1], frame=0, column=1, text="117.056789")
    assert run_cli(capsys, "check", clips[1], "--baseline", "b.json", "--update")[0] == 0
    set_value(clips[1], frame=0, column=1, text="117.056787")
    code, out, err = run_cli(capsys, "check", clips[1], "--baseline", "b.json")
    assert code == 1 and "check passed" not in out
    assert f"motionclean: error: {clips[1]}: content digest changed from " in err
    assert [line.split()[-1] for line in out.splitlines() if "content digest" in line] == [
        "CHANGED"
    ]


def test_a_baseline_of_float32_digests_is_checked_on_its_figures_until_updated(clips, capsys):
    """Format 3's digests (values as float32) are not compared: the clips pass on their
    figures, with a note; an update records today's digests, which catch an edit."""
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    document = json.loads(Path("b.json").read_text())
    document["format"] = 3
    for entry in document["clips"].values():
        entry["content"] = "0" * 64
    Path("b.json").write_text(json.dumps(document))
    code, out, err = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert (code, err) == (0, "") and "check passed" in out
    assert "note: the baseline's content digests are of format 3, not compared" in out
    assert run_cli(capsys, "check", clips[0], "--baseline", "b.json", "--update")[0] == 0
    updated = json.loads(Path("b.json").read_text())
    assert updated["format"] == FORMAT and "content" not in updated["clips"][clips[1]]
    edit_value(clips[0], frame=40, column=0, change=5.0)
    code, out, err = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert code == 1 and f"{clips[0]}: content digest changed" in err and "note:" not in out


def test_a_baseline_recorded_without_a_digest_is_checked_on_its_figures(clips, capsys):
    """Baselines written before the digest (format 2) are read as they were: the clip
    passes on its figures, and a noisier clip still fails."""
    assert run_cli(capsys, "check", *clips, "--baseline", "b.json", "--update")[0] == 0
    document = json.loads(Path("b.json").read_text())
    document["format"] = 2
    for entry in document["clips"].values():
        del entry["content"]
    Path("b.json").write_text(json.dumps(document))
    code, out, err = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert (code, err) == (0, "") and "check passed" in out and "content" not in out
    make_noisier(clips[1])
    code, _, err = run_cli(capsys, "check", *clips, "--baseline", "b.json")
    assert code == 1 and f"{clips[1]}: noise before changed" in err


def test_a_folder_given_as_a_clip_says_so_as_the_other_commands_do(tmp_path, capsys):
    """click had refused it in its own words (exit 2); the reader's line, exit 1, as for
    clean and report."""
    folder = tmp_path / "captures"
    folder.mkdir()
    code, _, err = run_cli(capsys, "check", folder, "--baseline", tmp_path / "b.json", "--update")
    assert code == 1 and err == f"motionclean: error: {folder}: is a directory, not a clip\n"


def test_a_clip_too_short_to_measure_passes_its_own_baseline(tmp_path, capsys, monkeypatch):
    """Two frames: no noise figure (null), in the baseline and now: the same, not a changed
    clip (it had failed right after --update: "noise before changed from - to -")."""
    monkeypatch.chdir(tmp_path)
    clip = cut_bvh(SAMPLE, Path("two.bvh"), 2).as_posix()
    code, _, _ = run_cli(capsys, "check", clip, "--baseline", "b.json", "--update")
    assert code == 0
    code, out, err = run_cli(capsys, "check", clip, "--baseline", "b.json")
    assert (code, err) == (0, "") and "check passed" in out


def test_check_reads_clips_as_clean_does(tmp_path, capsys, monkeypatch):
    """The read options reach check: a channel CSV checked with its skeleton (as it is
    cleaned) records and passes; the skeleton is never the baseline written."""
    monkeypatch.chdir(tmp_path)
    rig = cut_bvh(SAMPLE, Path("rig.bvh"), 60)
    assert run_cli(capsys, "convert", rig, "clip.csv")[0] == 0
    args = ("check", "clip.csv", "--skeleton", rig)
    code, _, err = run_cli(capsys, *args, "--baseline", "b.json", "--update")
    assert (code, err) == (0, "")
    code, out, _ = run_cli(capsys, *args, "--baseline", "b.json")
    assert code == 0 and "check passed" in out
    code, _, err = run_cli(capsys, *args, "--input-fps", "60", "--baseline", "b.json")
    assert code == 2 and "--input-fps applies to SMPL" in err  # (no clip here uses it)
    code, _, err = run_cli(capsys, *args, "--baseline", rig, "--update")
    assert code == 2 and "a baseline must end in .json" in err  # (never an input's name)
