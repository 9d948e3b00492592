"""A glTF exported by Blender, cleaned by motionclean and imported again by Blender's own
glTF importer, poses its bones as the cleaned BVH does through Blender's BVH importer."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest
from helpers import ROOT, SAMPLE, cut_bvh, run_cli

BLENDER_PYTHON = ROOT / ".venv-blender" / "bin" / "python"
POSE_FRAMES = ROOT / "tests" / "io" / "blender" / "pose_frames.py"
BLENDER_GLB = ROOT / "tests" / "data" / "blender" / "131_02_cut.glb"
FRAMES = 96

pytestmark = [
    pytest.mark.slow,  # one Blender process importing four clips, about 1.5 s
    pytest.mark.skipif(
        not BLENDER_PYTHON.exists(),
        reason=f"no Blender Python at {BLENDER_PYTHON} (make test creates it: bpy 5.0.1)",
    ),
]


def blender_poses(*clips: tuple) -> list[dict]:
    """Per clip ``(path, first frame)``: per frame (``first`` on, FRAMES of them) and bone,
    Blender's world rotation (w, x, y, z) and head (one Blender process for all)."""
    args = [str(a) for clip, first in clips for a in (clip, first, first + FRAMES - 1)]
    done = subprocess.run(
        [str(BLENDER_PYTHON), str(POSE_FRAMES), "120", *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    line = next(line for line in done.stdout.splitlines() if line.startswith("POSES"))
    return json.loads(line[len("POSES") :])


def arrays(poses: dict, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    frames = sorted(poses, key=int)
    q = np.array([[poses[f][n][0] for n in names] for f in frames])
    p = np.array([[poses[f][n][1] for n in names] for f in frames])
    return q, p


def times_inverse(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``q p^-1`` of (w, x, y, z) quaternions."""
    w0, v0 = p[..., :1], -p[..., 1:]
    w, v = q[..., :1], q[..., 1:]
    return np.concatenate(
        [w * w0 - np.sum(v * v0, axis=-1, keepdims=True), w * v0 + w0 * v + np.cross(v, v0)],
        axis=-1,
    )


def relative(q: np.ndarray) -> np.ndarray:
    """World rotations relative to the first frame: the bones' rest orientations, which
    each importer chooses in its own way, cancel out."""
    return times_inverse(q, q[:1])


def degrees_apart(a: np.ndarray, b: np.ndarray) -> float:
    """Largest rotation between ``a`` and ``b``, degrees (from the difference quaternion's
    vector part: accurate for Blender's single-precision values, unlike an arccos)."""
    d = times_inverse(a, b)
    return float(
        np.degrees(2 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))).max()
    )


def test_cleaned_glb_imports_in_blender_as_the_cleaned_bvh(tmp_path, capsys):
    bvh = cut_bvh(SAMPLE, tmp_path / "cut.bvh", FRAMES)
    for source, target in ((BLENDER_GLB, "clean.glb"), (bvh, "clean.bvh")):
        code, _, err = run_cli(capsys, "clean", source, "-o", tmp_path / target, "-q")
        assert code == 0, err
    # a BVH written as a new glTF (its keys start at time 0, Blender's frame 0; the BVH
    # importer starts at frame 1)
    code, _, err = run_cli(capsys, "convert", tmp_path / "clean.bvh", tmp_path / "new.glb")
    assert code == 0, err
    from_glb, from_bvh, new, before = blender_poses(
        (tmp_path / "clean.glb", 1),
        (tmp_path / "clean.bvh", 1),
        (tmp_path / "new.glb", 0),
        (bvh, 1),
    )
    names = sorted(from_bvh["1"])
    assert sorted(from_glb["1"]) == names and len(names) == 31
    q_glb, p_glb = arrays(from_glb, names)
    q_bvh, p_bvh = arrays(from_bvh, names)
    assert np.abs(p_glb - p_bvh).max() < 1e-3  # bone heads, Blender units (24 tall)
    assert degrees_apart(relative(q_glb), relative(q_bvh)) < 0.01
    # the new glTF imports in Blender as the BVH does
    q_new, p_new = arrays(new, names)
    assert np.abs(p_new - p_bvh).max() < 1e-3
    assert degrees_apart(relative(q_new), relative(q_bvh)) < 0.01
    # and the cleaning did something Blender sees: the thumb's half-turn flips are gone
    q_in, _ = arrays(before, names)
    thumb = names.index("RThumb")
    assert degrees_apart(relative(q_in)[:, thumb], relative(q_bvh)[:, thumb]) > 90
