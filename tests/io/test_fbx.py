"""FBX without Blender: one line naming the extra that brings ``bpy``, exit code 2.

(FBX through a real Blender is checked in ``tests/blender``.)
"""

from __future__ import annotations

import importlib.util

import pytest
from helpers import SAMPLE, run_cli

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("bpy") is not None, reason="bpy is installed here"
)
EXTRA = "pip install 'motionclean[blender]'"


@pytest.mark.parametrize("command", [["info"], ["clean", "-o", "out.bvh"], ["report"]])
def test_reading_fbx_without_bpy_names_the_extra(capsys, tmp_path, command):
    take = tmp_path / "take.fbx"
    take.write_bytes(b"Kaydara FBX Binary  \x00\x1a\x00")
    args = [command[0], take, *[tmp_path / a if a.endswith(".bvh") else a for a in command[1:]]]
    code, out, err = run_cli(capsys, *args)
    assert code == 2 and out == ""
    assert err == (f"motionclean: error: {take}: reading FBX needs Blender's bpy module: {EXTRA}\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take.fbx"]


def test_writing_fbx_without_bpy_names_the_extra_and_writes_nothing(capsys, tmp_path):
    target = tmp_path / "take.fbx"
    code, _, err = run_cli(capsys, "convert", SAMPLE, target)
    assert code == 2
    assert err == (
        f"motionclean: error: {target}: writing FBX needs Blender's bpy module: {EXTRA}\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_missing_fbx_is_named_before_the_extra(capsys, tmp_path):
    code, _, err = run_cli(capsys, "info", tmp_path / "none.fbx")
    assert code == 1 and err.endswith("none.fbx: no such file\n")
