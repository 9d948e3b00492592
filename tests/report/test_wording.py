"""What the program prints agrees with itself: plurals, one frame rate for one file, the
rest frames named by info, and #frame=N opening frame N on long clips."""

from __future__ import annotations

import re

import pytest
from helpers import SAMPLE, bending_hand, corpus_clip, cut_bvh, run_cli, with_t_pose

import motionclean as mc
from motionclean.core.words import percent, whole_percent
from motionclean.report.html_world import _frames
from motionclean.report.terminal import note_text
from motionclean.report.world import format_contacts, format_floor
from motionclean.steps.base import fps_text


def test_one_of_a_thing_is_singular():
    despike = {"frames_repaired": 1, "unflipped": [[7, 8]], "interpolated": []}
    assert note_text("despike", despike).startswith("1 frame repaired;")
    footlock = {"contacts": [[10, 11]], "frames": 1}
    assert note_text("footlock", footlock).startswith("held 1 contact (1 frame)")
    feet = {
        "feet": {
            "LeftAnkle": {
                "contacts": [[3, 4]],
                "frames": 1,
                "skate_body_heights": {"before": 0.1, "after": None},
                "penetration": {"before": None, "after": None},
            }
        }
    }
    assert format_contacts(feet)[0].startswith("foot LeftAnkle: 1 contact (1 frame)")
    despike["frames_repaired"] = 2
    assert note_text("despike", despike).startswith("2 frames repaired;")
    floor = {"height": 0.0, "tilt_deg": 0.0, "normal": [0.0, 1.0, 0.0], "contacts": 1}
    assert format_floor({"floor": floor}).endswith("(through the soles of 1 contact)")


def test_an_opensim_file_says_one_column_it_carries(tmp_path, capsys):
    """A .mot with one column of states carried as text: "1 column of states", not
    "1 columns"."""
    motion = tmp_path / "one.mot"
    rows = "\n".join(f"{i / 100:.2f}\t{i * 0.1:.4f}\t{0.5:.4f}" for i in range(20))
    motion.write_text(
        "one\nversion=1\nnRows=20\nnColumns=3\ninDegrees=yes\nendheader\n"
        f"time\tknee_angle_r\tknee_angle_r/speed\n{rows}\n"
    )
    code, out, err = run_cli(capsys, "info", motion)
    assert code == 0, err
    assert re.search(r"\b1 column of ", out + err) and "1 columns" not in out + err


def test_info_and_resample_give_one_rate_for_one_file(tmp_path, capsys):
    # the sample's Frame Time is 0.008333 s: 120.0048 fps, which every message calls 120
    assert fps_text(0.008333) == "120" and fps_text(1 / 29.97) == "29.97"
    code, info, _ = run_cli(capsys, "info", SAMPLE)
    assert code == 0 and "rate: 120 fps" in info
    code, out, err = run_cli(capsys, "resample", SAMPLE, tmp_path / "r.bvh", "--fps", "60")
    assert code == 0, err
    assert "at 120 fps -> " in out and "at 60 fps" in out


def test_info_names_the_rest_frames(tmp_path, capsys):
    code, out, _ = run_cli(capsys, "info", with_t_pose(SAMPLE, tmp_path / "t.bvh"))
    assert code == 0
    assert "rest pose: frame 0 kept as it is" in out
    code, plain, _ = run_cli(capsys, "info", SAMPLE)
    assert "rest pose:" not in plain

    def steps(text: str) -> dict[str, tuple[str, int]]:  # joint: (largest step, at frame)
        rows = text[text.index("largest step") :].splitlines()[1:-2]
        return {row.split()[0]: (row.split()[-4], int(row.split()[-3])) for row in rows}

    # the step out of the T-pose is no step of the motion: the same steps, a frame later
    assert steps(out) == {name: (step, at + 1) for name, (step, at) in steps(plain).items()}


@pytest.mark.parametrize("n_frames", [1190, 1247, 10_000, 100_000])
def test_a_long_clip_carries_round_frames(n_frames):
    frames = _frames(n_frames)
    assert len(frames) <= 400 and frames[0] == 0 and frames[-1] == n_frames - 1
    stride = frames[1] - frames[0]
    assert stride in (2, 5, 10, 20, 25, 50, 100, 200, 250, 500)
    assert (frames[:-1] % stride == 0).all()
    if n_frames <= 10_000:
        assert 150 in frames  # #frame=150 opens frame 150 (149 on a 1,190-frame clip before)


@pytest.mark.browser
def test_the_player_says_when_it_shows_a_nearby_frame(tmp_path, chromium):
    from test_html_world import chromium_dom, page_of

    page = tmp_path / "report.html"
    page.write_text(page_of(corpus_clip("131_02.bvh")), encoding="utf-8")
    assert re.search(r'id="mc-frame">frame 150<', chromium_dom(chromium, page, "#frame=150"))
    later = chromium_dom(chromium, page, "#frame=152")
    assert re.search(r'id="mc-frame">frame 150 \(nearest carried to frame 152\)<', later)


@pytest.mark.parametrize("share", [-0.001, -0.004, 0.0, -0.0])
def test_a_share_that_rounds_to_nothing_reads_0_percent(share):
    """A removed share a rounding below zero (a second pass, a short range) had read
    "-0%" on the page, the batch index and the Blender panel, which share this wording."""
    assert whole_percent(share) == "0%" and percent(share) == "0 %"
    assert whole_percent(-0.05) == "-5%" and whole_percent(0.934) == "93%"


def test_info_says_what_it_has_no_motion_body_or_feet_for(tmp_path, capsys):
    """A clip of 0 frames had its up axis "found from the motion"; a hand had a "body
    height" and "feet: none found (no ground contact)", as if its feet were off the ground.
    Without frames the axis is found from the rest pose; a skeleton without trunk or legs
    has a size, no body height, and no feet; the sample reads as before."""
    _, out, _ = run_cli(capsys, "info", cut_bvh(SAMPLE, tmp_path / "none.bvh", 0))
    assert "up axis: y (found from the rest pose)   body height: " in out
    hand = tmp_path / "hand.bvh"
    mc.save(bending_hand(), hand)
    _, out, _ = run_cli(capsys, "info", hand)
    assert re.search(r"   size: \S+ units \(no body: no trunk or legs\)\n", out), out
    assert "body height" not in out and "feet: none (no feet in this skeleton)" in out
    _, out, _ = run_cli(capsys, "clean", hand, "-o", tmp_path / "out.bvh")
    assert re.search(r"^world: up axis \S+, size \S+ units \(no body\)", out, re.M), out
    _, out, _ = run_cli(capsys, "info", SAMPLE)
    assert "up axis: y (found from the motion)   body height: 24.27 units" in out
