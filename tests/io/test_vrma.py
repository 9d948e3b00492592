"""VRM animations (.vrma): the humanoid bone map is the skeleton; expression weights and
the look-at target are carried as they are, never cleaned as joints."""

from __future__ import annotations

import json
import struct

import numpy as np
from helpers import ROOT, run_cli

import motionclean as mc
from motionclean.core import kinematics

#: pixiv/three-vrm's example VRM animation (MIT; tests/data/vrm/README.md): a right upper
#: arm raised, expression ``happy`` weighted 0,0,0,1,0,0,0, a look-at turn; 7 keys at 2 fps.
VRMA = ROOT / "tests" / "data" / "vrm" / "test.vrma"


def glb_parts(data: bytes) -> tuple[dict, bytes]:
    size = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20 : 20 + size]), data[20 + size + 8 :]


def keys_of(data: bytes, node: int) -> list[tuple[dict, list[bytes]]]:
    """Each channel of ``node`` in the first animation: its sampler and the bytes of its
    input and output accessors."""
    document, binary = glb_parts(data)
    animation = document["animations"][0]
    out = []
    for channel in animation["channels"]:
        if channel["target"]["node"] != node:
            continue
        sampler = animation["samplers"][channel["sampler"]]
        views = [
            document["bufferViews"][document["accessors"][sampler[k]]["bufferView"]]
            for k in ("input", "output")
        ]
        spans = [binary[v["byteOffset"] : v["byteOffset"] + v["byteLength"]] for v in views]
        out.append((sampler, spans))
    return out


def small_vrma() -> bytes:
    """A VRM animation made here: hips (keyed in place), spine, a node between spine and
    head that is no humanoid bone, head, two legs; the spine turns with rotation noise;
    expression ``happy`` weighted 0,0,0,1,0,0,0 at 2 fps, ``blink`` 1 on one frame of the
    spine's 30 fps (a spike, were it a joint's); a look-at node under the head."""
    rng = np.random.default_rng(5)
    times = np.arange(91) / 30.0
    nodes = [
        {"name": "hips", "translation": [0, 0.9, 0], "children": [1, 5, 7]},
        {"name": "spine", "translation": [0, 0.1, 0], "children": [2]},
        {"name": "J_upperChest", "translation": [0, 0.2, 0], "rotation": [0, 0, 0.6, 0.8],
         "children": [3]},
        {"name": "head", "translation": [0, 0.4, 0], "children": [4]},
        {"name": "lookAt", "translation": [0, 0.06, 0.5]},
        {"name": "leftUpperLeg", "translation": [0.1, 0, 0], "children": [6]},
        {"name": "leftFoot", "translation": [0, -0.85, 0]},
        {"name": "rightUpperLeg", "translation": [-0.1, 0, 0], "children": [8]},
        {"name": "rightFoot", "translation": [0, -0.85, 0]},
        {"name": "happy"},
        {"name": "blink"},
    ]  # fmt: skip
    bones = {"hips": 0, "spine": 1, "head": 3, "leftUpperLeg": 5, "leftFoot": 6}
    bones |= {"rightUpperLeg": 7, "rightFoot": 8}
    angle = 0.4 * np.sin(2 * np.pi * times / 3) + rng.normal(0, 0.02, times.size)
    spine = np.stack([0 * angle, np.sin(angle / 2), 0 * angle, np.cos(angle / 2)], axis=-1)
    weight = np.array([0, 0, 0, 1, 0, 0, 0])[:, None] * [1, 0, 0]
    blink = np.zeros((times.size, 3))
    blink[45, 0] = 1.0
    look = np.tile([0.0, 0.0, 0.0, 1.0], (7, 1))
    look[5] = [0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5)]
    tracks = [
        (0, "translation", times, np.tile([0, 0.9, 0], (times.size, 1))),
        (1, "rotation", times, spine),
        (9, "translation", np.arange(7) / 2.0, weight),
        (10, "translation", times, blink),
        (4, "rotation", np.arange(7) / 2.0, look),
    ]
    data, views, accessors, samplers, channels = b"", [], [], [], []
    for node, path, keys, values in tracks:
        for array, kind in ((keys[:, None], "SCALAR"), (values, f"VEC{values.shape[1]}")):
            raw = np.asarray(array, dtype="<f4").tobytes()
            views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(raw)})
            accessors.append(
                {"bufferView": len(views) - 1, "componentType": 5126, "count": len(array),
                 "type": kind}
            )  # fmt: skip
            data += raw
        samplers.append({"input": len(accessors) - 2, "output": len(accessors) - 1})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})
    document = {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["VRMC_vrm_animation"],
        "extensions": {
            "VRMC_vrm_animation": {
                "specVersion": "1.0",
                "humanoid": {"humanBones": {name: {"node": n} for name, n in bones.items()}},
                "expressions": {"preset": {"happy": {"node": 9}, "blink": {"node": 10}}},
                "lookAt": {"node": 4, "offsetFromHeadBone": [0, 0.06, 0]},
            }
        },
        "scenes": [{"nodes": [0, 9, 10]}],
        "nodes": nodes,
        "animations": [{"channels": channels, "samplers": samplers}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(data)}],
    }
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(data), 0x004E4942) + data
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def test_the_example_s_smile_is_kept_and_its_skeleton_is_the_humanoid(tmp_path, capsys):
    """three-vrm's example had been read as three root joints (rightUpperArm, happy,
    lookAt): despike repaired the smile's weight 1 to 0 ("1 spike repaired on happy"), and
    the skeleton hung under rightShoulder, -y up. Its humanoid bones are the skeleton,
    hips at the root, y up; the expression and look-at nodes are named in a note and a
    default clean leaves the file as it was."""
    clip = mc.load(VRMA)
    assert clip.n_joints == 51 and clip.names[0] == "hips" and clip.parents[0] == -1
    assert np.count_nonzero(clip.parents < 0) == 1
    assert "happy" not in clip.names and "lookAt" not in clip.names
    assert clip.up == "y" and abs(kinematics.body_height(clip) - 1.558) < 1e-3
    assert kinematics.source_notes(clip) == (
        "2 VRM animation nodes, not joints, kept as they are when written back to glTF: "
        "expression 'happy', lookAt",
    )
    report = tmp_path / "report.json"
    out = tmp_path / "clean.vrma"
    code, stdout, err = run_cli(capsys, "clean", VRMA, "-o", out, "--report", report)
    assert code == 0, err
    assert out.read_bytes() == VRMA.read_bytes()
    figures = json.loads(report.read_text())
    assert "happy" not in figures["joints"] and not figures["verdict"]["repairs"]
    assert "happy" not in figures["verdict"]["text"] and "spike" not in stdout
    code, _, err = run_cli(capsys, "convert", VRMA, tmp_path / "clip.bvh")
    assert code == 0, err
    bvh = (tmp_path / "clip.bvh").read_text()
    assert "ROOT hips" in bvh and "happy" not in bvh and "lookAt" not in bvh


def test_a_humanoid_joint_is_cleaned_and_the_expression_keys_are_written_back(tmp_path):
    """A VRM animation made here: the default pipeline cleans the spine's rotation noise
    while the expressions' and the look-at's channels keep their samplers and key bytes
    (blink's one-frame weight had been despiked to 0). The node between two humanoid bones
    is a joint (its rest turn is part of the skeleton); the look-at node under the head is
    no end site of it."""
    source = tmp_path / "small.vrma"
    source.write_bytes(small_vrma())
    clip = mc.load(source)
    assert clip.names == [
        "hips", "spine", "J_upperChest", "head", "leftUpperLeg", "leftFoot", "rightUpperLeg",
        "rightFoot",
    ]  # fmt: skip
    assert clip.parents.tolist() == [-1, 0, 1, 2, 0, 4, 0, 6] and clip.up == "y"
    assert clip.names.index("head") not in clip.end_sites
    cleaned, _ = mc.Pipeline.default().run(clip)
    spine = clip.names.index("spine")
    before = np.diff(clip.rotations[:, spine], 2, axis=0)
    after = np.diff(cleaned.rotations[:, spine], 2, axis=0)
    assert np.sqrt((after**2).mean()) < 0.5 * np.sqrt((before**2).mean())
    mc.save(cleaned, tmp_path / "clean.vrma")
    written = (tmp_path / "clean.vrma").read_bytes()
    assert keys_of(written, 1) != keys_of(source.read_bytes(), 1)  # the spine rewritten
    for node in (9, 10, 4):  # happy, blink, lookAt
        assert keys_of(written, node) == keys_of(source.read_bytes(), node)
