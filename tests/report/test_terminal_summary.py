"""The terminal summary stays one screenful: one line per repaired joint, short lines."""

from __future__ import annotations

from helpers import NOISY, run_cli

import motionclean as mc
from motionclean.report.summary import build_report
from motionclean.report.terminal import LINE_LIMIT, format_repairs, format_table, note_text
from motionclean.steps.base import PAGE_RUNS


def despike_note(runs: list[list[int]]) -> dict:
    return {
        "frames_repaired": sum(b - a for a, b in runs),
        "unflipped": [],
        "interpolated": runs,
        "max_step": {"before": 170.0, "after": 2.0},
    }


def test_long_frame_lists_are_summarised_in_the_terminal_and_capped_on_the_page():
    """The terminal names a long list's first run, the page its first PAGE_RUNS (it had
    listed all 533 runs of a 51,127-frame clip, about 95 lines), both with the count."""
    runs = [[198 + 10 * i, 202 + 10 * i] for i in range(38)]
    report = {"joints": {"Hips": {"despike": despike_note(runs)}}}
    (line,) = format_repairs(report)
    assert "152 frames in 38 runs, first 198-201 and 37 more;" in line
    page = note_text("despike", despike_note(runs))
    named = ", ".join(f"{a}-{b - 1}" for a, b in runs[:PAGE_RUNS])
    assert f"152 frames in 38 runs, first {named} and {38 - PAGE_RUNS} more;" in page
    assert f"{runs[PAGE_RUNS][0]}-" not in page
    short = runs[:PAGE_RUNS]
    assert f"interpolated {', '.join(f'{a}-{b - 1}' for a, b in short)};" in note_text(
        "despike", despike_note(short)
    )


def test_short_frame_lists_are_listed_in_full():
    report = {"joints": {"Hips": {"despike": despike_note([[5, 6], [9, 12]])}}}
    assert "interpolated 5, 9-11;" in format_repairs(report)[0]


def test_one_line_per_joint_and_at_most_limit_joints():
    note = despike_note([[1, 3]])
    joints = {f"J{i}" * (1 + 100 * (i == 0)): {"despike": note} for i in range(14)}
    joints["J1"]["position_despike"] = note
    lines = format_repairs({"joints": joints}, limit=10)
    assert len(lines) == 11 and lines[-1].startswith("... 4 more joints")
    assert all(len(line) <= LINE_LIMIT for line in lines)
    assert "positions:" in lines[1]


def test_clean_prints_short_lines(tmp_path, capsys):
    code, out, err = run_cli(capsys, "clean", NOISY, "-o", tmp_path / "out.bvh")
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) < 50 and max(map(len, lines)) < 200
    repaired = [line.split(":")[0] for line in lines if line.startswith("repaired ")]
    assert len(repaired) == len(set(repaired))


def test_joint_names_stay_whole_or_keep_their_distinguishing_end(tmp_path):
    """Mixamo-style names that differ only at the end print apart: in full when short
    enough (the column as wide as the longest), longer ones with their start and end kept
    around "...", every figure still in its column."""
    text = NOISY.read_text()
    renames = {"LFingers": "mixamorig:LeftHandIndex1", "LThumb": "mixamorig:LeftHandIndex2"}
    for side in ("Left", "Right"):
        for n, joint in enumerate((f"{side}Knee", f"{side}Ankle"), 1):
            renames[joint] = f"Armature|Character1_Ctrl:mixamorig:{side}LegSegment{n}"
    for old, new in renames.items():
        text = text.replace(f"JOINT {old}\n", f"JOINT {new}\n", 1)
    clip = tmp_path / "mixamo.bvh"
    clip.write_text(text)
    motion = mc.load(clip)
    lines = format_table(build_report(motion), limit=motion.n_joints).splitlines()
    head, rule = lines[1:3]
    table = lines[3 : lines.index(rule, 3)]
    shown = [line[: head.index("accel rms") - 5].rstrip() for line in table]
    assert len(set(shown)) == len(shown) == motion.n_joints
    assert {len(line) for line in table} == {len(head)}
    assert "mixamorig:LeftHandIndex1" in shown and "mixamorig:LeftHandIndex2" in shown
    for name in renames.values():
        (label,) = [s for s in shown if s.endswith(name[-len("LeftLegSegment1") :])]
        assert label == name or (label[:10] == name[:10] and "..." in label)
    assert max(map(len, lines)) < 200


def test_wide_characters_in_joint_names_keep_the_table_aligned(tmp_path, capsys):
    """A joint named in Japanese (each character two terminal columns) and one with a
    combining mark (none): every row's figures start in the same terminal column, as the
    header's, where padding by characters had shifted them."""
    import unicodedata

    clip = mc.load(NOISY)
    names = list(clip.names)
    names[names.index("RThumb")] = "右手の親指"
    names[names.index("RightWrist")] = "Rig\u0301htWrist"
    source = tmp_path / "wide.bvh"
    mc.save(
        clip.replace(names=names, source=None, source_values=None, source_rotations=None), source
    )
    code, out, err = run_cli(capsys, "clean", source, "-o", tmp_path / "out.bvh")
    assert code == 0, err

    def width(text: str) -> int:
        return sum(
            0 if unicodedata.combining(c) else 2 if unicodedata.east_asian_width(c) in "WF" else 1
            for c in text
        )

    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("joint"))
    rows = lines[head + 2 : head + 12]
    assert any("右手の親指" in row for row in rows) and any("\u0301" in row for row in rows)
    ends = {width(row[: row.index(row.split()[1]) + len(row.split()[1])]) for row in rows}
    assert ends == {width(lines[head][: lines[head].index("rms") + 3])}
