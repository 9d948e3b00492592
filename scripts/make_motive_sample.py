"""Build sample_data/131_02_motive.csv: an OptiTrack Motive CSV export (format 1.23) of
rigid bodies tracked on the sample clip.

Five rigid bodies (head, hands, feet) follow the world transforms of those joints of
sample_data/131_02_cut.bvh (frames [0, FRAMES), 120 fps), positions converted to metres
(CMU length units are 0.056444 m). Each body carries three rigid-body markers at fixed
offsets; two unlabeled markers drift on their own. The left hand is occluded for
GAP frames (its cells and its markers' cells blank), as optical trackers lose a body.
Values are printed with six decimals, as Motive does. Seeded: reproducible.

    python scripts/make_motive_sample.py

:func:`motive_export` writes any rigid-body tracks in this layout (bench/motive.py uses it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import motionclean as mc
from motionclean.core import quat
from motionclean.core.kinematics import forward

ROOT = Path(__file__).resolve().parents[1]
BODIES = {"head": "Head", "hand_l": "lhand", "hand_r": "rhand", "foot_l": "LeftAnkle"}
BODIES["foot_r"] = "RightAnkle"
FRAMES = 120
METRES_PER_UNIT = 0.056444  # CMU: (1 / 0.45) * 2.54 / 100
GAP = slice(40, 48)  # frames the left hand is occluded
SEED = 14


def motive_export(
    names: list[str],
    positions: np.ndarray,
    rotations: np.ndarray,
    rate: float,
    missing: np.ndarray | None = None,
    body_markers: np.ndarray | None = None,
    markers: np.ndarray | None = None,
    eol: str = "\r\n",
) -> bytes:
    """A Motive CSV export (format 1.23, quaternions, metres) of rigid-body tracks.

    ``positions`` ``(F, B, 3)`` metres and ``rotations`` ``(F, B, 4)`` ``(w, x, y, z)``;
    ``missing`` ``(F, B)`` bool blanks a body (and its markers) on a frame;
    ``body_markers`` ``(F, B, M, 3)`` rigid-body marker positions; ``markers`` ``(F, N, 3)``
    unlabeled markers (NaN: occluded). Each body gets a Mean Marker Error column.
    """
    n_frames, n_bodies = positions.shape[:2]
    missing = np.zeros((n_frames, n_bodies), bool) if missing is None else missing
    n_body_markers = 0 if body_markers is None else body_markers.shape[2]
    n_markers = 0 if markers is None else markers.shape[1]
    header = [
        "Format Version", "1.23", "Take Name", "sample_131_02", "Take Notes", "",
        "Capture Frame Rate", f"{rate:.6f}", "Export Frame Rate", f"{rate:.6f}",
        "Capture Start Time", "2024-05-01 10.00.00.000 AM", "Capture Start Frame", "0",
        "Total Frames in Take", str(n_frames), "Total Exported Frames", str(n_frames),
        "Rotation Type", "Quaternion", "Length Units", "Meters", "Coordinate Space", "Global",
    ]  # fmt: skip
    types, labels, ids, properties, axes = [], [], [], [], []
    for b, name in enumerate(names):
        types += ["Rigid Body"] * 8
        labels += [name] * 8
        ids += [str(b + 1)] * 8
        properties += ["Rotation"] * 4 + ["Position"] * 3 + ["Mean Marker Error"]
        axes += ["X", "Y", "Z", "W", "X", "Y", "Z", ""]
        for m in range(n_body_markers):
            types += ["Rigid Body Marker"] * 4
            labels += [f"{name}:Marker{m + 1}"] * 4
            ids += [f"{b + 1}:{m + 1}"] * 4
            properties += ["Position"] * 3 + ["Marker Quality"]
            axes += ["X", "Y", "Z", ""]
    for m in range(n_markers):
        types += ["Marker"] * 3
        labels += [f"Unlabeled {1000 + m}"] * 3
        ids += [f"0:{1000 + m}"] * 3
        properties += ["Position"] * 3
        axes += ["X", "Y", "Z"]
    lines = [
        ",".join(header),
        "",
        ",Type," + ",".join(types),
        ",Name," + ",".join(labels),
        ",ID," + ",".join(ids),
        ",," + ",".join(properties),
        "Frame,Time (Seconds)," + ",".join(axes),
    ]
    # Data cells: per body X Y Z W, X Y Z, mean marker error, then its markers.
    w, xyz = rotations[..., :1], rotations[..., 1:]
    error = np.full((n_frames, n_bodies, 1), 0.00021)
    blocks = [np.concatenate([xyz, w, positions, error], axis=-1)]  # (F, B, 8)
    if body_markers is not None:
        quality = np.ones(body_markers.shape[:3] + (1,))
        blocks.append(
            np.concatenate([body_markers, quality], axis=-1).reshape(n_frames, n_bodies, -1)
        )
    per_body = np.concatenate(blocks, axis=-1)
    per_body[missing] = np.nan
    values = [per_body.reshape(n_frames, -1)]
    if markers is not None:
        values.append(markers.reshape(n_frames, -1))
    table = np.concatenate(values, axis=1)
    text = np.char.mod("%.6f", table)
    text[np.isnan(table)] = ""
    times = np.char.mod("%.6f", np.arange(n_frames) / rate)
    rows = [
        f"{f},{t}," + ",".join(cells)
        for f, (t, cells) in enumerate(zip(times.tolist(), text.tolist(), strict=True))
    ]
    return (eol.join(lines + rows) + eol).encode()


def main() -> None:
    clip = mc.load(ROOT / "sample_data" / "131_02_cut.bvh")
    world_p, world_q = forward(clip)
    joints = [clip.joint_index(name) for name in BODIES.values()]
    positions = world_p[:FRAMES, joints] * METRES_PER_UNIT
    rotations = quat.make_continuous(world_q[:FRAMES, joints])
    rng = np.random.default_rng(SEED)
    offsets = rng.uniform(-0.05, 0.05, (len(joints), 3, 3))  # three markers per body
    body_markers = positions[:, :, None] + quat.rotate(rotations[:, :, None], offsets[None])
    body_markers += rng.normal(scale=2e-4, size=body_markers.shape)
    markers = np.cumsum(rng.normal(scale=1e-3, size=(FRAMES, 2, 3)), axis=0) + [0.0, 1.0, 0.0]
    markers[rng.uniform(size=(FRAMES, 2)) < 0.1] = np.nan
    missing = np.zeros((FRAMES, len(joints)), dtype=bool)
    missing[GAP, list(BODIES).index("hand_l")] = True
    data = motive_export(
        list(BODIES), positions, rotations, round(clip.frame_rate), missing, body_markers, markers
    )
    (ROOT / "sample_data" / "131_02_motive.csv").write_bytes(data)


if __name__ == "__main__":
    main()
