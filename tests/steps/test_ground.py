"""The floor found from contacts (height, tilt) and the ``ground`` step: a tilted, raised
floor is levelled and put at height 0 by moving the root alone."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import ROOT, SAMPLE, bending_hand, corpus_clip, turned_copy, uphill

import motionclean as mc
from motionclean.core import contacts as found
from motionclean.core import kinematics, quat
from motionclean.report.world import contact_figures, format_contacts
from motionclean.run.jobs import clean_motion
from motionclean.steps.ground import floor_of
from motionclean.steps.pipeline import Pipeline

TILT_DEG = 8.0
EXPORTERS = ROOT / "tests" / "data" / "exporters"


@pytest.fixture(scope="module")
def walk() -> mc.Motion:
    return mc.load(corpus_clip("131_02.bvh"))


def _tilted(motion: mc.Motion, rise: float, degrees: float = TILT_DEG) -> mc.Motion:
    """``motion`` on a floor tilted by ``degrees`` about the x axis and raised by ``rise``."""
    turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.radians(degrees))
    translations = motion.translations.copy()
    rotations = motion.rotations.copy()
    rotations[:, 0] = quat.multiply(turn, rotations[:, 0])
    translations[:, 0] = quat.rotate(turn, translations[:, 0]) + np.array([0.0, rise, 0.0])
    return motion.replace(rotations=rotations, translations=translations, source_values=None)


def test_the_floor_of_a_flat_capture_is_level_and_a_tilted_one_is_found(walk):
    section, _ = contact_figures(walk)
    floor = section["floor"]
    assert floor["tilt_deg"] < 1.0 and floor["contacts"] >= 10
    height = kinematics.body_height(walk)
    tilted, _ = contact_figures(_tilted(walk, 5.0))
    assert tilted["floor"]["tilt_deg"] == pytest.approx(TILT_DEG, abs=1.0)
    assert tilted["floor"]["normal"][2] == pytest.approx(np.sin(np.radians(TILT_DEG)), abs=0.02)
    assert abs(floor["height"]) < 0.05 * height


def test_ground_levels_the_floor_and_puts_it_at_zero_moving_the_root_only(walk):
    height = kinematics.body_height(walk)
    tilted = _tilted(walk, 5.0)
    grounded, logs = Pipeline.from_inline(["ground"]).run(tilted)
    floor = floor_of(grounded).floor
    assert floor is not None
    assert floor.tilt_deg < 1.0
    assert abs(floor.offset) < 0.01 * height
    np.testing.assert_array_equal(grounded.rotations[:, 1:], tilted.rotations[:, 1:])
    np.testing.assert_array_equal(grounded.translations[:, 1:], tilted.translations[:, 1:])
    # the motion itself is kept: every point moves by one rigid transform
    before = kinematics.forward(tilted, end_sites=True)[0]
    after = kinematics.forward(grounded, end_sites=True)[0]
    centred_b = before - before.mean(axis=(0, 1))
    centred_a = after - after.mean(axis=(0, 1))
    u, _, vt = np.linalg.svd(centred_a.reshape(-1, 3).T @ centred_b.reshape(-1, 3))
    fit = (u @ vt) @ centred_b.reshape(-1, 3).T
    np.testing.assert_allclose(fit.T, centred_a.reshape(-1, 3), atol=1e-6 * height)
    note = logs[0].notes["Hips"]["position_ground"]
    assert note["tilt_deg"] == pytest.approx(TILT_DEG, abs=1.0)


def test_ground_commutes_with_a_turn_of_the_whole_clip(walk):
    """Found on a Z-up copy, the floor is the same plane turned, and ground leaves both
    clips on the same floor at height 0."""
    z_turn = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
    tilted = _tilted(walk, 3.0)
    a, _ = Pipeline.from_inline(["ground"]).run(tilted)
    b, _ = Pipeline.from_inline(["ground"]).run(turned_copy(tilted, z_turn))
    pa = kinematics.forward(a, end_sites=True)[0]
    pb = kinematics.forward(b, end_sites=True)[0]
    np.testing.assert_allclose(pb[..., 2], pa[..., 1], atol=1e-6 * kinematics.body_height(walk))


def test_ground_on_a_head_down_copy_is_the_same_move_turned(walk):
    """A clip head down along y (a half turn about x, as y-down camera coordinates have it):
    its floor is found through the same contacts, and ground levels it and puts it at y = 0
    as it does the clip upright, turned the same way; the report's up axis says -y."""
    half = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi)
    tilted = _tilted(walk, 3.0)
    a, _ = Pipeline.from_inline(["ground"]).run(tilted)
    b, _ = Pipeline.from_inline(["ground"]).run(turned_copy(tilted, half))
    pa = kinematics.forward(a, end_sites=True)[0]
    pb = kinematics.forward(b, end_sites=True)[0]
    np.testing.assert_allclose(pb, quat.rotate(half, pa), atol=1e-6 * kinematics.body_height(walk))
    up, down = contact_figures(tilted)[0], contact_figures(turned_copy(tilted, half))[0]
    assert (up["up_axis"], down["up_axis"]) == ("y", "-y")
    assert down["feet"].keys() == up["feet"].keys()
    for name, foot in up["feet"].items():
        assert down["feet"][name]["contacts"] == foot["contacts"]


def test_ground_without_contacts_or_without_level_moves_only_up_and_down(walk):
    height = kinematics.body_height(walk)
    translations = walk.translations.copy()
    translations[:, 0, 1] += height * np.arange(walk.n_frames) * walk.frame_time
    flying = walk.replace(translations=translations)
    out, _ = Pipeline.from_inline(["ground"]).run(flying)
    np.testing.assert_array_equal(out.translations, flying.translations)
    raised = _tilted(walk, 5.0)
    out, _ = Pipeline.from_inline(["ground:level=false"]).run(raised)
    np.testing.assert_array_equal(out.rotations, raised.rotations)
    moved = out.translations[:, 0] - raised.translations[:, 0]
    assert np.ptp(moved[:, 1]) < 1e-9 and moved[0, 1] < -4.0
    np.testing.assert_array_equal(moved[:, [0, 2]], 0.0)


def test_the_report_measures_feet_below_each_clips_own_ground(walk):
    """Raised by 5 units and grounded, a walk's feet go as deep below the floor as before,
    each clip measured against its own ground (the input's ground put the grounded feet
    5 units under it)."""
    raised = _tilted(walk, 5.0)
    grounded, _ = Pipeline.from_inline(["ground:level=false"]).run(raised)
    section, _ = contact_figures(raised, grounded)
    for foot in section["feet"].values():
        depth = foot["penetration"]
        assert depth["after"] == pytest.approx(depth["before"], abs=0.01)


def test_the_report_gives_the_floor_the_grounded_clip_stands_on(walk):
    """Tilted, raised and grounded, a walk's report gives beside the input's floor the
    cleaned clip's (``contacts.floor_after``): level, at height 0, the floor its own report
    finds, far from the input's; the terminal's floor line says it. Compared with itself
    or cleaned by the default pipeline, a clip keeps the input's floor (``same``) and the
    line names one. (The report had given the input's floor alone: after ground the
    cleaned figure stood up to 0.44 body heights off the only floor it showed.)"""
    height = kinematics.body_height(walk)
    tilted = _tilted(walk, 5.0)
    grounded, _ = Pipeline.from_inline(["ground"]).run(tilted)
    section, _ = contact_figures(tilted, grounded)
    alone, _ = contact_figures(tilted)
    floor, after = section["floor"], section["floor_after"]
    assert alone["floor_after"] is None and floor == alone["floor"]
    assert after["tilt_deg"] < 1.0 and abs(after["height"]) < 0.01 * height
    own = floor_of(grounded).floor
    assert own is not None
    np.testing.assert_allclose(after["normal"], own.normal, atol=1e-3)
    assert after["offset"] == pytest.approx(own.offset, abs=0.01 * height)
    assert after["apart"] > 0.1 * height and not after["same"]
    line = format_contacts(section)[0]
    told = re.search(r"\) -> height (\S+), tilt (\S+) deg after$", line)
    assert told is not None, line
    assert float(told.group(1)) == pytest.approx(after["height"], abs=0.001)
    assert told.group(2) == f"{after['tilt_deg']:.2f}"
    for cleaned in (tilted, Pipeline.default().run(tilted)[0]):
        kept, _ = contact_figures(tilted, cleaned)
        assert kept["floor_after"]["same"]
        assert kept["floor_after"]["tilt_deg"] == pytest.approx(floor["tilt_deg"], abs=0.1)
        assert format_contacts(kept)[0] == format_contacts(alone)[0]


def test_the_report_gives_the_depth_below_the_ground_during_contacts_and_at_any_frame():
    """A clip's feet may go below the ground between contacts (a heel's impact the frame
    before its contact starts, deepened by auto's smoothing), where footlock holds nothing:
    the report gives the depth during the contacts apart from the depth at any frame (a
    LaFAN1 walk's line had read "below ground 1.38 -> 1.94 units" beside "feet planted",
    both from such frames; during its contacts 1.18 -> 0.95). PyMO's walk lowered by 0.06
    body heights on a frame where neither foot stands (one lifting off, the other landing)
    goes that deep there and no deeper during its contacts."""
    walk = mc.load(EXPORTERS / "pymo_walk_tpose.bvh")
    feet, up, height = found.skeleton_feet(walk)
    section, _ = contact_figures(walk)
    standing = np.zeros(walk.n_frames, dtype=bool)
    for foot in section["feet"].values():
        for first, stop in foot["contacts"]:
            standing[first:stop] = True
    between = np.flatnonzero(~standing)
    frame = int(between[between.size // 2])
    translations = walk.translations.copy()
    translations[frame, 0, up] -= 0.06 * height
    section, _ = contact_figures(walk, walk.replace(translations=translations))
    anywhere = max(foot["penetration"]["after"] for foot in section["feet"].values())
    assert (
        anywhere
        > 0.04 * height
        > 0.02 * height
        > max(foot["penetration"]["before"] for foot in section["feet"].values())
    )
    for foot in section["feet"].values():
        during = foot["penetration_during_contacts"]
        assert during["after"] == pytest.approx(during["before"], abs=1e-9 * height)
        assert during["before"] <= foot["penetration"]["before"]
    for line in format_contacts(section)[1:]:
        assert re.search(r"below ground during contacts \S+ -> \S+ units \(at any frame", line)


def _standing_with_a_drop(walk: mc.Motion, frames: list[int]) -> mc.Motion:
    """One double-support pose of ``walk`` held for 60 frames, the whole body dropped by a
    third of its height on ``frames`` (a root marker's glitch, as a tracker gives)."""
    feet, up, height = found.skeleton_feet(walk)
    positions = kinematics.forward(walk, end_sites=True)[0]
    contacts, _ = found.detect(found.FootScene(positions, feet, up, height, walk.frame_time))
    pose = int(np.flatnonzero(contacts.all(axis=1))[0])
    translations = np.repeat(walk.translations[pose : pose + 1], 60, axis=0)
    translations[frames, 0, up] -= height / 3.0
    rotations = np.repeat(walk.rotations[pose : pose + 1], 60, axis=0)
    return walk.replace(rotations=rotations, translations=translations, source_values=None)


@pytest.mark.parametrize("frames", [[30], [30, 31]])
def test_a_glitch_of_the_root_does_not_take_the_floor_down(walk, frames):
    """Both feet stand through a drop of the whole body: a one-frame drop is passed over
    (the floor is where the feet stand), a two-frame one is not told from a step down, and
    neither leaves the floor without soles (its height had been the mean of no sole,
    NaN, with numpy's warning)."""
    steady = _standing_with_a_drop(walk, [])
    glitched = _standing_with_a_drop(walk, frames)
    height = kinematics.body_height(steady)
    level = contact_figures(steady)[0]["floor"]["height"]
    floor = contact_figures(glitched)[0]["floor"]
    assert np.isfinite(floor["height"]) and floor["contacts"] >= 2
    if len(frames) == 1:
        assert floor["height"] == pytest.approx(level, abs=1e-9 * height)


@pytest.mark.parametrize("name", ["131_02.bvh", "pymo_walk_tpose.bvh"])
def test_contacts_uphill_are_found_above_the_floor_as_on_the_level(walk, name):
    """A walk up a floor tilted 5 degrees rises by more than the contact height: above a
    level ground its high side's contacts had been missed (2 of 5 found on a game walk)
    and footlock left those feet sliding. Contacts are now found above the floor where it
    rises that far across its soles: the same contacts as the level walk's, each within
    a few frames, the same feet planted by the default; a level capture keeps the level
    ground's (the report says which)."""
    level = walk if name == "131_02.bvh" else mc.load(EXPORTERS / name)
    sloped = uphill(level, 5.0)
    flat, _ = contact_figures(level)
    tilted, _ = contact_figures(sloped)
    assert flat["floor"]["contacts_found_above_it"] is False
    assert tilted["floor"]["contacts_found_above_it"] is True
    assert tilted["floor"]["tilt_deg"] == pytest.approx(5.0, abs=1.0)
    for foot, figures in flat["feet"].items():
        runs, runs_up = figures["contacts"], tilted["feet"][foot]["contacts"]
        assert len(runs_up) == len(runs)
        assert np.abs(np.array(runs_up) - np.array(runs)).max() <= 3
    # the default plants the uphill walk's feet as the level one's, 3 degrees of noise
    noise = quat.exp(
        np.random.default_rng(2).normal(
            scale=np.radians(3.0) / 2, size=(level.n_frames, level.n_joints, 3)
        )
    )
    skates = []
    for clip in (level, sloped):
        noisy = clip.replace(rotations=quat.multiply(clip.rotations, noise), source_values=None)
        out, _ = Pipeline.default().run(noisy)
        section, _ = contact_figures(noisy, out)
        skates.append([f["skate_body_heights"]["after"] for f in section["feet"].values()])
    np.testing.assert_allclose(skates[1], skates[0], rtol=0.25)


def test_ground_levels_a_short_walk_up_a_slope_as_the_report_finds_it():
    """PyMO's 2.5 s walk turned up a 5-degree slope: its high side lies beyond a level
    ground's reach, and `ground` had levelled the 0.5 degree its level-ground contacts
    showed (the report read 4.40 degrees after). It now levels the floor the report finds,
    and the page says the plots' ground is measured above that tilted floor."""
    from motionclean.report.html import _ground_lines

    sloped = uphill(mc.load(EXPORTERS / "pymo_walk_tpose.bvh"), 5.0)
    before, _ = contact_figures(sloped)
    assert before["floor"]["contacts_found_above_it"] and before["floor"]["tilt_deg"] > 4.0
    assert "above the tilted floor" in "".join(_ground_lines(before))
    levelled, _ = Pipeline.from_inline(["ground"]).run(sloped)
    after, _ = contact_figures(levelled)
    assert after["floor"]["tilt_deg"] < 1.0
    assert "along the up axis" in "".join(_ground_lines(after))


def _stairs(walk: mc.Motion) -> mc.Motion:
    """A figure standing in ``walk``'s first double-support pose (120 fps, Y up), swaying a
    little, hopping up three steps of a tenth of its height, 0.18 of it forward each (a
    staircase, its body upright throughout)."""
    feet, up, height = found.skeleton_feet(walk)
    positions = kinematics.upright_positions(walk)
    both = found.detect(found.FootScene(positions, feet, up, height, walk.frame_time))[0]
    both = both.all(axis=1)
    pose = int(np.flatnonzero(both)[0])
    n = 480
    t = np.arange(n)
    sway = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(0.5) * np.sin(t / 40.0))
    rotations = np.repeat(walk.rotations[pose : pose + 1], n, axis=0)
    rotations[:, 0] = quat.multiply(sway, rotations[:, 0])
    translations = np.repeat(walk.translations[pose : pose + 1], n, axis=0)
    for start in (80, 200, 320):  # a hop of 40 frames onto the next step
        u = np.clip((t - start) / 40.0, 0.0, 1.0)
        ease = u * u * (3.0 - 2.0 * u)
        translations[:, 0, 1] += 0.1 * height * ease + 0.03 * height * np.sin(np.pi * u)
        translations[:, 0, 0] += 0.18 * height * ease
    return walk.replace(rotations=rotations, translations=translations, source_values=None)


def test_ground_keeps_the_slope_of_stairs_under_an_upright_body(walk):
    """A staircase's floor, fitted through the soles on each step, tilts 22.5 degrees, and
    the body stands upright on it (4 degrees off the up axis): ground had turned the whole
    clip by that much. It now moves the clip along the up axis alone (the lowest sole to 0)
    and the report says the floor rises under an upright body, also with a tracker's
    dropout in the clip (the trunk read from the poses where it is known); a walk tilted
    as a whole by 25 degrees (a camera's tilt: the body turned with the floor) is still
    levelled."""
    stairs = _stairs(walk)
    height = kinematics.body_height(stairs)
    found_floor = floor_of(stairs)
    assert found_floor.floor is not None and found_floor.floor.tilt_deg > 20.0
    assert found_floor.terrain
    section, _ = contact_figures(stairs)
    assert section["floor"]["terrain"] is True
    assert "under an upright body: stairs or a slope" in format_contacts(section)[0]
    out, logs = Pipeline.from_inline(["ground"]).run(stairs)
    np.testing.assert_array_equal(out.rotations, stairs.rotations)
    moved = out.translations[:, 0] - stairs.translations[:, 0]
    np.testing.assert_array_equal(moved[:, [0, 2]], 0.0)
    assert np.ptp(moved[:, 1]) < 1e-9
    lowest = kinematics.world_positions(out)[..., 1].min()
    assert abs(lowest) < 0.01 * height
    note = logs[0].notes["Hips"]["position_ground"]
    assert note["terrain"] is True and note["levelled"] is False
    missing = np.zeros((stairs.n_frames, stairs.n_joints), dtype=bool)
    missing[200, stairs.names.index("LeftWrist")] = True
    assert floor_of(stairs.replace(missing=missing)).terrain
    camera = _tilted(walk, 5.0, degrees=25.0)
    assert floor_of(camera).floor.tilt_deg > 20.0
    assert floor_of(camera).terrain is False
    levelled, _ = Pipeline.from_inline(["ground"]).run(camera)
    assert floor_of(levelled).floor.tilt_deg < 2.0


@pytest.mark.parametrize("joint", ["LeftWrist", "Hips"])
def test_ground_moves_a_clip_with_dropouts_as_it_moves_it_whole(walk, joint):
    """A tracker's dropout on one joint had `ground` run on each known stretch of that
    joint alone, without the root, and refused ("the root 'Hips' is not selected"). It
    moves the whole clip at once, the dropout kept, onto a level floor at 0; the frames
    where a foot's place is unknown (its samples held) give no contact."""
    tilted = _tilted(walk, 5.0)
    height = kinematics.body_height(tilted)
    missing = np.zeros((tilted.n_frames, tilted.n_joints), dtype=bool)
    missing[200:230, tilted.names.index(joint)] = True
    gappy = tilted.replace(missing=missing)
    out, _ = Pipeline.from_inline(["ground"]).run(gappy)
    np.testing.assert_array_equal(out.missing_mask(), missing)
    np.testing.assert_array_equal(out.rotations[:, 1:], gappy.rotations[:, 1:])
    found_after = floor_of(out).floor
    assert found_after.tilt_deg < 1.0 and abs(found_after.offset) < 0.01 * height
    feet, up, _ = found.skeleton_feet(gappy)
    unknown = found.feet_unknown(kinematics.missing_points(gappy), feet)
    section, _ = contact_figures(gappy)
    for k, foot in enumerate(feet):
        runs = section["feet"][foot.name]["contacts"]
        inside = [f for a, b in runs for f in range(a, b)]
        assert not unknown[inside, k].any()


def _legs_sideways_deg(motion: mc.Motion) -> float:
    """How far the body leans sideways (degrees, :func:`kinematics.sideways_lean`)."""
    lean = kinematics.sideways_lean(motion)
    return float(np.degrees(np.arcsin(min(1.0, np.linalg.norm(lean)))))


@pytest.mark.parametrize(
    ("name", "degrees"),
    [("131_02.bvh", 20.0), ("131_02.bvh", -20.0), ("pymo_walk_tpose.bvh", 20.0)],
)
def test_ground_levels_a_floor_tilted_across_the_walk(walk, name, degrees):
    """Footprints along one line show no sideways tilt, and a walk rolled 20 degrees about
    its direction of travel (a camera pitched down at a walk across its view) had been
    'levelled' by 0.7 degrees. Trunk and legs lean sideways with the roll, which a body
    does not do on its own: the floor's prior follows them, and ground stands the walk up
    (its trunk and legs within 3 degrees of upright sideways, either way of rolling); the
    level walk's floor is read as before."""
    level = walk if name == "131_02.bvh" else mc.load(EXPORTERS / name)
    rolled = uphill(level, degrees, along=True)
    assert floor_of(rolled).floor.tilt_deg > 15.0
    levelled, _ = Pipeline.from_inline(["ground"]).run(rolled)
    assert _legs_sideways_deg(levelled) < _legs_sideways_deg(level) + 3.0
    assert floor_of(level).floor.tilt_deg < 1.5


def test_a_bend_at_the_waist_is_no_roll_of_the_capture():
    """A walk bent 40 degrees sideways at the spine, on a level floor: its trunk leans as
    under a camera's roll, its legs do not. The floor had been read tilted 12.3 degrees and
    ground rolled the whole clip by that much, a foot 0.36 units below the floor; the
    floor stays level now (the lean counts where trunk and legs share it)."""
    level = mc.load(EXPORTERS / "pymo_walk_tpose.bvh")
    spine = level.names.index("Spine")
    bend = quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(-40.0))
    rotations = level.rotations.copy()
    rotations[:, spine] = quat.multiply(bend, rotations[:, spine])
    bent = level.replace(rotations=rotations, source_values=None)
    assert np.degrees(np.arccos(kinematics.upright_body_up(bent)[1])) > 10.0
    assert floor_of(bent).floor.tilt_deg < 1.0
    grounded, _ = Pipeline.from_inline(["ground"]).run(bent)
    np.testing.assert_array_equal(grounded.rotations[:, 1:], bent.rotations[:, 1:])
    assert quat.angle_between(grounded.rotations[:, 0], bent.rotations[:, 0]).max() < np.radians(1)


def _held(frames: int = 240) -> mc.Motion:
    """The sample's first frame held: a still stance, the right foot 0.05 body heights
    above the left (its ankle 4.5 units up against 1.7)."""
    return mc.load(SAMPLE).at_frames(np.zeros(frames, dtype=np.intp))


def _grounded(motion: mc.Motion, step: str = "ground") -> tuple[mc.Motion, dict, str]:
    """``motion`` through ``step``: the clip, the root's ground note, the verdict's text."""
    result = clean_motion(motion, Pipeline.from_inline([step]), "clip.bvh")
    note = result.report["joints"][motion.names[0]].get("position_ground")
    return result.after, note, result.report["verdict"]["text"]


def test_a_stance_on_two_footprints_is_put_on_its_lowest_sole_not_tilted():
    """Through two footprints a floor's slope is the height between two soles: a still
    stance with one foot raised read a floor tilted 3.0 degrees, and ground turned the
    figure by that much, a toe left 0.49 units under the floor it set. A tilt needs soles
    at three places: the stance is moved along the up axis alone, its lowest sole to 0,
    and the note and the verdict say the tilt was not applied."""
    still = _held()
    height = kinematics.body_height(still)
    assert floor_of(still).floor.tilt_deg > 2.0  # (the report's fit through two soles)
    out, note, text = _grounded(still)
    np.testing.assert_array_equal(out.rotations, still.rotations)
    points = kinematics.world_positions(out)[..., 1]
    assert points.min() == pytest.approx(0.0, abs=1e-9 * height)
    assert note["places"] == pytest.approx(2.0) and note["unsupported"]
    assert not note["levelled"] and note["height"] > 0.02 * height
    assert "not levelled (a tilt of" in text and "through soles at 2 places" in text


def _lying(frames: int = 240) -> mc.Motion:
    """The held stance laid on its back along z, its hips 3 units above y = 0 (Y up kept)."""
    still = _held(frames)
    down = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), -np.pi / 2)
    rotations, translations = still.rotations.copy(), still.translations.copy()
    rotations[:, 0] = quat.multiply(down, rotations[:, 0])
    translations[:, 0] = [0.0, 3.0, 0.0]
    return still.replace(rotations=rotations, translations=translations, source_values=None)


def test_a_body_resting_below_its_feet_is_put_on_the_floor_by_its_lowest_point():
    """A figure lying on its back, ground asked with up y: the floor through its heels (the
    contacts) had been levelled and set at 0, its elbows, shoulders and head left 2.1-2.4
    units under it, the verdict "put on the floor ... feet planted". Its body rests below
    its feet, so its lowest point goes to 0, nothing turned and nothing under the floor,
    and the note and verdict say why."""
    lying = _lying()
    height = kinematics.body_height(lying)
    out, note, text = _grounded(lying, "ground:up=y")
    np.testing.assert_array_equal(out.rotations, lying.rotations)
    points = kinematics.world_positions(out)[..., 1]
    assert points.min() == pytest.approx(0.0, abs=1e-9 * height)
    resting = note["resting"]
    assert resting["below"] > 0.06 * height and not note["levelled"]
    assert f"by its lowest point: {note['height']:.3g} units down" in text
    assert f"the body rests below its feet: {resting['point']}" in text
    assert "levelled" not in text


@pytest.mark.parametrize(
    ("clip", "why"),
    [("flying", "no foot in contact found"), ("hand", "no feet in this skeleton")],
)
def test_ground_without_a_floor_says_why(walk, clip, why):
    """A clip rising off the ground (no contact) or a hand (no feet) had been returned by
    ground without a word: the note (the root's, in the JSON) and the verdict say that it
    was not put on the floor, and why."""
    if clip == "flying":
        translations = walk.translations.copy()
        translations[:, 0, 1] += 10.0 * np.arange(walk.n_frames) * walk.frame_time
        motion = walk.replace(translations=translations, source_values=None)
    else:
        motion = bending_hand()
    out, note, text = _grounded(motion)
    np.testing.assert_array_equal(out.translations, motion.translations)
    assert note == {"why": why}
    assert f"not put on the floor: {why}" in text


@pytest.mark.parametrize(
    "steps", [["ground"], ["despike", "fill-gaps", "auto", "footlock", "ground"]]
)
def test_levelling_is_told_apart_from_smoothing(walk, steps):
    """The levelling turn of the roots is no smoothing: a clean capture on a tilted floor,
    levelled, reads clean (or not smoothed), its roots' change measured from the input
    turned by the note's turn; the figures still see smoothing where there was some."""
    tilted = _tilted(walk, 30.0)
    result = clean_motion(tilted, Pipeline.from_inline(steps), "tilted.bvh")
    verdict = result.report["verdict"]
    assert "levelled from" in verdict["text"]
    assert verdict["status"] in ("clean", "not smoothed", "repaired"), verdict["text"]
    assert "Hips by" not in verdict["text"]
    note = result.report["joints"]["Hips"]["position_ground"]
    turn = np.array(note["turn"])
    assert np.degrees(quat.angle(turn)) == pytest.approx(TILT_DEG, abs=1.0)
    root = result.after.rotations[:, 0]
    assert (
        np.degrees(quat.angle_between(quat.multiply(turn, tilted.rotations[:, 0]), root)).max()
        < 0.5
    )
    smoothed = clean_motion(
        tilted, Pipeline.from_inline(["lee-shin:k=2,iterations=3", "ground"]), "tilted.bvh"
    )
    assert smoothed.report["verdict"]["change_deg_max"] > 0.5


def test_ground_on_takes_joined_end_to_end_is_told_without_a_turn_of_its_own(walk):
    """Two takes joined, each levelled on its own (two turns): the report measures the
    roots' change as the cleaning's (one turn of every frame is what it discounts) rather
    than failing on the notes' two turns."""
    first = _tilted(walk, 30.0)
    second = walk
    joined = first.replace(
        rotations=np.concatenate([first.rotations, second.rotations]),
        translations=np.concatenate([first.translations, second.translations]),
    )
    assert clean_motion(joined, Pipeline.from_inline(["ground"]), "j.bvh").report["verdict"]
    ranged = clean_motion(first, Pipeline.from_inline(["ground:frames=[0,600]"]), "r.bvh")
    assert ranged.report["verdict"]["text"]
