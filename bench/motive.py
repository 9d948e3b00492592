"""Reading an OptiTrack Motive CSV export against reading the same values as our rigid-body
CSV, same process, same numbers (the same six-decimal text in both files).

Run ``python bench/motive.py [--repeats N]``. The tracks are the head, hands and feet of
sample_data/131_02_cut.bvh (world transforms, 120 fps) tiled to each length. Three files
per length: a Motive export of the five rigid bodies (with their Mean Marker Error
columns), the same bodies as a rigid-body CSV (``time,head.px,...,head.qz,...``), and a
Motive export that also carries three rigid-body markers per body and two unlabeled
markers (columns that are carried as text, never parsed). For reference, also the
rigid-body CSV that motionclean itself writes for the clip read from the Motive export
(``format_csv(clip, layout="rigid")``: renormalised quaternions in shortest round-trip repr,
up to 17 digits). Prints milliseconds per read (``motionclean.load``, best of N) and the
ratios rigid-body CSV / Motive (above 1: the Motive export reads faster).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from common import ROOT, best_of

import motionclean as mc
from motionclean.core import quat
from motionclean.core.kinematics import forward

sys.path.insert(0, str(ROOT / "scripts"))
from make_motive_sample import BODIES, METRES_PER_UNIT, motive_export  # noqa: E402

LENGTHS = (1_200, 12_000, 120_000)


def tracks(n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (F, 5, 3) metres and rotations (F, 5, 4) of the sample's five bodies."""
    clip = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    world_p, world_q = forward(clip)
    joints = [clip.joint_index(name) for name in BODIES.values()]
    reps = -(-n_frames // clip.n_frames)
    p = np.tile(world_p[:, joints], (reps, 1, 1))[:n_frames] * METRES_PER_UNIT
    q = quat.make_continuous(np.tile(world_q[:, joints], (reps, 1, 1))[:n_frames])
    return p, q


def rigid_csv(positions: np.ndarray, rotations: np.ndarray, rate: float) -> bytes:
    """The same values as a rigid-body CSV, each printed like Motive prints it (%.6f)."""
    n_frames = positions.shape[0]
    header = "time," + ",".join(f"{b}.{s}" for b in BODIES for s in mc.io.csv.RIGID_SUFFIXES)
    table = np.concatenate([positions, rotations], axis=-1).reshape(n_frames, -1)
    times = np.arange(n_frames) / rate
    text = np.char.mod("%.6f", np.concatenate([times[:, None], table], axis=1))
    return ("\n".join([header] + [",".join(row) for row in text.tolist()]) + "\n").encode()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rate = 120.0
    rng = np.random.default_rng(0)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for n_frames in LENGTHS:
            p, q = tracks(n_frames)
            offsets = rng.uniform(-0.05, 0.05, (len(BODIES), 3, 3))
            body_markers = p[:, :, None] + quat.rotate(q[:, :, None], offsets[None])
            markers = rng.normal(size=(n_frames, 2, 3))
            files = {
                "motive": motive_export(list(BODIES), p, q, rate, eol="\n"),
                "rigid": rigid_csv(p, q, rate),
                "motive+markers": motive_export(
                    list(BODIES), p, q, rate, body_markers=body_markers, markers=markers, eol="\n"
                ),
            }
            motive_path = folder / "motive.csv"
            motive_path.write_bytes(files["motive"])
            files["ours"] = mc.io.csv.format_csv(mc.load(motive_path), layout="rigid")
            times = {}
            for name, data in files.items():
                path = folder / f"{name}.csv"
                path.write_bytes(data)
                times[name] = best_of(lambda path=path: mc.load(path), args.repeats, warm_up=True)
            motive, rigid = mc.load(folder / "motive.csv"), mc.load(folder / "rigid.csv")
            assert np.array_equal(motive.translations, rigid.translations)
            assert np.array_equal(motive.rotations, rigid.rotations)
            sizes = {name: len(data) for name, data in files.items()}
            rows.append((n_frames, times, sizes))

    print(
        f"Read a Motive export vs the same values as a rigid-body CSV (5 bodies, 120 fps), "
        f"best of {args.repeats}, milliseconds\n"
    )
    print(
        "| frames | Motive | rigid-body CSV, same text | rigid / Motive "
        "| rigid-body CSV as motionclean writes it | ours / Motive | Motive + markers "
        "| MB (Motive / rigid / ours / + markers) |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---|")
    ms = 1e3
    for n_frames, t, size in rows:
        print(
            f"| {n_frames} | {t['motive'] * ms:.1f} | {t['rigid'] * ms:.1f} "
            f"| {t['rigid'] / t['motive']:.2f} | {t['ours'] * ms:.1f} "
            f"| {t['ours'] / t['motive']:.2f} | {t['motive+markers'] * ms:.1f} "
            f"| {size['motive'] / 1e6:.2f} / {size['rigid'] / 1e6:.2f} / "
            f"{size['ours'] / 1e6:.2f} / {size['motive+markers'] / 1e6:.2f} |"
        )


if __name__ == "__main__":
    main()
