"""The one Blender session the Blender tests share (session scoped; see ``session.py``).

Blender's Python (``bpy`` pins Python 3.11 and numpy < 2) lives in its own environment,
``.venv-blender`` (made by ``make test``); ``MOTIONCLEAN_BLENDER_PYTHON`` names another one
(``make test-blender45`` runs the operator checks in bpy 4.5 this way, with
``MOTIONCLEAN_BLENDER_OPERATOR_ONLY=1``). Without it the tests skip, saying so.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from helpers import ROOT, corpus_clip, cut_bvh

BLENDER_PYTHON = Path(
    os.environ.get("MOTIONCLEAN_BLENDER_PYTHON", ROOT / ".venv-blender" / "bin" / "python")
)
OPERATOR_ONLY = os.environ.get("MOTIONCLEAN_BLENDER_OPERATOR_ONLY") == "1"
SESSION = Path(__file__).with_name("session.py")
#: Frames of corpus clip 131_01 the session uses.
FRAMES = 400


@dataclass
class BlenderSession:
    """What the session left: its figures (``results.json``) and files in ``out``."""

    out: Path
    results: dict
    seconds: float
    clip: Path  # the BVH file the rigs were imported from


def _build_extension(folder: Path) -> Path:
    spec = importlib.util.spec_from_file_location(
        "build_blender_extension", ROOT / "scripts" / "build_blender_extension.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build(folder)


@pytest.fixture(scope="session")
def blender(tmp_path_factory: pytest.TempPathFactory) -> BlenderSession:
    if not BLENDER_PYTHON.is_file():
        pytest.skip(f"no Blender Python at {BLENDER_PYTHON} (`make test` makes .venv-blender)")
    work = tmp_path_factory.mktemp("blender")
    # its first FRAMES frames: flips (RThumb, 178-191), spikes (RightWrist) and both feet's
    # contacts, in less time than the whole take
    clip = cut_bvh(corpus_clip("131_01.bvh"), work / "131_01.bvh", FRAMES)
    extension = _build_extension(work / "dist")
    out = work / "out"
    out.mkdir()
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(work / "user")}
    args = [BLENDER_PYTHON, SESSION, extension, clip, out] + (["operator"] if OPERATOR_ONLY else [])
    start = time.perf_counter()
    done = subprocess.run(
        [os.fspath(a) for a in args], env=env, capture_output=True, text=True, timeout=900
    )
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        pytest.fail(f"the Blender session failed ({BLENDER_PYTHON}):\n{done.stderr[-4000:]}")
    results = json.loads((out / "results.json").read_text())
    print(f"Blender {results['blender']} session: {seconds:.1f} s", file=sys.stderr)
    return BlenderSession(out, results, seconds, clip)
