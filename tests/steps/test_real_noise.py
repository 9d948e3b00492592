"""The default pipeline on joint-coordinate captures like those of markerless systems: channel
CSVs at 60 fps, every coordinate a root joint rotating about Z, dropouts as blank cells.

Despike next to dropouts: a coordinate whose estimate sits half a turn off for a run that
begins (or ends) at a dropout is repaired on that run, never on the correct frames beside
it (the case of the realnoise takes: a shoulder rotation 180 degrees off for 70 frames
after a dropout, then 137 correct frames).
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import run_cli

FPS = 60.0
NAMES = ("RHip_FE", "RKnee_FE", "RShoulder_RIE", "RElbow_FE")


def smooth_coordinates(frames: int, seed: int = 0) -> np.ndarray:
    """(F, C) degrees: slow sums of sines, like joint angles of a walk or a lift."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / FPS
    out = np.zeros((frames, len(NAMES)))
    for _ in range(3):
        amplitude = rng.uniform(5.0, 25.0, len(NAMES))
        hz = rng.uniform(0.3, 1.2, len(NAMES))
        phase = rng.uniform(0.0, 2.0 * np.pi, len(NAMES))
        out += amplitude * np.sin(2.0 * np.pi * hz * t + phase)
    return out


def write_channel_csv(path, x: np.ndarray) -> None:
    """As ``../shared/realnoise/to_channel_csv.py`` writes: NaN rows are blank cells."""
    channels = ("Zrotation", "Xrotation", "Yrotation")
    lines = [",".join(["time"] + [f"{n}.{c}" for n in NAMES for c in channels])]
    for i, row in enumerate(x):
        cells = [f"{i / FPS:.9f}"]
        for v in row:
            cells += ["", "", ""] if np.isnan(v) else [f"{v:.6f}", "0", "0"]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")


def read_z(path) -> np.ndarray:
    header = path.read_text().splitlines()[0].split(",")
    values = np.genfromtxt(path, delimiter=",", skip_header=1)
    return np.stack([values[:, header.index(f"{n}.Zrotation")] for n in NAMES], axis=1)


def wrapped(d: np.ndarray) -> np.ndarray:
    return (d + 180.0) % 360.0 - 180.0


@pytest.mark.parametrize(
    "gaps, flipped",
    [
        ([(100, 110)], (110, 180)),  # the realnoise case: 70 frames after a dropout
        ([(100, 110), (180, 190)], (110, 180)),  # dropouts on both sides
        ([(210, 222)], (140, 210)),  # the run ends at a dropout
        ([(100, 110), (180, 320)], (110, 180)),  # a dropout too long to fill follows
    ],
)
def test_a_half_turn_run_beside_dropouts_is_the_one_repaired(tmp_path, capsys, gaps, flipped):
    truth = smooth_coordinates(460)
    x = truth.copy()
    x[flipped[0] : flipped[1], 2] += 180.0  # the shoulder's estimate half a turn off
    for first, stop in gaps:
        x[first:stop] = np.nan
    source, target = tmp_path / "take.csv", tmp_path / "clean.csv"
    write_channel_csv(source, x)
    code, _, err = run_cli(capsys, "clean", source, "-o", target, "-q")
    assert code == 0, err
    out = read_z(target)
    known = ~np.isnan(x[:, 2]) & ~np.isnan(out[:, 2])
    error = np.abs(wrapped(out[:, 2] - truth[:, 2]))[known]
    assert error.max() < 5.0  # every known frame back on the truth (auto smooths a little)
