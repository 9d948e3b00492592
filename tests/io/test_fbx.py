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


@pytest.mark.parametrize("content", [b"", b"; FBX 7.4.0 project file\n"])
def test_the_extra_is_named_before_the_content_is_judged(capsys, tmp_path, content):
    """An empty take.fbx had said 'empty file' (exit 1) where README says an .fbx without
    bpy stops with the extra named (exit 2): what the file holds is Blender's to read."""
    take = tmp_path / "take.fbx"
    take.write_bytes(content)
    code, out, err = run_cli(capsys, "info", take)
    assert (code, out) == (2, "")
    assert err == f"motionclean: error: {take}: reading FBX needs Blender's bpy module: {EXTRA}\n"


def test_an_add_on_failure_is_said_in_one_line_by_its_exception():
    """Blender raises an add-on's failure as its whole traceback in one RuntimeError; the
    error line gives its last line (it had squeezed every frame of the traceback in)."""
    from motionclean.io.fbx import _reason

    failure = RuntimeError(
        "Error: Python: Traceback (most recent call last):\n"
        '  File "/bpy/addons_core/io_scene_fbx/import_fbx.py", line 2255, in blen_read_light\n'
        "    lamp.cycles.cast_shadow = lamp.use_shadow\n"
        "AttributeError: 'CyclesLightSettings' object has no attribute 'cast_shadow'\n"
        "Location: /bpy/ops.py:109\n"
    )
    assert _reason([], failure) == (
        "Blender's add-on failed: AttributeError: 'CyclesLightSettings' object has no "
        "attribute 'cast_shadow'"
    )
    assert _reason(["Error: Couldn't open file (failed to read)"]) == (
        "Couldn't open file (failed to read)"
    )


def test_the_takes_of_a_binary_fbx_are_found_by_name():
    from motionclean.io.fbx import _anim_stacks

    def stack(name: bytes) -> bytes:  # a string property: S, uint32 length, the text
        text = name + b"\x00\x01AnimStack"
        return b"S" + len(text).to_bytes(4, "little") + text

    data = b"Kaydara FBX Binary\x00" + stack(b"Take 001") + b"\x00" * 9 + stack(b"a|b")
    assert _anim_stacks(data) == ["Take 001", "a|b"]
