"""Reading the SMPL (.npz, .pkl), OpenSim (.mot) and glTF (.glb) formats against the
minimum a reader of each must do, same process, same files.

Run ``python bench/formats.py [--repeats N]``. Per length, four files: an AMASS SMPL-H
``.npz`` (``poses`` of 156 float64 values per frame, ``trans``, rate, betas), the same record
as a protocol-4 pickle, an OpenSim ``.mot`` of 23 coordinates (the gait2392 model's count,
``%.8f`` text, tab separated), and a ``.glb`` of the 31-joint sample clip tiled to the
length. Peers: ``np.load`` of every array (the .npz), ``pickle.loads`` (the .pkl: no
restriction, so it runs whatever the file names), ``np.loadtxt`` (the .mot) and ``json`` +
``np.frombuffer`` views of every accessor (the .glb: no sampling, no checks). motionclean
does more: validation, conversion to quaternions, sign continuity and the text offsets
for a byte-exact write-back. Prints milliseconds per read (best of N) and the ratio
motionclean / peer.
"""

from __future__ import annotations

import argparse
import json
import pickle
import struct
import tempfile
from pathlib import Path

import numpy as np
from common import ROOT, best_of

import motionclean as mc

LENGTHS = (1_200, 12_000, 120_000)


def smpl_record(frames: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    t = np.arange(frames)[:, None] / 120.0
    poses = 0.4 * np.sin(rng.uniform(0.5, 2, (1, 156)) * t + rng.uniform(0, 6, (1, 156)))
    return {
        "trans": np.cumsum(rng.normal(0, 0.001, (frames, 3)), axis=0),
        "gender": np.array("female"),
        "mocap_framerate": np.array(120.0),
        "betas": rng.normal(0, 1, 16),
        "poses": poses,
    }


def mot_text(frames: int) -> bytes:
    rng = np.random.default_rng(1)
    t = np.arange(frames) / 100.0
    values = 30 * np.sin(rng.uniform(0.5, 3, 23) * t[:, None] + rng.uniform(0, 6, 23))
    names = [f"coord_{k}" for k in range(20)] + ["pelvis_tx", "pelvis_ty", "pelvis_tz"]
    head = f"ik\nversion=1\nnRows={frames}\nnColumns=24\ninDegrees=yes\nendheader\n"
    body = np.char.mod("%.8f", np.concatenate([t[:, None], values], axis=1))
    lines = ["time\t" + "\t".join(names)] + ["\t" + "\t".join(row) for row in body.tolist()]
    return (head + "\n".join(lines) + "\n").encode()


def glb_views(data: bytes) -> list[np.ndarray]:
    """The peer: the JSON chunk parsed and a numpy view of every accessor."""
    size = struct.unpack_from("<I", data, 12)[0]
    document = json.loads(data[20 : 20 + size])
    binary = memoryview(data)[20 + size + 8 :]
    out = []
    for accessor in document["accessors"]:
        view = document["bufferViews"][accessor["bufferView"]]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[accessor["type"]]
        start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
        out.append(np.frombuffer(binary, "<f4", accessor["count"] * width, start))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    sample = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    print(f"{'format':<6}{'frames':>9}{'motionclean ms':>16}{'peer ms':>10}{'ratio':>8}")
    with tempfile.TemporaryDirectory() as folder:
        for frames in LENGTHS:
            record = smpl_record(frames)
            npz, pkl, mot, glb = (
                Path(folder) / f"c{frames}{s}" for s in (".npz", ".pkl", ".mot", ".glb")
            )
            np.savez(npz, **record)
            pkl.write_bytes(pickle.dumps(record, protocol=4))
            mot.write_bytes(mot_text(frames))
            reps = -(-frames // sample.n_frames)
            index = np.tile(np.arange(sample.n_frames), reps)[:frames]
            tiled = sample.at_frames(index)
            mc.save(tiled.replace(rotations=mc.core.quat.make_continuous(tiled.rotations)), glb)
            peers = {
                ".npz": lambda p=npz: {k: v for k, v in np.load(p).items()},
                ".pkl": lambda p=pkl: pickle.loads(p.read_bytes()),
                ".mot": lambda p=mot: np.loadtxt(p, skiprows=7),
                ".glb": lambda p=glb: glb_views(p.read_bytes()),
            }
            for path in (npz, pkl, mot, glb):
                ours = best_of(lambda p=path: mc.load(p), args.repeats, warm_up=True)
                peer = best_of(peers[path.suffix], args.repeats, warm_up=True)
                print(
                    f"{path.suffix:<6}{frames:>9,}{ours * 1e3:>16.1f}{peer * 1e3:>10.1f}"
                    f"{ours / peer:>8.2f}",
                    flush=True,
                )
            del record


if __name__ == "__main__":
    main()
