"""Build sample_data/ from the CMU corpus: a real cut and a noisy variant.

The cut keeps frames [START, STOP) of 131_02 as text (values untouched). The noisy variant
multiplies every rotation sample by exp(delta), delta uniform in a ball of radius
ROTATION_NOISE (log units, 000 Sec. VI-B), and adds uniform noise of POSITION_NOISE length
units per axis to the root position channels. Seeded: the output is reproducible.

    python scripts/make_sample.py [CORPUS_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import motionclean as mc
from motionclean.core import quat

ROOT = Path(__file__).resolve().parents[1]
CLIP, START, STOP = "131_02.bvh", 150, 450
ROTATION_NOISE = 0.01  # radians in log units: up to about 1.15 degrees of rotation
POSITION_NOISE = 0.05  # length units
SEED = 131


def cut(source: Path, target: Path, start: int, stop: int) -> None:
    """Copy frames [start, stop) of a BVH file, keeping every value's text."""
    data = source.read_bytes()
    head, _, body = data.partition(b"\nFrame Time:")
    time_line, _, rows = body.partition(b"\n")
    hierarchy, _, _ = head.rpartition(b"Frames:")
    eol = b"\r\n" if hierarchy.endswith(b"\r\n") else b"\n"
    kept = rows.split(b"\n")[start:stop]
    target.write_bytes(
        hierarchy
        + b"Frames: %d" % len(kept)
        + eol
        + b"Frame Time:"
        + time_line
        + b"\n"
        + b"\n".join(kept)
        + b"\n"
    )


def add_noise(motion: mc.Motion, rng: np.random.Generator) -> mc.Motion:
    """Rotation noise exp(delta) on every joint, position noise on every position channel."""
    shape = motion.rotations.shape[:-1]
    direction = rng.normal(size=(*shape, 3))
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    radius = ROTATION_NOISE * rng.uniform(size=shape) ** (1 / 3)
    rotations = quat.multiply(motion.rotations, quat.exp(direction * radius[..., None]))
    has_rotation = motion.layout.has_rotation
    rotations = np.where(has_rotation[None, :, None], rotations, motion.rotations)
    noise = rng.uniform(-POSITION_NOISE, POSITION_NOISE, motion.translations.shape)
    has_position = motion.layout.position_columns >= 0  # (joints, axes) with a channel
    translations = motion.translations + np.where(has_position[None], noise, 0.0)
    return motion.replace(rotations=rotations, translations=translations)


def main() -> None:
    corpus = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "corpus" / "cmu"
    out = ROOT / "sample_data"
    clean_path = out / "131_02_cut.bvh"
    cut(corpus / CLIP, clean_path, START, STOP)
    motion = mc.load(clean_path)
    mc.save(add_noise(motion, np.random.default_rng(SEED)), out / "131_02_noisy.bvh")


if __name__ == "__main__":
    main()
