"""The verdict: one plain line per clip from the figures, the same on the terminal, the page,
the JSON report and the batch index; headline figures keep repairs apart from smoothing."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from helpers import NOISY, ROOT, SAMPLE, Page, corpus_clip, plant, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.report import verdict as verdict_rules
from motionclean.report.html import render_html
from motionclean.report.verdict import (
    CLEAN_CHANGE_DEG,
    LOOK_CHANGE_DEG,
    UNCHANGED_DEG,
    build_verdict,
    repaired_frames,
)
from motionclean.run.jobs import clean_clip, clean_motion
from motionclean.steps.pipeline import Pipeline


@pytest.fixture(scope="module")
def demo():
    return clean_clip(NOISY, None, Pipeline.default())


def outside(mask: np.ndarray, rows: int) -> np.ndarray:
    """Rows of an acceleration table (frames i..i+2) that touch no frame in ``mask``."""
    touched = mask[:-2] | mask[1:-1] | mask[2:]
    return ~touched[:rows]


def reach_of(clip: mc.Motion) -> np.ndarray:
    """Each joint's reach: the farthest point below it in the rest pose, walked up the
    hierarchy one point at a time (the project's own is vectorised)."""
    rest = kinematics.rest_positions(clip)
    reach = np.zeros(clip.n_joints)
    for point, parent in enumerate(list(clip.parents) + sorted(clip.end_sites)):
        while parent >= 0:
            reach[parent] = max(reach[parent], np.linalg.norm(rest[point] - rest[parent]))
            parent = clip.parents[parent]
    return reach


def test_demo_verdict_names_the_repairs_and_measures_smoothing_outside_them(demo):
    verdict = demo.report["verdict"]
    notes = demo.report["joints"]["RThumb"]["despike"]
    flips = len(notes["unflipped"])
    assert verdict["status"] == "cleaned"
    text = verdict["text"]
    assert text.startswith("noisy capture, cleaned: ")
    assert f"{flips} flips repaired on RThumb" in text
    # the largest change outside repairs, measured here from the clips and the notes alone
    frames = repaired_frames(demo.report["joints"], demo.before.n_frames)
    angles = np.degrees(quat.angle_between(demo.before.rotations, demo.after.rotations))
    names = list(demo.before.names)
    for name, mask in frames.items():
        angles[mask, names.index(name)] = 0.0
    largest = float(angles.max())
    assert largest < 5.0 < 179.0 < demo.report["summary"]["deviation_deg_max"]
    assert verdict["change_deg_max"] == pytest.approx(largest, rel=1e-12)
    assert f"largest change {largest:.1f} degrees outside repairs" in text
    assert verdict["change_joint"] == names[int(np.argmax(angles.max(axis=0)))]
    # the jitter removed, outside repairs, from the same clips
    dt = demo.before.frame_time
    from motionclean.report.metrics import angular_acceleration

    # each joint's squared acceleration weighted by its reach squared
    reach = reach_of(demo.before)
    sums = np.zeros((2, 2))  # (weighted, plain) x (before, after)
    for k, clip in enumerate((demo.before, demo.after)):
        acc = angular_acceleration(clip.rotations, dt)
        keep = np.ones_like(acc, dtype=bool)
        for name, mask in frames.items():
            keep[:, names.index(name)] = outside(mask, acc.shape[0])
        per_joint = np.sum(np.where(keep, acc, 0.0) ** 2, axis=0)
        sums[:, k] = np.dot(reach**2, per_joint), per_joint.sum()
    removed, plain = 1.0 - np.sqrt(sums[:, 1] / sums[:, 0])
    assert verdict["noise_removed"] == pytest.approx(removed, rel=1e-9)
    assert f"{removed:.0%} of the jitter removed".replace("%", " %") in text
    assert plain < demo.report["summary"]["noise_reduction"]  # the flips inflated it
    assert verdict["repairs"]["RThumb"] == {
        "flips": flips,
        "spikes": len(notes["interpolated"]) - len(notes["capped"]),
        "capped": len(notes["capped"]),
        "gaps_filled": 0,
        "gaps_left": 0,
        "frames": notes["frames_repaired"],
    }


def test_the_json_report_keeps_its_schema_and_adds_the_verdict(demo):
    report = demo.report
    assert list(report)[:6] == ["file", "frames", "frame_time", "pipeline", "joints", "summary"]
    assert set(report["summary"]) == {"angular_accel_rms", "noise_reduction", "deviation_deg_max"}
    assert json.loads(json.dumps(report["verdict"]))["text"] == report["verdict"]["text"]


def test_page_leads_with_the_verdict_and_no_repair_headline(demo):
    page = render_html(demo.report, demo.series)
    text = "".join(Page(page).text)
    verdict = demo.report["verdict"]["text"]
    assert verdict in text
    stats = re.findall(r'<div class="stat"><b>(.*?)</b><span>(.*?)</span>', page)
    value, label = stats[0]
    assert "179" not in value and "deviation" not in label
    assert text.index(verdict) < text.index(label)
    # the change a repair made is still told, as such
    assert any("repair" in lab and "179.99" in val for val, lab in stats)


def test_terminal_prints_the_same_verdict(tmp_path, capsys):
    report = tmp_path / "r.json"
    code, out, err = run_cli(capsys, "clean", NOISY, "-o", tmp_path / "c.bvh", "--report", report)
    assert code == 0, err
    verdict = json.loads(report.read_text())["verdict"]["text"]
    assert f"verdict: {verdict}" in out.splitlines()


def test_a_clean_capture_is_called_clean(tmp_path):
    """The sample as captured: clean, and 'barely moved' where its largest change is a few
    tenths of a degree ('left as it was' only where nothing moved that much)."""
    result = clean_clip(SAMPLE, None, Pipeline.default())
    verdict = result.report["verdict"]
    assert verdict["change_deg_rms"] < CLEAN_CHANGE_DEG
    assert verdict["status"] in ("clean", "repaired")
    assert verdict["text"].startswith("clean capture")
    left = "left as it was" if verdict["change_deg_max"] < CLEAN_CHANGE_DEG else "barely moved"
    assert left in verdict["text"], verdict["text"]


def test_where_nothing_changed_outside_repairs_no_joint_is_named():
    """131_02 cut as captured: every rotation outside the RThumb repairs comes back as it
    was (to the conversions' rounding), so the verdict, the JSON and the page name no joint
    for the largest change (the page's card read '0.00 degrees (LThumb)')."""
    result = clean_clip(SAMPLE, None, Pipeline.default())
    verdict = result.report["verdict"]
    frames = repaired_frames(result.report["joints"], result.before.n_frames)
    angles = np.degrees(quat.angle_between(result.before.rotations, result.after.rotations))
    for name, mask in frames.items():
        angles[mask, list(result.before.names).index(name)] = 0.0
    assert angles.max() < UNCHANGED_DEG
    assert verdict["change_deg_max"] < UNCHANGED_DEG
    assert "no rotation changed outside repairs" in verdict["text"]
    assert verdict["change_joint"] is None
    card = re.search(r"largest change outside repairs[^<]*<", render_html(result.report))
    assert card is not None and "(" not in card.group(0), card


@pytest.mark.parametrize(
    "steps", [["despike", "resample:fps=240"], ["resample:fps=240", "despike"]]
)
def test_repairs_before_or_after_a_new_frame_rate_are_told_apart(steps):
    """The sample's RThumb half-turn flips, un-flipped by despike before or after upsampling:
    the verdict counts them as repairs, numbered as the input's frames either way, not as
    a 180-degree change made by smoothing."""
    result = clean_clip(SAMPLE, None, Pipeline.from_inline(steps))
    verdict = result.report["verdict"]
    assert verdict["status"] == "repaired", verdict["text"]
    assert verdict["change_deg_max"] < 1.0


def test_a_joint_moved_far_by_smoothing_needs_a_look():
    motion = mc.load(SAMPLE)
    result = clean_clip(SAMPLE, None, Pipeline.from_inline(["lee-shin:k=6,iterations=60"]))
    verdict = result.report["verdict"]
    assert verdict["change_deg_max"] > LOOK_CHANGE_DEG
    assert verdict["status"] == "needs a look"
    assert verdict["text"].startswith("needs a look: ")
    assert verdict["change_joint"] in verdict["text"]
    assert motion.n_frames == result.report["frames"]


def rigid_csv(path, clip: mc.Motion, name: str, gone: slice) -> None:
    """Three bodies of ``clip`` in world space as a tracker writes them, ``name`` blank on
    the ``gone`` frames."""
    positions, rotations = kinematics.forward(clip)
    bodies = ["Head", "LeftWrist", "RightWrist"]
    rows = [
        "time,"
        + ",".join(f"{b}.{s}" for b in bodies for s in ["px", "py", "pz", "qw", "qx", "qy", "qz"])
    ]
    for f in range(clip.n_frames):
        cells = [f"{f * clip.frame_time:.6f}"]
        for body in bodies:
            j = clip.names.index(body)
            values = np.concatenate([positions[f, j], rotations[f, j]])
            blank = body == name and f in range(clip.n_frames)[gone]
            cells += [""] * 7 if blank else [f"{v:.6f}" for v in values]
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")


def test_a_gap_left_missing_needs_a_look(tmp_path):
    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), "RightWrist", slice(150, 250))
    verdict = clean_clip(source, None, Pipeline.default()).report["verdict"]
    assert verdict["status"] == "needs a look"
    assert "RightWrist missing on frames 150-249" in verdict["text"]
    assert verdict["repairs"]["RightWrist"]["gaps_left"] == 1


def test_an_input_alone_says_so():
    from motionclean.report.summary import build_report

    report = build_report(mc.load(SAMPLE))
    assert report["verdict"]["status"] == "input only"
    assert report["verdict"]["text"].startswith("input only, not cleaned")


def test_an_inputs_noise_leaves_out_its_flips_as_the_clean_verdict_does():
    """The noisy sample's five RThumb flips had been most of its headline noise: the line
    and the page's first figure now leave out the acceleration rows that touch a step
    over 90 degrees, measured here from the rotations alone, and say how many (each
    joint weighted by its reach, as the clean verdict's jitter is)."""
    from motionclean.report.metrics import angular_acceleration
    from motionclean.report.summary import build_report, build_series

    clip = mc.load(NOISY)
    series = build_series(clip)
    report = build_report(clip, series=series)
    q = clip.rotations
    steps = np.degrees(quat.angle_between(q[:-1], q[1:])) > 90.0  # (F-1, J)
    rows = steps[:-1] | steps[1:]  # acceleration rows i..i+2 touching such a step
    acc = angular_acceleration(q, clip.frame_time)
    weights = reach_of(clip) ** 2  # over their mean over the rows measured: deg/s^2 still
    weights *= np.sum(~rows) / np.dot(weights, np.sum(~rows, axis=0))
    expected = math.sqrt(np.sum(weights * np.where(rows, 0.0, acc) ** 2) / np.sum(~rows))
    verdict = report["verdict"]
    assert verdict["noise_before"] == pytest.approx(expected, rel=1e-9)
    assert verdict["unrepaired_jumps"] == int(steps.sum()) >= 5
    assert expected < 0.5 * report["summary"]["angular_accel_rms"]["before"]
    left = f"without {int(steps.sum())} steps over 90 degrees (flips or glitches)"
    assert verdict["text"] == (
        f"input only, not cleaned: noise {expected:,.0f} deg/s\u00b2 RMS angular "
        f"acceleration, {left}"
    )
    page = render_html(report, series)
    value, label = re.findall(r'<div class="stat"><b>(.*?)</b><span>(.*?)</span>', page)[0]
    assert value == f"{expected:,.0f}" and left in label


def _half_cleaned(joints: dict, frames: int) -> str:
    """The verdict's line of a report of ``joints`` over ``frames``, half its jitter removed,
    changed by 0.02 degrees at most."""
    report = {
        "frames": frames,
        "joints": joints,
        "summary": {"noise_reduction": 0.5},
        "contacts": None,
    }
    smoothing = {
        "noise_removed": 0.5,
        "change_deg_max": 0.02,
        "change_deg_rms": 0.01,
        "change_joint": next(iter(joints)),
    }
    return build_verdict(report, smoothing)["text"]


def test_verdict_words_follow_the_counts():
    joints = {
        "RThumb": {"despike": {"unflipped": [[4, 9]], "interpolated": [], "frames_repaired": 5}},
        "Head": {"despike": {"unflipped": [], "interpolated": [[2, 3], [7, 9]]}},
    }
    text = _half_cleaned(joints, 20)
    assert "1 flip repaired on RThumb" in text and "2 spikes repaired on Head" in text
    assert "flips" not in text.replace("1 flip ", "")


def test_one_held_pose_on_several_joints_is_counted_once():
    """A recorder's dropout holds many joints over the same frames: the verdict counts the
    distinct held runs, and the joints that held them."""
    held = {"fill-gaps": {"held": [[40, 44], [90, 93]], "filled": [[40, 44], [90, 93]]}}
    text = _half_cleaned({name: held for name in ("Hips", "Spine", "LeftArm")}, 200)
    assert "2 held poses bridged on 3 joints" in text, text


def test_a_repaired_run_marks_its_own_frames_only():
    """``[start, stop)`` runs: [5, 8) is frames 5, 6 and 7, at the clip's ends too."""
    runs = {"despike": {"unflipped": [[5, 8], [10, 12]], "interpolated": [[0, 1]]}}
    frames = repaired_frames({"J": runs}, 12)["J"]
    assert np.array_equal(np.flatnonzero(frames), [0, 5, 6, 7, 10, 11])


def test_a_capped_step_that_never_comes_back_is_told_as_such_not_as_a_spike(tmp_path, capsys):
    """An inertial suit's toe snapping flat in one direction, one step over despike's cap
    (an Xsens walk's "9 spikes repaired (RightToe 5, LeftToe 4)"): despike caps it as it
    did, and the line, the JSON and the joint's note tell it as a step too fast for a body,
    capped, apart from the spike kicked into another joint (away and back)."""
    clip = mc.load(SAMPLE)
    q = clip.rotations.copy()
    toe, wrist = clip.names.index("LeftToe"), clip.names.index("RightWrist")
    snap = np.zeros(clip.n_frames)  # degrees: a one-way turn with one 40 degree step
    snap[150:] = 60.0
    snap[148:150] = [10.0, 50.0]
    q[:, toe] = quat.multiply(q[:, toe], quat.from_axis_angle([1.0, 0.0, 0.0], np.radians(snap)))
    kick = quat.from_axis_angle([0.0, 0.0, 1.0], np.radians(60.0))
    q[200:202, wrist] = quat.multiply(q[200:202, wrist], kick)
    source, report = tmp_path / "snap.bvh", tmp_path / "snap.json"
    mc.save(clip.replace(rotations=q), source)
    code, out, err = run_cli(
        capsys, "clean", source, "-o", tmp_path / "c.bvh", "-f", "despike", "--report", report
    )
    assert code == 0, err
    verdict = json.loads(report.read_text())["verdict"]
    assert verdict["repairs"]["LeftToe"]["capped"] == 1
    assert verdict["repairs"]["LeftToe"]["spikes"] == 0
    assert verdict["repairs"]["RightWrist"]["spikes"] == 1
    assert verdict["repairs"]["RightWrist"]["capped"] == 0
    assert "1 spike repaired on RightWrist" in verdict["text"]
    assert "1 too-fast step capped on LeftToe" in verdict["text"]
    note = json.loads(report.read_text())["joints"]["LeftToe"]["despike"]
    assert note["capped"] == note["interpolated"] and len(note["capped"]) == 1
    (line,) = [row for row in out.splitlines() if row.startswith("repaired LeftToe")]
    assert "(a step over max_deg_per_s)" in line and "interpolated" not in line


def test_every_joint_moved_far_beyond_its_noise_needs_a_look_not_only_the_largest():
    """A move over 10 degrees needs a look where it is over 6 times the joint's noise: a
    hip moved 25 degrees with 1 degree of noise does, whatever a thumb moved 40 degrees
    with 8 degrees of noise (within its noise) beside it; only the largest change had been
    judged, so the thumb's had hidden the hip's."""
    joints = {
        "LeftHip": {"auto": {"noise": 1.0, "unit": "deg"}},
        "RThumb": {"auto": {"noise": 8.0, "unit": "deg"}},
    }
    report = {"frames": 200, "joints": joints, "summary": {"noise_reduction": 0.5}}
    smoothing = {
        "noise_removed": 0.5,
        "change_deg_max": 40.0,
        "change_deg_rms": 2.0,
        "change_joint": "RThumb",
        "joint_changes": {"LeftHip": 25.0, "RThumb": 40.0},
    }
    verdict = build_verdict(report, smoothing)
    assert verdict["status"] == "needs a look"
    assert "moved LeftHip by 25.0 degrees" in verdict["text"], verdict["text"]
    smoothing["joint_changes"] = {"LeftHip": 5.0, "RThumb": 40.0}
    assert " moved " not in build_verdict(report, smoothing)["text"]


def test_repairs_on_several_joints_are_counted_per_joint():
    """ "14 flips repaired on LeftElbow, RThumb" had not said which had how many."""

    def flips(count: int) -> dict:
        runs = [[10 * k, 10 * k + 2] for k in range(count)]
        return {"despike": {"unflipped": runs, "interpolated": [], "frames_repaired": 2 * count}}

    smoothing = {
        "noise_removed": 0.5,
        "change_deg_max": 0.02,
        "change_deg_rms": 0.01,
        "change_joint": "Head",
    }
    counts = {"LeftElbow": 1, "RThumb": 13, "Head": 2, "Neck": 2, "Hips": 1}
    joints = {name: flips(n) for name, n in counts.items()}
    report = {"frames": 200, "joints": joints, "summary": {}, "contacts": None}
    two = {n: joints[n] for n in ("LeftElbow", "RThumb")}
    text = build_verdict(report | {"joints": two}, smoothing)["text"]
    assert "14 flips repaired (RThumb 13, LeftElbow 1)" in text
    text = build_verdict(report, smoothing)["text"]
    assert "19 flips repaired (RThumb 13, Head 2, Neck 2 and 2 more joints)" in text


def test_the_terminal_table_says_its_totals_include_repairs(demo, tmp_path, capsys):
    """The page's total says "repairs included"; the table's all-joints row, the same
    figures, says so below it where a step repaired frames, and not otherwise."""
    from motionclean.report.terminal import format_table

    lines = format_table(demo.report).splitlines()
    row = next(k for k, line in enumerate(lines) if line.startswith("all joints"))
    assert lines[row + 1].startswith("(figures with repairs included;")
    assert "repairs included" in render_html(demo.report, demo.series)
    clean = clean_clip(SAMPLE, None, Pipeline.from_inline(["lee-shin"])).report
    assert "repairs included" not in format_table(clean)


def test_batch_index_and_table_carry_each_clips_verdict(tmp_path, capsys):
    from helpers import cut_bvh

    source = tmp_path / "in"
    cut_bvh(NOISY, source / "a.bvh", 120)
    cut_bvh(SAMPLE, source / "b.bvh", 120)
    pages = tmp_path / "pages"
    code, out, err = run_cli(
        capsys, "batch", source, "-o", tmp_path / "out", "--jobs", "1", "--report-dir", pages
    )
    assert code == 0, err
    index = "".join(Page((pages / "index.html").read_text()).text)
    for name in ("a.bvh", "b.bvh"):
        page = (pages / f"{name}.html").read_text()
        verdict = re.search(r'<p class="verdict[^"]*">(.*?)</p>', page).group(1)
        assert verdict.startswith(("noisy capture", "clean capture", "needs a look"))
        assert verdict.replace("&#x27;", "'") in index
        lead = verdict.split(":")[0]
        status = {"noisy capture, cleaned": "cleaned", "clean capture": "clean"}.get(lead, lead)
        row = next(line for line in out.splitlines() if line.startswith(name))
        shown = "repaired" if lead == "clean capture, repaired" else status
        assert row.endswith(f"  {shown:<14}ok")
        # the table's removed and change columns are the verdict's, outside repairs
        figures = clean_clip(source / name, None, Pipeline.default()).report["verdict"]
        assert f"{figures['noise_removed']:.0%}  " in row.replace("%", "%  ", 1)
        assert f"{figures['change_deg_max']:.2f}  " in row


def test_two_clips_compared_take_turns_over_a_quarter_turn_for_repairs(tmp_path, capsys):
    """`report IN CLEANED` of the noisy sample and its default clean: the frames RThumb
    turned half a turn are the repairs (no step's notes say so), counted and left out of the
    figures as `clean`'s verdict leaves its flips out (it had read "needs a look: ... 12.91
    degrees RMS ... motion taken for noise ... despike repairs them first" of a despiked
    clip). Only the repair phrase and the tail's words differ from `clean`'s line."""
    cleaned = tmp_path / "c.bvh"
    code, out, err = run_cli(capsys, "clean", NOISY, "-o", cleaned, "--report", tmp_path / "c.json")
    assert code == 0, err
    told = json.loads((tmp_path / "c.json").read_text())["verdict"]
    code, out, err = run_cli(capsys, "report", NOISY, cleaned, "--json", tmp_path / "r.json")
    report = json.loads((tmp_path / "r.json").read_text())
    verdict = report["verdict"]
    assert verdict["status"] == told["status"] == "cleaned"
    assert verdict["text"] == told["text"].replace(
        "5 flips repaired on RThumb", "5 repairs (a turn over 150 degrees) on RThumb"
    ).replace("outside repairs", "outside repairs (turns over 150 degrees: steps not recorded)")
    assert len(report["joints"]["RThumb"]["turned"]["runs"]) == 5
    assert f"verdict: {verdict['text']}" in out
    # the page's repair card counts them too (it had said "none" beside "repaired on 48")
    code, _, err = run_cli(capsys, "report", NOISY, cleaned, "--html", tmp_path / "r.html")
    page = (tmp_path / "r.html").read_text()
    assert code == 0 and ">5 turns<" in page and "repaired on 48 frames of RThumb" in page


def _with_excursion(clip: mc.Motion, joint: str, start: int, degrees: np.ndarray) -> mc.Motion:
    """``clip`` with ``joint`` turned by ``degrees`` about x on the frames from ``start``."""
    j = clip.names.index(joint)
    turn = quat.from_axis_angle([1.0, 0.0, 0.0], np.radians(degrees))
    q = clip.rotations.copy()
    q[start : start + degrees.size, j] = quat.multiply(q[start : start + degrees.size, j], turn)
    return clip.replace(rotations=q, source_values=None)


@pytest.mark.parametrize("frames", [6, 60])
def test_two_clips_compared_tell_a_brief_change_as_such_not_as_smoothing(tmp_path, capsys, frames):
    """`report IN CLEANED` of an Xsens walk and its default clean, which only capped a toe's
    step on 2 frames, had read "needs a look: smoothing changed it by 0.08 degrees RMS, more
    than 3 times its noise (0.019 degrees): motion taken for noise": the pair cannot tell
    repairs from smoothing, but a joint changed on a few frames in a row, the frames around
    them as they were, where the input jumps in and out (a spike taken out), is no smoothing.
    The line says what it can know; a change as large held longer than PAIR_BRIEF_S (0.5 s
    here) is still judged as smoothing."""
    clip = mc.load(SAMPLE)
    toe = clip.names.index("LeftToe")
    degrees = np.interp(np.arange(frames), [0, 1, frames - 2, frames - 1], [8, 18, 19, 8])
    spiky = tmp_path / "spiky.bvh"
    mc.save(_with_excursion(clip, "LeftToe", 150, degrees), spiky)
    code, out, err = run_cli(capsys, "report", spiky, SAMPLE, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    verdict, note = report["verdict"], report["joints"]["LeftToe"].get("brief_change")
    read = mc.load(spiky).rotations[:, toe]
    peak = float(np.degrees(quat.angle_between(read, clip.rotations[:, toe])).max())
    brief = frames * clip.frame_time <= verdict_rules.PAIR_BRIEF_S
    assert (note is not None) is brief
    if brief:
        assert note["runs"] == [[150, 150 + frames]]
        assert note["max_deg"] == pytest.approx(peak, abs=1e-6)
        assert verdict["status"] == "clean" and verdict["repairs"]["LeftToe"]["brief"] == 1
        assert "smooth" not in verdict["text"] and verdict["change_deg_max"] < 1e-6
        said = f"changed by up to {peak:.1f} degrees on LeftToe (frames 150-{149 + frames})"
        assert verdict["text"].startswith(f"clean capture: {said}, otherwise left as it was")
        assert verdict["text"].endswith("outside brief changes (steps not recorded)")
    else:
        assert verdict["change_deg_max"] == pytest.approx(peak, abs=1e-6)
        assert "smoothing changed it by" in verdict["text"]


def test_two_clips_compared_tell_no_brief_change_without_a_repair_in_the_input(tmp_path, capsys):
    """A thumb held still but for one 0.1 s twitch, smoothed (filtering a constant leaves it
    as it was): its frames around the twitch change, those beyond do not, yet the input
    enters and leaves them still (the twitch's steps, 840 deg/s at most, are under despike's
    cap). That is smoothing, judged as such; it had read "changed by up to 2.6 degrees on
    LThumb (frames 148-163)", left out of the figures."""
    clip = mc.load(SAMPLE)
    thumb = clip.names.index("LThumb")
    still = clip.rotations.copy()
    still[:, thumb] = still[0, thumb]
    twitch = 25 * np.sin(np.linspace(0, np.pi, 12)) ** 2
    source, cleaned = tmp_path / "twitch.bvh", tmp_path / "c.bvh"
    mc.save(_with_excursion(clip.replace(rotations=still), "LThumb", 150, twitch), source)
    code, _, err = run_cli(capsys, "clean", source, "-f", "lee-shin:k=3", "-o", cleaned, "-q")
    assert code == 0, err
    code, _, err = run_cli(capsys, "report", source, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    before, after = mc.load(source).rotations[:, thumb], mc.load(cleaned).rotations[:, thumb]
    changed = np.degrees(quat.angle_between(before, after))
    run = np.flatnonzero(changed > UNCHANGED_DEG)  # 148-163: brief, still frames around
    assert run[-1] - run[0] < verdict_rules.PAIR_BRIEF_S / clip.frame_time
    assert not any("brief_change" in joint for joint in report["joints"].values())
    assert "brief" not in report["verdict"]["text"]
    # its figures count the change (a brief change's frames are left out of them)
    assert report["joints"]["LThumb"]["deviation_deg"]["max"] == pytest.approx(changed.max())


@pytest.mark.parametrize("start", [0, 2])
def test_two_clips_compared_need_an_unchanged_frame_each_side_for_a_brief_change(
    tmp_path, capsys, start
):
    """A 12-frame clip with a spike on LeftToe taken out: on frames 2-9 (an unchanged frame
    each side) a brief change, not "repaired on 67% of its frames" (no repair is claimed);
    from frame 0 no brief change (a clip's end is no unchanged frame: clips of at most
    PAIR_BRIEF_S, smoothed whole, had read "needs a look: Hips repaired on 100% of its
    frames ... in 30 brief runs")."""
    clip = mc.load(SAMPLE).at_frames(slice(100, 112))
    spiky, cleaned = tmp_path / "spiky.bvh", tmp_path / "c.bvh"
    mc.save(_with_excursion(clip, "LeftToe", start, np.full(8, 20.0)), spiky)
    mc.save(clip, cleaned)
    code, _, err = run_cli(capsys, "report", spiky, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    verdict, note = report["verdict"], report["joints"]["LeftToe"].get("brief_change")
    assert "repaired on" not in verdict["text"]
    if start:
        assert note["runs"] == [[2, 10]] and note["max_deg"] == pytest.approx(20, abs=1e-3)
        assert verdict["status"] == "clean" and verdict["repairs"]["LeftToe"]["frames"] == 8
        assert verdict["text"].startswith("clean capture: changed by up to 20.0 degrees on")
    else:
        assert note is None and verdict["repairs"] == {}
        assert verdict["change_deg_max"] == pytest.approx(20, abs=1e-3)


@pytest.mark.parametrize("name", ["131_01.bvh", "131_03.bvh"])
def test_two_clips_compared_read_a_clean_capture_s_repairs_as_its_clean_did(tmp_path, capsys, name):
    """CMU 131_01 and 131_03 against their default cleans (RThumb un-flipped, wrist and thumb
    steps capped, nothing smoothed) had read "needs a look: the cleaning moved RightWrist by
    49.1 degrees; smoothing changed it by 0.51 degrees RMS ... motion taken for noise": the
    capped runs are brief changes, the frames changed around an un-flipped turn go with it,
    and the pair reads as the clean run did, no rotation changed outside them."""
    source, cleaned = corpus_clip(name), tmp_path / "c.bvh"
    code, _, err = run_cli(capsys, "clean", source, "-o", cleaned, "--report", tmp_path / "c.json")
    assert code == 0, err
    told = json.loads((tmp_path / "c.json").read_text())["verdict"]
    code, _, err = run_cli(capsys, "report", source, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    verdict = json.loads((tmp_path / "r.json").read_text())["verdict"]
    assert verdict["status"] == told["status"] == "repaired", verdict["text"]
    assert verdict["repairs"]["RThumb"]["turned"] == told["repairs"]["RThumb"]["flips"]
    assert verdict["change_deg_max"] < 1e-6 and "smooth" not in verdict["text"]
    assert sum(r.get("brief", 0) for r in verdict["repairs"].values()) > 0


def test_two_clips_with_dropouts_compared_say_which_gaps_the_second_filled(tmp_path, capsys):
    """A tracker CSV with a dropout and its cleaned copy (which `report IN OUT` had refused:
    "fill them first"): the gaps are read from the two files, filled or still missing."""
    dropouts = ROOT / "sample_data" / "131_02_motive.csv"
    cleaned = tmp_path / "c.csv"
    code, _, err = run_cli(capsys, "clean", dropouts, "-o", cleaned, "-q")
    assert code == 0, err
    code, out, err = run_cli(capsys, "report", dropouts, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    verdict = json.loads((tmp_path / "r.json").read_text())["verdict"]
    assert verdict["status"] == "repaired" and "1 gap filled on hand_l" in verdict["text"]
    assert "repaired hand_l: 1 gap, longest 8 frames; filled 40-47" in out
    code, out, err = run_cli(capsys, "report", dropouts, dropouts, "--json", tmp_path / "s.json")
    verdict = json.loads((tmp_path / "s.json").read_text())["verdict"]
    assert code == 0 and "hand_l missing on frames 40-47" in verdict["text"]
    assert "dropouts hand_l: 1 gap, longest 8 frames; left missing 40-47 (not filled)" in out
    # reported alone, the clip was not cleaned: its gaps are dropouts, not repairs
    code, out, err = run_cli(capsys, "report", dropouts)
    assert code == 0 and "repaired" not in out
    assert "dropouts hand_l: 1 gap, longest 8 frames; left missing 40-47 (not filled)" in out


def test_the_report_lists_the_gaps_per_body(tmp_path, capsys):
    """The contract's top-level `gaps`: per body with samples missing in the input, the gaps
    found and filled (its fill-gaps note), from `clean --report` and `report IN CLEANED`
    alike; empty for a clip without dropouts."""
    dropouts = ROOT / "sample_data" / "131_02_motive.csv"
    clip = mc.load(dropouts)
    gapped = {clip.names[j]: clip.missing[:, j] for j in np.flatnonzero(clip.missing.any(axis=0))}
    cleaned, made, compared = tmp_path / "c.csv", tmp_path / "m.json", tmp_path / "r.json"
    code, _, _ = run_cli(capsys, "clean", dropouts, "-o", cleaned, "-q", "--report", made)
    assert code == 0
    code, _, _ = run_cli(capsys, "report", dropouts, cleaned, "--json", compared)
    assert code == 0
    for report in (json.loads(made.read_text()), json.loads(compared.read_text())):
        assert set(report["gaps"]) == set(gapped)
        for name, note in report["gaps"].items():
            assert note == report["joints"][name]["fill-gaps"]
            frames = np.flatnonzero(gapped[name])
            assert note["filled"] == [[int(frames[0]), int(frames[-1]) + 1]]
            assert note["missing"] == [] and "why" not in note  # all filled: no reason
    # the input alone: its gaps, none filled (had been {})
    code, _, _ = run_cli(capsys, "report", dropouts, "--json", compared)
    assert code == 0
    alone = json.loads(compared.read_text())["gaps"]
    assert set(alone) == set(gapped)
    for name, note in alone.items():
        frames = np.flatnonzero(gapped[name])
        assert note["filled"] == [] and note["why"] == "not filled"
        assert note["missing"] == [[int(frames[0]), int(frames[-1]) + 1]]
    code, _, _ = run_cli(capsys, "report", NOISY, "--json", made)
    assert code == 0 and json.loads(made.read_text())["gaps"] == {}


def test_a_dropout_no_step_filled_is_a_reason_to_look(tmp_path, capsys):
    """A pipeline without fill-gaps leaves the tracker CSV's dropout missing: the verdict
    says so, as the README's table has it (it said "cleaned" and listed no gap), and the
    reason given is that it was not filled, not a max_gap no step had."""
    dropouts = ROOT / "sample_data" / "131_02_motive.csv"
    out_csv = tmp_path / "o.csv"
    code, out, _ = run_cli(capsys, "clean", dropouts, "-o", out_csv, "-f", "lee-shin:k=2")
    assert code == 0 and "verdict: needs a look: hand_l missing on frames 40-47" in out
    assert "left missing 40-47 (not filled)" in out and "max_gap" not in out
    code, out, _ = run_cli(capsys, "report", dropouts, out_csv)
    assert code == 0 and "left missing 40-47 (not filled)" in out


def test_sliding_feet_to_look_at_leave_no_empty_clause(tmp_path, capsys, monkeypatch):
    """fill-gaps alone on the noisy sample: nothing repaired, the feet slide (a reason to
    look, said first, here from 0.15 body heights/s: the sample's feet drift 0.2 over 0.1
    s), and the rest says nothing was repaired (it read "Not smoothed: ;")."""
    monkeypatch.setattr(verdict_rules, "LOOK_SKATE", 0.15)
    code, out, _ = run_cli(capsys, "clean", NOISY, "-o", tmp_path / "x.bvh", "-f", "fill-gaps")
    line = next(line for line in out.splitlines() if line.startswith("verdict: "))
    assert code == 0 and line.startswith("verdict: needs a look: feet slide")
    assert "Not smoothed: nothing repaired; no rotation changed" in line and ": ;" not in line


def test_a_clip_only_put_on_the_floor_is_not_judged_and_says_what_moved_it():
    """ground moves and levels the root, smoothing nothing: the verdict makes no noise
    judgement ('not smoothed') and says what moved the clip."""
    result = clean_clip(SAMPLE, None, Pipeline.from_inline(["ground"]))
    verdict = result.report["verdict"]
    assert verdict["status"] == "not smoothed", verdict["text"]
    assert "put on the floor" in verdict["text"] and "jitter" not in verdict["text"]
    kept = clean_clip(SAMPLE, None, Pipeline.from_inline(["ground:level=false"]))
    assert "levelled" not in kept.report["verdict"]["text"]


def test_a_pipeline_without_a_smoothing_step_tells_what_it_did_not_the_noise():
    """footlock alone on the noisy sample: 'not smoothed: feet ...' (planted, or their slide),
    no 'jitter removed' and no 'left as it was'; on a skeleton without legs it says that
    nothing was planted. With a smoothing step the noise is judged again."""
    planted = clean_clip(NOISY, None, Pipeline.from_inline(["footlock"])).report["verdict"]
    assert planted["status"] == "not smoothed", planted["text"]
    assert re.match(r"not smoothed: feet (planted|slide [0-9.]+ body heights/s);", planted["text"])
    assert "jitter" not in planted["text"] and "left as it was" not in planted["text"]
    clip = mc.load(NOISY)
    translations = clip.translations.copy()  # rising a body height per second: no contact
    translations[:, 0, 1] += kinematics.body_height(clip) * np.arange(clip.n_frames) / 120.0
    flying = clip.replace(translations=translations)
    result = clean_motion(flying, Pipeline.from_inline(["footlock"]), "flying.bvh")
    text = result.report["verdict"]["text"]
    assert text.startswith("not smoothed: no foot in contact found, nothing planted"), text
    smoothed = clean_clip(NOISY, None, Pipeline.from_inline(["despike", "footlock", "lee-shin"]))
    assert smoothed.report["verdict"]["status"] == "cleaned", smoothed.report["verdict"]["text"]
    assert "of the jitter removed" in smoothed.report["verdict"]["text"]


def test_footlock_on_a_clip_without_joint_positions_says_no_feet_were_looked_for(tmp_path):
    """SMPL parameters read without a body model have no joint positions: footlock could
    look for no feet, and the verdict had said 'no foot in contact found' as if it had. It
    says why none was looked for, as the world line does."""
    t = np.arange(60)[:, None] / 30.0
    poses = 0.3 * np.sin(t * np.linspace(0.5, 2.0, 72))  # SMPL's 24 joints, moving slowly
    np.savez(tmp_path / "walk.npz", poses=poses, trans=0.1 * t * [1.0, 0.0, 0.0])
    result = clean_clip(tmp_path / "walk.npz", None, Pipeline.from_inline(["footlock"]))
    skipped = result.report["world"]["skipped"]
    assert "no joint positions" in skipped
    assert result.report["verdict"]["text"].startswith(
        f"not smoothed: no feet looked for, nothing planted ({skipped});"
    )


@pytest.mark.parametrize(
    ("fraction", "words"),
    [
        (0.86, "86 % of the jitter removed"),
        (0.004, "no jitter removed"),
        (-0.004, "no jitter removed"),
        (-0.05, "jitter up 5 %"),
    ],
)
def test_jitter_words_never_say_minus_zero(fraction, words):
    from motionclean.report.verdict import removed_words

    assert removed_words(fraction) == words


@pytest.mark.parametrize(
    ("removed", "line"),
    [
        (0.0022, "clean capture, smoothed: no jitter removed; largest change 0.9 degrees"),
        (0.0080, "clean capture, smoothed: 1 % of the jitter removed; largest change 0.9"),
        (-0.006, "clean capture, smoothed: jitter up 1 %; largest change 0.9 degrees"),
        # (a rise is no lack of noise: a sharpening mask's "jitter up 46 %" is no clean clip)
        (-0.03, "noisy capture, cleaned: jitter up 3 %; largest change 0.9 degrees"),
        (0.018, "noisy capture, cleaned: 2 % of the jitter removed; largest change 0.9"),
    ],
)
def test_a_capture_whose_jitter_smoothing_did_not_lower_is_not_called_noisy(removed, line):
    """A clean 30 fps Bandai Namco walk: its fast motion makes an estimated noise of 0.34
    degrees, the default moved it by 0.06 degrees RMS and removed 0.2 % of its jitter, and
    the line had read "noisy capture, cleaned: no jitter removed". Under 1 % removed or
    added the capture is called clean; the figures stay as they were."""
    report = {"frames": 125, "joints": {}, "contacts": None, "pipeline": [{"filter": "auto"}]}
    smoothing = {
        "noise_before": 3708.3,
        "noise_after": 3708.3 * (1.0 - removed),
        "noise_removed": removed,
        "change_deg_max": 0.92,
        "change_deg_rms": 0.061,
        "change_joint": "LowerLeg_R",
        "noise_level": 0.34,
    }
    verdict = build_verdict(report, smoothing)
    assert verdict["text"].startswith(line), verdict["text"]
    assert verdict["status"] == "cleaned" and verdict["noise_removed"] == removed


def test_a_lower_rate_s_low_pass_is_told_as_the_resample_s_not_motion_taken_for_noise(
    capsys, tmp_path
):
    """The README's resample pipeline (despike, auto, resample to 30 fps) on the clean cut:
    the anti-alias low-pass takes the wrist's fast turn (10.5 degrees), but the line had
    blamed smoothing and called it motion taken for noise."""
    code, out, _ = run_cli(
        capsys, "clean", SAMPLE, "-o", tmp_path / "30.bvh",
        "-f", "despike", "-f", "auto", "-f", "resample:fps=30",
    )  # fmt: skip
    verdict = next(line for line in out.splitlines() if line.startswith("verdict: "))
    assert code == 0 and "motion taken for noise" not in verdict
    assert "the cleaning (its resample included) moved RightWrist" in verdict, verdict
    assert "before resample" not in verdict  # (auto read the clip at its own rate)


def test_auto_after_a_lower_rate_finds_no_noise_and_the_verdict_says_to_put_it_first():
    """After resample to 60 fps the low-pass has taken the band auto reads noise in: on
    the noisy sample it chose no filter for any joint (before it, most joints are
    filtered), and the line had called the clip a clean capture."""
    late = clean_clip(NOISY, None, Pipeline.from_inline(["resample:fps=60", "auto"])).report
    early = clean_clip(NOISY, None, Pipeline.from_inline(["auto", "resample:fps=60"])).report
    chosen = [
        [note["auto"]["filter"]["mask"] for note in report["joints"].values() if "auto" in note]
        for report in (late, early)
    ]
    assert set(chosen[0]) == {"none"} and chosen[1].count("none") < len(chosen[1]) / 2
    assert late["verdict"]["status"] == "needs a look"
    assert (
        "auto after resample to 60 fps reads only the noise the resample's low-pass left: "
        "put auto before resample" in late["verdict"]["text"]
    )
    assert "before resample" not in early["verdict"]["text"]


@pytest.mark.parametrize(
    ("steps", "words"),
    [
        (["resample:fps=30", "auto", "footlock"], "auto and footlock after resample to 30 fps "),
        (["resample:fps=240", "auto"], "its spline left none (above 60 Hz): put auto before"),
        (["resample:fps=30", "resample:fps=120", "auto"], "to 120 fps reads the noise where"),
        (["resample:fps=120.01", "auto"], None),
        (["auto", "resample:fps=30", "lee-shin"], None),
    ],
)
def test_only_steps_reading_the_noise_after_a_rate_change_are_told_to_move(steps, words):
    """auto and footlock read the noise; another smoother after a resample (its strength
    given) or a resample to the same rate is no reason to look."""
    report = {"frame_time": 1 / 120, "pipeline": Pipeline.from_inline(steps).describe()}
    told = verdict_rules._order_words(report)
    assert (words in told[0]) if words else not told, told


def test_a_slide_just_over_the_planted_limit_does_not_read_as_the_limit():
    """Feet are planted up to 0.1 body heights/s: a slide of 0.102 had read "feet slide
    0.10 body heights/s", the limit itself; three decimals where two would say it."""
    from motionclean.report.verdict import _over

    assert _over(0.102, 0.1) == "0.102" and _over(0.2, 0.1) == "0.20"
    assert _over(0.504, 0.5) == "0.504" and _over(0.55, 0.5) == "0.55"


def test_a_resampled_clip_does_not_claim_its_dropouts_filled():
    """A pipeline that changes the frame rate is compared on the input's frames without
    their gaps: no fill is read from that comparison (it had said "1 gap filled")."""
    clip = mc.load(ROOT / "sample_data" / "131_02_motive.csv")
    report = clean_motion(clip, Pipeline.from_inline(["resample:fps=60"]), "m.csv").report
    assert "gap filled" not in report["verdict"]["text"]


def test_a_clip_too_short_to_judge_says_so(tmp_path, capsys):
    """One to three frames of motion hold no noise any step can tell: the verdict had said
    "clean capture: left as it was"; it is not smoothed and says why. Four frames are
    judged as any clip."""
    clip = mc.load(NOISY)
    for frames, status in ((3, "not smoothed"), (4, "cleaned")):
        short = tmp_path / f"short{frames}.bvh"
        cut = clip.replace(
            rotations=clip.rotations[:frames],
            translations=clip.translations[:frames],
            source_values=None,
            source_rotations=None,
        )
        mc.save(cut, short)
        page = tmp_path / f"short{frames}.json"
        code, out, _ = run_cli(capsys, "clean", short, "-o", tmp_path / "o.bvh", "--report", page)
        verdict = json.loads(page.read_text())["verdict"]
        assert code == 0 and verdict["status"] == status
        assert ("too short to judge (3 frames)" in verdict["text"]) == (frames == 3)


# Positions (a BVH root's position, a tracker's positions, SMPL's trans) are judged as
# rotations are: a clip whose positions smoothing moved is not "left as it was".


def with_root_noise(clip: mc.Motion, amplitude: float, seed: int = 0) -> mc.Motion:
    """``clip`` with uniform noise of +-``amplitude`` units on its root position only."""
    translations = clip.translations.copy()
    rng = np.random.default_rng(seed)
    translations[:, 0] += rng.uniform(-amplitude, amplitude, translations[:, 0].shape)
    return clip.replace(translations=translations, source_values=None, source_rotations=None)


def position_share(report: dict) -> float:
    """1 - after / before of the RMS linear acceleration over the report's position joints
    (their own figures; every joint's rows counted alike)."""
    rows = [v["linear_accel_rms"] for v in report["joints"].values() if "linear_accel_rms" in v]
    before = math.fsum(r["before"] ** 2 for r in rows)
    return 1.0 - math.sqrt(math.fsum(r["after"] ** 2 for r in rows) / before)


def test_noise_on_the_root_position_alone_is_cleaned_and_told(tmp_path):
    """131_02 cut with +-0.05 units of noise on the root position only, despike and auto:
    the rotations are left as they were, the root's position is smoothed (it read "clean
    capture, repaired: ... otherwise left as it was")."""
    noisy = tmp_path / "root_noise.bvh"
    mc.save(with_root_noise(mc.load(SAMPLE), 0.05), noisy)
    report = clean_clip(noisy, None, Pipeline.from_inline(["despike", "auto"])).report
    verdict, text = report["verdict"], report["verdict"]["text"]
    assert verdict["status"] == "cleaned", text
    assert "left as it was" not in text
    moved = report["joints"]["Hips"]["deviation_length"]["max"]
    assert 0.05 < moved == pytest.approx(verdict["change_length_max"], rel=1e-12)
    assert verdict["change_length_joint"] == "Hips"
    assert verdict["position_noise_removed"] == pytest.approx(position_share(report), rel=1e-9)
    share = f"{verdict['position_noise_removed']:.0%}".replace("%", " %")
    assert text.startswith(f"noisy capture, cleaned: {share} of the position jitter removed, ")
    assert "5 flips repaired on RThumb" in text
    assert f"largest position change {moved:.2g} units on Hips, no rotation changed" in text
    assert verdict["length_scale_of"] == "body height"


def tracker_csv(path, clip: mc.Motion, body: str, noise: float, seed: int = 0) -> None:
    """One body of ``clip`` as a rigid-body tracker writes it, with white noise of ``noise``
    units (standard deviation per axis) on its position."""
    positions, rotations = kinematics.forward(clip)
    j = clip.names.index(body)
    moved = positions[:, j] + np.random.default_rng(seed).normal(0, noise, positions[:, j].shape)
    rows = ["time," + ",".join(f"{body}.{s}" for s in ["px", "py", "pz", "qw", "qx", "qy", "qz"])]
    for f in range(clip.n_frames):
        values = np.concatenate([moved[f], rotations[f, j]])
        rows.append(f"{f * clip.frame_time:.6f}," + ",".join(f"{v:.6f}" for v in values))
    path.write_text("\n".join(rows) + "\n")


def test_a_trackers_position_noise_is_counted(tmp_path):
    """A rigid body tracked on its own (no body height: its positions' range of travel is
    the scale) with position noise: the jitter removed is the positions' (it read "clean
    capture: left as it was" over a linear acceleration cut 25-fold)."""
    source = tmp_path / "tracker.csv"
    tracker_csv(source, mc.load(SAMPLE), "Head", 0.03)
    report = clean_clip(source, None, Pipeline.default()).report
    verdict, text = report["verdict"], report["verdict"]["text"]
    assert verdict["status"] == "cleaned", text
    assert "left as it was" not in text and verdict["length_scale_of"] != "body height"
    assert verdict["position_noise_removed"] == pytest.approx(position_share(report), rel=1e-9)
    assert verdict["position_noise_removed"] > 0.5
    assert " of the position jitter removed" in text
    assert "largest position change" in text and "on Head" in text


def test_an_smpl_trans_smoothing_moved_is_told(tmp_path):
    """An AMASS .npz whose trans (the pelvis's position) is white noise of 0.1 units about a
    standing place: smoothing moves it by tenths of a unit, most of its travel, which the
    line tells (it read "clean capture: left as it was"); within 6 times the noise auto
    found there, the move is that noise going, no reason to look (as for a rotation: an
    OpenSim walk's pelvis_tx moved 14 mm, 3 times its noise, closer to its truth, had been
    told to take a look)."""
    frames = 120
    rng = np.random.default_rng(3)
    t = np.arange(frames)[:, None] / 120.0
    poses = 0.4 * np.sin(rng.uniform(0.5, 2, (1, 156)) * t + rng.uniform(0, 6, (1, 156)))
    poses[:, :3] += [np.pi / 2, 0, 0]
    source = tmp_path / "amass.npz"
    np.savez(
        source,
        trans=rng.normal(0, 0.1, (frames, 3)) + [0, 0, 0.9],
        gender=np.array("female"),
        mocap_framerate=np.array(120.0),
        betas=np.zeros(16),
        poses=poses,
    )
    result = clean_clip(source, None, Pipeline.default())
    verdict, text = result.report["verdict"], result.report["verdict"]["text"]
    moved = float(np.abs(result.after.translations - result.before.translations).max())
    assert moved > 0.1
    assert "left as it was" not in text
    assert verdict["status"] == "cleaned", text
    joint = verdict["change_length_joint"]
    noise = result.report["joints"][joint]["position_auto"]["noise"]
    assert verdict["change_length_max"] < 6.0 * noise
    assert "of the position jitter removed" in text and "largest position change" in text
    assert f"on {joint}" in text


def test_a_position_moved_below_any_visible_change_is_said_by_how_little(tmp_path):
    """Root position noise of a thousandth of a unit (of a body 24 units tall), smoothed: still
    a clean capture, but the line says what moved and by how little instead of "left as it
    was" (the written clip is not the one read)."""
    noisy = tmp_path / "faint.bvh"
    mc.save(with_root_noise(mc.load(SAMPLE), 1e-3), noisy)
    result = clean_clip(noisy, None, Pipeline.from_inline(["auto"]))
    verdict, text = result.report["verdict"], result.report["verdict"]["text"]
    shift = result.after.translations - result.before.translations
    moved = float(np.linalg.norm(shift, axis=-1).max())
    assert 0.001 < moved < 0.01
    assert verdict["status"] == "clean", text
    bound = float(text.split("moved by under ")[1].split(" units")[0])
    assert text.startswith("clean capture: Hips position moved by under "), text
    assert moved <= bound < 2 * moved  # (one figure, rounded up: "1" had read for 0.115)
    assert text.endswith("; no rotation changed outside repairs") and "as it was" not in text


def rotation_only(source, target) -> None:
    """``source`` with its root's position channels taken out: a clip of rotations only."""
    out, motion = [], False
    for line in source.read_text().splitlines():
        if not motion and "CHANNELS 6 Xposition Yposition Zposition" in line:
            line = line.replace("CHANNELS 6 Xposition Yposition Zposition", "CHANNELS 3")
        elif motion and line.strip():
            line = " ".join(line.split()[3:])
        motion = motion or line.startswith("Frame Time")
        out.append(line)
    target.write_text("\n".join(out) + "\n")


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        (
            NOISY,
            "noisy capture, cleaned: 93 % of the jitter removed, 5 flips repaired on RThumb, "
            "feet planted; largest change 3.6 degrees outside repairs",
        ),
        (
            SAMPLE,
            "clean capture, repaired: 5 flips repaired on RThumb, otherwise left as it was, "
            "feet planted; no rotation changed outside repairs",
        ),
    ],
)
def test_rotation_only_clips_keep_their_verdicts(tmp_path, source, expected):
    clip = tmp_path / "rotations.bvh"
    rotation_only(source, clip)
    assert not mc.load(clip).layout.has_position.any()
    verdict = clean_clip(clip, None, Pipeline.default()).report["verdict"]
    assert verdict["text"] == expected
    assert verdict["change_length_max"] is None and verdict["position_noise_removed"] is None


def test_the_demo_verdict_is_the_readmes():
    """The demo's root position is smoothed too (its rotations lead the line: they were
    smoothed, so the positions add nothing to it); the README quotes the line."""
    readme = (ROOT / "README.md").read_text()
    quoted = re.search(r"```\nverdict: (.*)\n```", readme).group(1)
    assert clean_clip(NOISY, None, Pipeline.default()).report["verdict"]["text"] == quoted


def test_feet_made_to_slide_are_not_called_planted(tmp_path, capsys):
    """Smoothing the legs of a clip whose root moves makes its feet slide (a VR capture's
    did, 0.043 -> 0.065 body heights/s, under the 0.1 called planted): the verdict says
    they slide more than before, whatever their speed."""
    legs = "lee-shin:joints=[*Hip,*Knee],k=20,iterations=4,positions=false"
    code, out, _ = run_cli(capsys, "clean", SAMPLE, "-o", tmp_path / "o.bvh", "-f", legs)
    line = next(line for line in out.splitlines() if line.startswith("verdict:"))
    found = re.search(r"feet slide more than before: (\d\.\d+) -> (\d\.\d+) body heights/s", line)
    assert code == 0 and found is not None, line
    before, after = map(float, found.groups())
    assert after > 1.25 * before and "planted" not in line


def test_feet_the_cleaning_made_clearly_worse_need_a_look(tmp_path, capsys):
    """A Perception Neuron sit-to-stand read as markerless: the default made a foot slide
    3.5 times as fast (0.005 -> 0.018 body heights/s) and the other sink below ground, and
    the line had read "noisy capture, cleaned: 72 % of the jitter removed". A pair whose
    cleaned root sways 0.03 body heights at 2 Hz slides its feet 3 times as fast during
    their contacts: it needs a look, each foot named with its figures (the contacts'); a
    sway of 0.002 body heights (no clear change) does not."""
    clip = mc.load(SAMPLE)
    height = kinematics.body_height(clip)
    t = np.arange(clip.n_frames) * clip.frame_time
    for sway, flagged in ((0.03, True), (0.002, False)):
        translations = clip.translations.copy()
        translations[:, 0, 0] += sway * height * np.sin(2.0 * np.pi * 2.0 * t)
        swayed, report = tmp_path / f"sway{sway}.bvh", tmp_path / f"sway{sway}.json"
        mc.save(clip.replace(translations=translations), swayed)
        code, _, err = run_cli(capsys, "report", SAMPLE, swayed, "--json", report)
        assert code == 0, err
        figures = json.loads(report.read_text())
        verdict, feet = figures["verdict"], figures["contacts"]["feet"]
        skates = {name: foot["skate_body_heights"] for name, foot in feet.items()}
        slid = {
            name: skate
            for name, skate in skates.items()
            if skate["after"] > verdict_rules.LOOK_WORSE * skate["before"]
            and skate["after"] - skate["before"] > verdict_rules.SLID_MORE_BY
        }
        assert bool(slid) is flagged and (verdict["status"] == "needs a look") is flagged
        assert {name: found["skate"] for name, found in verdict["feet_worse"].items()} == slid
        for name, skate in slid.items():
            said = f"{name} slides {skate['before']:.3f} -> {skate['after']:.3f} body heights/s"
            assert said in verdict["text"].split(". ")[0]
        assert verdict["text"].startswith(
            "needs a look: the cleaning made the feet worse during contacts: "
            if flagged
            else "clean capture"
        ), verdict["text"]


@pytest.mark.parametrize(
    ("depth", "skate", "worse"),
    [
        # (body heights before and after; a clear rise is over twice and over the floor)
        ((0.0, 1.05), (0.001, 0.002), {"depth"}),  # 0.001 -> 0.002 body heights/s: no
        ((0.5, 0.999), (0.02, 0.02), set()),  # twice as deep, but under the floor
        ((5.0, 9.0), (0.02, 0.1), {"skate"}),  # deeper, not twice as deep
    ],
)
def test_a_foot_deeper_below_ground_needs_a_look_beyond_a_floor(depth, skate, worse):
    """The depth below ground during contacts counts too (the Neuron clip's other foot:
    0.00012 -> 0.0036 body heights), in body heights, as twice as deep and by more than
    LOOK_SANK_BY (depth given here as shares of it); a rise from 0.001 to 0.002 of either
    is no clear change."""
    height, floor = 180.0, verdict_rules.LOOK_SANK_BY
    foot = {
        "contacts": [[10, 90]],
        "skate_body_heights": {"before": skate[0], "after": skate[1]},
        "penetration_during_contacts": {
            "before": depth[0] * floor * height,
            "after": depth[1] * floor * height,
        },
    }
    report = {
        "frames": 100,
        "joints": {},
        "world": {"body_height": height},
        "contacts": {"feet": {"LeftFoot": foot}},
        "pipeline": [{"filter": "auto"}],
    }
    smoothing = {
        "noise_removed": 0.5,
        "change_deg_max": 0.9,
        "change_deg_rms": 0.1,
        "change_joint": "LeftHip",
        "noise_level": 0.3,
    }
    verdict = build_verdict(report, smoothing)
    assert set(verdict["feet_worse"].get("LeftFoot", {})) == worse
    assert (verdict["status"] == "needs a look") is bool(worse)
    if "depth" in worse:
        assert verdict["feet_worse"]["LeftFoot"]["depth"]["after"] == pytest.approx(
            depth[1] * floor
        )
        said = f"LeftFoot below ground 0 -> {depth[1] * floor:.2g} body heights"
        assert said in verdict["text"]


def test_smoothing_far_beyond_a_clips_noise_is_told_as_motion_taken_away(tmp_path, capsys):
    """A user's heavy smoothing of a clean capture (noise 0.01-0.03 degrees) had read "noisy
    capture, cleaned: 25 % of the jitter removed": the line now says it changed the clip by
    more than 3 times its noise, and the capture is called clean. The default, which changes
    a clip by less than its noise, is not told so."""
    steps = ["-f", "despike", "-f", "lee-shin:k=2,iterations=3"]
    code, out, _ = run_cli(capsys, "clean", SAMPLE, "-o", tmp_path / "x.bvh", *steps)
    line = next(line for line in out.splitlines() if line.startswith("verdict: "))
    assert code == 0 and line.startswith("verdict: needs a look: smoothing changed it by "), line
    assert "times its noise" in line and "Clean capture, smoothed: " in line
    for clip in (SAMPLE, NOISY):
        report = clean_clip(clip, None, Pipeline.default()).report
        assert "times its noise" not in report["verdict"]["text"]


def test_the_jitter_removed_weighs_each_joint_by_how_far_it_reaches(tmp_path):
    """Jitter planted on the fingers and the left thumb alone (1 degree; the right thumb
    flips) and smoothed away there: pooled plainly, their angular accelerations are most
    of the clip's, and most of them went; weighed by reach (a finger moves its centimetre,
    the body's own motion its limbs), the verdict's jitter removed stays small: the body
    seen in world space barely changed."""
    clip = mc.load(SAMPLE)
    fingers = [clip.names.index(n) for n in ("LFingers", "RFingers", "LThumb")]
    rng = np.random.default_rng(3)
    shake = quat.exp(rng.normal(scale=np.radians(1.0) / 2, size=(clip.n_frames, 3, 3)))
    noisy = clip.rotations.copy()
    noisy[:, fingers] = quat.multiply(noisy[:, fingers], shake)
    source = tmp_path / "fingers.bvh"
    mc.save(clip.replace(rotations=noisy), source)
    smooth = Pipeline.from_inline(
        ["lee-shin:joints=['*Fingers','LThumb'],mask=binomial,k=3,iterations=4"]
    )
    report = clean_clip(source, None, smooth).report
    rms = [report["joints"][n]["angular_accel_rms"] for n in clip.names if n != "RThumb"]
    pooled = 1.0 - math.sqrt(sum(r["after"] ** 2 for r in rms) / sum(r["before"] ** 2 for r in rms))
    assert pooled > 0.6
    assert 0.0 < report["verdict"]["noise_removed"] < 0.2


def test_the_line_says_when_the_end_effectors_lost_far_less_than_the_joints(tmp_path):
    """A video estimate's joint angles jitter against each other (fitted to keypoints): the
    default took a third of their jitter, its hands, feet and head 2 % of their world
    acceleration, which the line now says; where the two agree (a Z-up video estimate: 29
    % and 23 %) it says nothing more. The figure is the report's own end effectors',
    pooled; with repairs (the demo's flips, the Z-up estimate's lone outliers) there is
    none, as those figures count the repaired frames: PyMO's walk with a degree of white
    noise planted (93 % and 94 %) is the case where they agree."""
    demo = clean_clip(NOISY, None, Pipeline.default())
    assert demo.report["verdict"]["world_removed"] is None
    assert "world acceleration" not in demo.report["verdict"]["text"]
    exporters = ROOT / "tests" / "data" / "exporters"
    walk = mc.load(exporters / "pymo_walk_tpose.bvh")
    agreeing = tmp_path / "walk_noisy.bvh"
    mc.save(walk.replace(rotations=plant(walk.rotations, 1.0, 3)), agreeing)
    video = exporters / "video_estimate_cmu_names.bvh"
    for source, told in ((video, True), (agreeing, False)):
        result = clean_clip(source, None, Pipeline.default())
        verdict = result.report["verdict"]
        world = verdict["world_removed"]
        said = f"({world:.0%} of the end effectors' world acceleration removed)"
        assert (said.replace("%", " %") in verdict["text"]) is told
        assert (world < verdict_rules.WORLD_SHARE * verdict["noise_removed"]) is told
        # the page's jitter card gives it wherever it is measured, beside before -> after
        card = f"{world:.0%} of the end effectors' world acceleration removed"
        assert card.replace("%", "\u2009%") in render_html(result.report, result.series)


def test_the_page_says_a_rise_of_the_end_effectors_world_acceleration_as_a_rise():
    """The page had read "the end effectors' world acceleration -12 % removed" where the
    terminal said "up 12 %": a sharpening (multires' finest band doubled) on a clean walk
    raises it, and the page now says it as the line does."""
    source = ROOT / "tests" / "data" / "exporters" / "mocapbank_walk.bvh"
    result = clean_clip(source, None, Pipeline.from_inline(["multires:gains=[2]"]))
    world = result.report["verdict"]["world_removed"]
    assert world <= -0.005
    page = render_html(result.report, result.series)
    rise = f"end effectors' world acceleration up {-world:.0%}".replace("%", "\u2009%")
    assert rise in page
    assert "world acceleration -" not in page and "world acceleration \u2212" not in page


def test_tracked_bodies_pool_their_jitter_equally_and_the_page_says_no_reach():
    """Tracked rigid bodies reach no point: their jitter is pooled equally, the JSON says
    ``noise_weighting: equal`` and the page's headline does not claim a weighting by
    reach; a skeleton's says ``reach`` and its page does, cleaned or reported alone."""
    from motionclean.report.summary import build_report, build_series

    for source, weighting in (
        (ROOT / "sample_data" / "131_02_motive.csv", "equal"),
        (NOISY, "reach"),
    ):
        cleaned = clean_clip(source, None, Pipeline.default())
        clip = mc.load(source)
        alone = build_series(clip)
        for report, series in (
            (cleaned.report, cleaned.series),
            (build_report(clip, series=alone), alone),
        ):
            assert report["verdict"]["noise_weighting"] == weighting
            headline = re.findall(r'<div class="stat">.*?</div>', render_html(report, series))[0]
            assert ("weighted by" in headline) is (weighting == "reach")


def test_two_clips_compared_tell_a_spike_taken_out_of_a_smoothed_joint_as_a_brief_change(
    tmp_path, capsys
):
    """The noisy walk's Head with one 20-degree spike, cleaned by the default: despike takes
    the spike out and auto smooths the joint all along, so no frame beside the spike is
    left as it was. The two-file report had read "needs a look: the cleaning moved Head by
    19.4 degrees"; the spike's frame stands out of the changes around it (more than
    STANDOUT times) where the input jumped out and back, and is told as a brief change. A
    one-frame change of the same size where the input holds a step, not a spike, is not."""
    clip = mc.load(SAMPLE)
    rng = np.random.default_rng(3)
    noise = quat.exp(rng.normal(size=(*clip.rotations.shape[:2], 3)) * np.radians(0.3))
    noisy = clip.replace(rotations=quat.multiply(clip.rotations, noise), source_values=None)
    head = clip.names.index("Head")
    spiky, cleaned = tmp_path / "spiky.bvh", tmp_path / "c.bvh"
    mc.save(_with_excursion(noisy, "Head", 100, np.array([20.0])), spiky)
    code, _, err = run_cli(capsys, "clean", spiky, "-o", cleaned, "-q")
    assert code == 0, err
    code, out, err = run_cli(capsys, "report", spiky, cleaned, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    change = np.degrees(
        quat.angle_between(mc.load(spiky).rotations[:, head], mc.load(cleaned).rotations[:, head])
    )
    assert change[100] > 15 and max(change[99], change[101]) > UNCHANGED_DEG  # smoothed around
    assert report["joints"]["Head"]["brief_change"]["runs"] == [[100, 101]]
    assert "moved Head" not in report["verdict"]["text"]
    assert f"changed by up to {change[100]:.1f} degrees on Head (frames 100)" in out
    # the same change at frame 100 of a clip whose Head steps there (no spike): not brief
    stepped = np.r_[np.zeros(100), np.full(clip.n_frames - 100, 20.0)]
    source = tmp_path / "stepped.bvh"
    mc.save(_with_excursion(noisy, "Head", 0, stepped), source)
    moved = _with_excursion(noisy, "Head", 0, np.r_[np.zeros(101), stepped[101:]])
    mc.save(moved, cleaned)
    code, _, err = run_cli(capsys, "report", source, cleaned, "--json", tmp_path / "r2.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r2.json").read_text())
    assert "brief_change" not in report["joints"]["Head"]


@pytest.mark.parametrize("name", ["131_02.bvh", "131_03.bvh"])
def test_a_clip_compared_with_itself_shows_no_change(tmp_path, capsys, name):
    """`report CLIP CLIP`: nothing changed, so no brief change ("changed by up to 0.0
    degrees in 9 brief runs" had come of rounding, ~1e-15 degrees, standing out of the
    median change of 0 in joints with large input steps)."""
    clip = corpus_clip(name)
    code, out, err = run_cli(capsys, "report", clip, clip, "--json", tmp_path / "r.json")
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert not any("brief_change" in joint for joint in report["joints"].values())
    assert "brief" not in report["verdict"]["text"] and report["verdict"]["repairs"] == {}


def _verdict_moved(tmp_path, clip: mc.Motion, translations: np.ndarray, name: str) -> dict:
    """The default's verdict on ``clip`` with these ``translations``, read from a file."""
    source = tmp_path / f"{name}.bvh"
    mc.save(clip.replace(translations=translations, source_values=None), source)
    return clean_clip(source, None, Pipeline.default()).report["verdict"]


@pytest.mark.parametrize("frames", [1, 20])
def test_a_root_that_teleports_needs_a_look(tmp_path, frames):
    """The sample with its root moved by 0.4 body heights for 1 frame (a spike: despike
    takes it out, nothing to say) or for 20 frames at 120 fps (0.17 s, longer than
    despike's spikes: it had read "clean capture ... otherwise left as it was"): the
    cleaned clip's root steps at about 48 body heights/s, and the verdict asks for a look,
    naming the joint, its frames and the speed (JSON `position_jumps`)."""
    clip = mc.load(SAMPLE)
    height = kinematics.body_height(clip)
    moved = clip.translations.copy()
    moved[150 : 150 + frames, 0, 0] += 0.4 * height
    verdict = _verdict_moved(tmp_path, clip, moved, "jump")
    if frames == 1:
        assert verdict["position_jumps"] == {} and "jump" not in verdict["text"]
        return
    jumps = verdict["position_jumps"]["Hips"]
    assert jumps["frames"] == 2 and jumps["at"] in (150, 150 + frames)
    assert jumps["fastest"] == pytest.approx(0.4 / clip.frame_time, rel=0.05)
    assert verdict["text"].startswith("needs a look: Hips's position jumps (steps over 10 body")


def test_a_fast_smooth_move_of_a_position_is_no_jump(tmp_path):
    """The sample's root swung along a smooth arc at up to 15 body heights/s (a serve's
    hand: faster than the jump limit, but its steps around as fast): no jump; the same
    clip with one 0.4 body-height teleport held 0.17 s is one (its two steps)."""
    clip = mc.load(SAMPLE)
    height = kinematics.body_height(clip)
    t = np.arange(clip.n_frames) * clip.frame_time
    swung = clip.translations.copy()
    swung[:, 0, 0] += 0.6 * height * np.sin(2 * np.pi * 4.0 * t)  # peak 15 body heights/s
    for name, moved in (("arc", swung), ("teleport", swung.copy())):
        if name == "teleport":
            moved[150:170, 0, 2] += 0.4 * height
        jumps = _verdict_moved(tmp_path, clip, moved, name)["position_jumps"]
        assert (jumps == {}) is (name == "arc")


def test_smoothing_across_unrepaired_flips_is_not_called_motion_taken_for_noise(tmp_path, capsys):
    """multires across the noisy sample's thumb flips (cut_deg=180: no repair) moves the
    frames near them by up to 177 degrees: told as such. Its change away from them is
    within 3 times the noise, so no "motion taken for noise" (the RMS over every frame,
    4.9 degrees, had said so)."""
    out = tmp_path / "mr.bvh"
    code, stdout, err = run_cli(
        capsys,
        "clean",
        NOISY,
        "-o",
        out,
        "-f",
        "multires:level=2,cut_deg=180",
        "--report",
        tmp_path / "r.json",
    )
    assert code == 0, err
    report = json.loads((tmp_path / "r.json").read_text())
    verdict = report["verdict"]["text"]
    assert "across 10 steps of over 90 degrees in the input" in verdict
    assert "motion taken for noise" not in verdict
    said = report["verdict"]
    assert said["change_deg_rms"] > 3 * said["noise_level_deg"] >= said["change_deg_rms_away"]


@pytest.mark.parametrize("spiked", [2, 9])
def test_a_capture_glitching_on_many_joints_is_no_clean_capture(spiked):
    """One-frame spikes of 40 degrees on ``spiked`` joints of a clean capture: repaired
    either way; the line calls the capture glitchy where a fifth of its joints or more
    glitched, clean otherwise."""
    clip = mc.load(corpus_clip("131_02.bvh"))
    joints = [n for n, name in enumerate(clip.names) if "Thumb" not in name][1 : 1 + spiked]
    rotations = clip.rotations.copy()
    kick = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(40.0))
    for k, joint in enumerate(joints):
        frame = 200 + 60 * k
        rotations[frame, joint] = quat.multiply(kick, rotations[frame, joint])
    result = clean_motion(clip.replace(rotations=rotations), Pipeline.default(), "spiked.bvh")
    verdict = result.report["verdict"]
    spikes = sum(c["spikes"] for c in verdict["repairs"].values())
    assert spikes >= spiked
    glitchy = spiked >= verdict_rules.GLITCHY_SHARE * clip.n_joints
    assert verdict["text"].startswith("glitchy capture") == glitchy, verdict["text"]
    assert verdict["status"] in ("repaired", "cleaned")


@pytest.mark.parametrize(
    ("step", "words"),
    [
        ("ground:up=z", "the up axis given to ground (z) contradicts the motion (y)"),
        ("footlock:up=x", "the up axis given to footlock (x) contradicts the motion (y)"),
        ("ground:up=y", None),
    ],
)
def test_a_steps_own_up_axis_is_checked_against_the_motion_as_the_clips_is(step, words):
    """`-f ground:up=z` moved a y-up clip 34 units sideways and read "put on the floor ...
    feet planted", where `--up z -f ground` needed a look: a step's own `up` gets the same
    check and the same words."""
    report = clean_clip(SAMPLE, None, Pipeline.from_inline([step])).report
    text = report["verdict"]["text"]
    if words is None:
        assert "contradicts" not in text and "steps_up_contradicted" not in report["world"]
        return
    assert report["verdict"]["status"] == "needs a look" and f"needs a look: {words}" in text
    (entry,) = report["world"]["steps_up_contradicted"]
    assert entry["shown"]["up_axis"] == "y" and entry["filter"] == step.split(":")[0]


def test_a_steps_up_that_is_the_clips_own_is_said_once():
    """`--up z -f ground:up=z`: the clip's up axis is told, not the step's again."""
    clip = mc.load(SAMPLE)
    clip.up = "z"
    report = clean_motion(clip, Pipeline.from_inline(["ground:up=z"]), "c.bvh").report
    assert report["verdict"]["text"].count("contradicts") == 1
    assert "the up axis given (z) contradicts the motion (y)" in report["verdict"]["text"]
