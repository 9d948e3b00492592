"""Plots treat rest frames and missing samples alike before and after cleaning (left out,
drawn as gaps, never as zeros), and the noise model's correlation is shown on a joint only
where it says something about that joint."""

from __future__ import annotations

import json
import re

import numpy as np
from helpers import NOISY, ROOT, SAMPLE, run_cli, with_t_pose

import motionclean as mc
from motionclean.core import kinematics
from motionclean.report.html import render_html
from motionclean.report.metrics import angular_acceleration
from motionclean.run.jobs import clean_clip
from motionclean.steps.pipeline import Pipeline


def joint_paths(page: str, joint: str) -> dict[str, str]:
    svg = re.search(rf'<svg class="plot" data-joint="{joint}".*?</svg>', page).group(0)
    return dict(re.findall(r'data-series="(\w+)" stroke="[^"]+" d="([^"]+)"', svg))


def first_x(path: str) -> float:
    return float(path[1:].split()[0])


def test_a_t_pose_is_left_out_of_both_curves_alike(tmp_path):
    source = with_t_pose(SAMPLE, tmp_path / "t.bvh")
    result = clean_clip(source, None, Pipeline.default())
    assert result.report["rest_frames"]["leading"] == 1
    for name, data in result.series["joints"].items():
        before, after = data["accel_before"], data["accel_after"]
        # row 0 (frames 0-2) holds the jump out of the T-pose: left out of both
        assert np.isnan(before.low[:1]).all() and np.isnan(after.low[:1]).all(), name
        np.testing.assert_array_equal(np.isnan(before.low), np.isnan(after.low))
        assert before.peak == np.nanmax(before.high)
    page = render_html(result.report, result.series)
    for joint in ("Hips", "LeftKnee", "RThumb"):
        paths = joint_paths(page, joint)
        assert first_x(paths["before"]) == first_x(paths["after"]) > 54.0


def rigid_csv(path, clip: mc.Motion, gone: slice) -> None:
    from motionclean.core import kinematics

    positions, rotations = kinematics.forward(clip)
    bodies = ["Head", "LeftWrist", "RightWrist"]
    cols = [f"{b}.{s}" for b in bodies for s in ("px", "py", "pz", "qw", "qx", "qy", "qz")]
    rows = ["time," + ",".join(cols)]
    for f in range(clip.n_frames):
        cells = [f"{f * clip.frame_time:.6f}"]
        for body in bodies:
            j = clip.names.index(body)
            values = np.concatenate([positions[f, j], rotations[f, j]])
            blank = body == "RightWrist" and f in range(clip.n_frames)[gone]
            cells += [""] * 7 if blank else [f"{v:.6f}" for v in values]
        rows.append(",".join(cells))
    path.write_text("\n".join(rows) + "\n")


def test_a_body_missing_for_100_frames_is_a_gap_not_zero_acceleration(tmp_path):
    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), slice(150, 250))
    result = clean_clip(source, None, Pipeline.default())
    data = result.series["joints"]["RightWrist"]
    for key in ("accel_before", "accel_after"):
        trace = data[key]
        gone = np.isnan(trace.low)
        # rows i..i+2 touching frames 150-249: rows 148-249
        np.testing.assert_array_equal(np.flatnonzero(gone), np.arange(148, 250))
    assert np.isnan(data["deviation"].low[150:250]).all()
    page = render_html(result.report, result.series)
    paths = joint_paths(page, "RightWrist")
    assert paths["before"].count("M") == paths["after"].count("M") == 2
    # the figures leave those rows out too (not zeros in the mean)
    clip = mc.load(source)
    j = clip.names.index("RightWrist")
    acc = angular_acceleration(clip.rotations[:, j], clip.frame_time)
    known = np.ones(acc.shape[0], dtype=bool)
    known[148:250] = False
    rms = np.sqrt(np.mean(acc[known] ** 2))
    figure = result.report["joints"]["RightWrist"]["angular_accel_rms"]["before"]
    np.testing.assert_allclose(figure, rms, rtol=1e-12)


def auto_notes(page: str) -> list[str]:
    return re.findall(r"<b>auto</b> ([^<]*)</div>", page)


def test_the_noise_correlation_is_shown_where_it_tells_something(tmp_path):
    # 30 fps: the model takes the noise as white on every joint; no joint says rho 0.00
    low = tmp_path / "low.bvh"
    clip = mc.load(NOISY)
    mc.save(
        clip.replace(
            rotations=clip.rotations[::4],
            translations=clip.translations[::4],
            frame_time=clip.frame_time * 4,
            source_values=None,
            source_rotations=None,
        ),
        low,
    )
    result = clean_clip(low, None, Pipeline.default())
    page = render_html(result.report, result.series)
    notes = auto_notes(page)
    assert notes and not any("rho" in n for n in notes)
    assert "taken as white" in page
    # 120 fps: the clip's typical correlation once, a joint's own only where it differs
    result = clean_clip(NOISY, None, Pipeline.default())
    page = render_html(result.report, result.series)
    rhos = {n: j["auto"]["rho"] for n, j in result.report["joints"].items() if "auto" in j}
    typical = float(np.median(list(rhos.values())))
    assert f"AR(1) rho {typical:.2f} (median" in page
    shown = [
        n
        for n in rhos
        if re.search(rf'id="j-{n}".*?<b>auto</b>[^<]*rho', page, flags=re.S)
        and re.search(rf'id="j-{n}"(?:(?!</section>).)*rho', page, flags=re.S)
    ]
    expected = [n for n, r in rhos.items() if abs(r - typical) >= 0.2]
    assert sorted(shown) == sorted(expected)
    assert len(expected) < len(rhos)


def test_the_trajectories_leave_the_rest_pose_out(tmp_path):
    """A T-pose first frame is no part of where the hands and feet go: no track starts with
    a line out of it, and it does not set the view's bounds."""
    source = with_t_pose(SAMPLE, tmp_path / "t.bvh")
    result = clean_clip(source, None, Pipeline.default())
    page = render_html(result.report, result.series)
    tracks = re.findall(r'<polyline class="track" data-series="(\w+)"[^>]* points="([^"]+)"', page)
    assert tracks
    for _, points in tracks:
        assert len(points.split()) == result.before.n_frames - 1  # frames 1 .. 300


def test_position_figures_leave_out_the_rows_next_to_a_dropout(capsys, tmp_path):
    """Position figures follow the rotations' rule: rows that involve a missing sample of
    either clip are left out of both (the placeholder is no motion, and clean filled it),
    in the joint's figures and its world end-effector figures, and `report IN` gives the
    same figures of the input as `clean --report`."""
    source = ROOT / "sample_data" / "131_02_motive.csv"
    clip = mc.load(source)
    j = clip.names.index("hand_l")
    gone = clip.missing[:, j]
    rows = ~(gone[:-2] | gone[1:-1] | gone[2:])
    result = clean_clip(source, None, Pipeline.default())
    assert gone.any() and result.after.missing is None  # filled: no gap of its own after
    joint = result.report["joints"]["hand_l"]
    effector = result.report["world"]["effectors"]["hand_l"]
    for key, motion in (("before", clip), ("after", result.after)):
        for figures, points in (
            (joint, motion.translations[:, j]),
            (effector, kinematics.forward(motion)[0][:, j]),
        ):
            accel = np.linalg.norm(np.diff(points, n=2, axis=0), axis=-1)[rows]
            accel /= clip.frame_time**2
            rms = np.sqrt(np.mean(accel**2))
            np.testing.assert_allclose(figures["linear_accel_rms"][key], rms, rtol=1e-9)
            np.testing.assert_allclose(figures["linear_accel_max"][key], accel.max(), rtol=1e-9)
    moved = np.linalg.norm(result.after.translations[:, j] - clip.translations[:, j], axis=-1)
    assert joint["deviation_length"]["max"] == moved[~gone].max()
    code, _, _ = run_cli(capsys, "report", str(source), "--json", str(tmp_path / "r.json"))
    alone = json.loads((tmp_path / "r.json").read_text())["joints"]["hand_l"]
    assert code == 0 and alone["linear_accel_rms"]["before"] == joint["linear_accel_rms"]["before"]


def test_a_body_missing_on_every_frame_has_no_figures_not_zeros(tmp_path, capsys):
    """Nothing measured is said as such: null in the JSON (figures, auto's noise), "-" in
    the terminal, the page and info, and the verdict names the joint once."""
    source = tmp_path / "t.csv"
    rigid_csv(source, mc.load(SAMPLE), slice(None))
    report = tmp_path / "r.json"
    code, out, err = run_cli(
        capsys, "clean", str(source), "-o", str(tmp_path / "o.csv"), "--report", str(report)
    )
    assert code == 0 and err == ""
    text = report.read_text()
    json.loads(text)  # strict JSON: no NaN token
    entry = json.loads(text)["joints"]["RightWrist"]
    for key in ("angular_accel_rms", "angular_accel_max"):
        assert entry[key] == {"before": None, "after": None}
    assert entry["deviation_deg"] == {"rms": None, "max": None}
    assert entry["auto"]["noise"] is None and entry["auto"]["filter"] == {"mask": "none"}
    assert "nothing to measure" in entry["auto"]["why"]
    head = json.loads(text)["joints"]["Head"]  # measured joints keep their figures
    assert head["angular_accel_rms"]["before"] > 0 and head["auto"]["noise"] > 0
    rows = [line for line in out.splitlines() if line.startswith(("Head", "LeftWrist", "Right"))]
    assert rows[-1].startswith("RightWrist"), rows  # nothing measured: listed last
    assert rows[-1].split()[1:6] == ["-"] * 5, rows
    assert "RightWrist missing on frames 0-" in out
    page = render_html(json.loads(text), None)
    cells = re.search(r"<tr><td>RightWrist</td>(.*?)</tr>", page).group(1)
    assert set(re.findall(r"<td>([^<]*)</td>", cells)) == {"-"}

    code, out, _ = run_cli(capsys, "info", str(source))
    row = next(line for line in out.splitlines() if line.strip().startswith("RightWrist"))
    assert code == 0 and row.split()[-4:] == ["-"] * 4, row


def test_joints_missing_on_the_same_frames_are_named_together():
    from motionclean.report.verdict import _missing_words

    gone = {"fill-gaps": {"missing": [[0, 300]]}}
    joints = {f"J{k}": gone for k in range(5)} | {"Other": {"fill-gaps": {"missing": [[4, 9]]}}}
    assert _missing_words(joints) == [
        "J0, J1, J2 and 2 more joints missing on frames 0-299",
        "Other missing on frames 4-8",
    ]
