"""The Blender extension and FBX through Blender, checked in a real Blender (``bpy``).

One Blender session (``session.py``, run once by the ``blender`` fixture) installs the
built extension, cleans armatures imported from a corpus BVH with the panel's operator, and
takes FBX files written by Blender's exporter through the command line; these tests compare
what it recorded with ``motionclean clean`` of the same clips, run here.

Blender stores curves in float32: a rotation read back from keys is within float32 rounding
of the float64 result written (an Euler angle near 180 degrees: 1.5e-5 degrees per angle; a
quaternion component: 6e-8), and the BVH files the command line reads and writes carry six
decimals (5e-7 degrees). The bounds below are these, not looser.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from helpers import degrees_between, run_cli

import motionclean as mc
from motionclean.core import kinematics, quat
from motionclean.io.blender_action import KEEP_DEGREES
from motionclean.steps import REGISTRY
from motionclean.steps.pipeline import DEFAULT_STEPS

#: Largest rotation difference between keys read back and the command line's float64
#: result: float32 keys (up to three Euler angles of 1.2e-5 degrees each, or four
#: quaternion components) plus the BVH's six decimals, degrees.
FLOAT32_DEGREES = 3e-5
#: The same for translations, in the clip's length units (float32 at ~40 units: 4e-6).
FLOAT32_LENGTH = 2e-5
RIGS = ("quaternion", "euler", "euler_yxz", "axis")
MODES = {
    "quaternion": ["QUATERNION"],
    "euler": ["ZXY", "ZYX"],  # the BVH importer's "native" orders of CMU's joints
    "euler_yxz": ["YXZ"],
    "axis": ["AXIS_ANGLE"],
}
FRAMES = 400  # of corpus clip 131_01: the session's clip (conftest.FRAMES)
needs_fbx = pytest.mark.skipif(
    os.environ.get("MOTIONCLEAN_BLENDER_OPERATOR_ONLY") == "1",
    reason="the bpy 4.5 run (make test-blender45) checks the operator only",
)


def _cleaned_by_cli(capsys, tmp_path, source) -> mc.Motion:
    target = tmp_path / f"{source.stem}_cli.bvh"
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q")
    assert code == 0, err
    return mc.load(target)


def test_extension_installs_with_blenders_installer_and_unregisters(blender):
    install, gone = blender.results["install"], blender.results["unregister"]
    assert install["done"] == ["FINISHED"] and install["enabled"]
    assert len(install["classes"]) == 4 and install["scene_settings"]
    assert install["undo_option"] == ["REGISTER", "UNDO"]  # one undo step per press
    assert not gone["enabled"] and gone["classes_left"] == [] and not gone["scene_settings"]
    assert gone["enabled_again"]


@pytest.mark.parametrize("state", ["draw_empty", "draw_results"])
def test_panels_draw_in_both_sidebars(blender, state):
    draw = blender.results[state]
    assert draw["problems"] == []
    assert draw["spaces"] == ["GRAPH_EDITOR", "DOPESHEET_EDITOR"]
    assert draw["regions"] == ["UI", "UI"] and draw["categories"] == ["motionclean"] * 2
    for drawn in draw["drawn"]:
        assert "operator:motionclean.clean" in drawn and "prop:pipeline" in drawn
    choices = {tuple(d) for d in draw["drawn"]}
    assert any("prop:pipeline_file" in d for d in choices)
    assert any("prop:steps" in d for d in choices)
    if state == "draw_results":  # the report's figures and its button
        labels = [line for line in draw["drawn"][0] if line.startswith("label:")]
        assert any(re.search(r"Noise removed \d+%", line) for line in labels)
        assert any(line.startswith("label:foot ") for line in labels)
        assert "operator:motionclean.open_report" in draw["drawn"][0]
        assert any(re.fullmatch(r"label:Report: /.*\.html", line) for line in labels)
        rounded = [line for line in blender.results["draw_rounded"]["drawn"][0] if "Noise" in line]
        assert rounded and all("Noise removed 0%," in line for line in rounded)  # not "-0%"


@pytest.mark.parametrize("rig", RIGS)
def test_operator_gives_the_command_lines_rotations(blender, capsys, tmp_path, rig):
    """The panel's operator on an imported armature = `motionclean clean` of the same
    motion, in every rotation mode; the original action is kept as it was."""
    entry = blender.results["rigs"][rig]
    assert entry["done"] == ["FINISHED"] and entry["modes"] == MODES[rig]
    assert entry["result"] == f"{entry['original']}.clean"
    assert entry["original_untouched"] and entry["original_kept"]
    expected = _cleaned_by_cli(capsys, tmp_path, blender.out / f"{rig}_in.bvh")
    rotations = np.load(blender.out / f"{rig}_out_rotations.npy")
    translations = np.load(blender.out / f"{rig}_out_translations.npy")
    before = mc.load(blender.out / f"{rig}_in.bvh")
    assert degrees_between(before.rotations, expected.rotations).max() > 90  # flips repaired
    assert degrees_between(rotations, expected.rotations).max() < FLOAT32_DEGREES
    assert np.abs(translations - expected.translations).max() < FLOAT32_LENGTH
    panel = entry["panel"]
    report_removed = panel["noise_removed"]
    assert 0.5 < report_removed < 1.0 and panel["deviation_max"] > 90
    assert "repaired RThumb" in panel["lines"] and "foot LeftAnkle" in panel["lines"]
    assert re.fullmatch(r"Keys: [\d,]+ changed, 0 added", panel["keys"])  # baked: no new key
    page = Path(panel["report"])  # what Open Report opens
    assert page.suffix == ".html" and "<html" in page.read_text()[:200].lower()


def test_operator_gives_what_cleaning_the_file_itself_gives(blender, capsys, tmp_path):
    """Against the BVH file the rig was imported from: the same rotations, turned from the
    file's Y up to Blender's Z up, within what Blender's BVH importer keeps of the file
    (its float32 arithmetic)."""
    expected = _cleaned_by_cli(capsys, tmp_path, blender.clip)
    y_to_z = quat.from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
    turned = quat.multiply(quat.multiply(y_to_z, expected.rotations), quat.conjugate(y_to_z))
    rotations = np.load(blender.out / "quaternion_out_rotations.npy")
    imported = mc.load(blender.out / "quaternion_in.bvh")  # what the import kept of the file
    kept = degrees_between(
        imported.rotations,
        quat.multiply(
            quat.multiply(y_to_z, mc.load(blender.clip).rotations), quat.conjugate(y_to_z)
        ),
    )
    errors = degrees_between(rotations, turned)
    assert errors.max() < 2 * kept.max() + FLOAT32_DEGREES


def test_one_undo_restores_the_original_action(blender):
    rig = blender.results["rigs"]["quaternion"]
    undone = rig["after_undo"]
    assert rig["undo_poll"]
    assert undone["action"] == rig["original"] and undone["actions"] == [rig["original"]]
    assert undone["untouched"] and undone["results"] == 0
    assert rig["after_redo"]["action"] == rig["result"]


def test_preview_range_in_place(blender, capsys, tmp_path):
    """A range: the steps run on the whole action limited to it, blended in and out over
    its first and last 5 frames (`frames`/`blend` on the command line), nothing outside."""
    result = blender.results["range"]
    assert result["done"] == ["FINISHED"] and result["action"] == "131_01"  # in place
    # (the repair lines below it count the action's keys from 0: where that frame is)
    key0 = 150 - result["clip_range"][0]  # the action's first key (Blender's BVH import: 1)
    assert result["panel_frames"] == f"150-250 (0 below: frame {key0})" and key0 == 1
    assert result["outside_untouched"] and result["inside_changed"] > 0
    first, last = result["clip_range"]
    steps = []
    for table in DEFAULT_STEPS:
        text = table["filter"]
        if REGISTRY[table["filter"]].run_motion is None:  # a step that takes a range
            text += f":frames=[{first + 5},{last - 5}],blend=5"
        steps += ["-f", text]
    target = tmp_path / "range_cli.bvh"
    code, _, err = run_cli(
        capsys, "clean", blender.out / "range_in.bvh", "-o", target, "-q", *steps
    )
    assert code == 0, err
    expected = mc.load(target)
    rotations = np.load(blender.out / "range_out_rotations.npy")
    assert degrees_between(rotations, expected.rotations).max() < FLOAT32_DEGREES
    before = mc.load(blender.out / "range_in.bvh")
    moved = degrees_between(before.rotations, expected.rotations).max(axis=1)
    assert moved[:first].max() < 1e-9 and moved[last + 1 :].max() < 1e-9  # (rounding)
    assert moved[first : last + 1].max() > 1e-3


def test_keys_between_frames_are_cleaned_where_they_are(blender):
    """An action keyed every 0.2 frames (a 120 fps BVH imported with Scale FPS into a 24
    fps scene) is read and written at its keys: no key added or moved, and the rotations
    are those of the same motion keyed on whole frames (the quaternion rig), cleaned.
    (Read on whole frames, it had gained a key per frame beside the old ones.) A constant
    scale keyed at the ends alone, as Blender's glTF importer keys one, is on that grid
    too (the action had been refused)."""
    result = blender.results["subframe"]
    assert result["done"] == ["FINISHED"] and result["keys"] == FRAMES
    assert result["whole_keys"] < 5 and result["same_times"]
    assert re.fullmatch(r"Keys: [\d,]+ changed, 0 added", result["panel_keys"])
    # (the rate the action was read at, its keys': it had named the scene's 24 fps)
    said = "cleaned 1 action(s) at 120 fps, its keys' rate; the scene's is 24"
    assert said in result["said"]
    rotations = np.load(blender.out / "subframe_out_rotations.npy")
    expected = np.load(blender.out / "quaternion_out_rotations.npy")
    assert degrees_between(rotations, expected).max() < FLOAT32_DEGREES


def test_a_key_a_float32_rounding_off_its_frame_is_on_it(blender):
    near = blender.results["near_frame"]
    assert near["done"] == ["FINISHED"] and 31.99 < near["off_frame"] < 32.0
    assert near["same_times"] and near["values_changed"]


def test_keys_off_the_grid_are_refused_by_the_panel_and_sampled_from_fbx(blender):
    """(2 of 4 Mixamo FBX files had been refused on the command line, where no one can
    bake the action first.)"""
    off = blender.results["off_grid"]
    first, last = off["range"]
    assert off["frames"] == [first, last, last - first + 1] and off["step"] == 1.0
    assert off["notes"] == [
        "keys between frames that the bone curves do not share evenly spaced: read on "
        "whole frames, as Blender plays them (written back baked on them)"
    ]
    assert off["panel"]["done"] == ["CANCELLED"]
    assert "keys between frames (at 31.5)" in off["panel"]["message"]


def test_a_press_that_cannot_clean_says_why_and_changes_nothing(blender):
    errors = blender.results["errors"]
    assert errors["untouched"] and errors["actions"] == ["131_01", "131_01 [library.blend]"]
    assert errors["fake_users"] == [] and errors["results_kept"]
    expected = {
        "unknown_step": "unknown filter 'lee-shim'",
        "no_steps": "type the steps in",
        "preview_off": "the preview range is off",
        "resample": "the pipeline changes the frame count",
        # (it had raised a traceback after making a copy and setting a fake user)
        "tweak": "in NLA tweak mode: leave it",
        "tweak_in_place": "in NLA tweak mode: leave it",
        # (it had reported keys changed that saving the file lost)
        "linked_in_place": "linked action: turn In Place off or make it local",
        # (a traceback after the action had been copied and assigned)
        "reports_folder": "reports-file: cannot make the reports folder: File exists",
    }
    for name, words in expected.items():
        run = errors["runs"][name]
        assert run["done"] == ["CANCELLED"] and run["message"].startswith("Error: motionclean: ")
        assert words in run["message"] and "\n" not in run["message"]


def test_two_actions_of_one_name_are_two_actions(blender):
    """A local and a linked action both named 131_01 are cleaned each into its own copy
    (they had been planned as one, by name: the second armature got the first's copy)."""
    result = blender.results["same_name"]
    assert result["done"] == ["FINISHED"]
    assert result["plays"] == ["131_01.clean", "131_01.clean.001"]
    assert result["results"] == [["131_01", "131_01"], ["Linked", "131_01 [library.blend]"]]


def test_keyed_curves_take_keys_per_frame_only_where_the_motion_moved(blender):
    keyed = blender.results["keyed"]
    assert keyed["done"] == [["FINISHED"], ["FINISHED"]]
    assert keyed["untouched_knee"] and keyed["other_changed"]  # a step on the other knee
    # ... whose pattern that matches no joint is warned of, as on the command line
    assert (
        "Warning: motionclean: warning: 131_01: step 1 (lee-shin): joints pattern "
        "'Nope' matches no joint" in keyed["said"]
    )
    # and the press says the rate it cleaned at: the scene's (a 120 fps capture imported
    # without "Update Scene FPS" sits in a 24 fps scene, and was cleaned so, unsaid)
    assert "motionclean: cleaned 1 action(s) at 120 fps, the scene's frame rate" in keyed["said"]
    assert keyed["frames_moved"] > 30  # the ranged step moved frames 195-265 ...
    new = np.array(keyed["new_key_frames"])  # ... keyed every 10 frames from frame 1:
    assert new.size and new.min() > 181 and new.max() < 281  # keys between 191 and 271

    assert keyed["far_keys_kept"] and keyed["keys_after"][0] == keyed["keys_before"] + new.size
    # added keys play as the key that starts their stretch (they had all taken the first
    # key's interpolation, a CONSTANT hold: the Bezier stretches played stepped)
    assert keyed["new_key_interpolations"] == ["BEZIER"]
    # the curve plays the cleaned motion: within the keep tolerance plus float32
    assert keyed["error_deg_max"] < KEEP_DEGREES + FLOAT32_DEGREES


# ----------------------------------------------------------------------------- FBX


def _bone_rotations(loaded: dict) -> dict[str, np.ndarray]:
    found: dict[str, list] = {}
    for key, values in loaded["curves"].items():
        match = re.match(r'pose\.bones\["(.*)"\]\.rotation_quaternion\[(\d)\]', key)
        if match:
            found.setdefault(match.group(1), [None] * 4)[int(match.group(2))] = values
    return {name: np.array(v).T for name, v in found.items() if None not in v}


@needs_fbx
def test_fbx_commands_run_through_blender(blender):
    runs = dict(blender.results["fbx_runs"])
    refused = runs.pop("not_binary")  # an ASCII FBX: Blender's importer reads binary only
    assert refused["code"] == 1 and refused["stdout"] == ""
    assert refused["stderr"] == (
        "motionclean: error: ascii.fbx: cannot read FBX: ASCII FBX files are not supported\n"
    )
    two = runs.pop("two_takes")  # (the take the armature did not play had been dropped)
    assert two["code"] == 1 and two["stderr"].count("\n") == 1
    assert two["stderr"].startswith("motionclean: error: two_takes.fbx: 2 takes (AnimStacks: ")
    assert "FBX files with one take are read" in two["stderr"]
    empty = runs.pop("empty")  # (Blender's importer had called it an ASCII FBX)
    assert empty["code"] == 1 and empty["stderr"] == "motionclean: error: empty.fbx: empty file\n"
    for name, run in runs.items():
        assert run["code"] == 0, (name, run["stderr"])
        assert run["stderr"] == ""  # nothing Blender prints reaches the terminal
    info = blender.results["fbx_runs"]["info"]["stdout"]
    # 38 bones: the 31 joints and Blender's seven *_end tips, read as their end sites
    assert f"frames: {FRAMES}" in info and "joints: 31" in info and "rate: 120 fps" in info
    report = json.loads((blender.out / "report.json").read_text())  # take.fbx vs identity.fbx
    assert report["frames"] == FRAMES and {"Hips", "RThumb", "LeftKnee"} <= report["joints"].keys()
    # (the rest orientation of CMU's 0.01-long wrist bones comes back from the file's
    # float32 transforms 0.02 degrees off; every other bone within 1e-3)
    assert report["summary"]["deviation_deg_max"] < 0.05
    deviations = [entry["deviation_deg"]["max"] for entry in report["joints"].values()]
    assert sorted(deviations)[-3] < 1e-3


@needs_fbx
@pytest.mark.parametrize("output", ["identity.fbx", "batch/take.fbx"])
def test_fbx_written_loads_back_with_the_inputs_bones_rest_and_rate(blender, output):
    loaded = blender.results["fbx_loaded"]
    source, written = loaded["takes/take.fbx"], loaded[output]
    assert written["bones"] == source["bones"] and written["parents"] == source["parents"]
    assert written["fps"] == source["fps"] and written["frames"] == source["frames"]
    rest = np.load(blender.out / "takes" / "take.rest.npy")
    again = np.load(blender.out / output.replace(".fbx", ".rest.npy"))
    assert np.abs(rest - again).max() < 1e-5 * np.abs(rest).max()  # float32 rest
    assert set(source["curves"]) <= set(written["curves"])
    # the object's and the bone's custom properties (the exporter's default dropped them)
    assert source["properties"] == written["properties"] == [3, "root"]


@needs_fbx
def test_fbx_identity_keeps_the_curves(blender):
    loaded = blender.results["fbx_loaded"]
    source, written = loaded["takes/take.fbx"], loaded["identity.fbx"]
    before, after = _bone_rotations(source), _bone_rotations(written)
    errors = np.concatenate([degrees_between(before[n], after[n]) for n in before])
    # FBX stores Euler angles as float32: 1e-4 degrees everywhere but where a bone's
    # angles sit near gimbal lock (CMU's RThumb on its flipped frames: 3.3e-4)
    assert np.percentile(errors, 99) < 1e-4 and errors.max() < 1e-3
    for key, values in source["curves"].items():
        if ".location[" in key:
            assert np.abs(np.subtract(values, written["curves"][key])).max() < 1e-4
    # the take keeps its name (it had become "Scene": engines find clips by take name)
    assert written["action"] == source["action"] and "Scene" not in source["action"]


@needs_fbx
def test_fbx_default_clean_is_the_pipelines_result(blender):
    """`batch` with the default pipeline on an FBX folder writes what the pipeline gives
    the clip (read through the Python API), to FBX's float32 precision."""
    expected = np.load(blender.out / "fbx_expected_rotations.npy")
    written = np.load(blender.out / "fbx_batch_rotations.npy")
    source = np.load(blender.out / "fbx_input_rotations.npy")
    assert degrees_between(source, expected).max() > 90  # the flips were repaired
    errors = degrees_between(written, expected)
    # Keys are kept where the clip moved less than KEEP_DEGREES, and FBX holds float32 Euler
    # angles: 1e-4 degrees, but near gimbal lock float32 angles are coarser (CMU's
    # zero-length wrists and RThumb sit there in the file's bone axes: up to 0.017 degrees
    # on their frames; Blender's own export and import of new values, not the writer's).
    # (the file's seven *_end tips are end sites, no longer joints whose zero errors
    # counted: the 90th percentile is 1.03e-4 of the 31 joints')
    assert np.median(errors) < 1e-5
    assert np.percentile(errors, 90) < 2 * KEEP_DEGREES and errors.max() < 0.05
    assert (blender.out / "reports").is_dir()


@needs_fbx
def test_fbx_resampled_has_the_new_rate_and_frames(blender):
    resampled = blender.results["fbx_loaded"]["r60.fbx"]
    source = blender.results["fbx_loaded"]["takes/take.fbx"]
    assert resampled["fps"] == [60, 1.0] and resampled["bones"] == source["bones"]
    assert resampled["frames"] == [1, FRAMES // 2]


@needs_fbx
def test_fbx_converts_to_bvh_and_back(blender):
    names = blender.results["fbx_names"]
    bvh = mc.load(blender.out / "take.bvh")
    assert bvh.names == names and bvh.n_frames == FRAMES
    again = blender.results["fbx_loaded"]["from_bvh.fbx"]
    # a new FBX writes each end site as a tip bone (FBX has no bone tails): read back, the
    # joints and end sites of the BVH
    tips = [bone for bone in again["bones"] if bone.endswith("_end")]
    assert [bone for bone in again["bones"] if bone not in tips] == names
    assert sorted(tips) == sorted(f"{bvh.names[j]}_end" for j in bvh.end_sites)
    sites = blender.results["from_bvh_end_sites"]
    assert sorted(sites) == sorted(bvh.names[j] for j in bvh.end_sites)
    for j, site in bvh.end_sites.items():  # (the importer's guessed tails had doubled them)
        assert np.abs(np.array(sites[bvh.names[j]]) - site).max() < 1e-4
    assert again["fps"] == [120, 1.0]
    assert again["frames"] == [1, FRAMES]  # BVH frame 0 at time 0: Blender's frame 1


def test_fbx_keeps_a_travel_under_a_still_root_and_end_sites_at_their_joints(blender):
    """The corpus clip under a still ``Reference`` root (its travel on ``Hips``' position
    channels, as Bandai Namco's files have it) with every end site at its joint, written to
    FBX: Blender's importer leaves ``Hips`` unconnected, so its travel plays (a bone's tail
    on its head had connected it and it ran in place), and the file reads back with the
    same channels in the same order (the still root's too), end sites at zero (their
    bones' tails had read back 5 % of the skeleton long) and the same world positions."""
    source = mc.load(blender.out / "under_reference.bvh")
    back = mc.load(blender.out / "under_reference_back.bvh")
    assert not blender.results["reference_connected"]["Hips"]
    # channels named on a bone are the least it has: a rotation keyed since is read too
    assert blender.results["keyed_since"][:3] == ["Xposition", "Yposition", "Zposition"]
    assert any(name.endswith("rotation") for name in blender.results["keyed_since"])
    assert back.names == source.names and back.channels == source.channels
    assert all(not np.any(site) for site in back.end_sites.values())
    assert sorted(back.end_sites) == sorted(source.end_sites)
    height = kinematics.body_height(source)
    np.testing.assert_allclose(
        kinematics.forward(back, end_sites=True)[0],
        kinematics.forward(source, end_sites=True)[0],
        atol=1e-5 * height,
    )


def test_fbx_of_a_figure_standing_head_down_stands_up_in_blender(blender):
    """A clip whose up is -y (a camera's coordinates) written to FBX imports into Blender
    standing on its feet, as its glTF does: the FBX writer had turned it by its up axis
    without the sign, the head 24 units below the ground."""
    head, ankle = blender.results["head_down_heights"]
    assert head > ankle + 10.0
