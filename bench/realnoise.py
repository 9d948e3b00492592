"""Real noise with truth: the default pipeline against tuned baselines on markerless takes.

Data: ``../shared/realnoise`` (see its README): joint coordinates of markerless (video)
pipelines at 60 Hz, with the marker-based capture of the same takes (120 Hz) as the truth.
Each estimate goes through the project's own channel-CSV path, as ``to_channel_csv.py`` there
writes it (every coordinate a root joint rotating about Z, degrees; dropouts as blank
cells; coordinates with half or more of their samples missing left out), and is cleaned by
:func:`motionclean.run.jobs.clean_file` with the default pipeline, which is what
``motionclean clean take.csv -o out.csv`` does; the cleaned CSV is read back and scored.

Scoring, as the README there says: the truth is interpolated linearly to the estimate's
times; frames missing in the input are left out. **AccErr**: mean over frames and
coordinates of ``|second difference of the output - that of the truth|``, degrees per
frame squared. **RMSE**: degrees, each coordinate's mean difference over the take removed
first (systems disagree on joint conventions by a constant). **Fill**: RMS error (same
bias removed) on the samples missing in the input that the default filled, against a
straight line across each gap (in unwrapped degrees) on the same samples.

Baselines, run in this process on the same takes (dropouts bridged by the straight line,
which they need): zero-phase Butterworth, order 2, forward-backward (scipy ``filtfilt``),
its cutoff chosen per take in hindsight among 2-15 Hz (0.5 Hz steps) for the least AccErr;
the fixed 6 Hz Butterworth of biomechanics pipelines; the One Euro filter (Casiez et al.
2012) and a Savitzky-Golay filter, each tuned per take in hindsight (``f_min``, ``beta``;
window and degree 2 or 3) for the least AccErr. The default is not tuned.

Each take's row says which capture source the default found (``auto``'s ``source=auto``:
markerless when the clip's motion slope over 2-8 Hz is flatter than -1, see
``motionclean.filters.noise.motion_slope``) and the slope.

A second table checks that clean captures are left alone at any frame rate: the corpus
clips (``../shared/corpus/cmu``, 120 fps, and every 2nd, 4th and 5th frame: 60, 30 and
24 fps), the exporters' files of ``tests/data/exporters`` and the sample clips, cleaned by
the default, each its own truth: the source found, the RMS and largest rotation change in
degrees and the acceleration change (mean ``|a_out - a_in|`` over mean ``|a_in|``, ``a`` the
second difference of the rotation in each sample's frame, percent), on the joints
``bench/quality.py`` scores (not RThumb, whose capture toggles by half-turns, nor any joint
with a step above 30 degrees). Targets: 0.3 degrees RMS and 2 %.

Run ``python bench/realnoise.py`` (about 20 s); ``--takes theia3d/gait ...`` for a subset,
``--data DIR`` for takes kept aside in a folder laid out as ``../shared/realnoise``
(``estimates/PIPELINE/TASK_participant_NN.csv`` and ``truth/`` with the same names).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import CORPUS, ROOT
from noise_kinds import one_euro
from quality import scored_joints
from scipy.signal import butter, filtfilt, savgol_filter

import motionclean as mc
from motionclean.core import quat
from motionclean.run.jobs import clean_file
from motionclean.steps.pipeline import DEFAULT_STEPS, Pipeline

#: The shared real-noise takes beside the project.
DATA = ROOT.parent / "shared" / "realnoise"
#: Hindsight grids of the baselines.
BUTTER_CUTOFFS = np.arange(2.0, 15.01, 0.5)
EURO_MIN_CUTOFFS = (0.25, 0.5, 1.0, 2.0, 4.0)
EURO_BETAS = (0.0, 0.001, 0.003, 0.01, 0.03, 0.1)
SAVGOL_WINDOWS = (5, 7, 9, 11, 15, 19, 25, 31, 41, 51)


# ----------------------------------------------------------------------------- takes


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path, encoding="utf-8-sig") as fh:
        header = fh.readline().strip().split(",")
    values = np.genfromtxt(path, delimiter=",", skip_header=1)
    return header, values.reshape(-1, len(header))


def takes(data: Path, wanted: list[str] | None) -> list[tuple[str, str, Path, Path]]:
    """``(pipeline, task, estimate, truth)`` of every take in ``data`` (laid out as
    ``../shared/realnoise``), or of ``wanted`` (``pipeline/task``)."""
    found = []
    for folder in sorted((data / "estimates").iterdir()):
        for estimate in sorted(folder.glob("*.csv")):
            task = estimate.name.split("_participant")[0]
            if wanted and f"{folder.name}/{task}" not in wanted:
                continue
            found.append((folder.name, task, estimate, data / "truth" / estimate.name))
    return found


#: A coordinate as the channel CSV writes it (degrees, 6 decimals).
_cell = "{:.6f}".format


def load_take(estimate: Path, truth: Path):
    """Times (s), estimate (F, C) in degrees with NaN for dropouts, the truth at the same
    times (F, C) and the coordinates' names, the ones with under half missing (as
    ``to_channel_csv.py`` keeps them); None when no coordinate is kept."""
    header, values = read_csv(estimate)
    times, x = values[:, 0], np.degrees(values[:, 1:])
    keep = [j for j in range(x.shape[1]) if np.mean(~np.isnan(x[:, j])) > 0.5]
    names = [header[1 + j] for j in keep]
    if not names:
        return None
    # the values as the channel CSV gives them to the tool (6 decimals): scored the same
    x = np.char.mod("%.6f", x[:, keep]).astype(np.float64)
    truth_header, truth_values = read_csv(truth)
    truth_times = truth_values[:, 0]
    columns = [truth_values[:, truth_header.index(n)] for n in names]
    y = np.stack([np.interp(times, truth_times, column) for column in columns], axis=1)
    return times, x, np.degrees(y), names


def write_channel_csv(path: Path, times, x, names) -> None:
    """The channel CSV of ``to_channel_csv.py``: ``NAME.Zrotation,Xrotation,Yrotation``."""
    channels = ("Zrotation", "Xrotation", "Yrotation")
    lines = [",".join(["time"] + [f"{n}.{c}" for n in names for c in channels])]
    for t, row in zip(times, x, strict=True):
        cells = [f"{t:.9f}"]
        for v in row:
            cells += ["", "", ""] if np.isnan(v) else [_cell(v), "0", "0"]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n")


def run_default(times, x, names, steps=None) -> tuple[np.ndarray, str]:
    """The take cleaned as ``motionclean clean`` does (``steps``: a pipeline's tables
    instead of the default), read back from the written CSV: (F, C) degrees, NaN where
    the output is blank; and the capture source ``auto`` assumed, with its slope."""
    with tempfile.TemporaryDirectory() as folder:
        source, target = Path(folder) / "take.csv", Path(folder) / "clean.csv"
        page = Path(folder) / "report.json"
        write_channel_csv(source, times, x, names)
        pipeline = Pipeline.default() if steps is None else Pipeline.from_tables(steps, "bench")
        result = clean_file(source, target, pipeline, report=page)
        if result.status != "ok":
            raise SystemExit(f"{source}: {result.error}")
        header, values = read_csv(target)
        notes = [j["auto"] for j in json.loads(page.read_text())["joints"].values()]
    return np.stack([values[:, header.index(f"{n}.Zrotation")] for n in names], axis=1), found(
        notes
    )


def found(notes: list[dict]) -> str:
    """``model (slope)`` of auto's notes, e.g. ``markerless (-0.49)``."""
    rotations = [n for n in notes if "model" in n]
    if not rotations:
        return "-"
    slope = rotations[0].get("motion_slope")
    return rotations[0]["model"] + ("" if slope is None else f" ({slope:.2f})")


# ----------------------------------------------------------------------------- scores


def line_fill(x: np.ndarray) -> np.ndarray:
    """Each gap bridged by a straight line in unwrapped degrees; gaps at an end hold."""
    out = np.empty_like(x)
    frames = np.arange(x.shape[0])
    for c in range(x.shape[1]):
        known = ~np.isnan(x[:, c])
        values = np.unwrap(x[known, c], period=360.0)
        out[:, c] = np.interp(frames, frames[known], values)
    return out


def near(out: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``out`` moved by whole turns to within 180 degrees of ``ref``."""
    return ref + (out - ref + 180.0) % 360.0 - 180.0


def scores(x, out, y) -> dict:
    """AccErr (deg/frame^2), bias-removed RMSE (deg) and the filled samples' errors.

    As the take's ``score.py`` does: AccErr on the output unwrapped along time (whole turns
    between frames taken out; a blank output cell read as 0 first), the differences to the
    truth wrapped to within half a turn for the RMSE. (Moving each sample to within half a
    turn of the truth before differencing would add whole-turn steps wherever an estimate
    sits half a turn off its truth.)"""
    known = ~np.isnan(x)
    seen = np.unwrap(np.where(np.isnan(out), 0.0, out), period=360.0, axis=0)
    seen[~known] = np.nan
    acc = np.abs(np.diff(seen, 2, axis=0) - np.diff(y, 2, axis=0))
    out = near(out, y)
    diff = np.where(known, out - y, np.nan)
    bias = np.nanmean(diff, axis=0)
    filled = ~known & ~np.isnan(out)
    return {
        "acc": float(np.nanmean(acc)),
        "rmse": float(np.sqrt(np.nanmean((diff - bias) ** 2))),
        "filled": filled,
        "fill_sq": ((out - y - bias)[filled]) ** 2,
        "bias": bias,
    }


def butterworth(x: np.ndarray, cutoff: float, fps: float) -> np.ndarray:
    b, a = butter(2, cutoff / (fps / 2.0))
    return filtfilt(b, a, x, axis=0)


def hindsight(candidates, x, y) -> tuple[float, object]:
    """The least AccErr over ``(setting, output)`` candidates, and its setting."""
    best = (math.inf, None)
    for setting, out in candidates:
        acc = scores(x, out, y)["acc"]
        if acc < best[0]:
            best = (acc, setting)
    return best


def baselines(x, y, fps) -> dict:
    filled = line_fill(x)
    bw, cutoff = hindsight(((c, butterworth(filled, c, fps)) for c in BUTTER_CUTOFFS), x, y)
    euro, euro_at = hindsight(
        (((f, b), one_euro(filled, fps, f, b)) for f in EURO_MIN_CUTOFFS for b in EURO_BETAS),
        x,
        y,
    )
    sg, sg_at = hindsight(
        (
            ((w, d), savgol_filter(filled, w, d, axis=0))
            for w in SAVGOL_WINDOWS
            for d in (2, 3)
            if w < filled.shape[0]
        ),
        x,
        y,
    )
    return {
        "raw": scores(x, filled, y),
        "bw": bw,
        "cutoff": cutoff,
        "bw6": scores(x, butterworth(filled, 6.0, fps), y)["acc"],
        "euro": euro,
        "euro_at": euro_at,
        "savgol": sg,
        "savgol_at": sg_at,
    }


# ----------------------------------------------------------------------------- corpus


def _accelerations(q: np.ndarray) -> np.ndarray:
    """(F-2, J, 3) second differences of the angular displacements (rad per frame^2)."""
    w = 2.0 * quat.log(quat.multiply(quat.conjugate(q[:-1]), q[1:]))
    return np.diff(w, axis=0)


#: Clean captures: the corpus at these frame steps (120, 60, 30, 24 fps) ...
STEPS = (1, 2, 4, 5)
#: ... and the exporters' files and sample clips of the project.
CLEAN_FILES = (
    *sorted((ROOT / "tests" / "data" / "exporters").glob("*.bvh")),
    ROOT / "sample_data" / "131_02_cut.bvh",
)


def clean_clips():
    """``(label, Motion)`` of every clean capture checked (one-frame files left out)."""
    for clip in sorted(CORPUS.glob("*.bvh")):
        motion = mc.load(clip)
        for step in STEPS:
            yield (
                f"{clip.stem} at {round(1.0 / (motion.frame_time * step))} fps",
                motion.replace(
                    rotations=quat.make_continuous(motion.rotations[::step], axis=0),
                    translations=motion.translations[::step],
                    frame_time=motion.frame_time * step,
                    source_values=None,
                    source_rotations=None,
                ),
            )
    for path in CLEAN_FILES:
        motion = mc.load(path)
        if motion.n_frames > 1:
            yield f"{path.parent.name}/{path.name} at {round(1.0 / motion.frame_time)} fps", motion


def clean_rows() -> list[tuple]:
    rows = []
    for label, motion in clean_clips():
        cleaned, logs = Pipeline.default().run(motion)
        notes = [n["auto"] for log in logs for n in log.notes.values() if "auto" in n]
        cols = scored_joints(motion)
        q_in = quat.make_continuous(motion.rotations[:, cols], axis=0)
        q_out = quat.make_continuous(cleaned.rotations[:, cols], axis=0)
        a_in, a_out = _accelerations(q_in), _accelerations(q_out)
        acc = np.mean(np.linalg.norm(a_out - a_in, axis=-1)) / np.mean(
            np.linalg.norm(a_in, axis=-1)
        )
        change = np.degrees(quat.angle_between(q_in, q_out))
        rms = float(np.sqrt(np.mean(change**2)))
        rows.append((label, found(notes), rms, float(change.max()), 100.0 * acc))
    return rows


# ----------------------------------------------------------------------------- main


#: The default pipeline with the capture source given as video (``auto``'s ``source``).
VIDEO_STEPS = [
    dict(step, source="video") if step["filter"] == "auto" else step for step in DEFAULT_STEPS
]


def print_rmse_above(label: str, rows: list[tuple[str, float, float]]) -> None:
    """The takes whose bias-removed RMSE went up, ``(take, raw, out)`` rows."""
    worse = [(take, raw, out) for take, raw, out in rows if out > raw]
    print(
        f"{label}: "
        + (", ".join(f"{t} ({r:.4f} -> {o:.4f})" for t, r, o in worse) if worse else "none")
        + "."
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--takes", nargs="+", help="pipeline/task names, e.g. theia3d/gait")
    parser.add_argument(
        "--data",
        type=Path,
        default=DATA,
        help="a folder laid out as ../shared/realnoise (estimates/PIPELINE/*.csv, truth/): "
        "takes kept aside",
    )
    args = parser.parse_args(argv)
    if not (args.data / "estimates").is_dir():
        print(
            f"real-noise takes not found: {args.data} (expected ../shared/realnoise beside the "
            "project root); nothing to score",
            file=sys.stderr,
        )
        return 0
    start = time.perf_counter()
    print("# Real noise: markerless takes against their marker-based truth\n")
    print(
        "AccErr in deg/frame^2 (60 Hz); ratios are AccErr over the per-take hindsight-best "
        "zero-phase Butterworth (order 2, 2-15 Hz). RMSE: bias-removed, degrees.\n"
    )
    print(
        "| take | DOF | missing | source found (slope) | raw | best Butterworth (Hz) | 6 Hz | "
        "One Euro | Savitzky-Golay | **default** | default / best | RMSE raw | RMSE default | "
        "`--source video` / best | its RMSE |"
    )
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    ratios, video_ratios, by_pipeline, rmse_rows, smooth_rows = [], [], {}, [], []
    video_rmse_rows = []
    fill_default, fill_line = [], []
    for pipeline, task, estimate, truth in takes(args.data, args.takes):
        take = load_take(estimate, truth)
        if take is None:
            print(f"| {pipeline}/{task} | 0 | every coordinate half missing: not scored |")
            continue
        times, x, y, names = take
        fps = 1.0 / np.median(np.diff(times))
        base = baselines(x, y, fps)
        out, source = run_default(times, x, names)
        mine = scores(x, out, y)
        line = scores(x, line_fill(x), y)
        video = scores(x, run_default(times, x, names, VIDEO_STEPS)[0], y)
        ratio = mine["acc"] / base["bw"]
        ratios.append(ratio)
        video_ratios.append(video["acc"] / base["bw"])
        video_rmse_rows.append((f"{pipeline}/{task}", base["raw"]["rmse"], video["rmse"]))
        by_pipeline.setdefault(pipeline, []).append(ratio)
        rmse_rows.append((f"{pipeline}/{task}", base["raw"]["rmse"], mine["rmse"]))
        if pipeline == "theia-biorbd":
            smooth_rows.append(
                (task, mine["acc"] / base["raw"]["acc"], mine["rmse"] / base["raw"]["rmse"])
            )
        if mine["filled"].any():  # the straight line on the same samples, same bias
            fill_default.append(mine["fill_sq"])
            at = mine["filled"]
            fill_line.append(((near(line_fill(x), y) - y - mine["bias"])[at]) ** 2)
        print(
            f"| {pipeline}/{task} | {len(names)} | {np.isnan(x).mean():.1%} | {source} | "
            f"{base['raw']['acc']:.3f} | {base['bw']:.3f} ({base['cutoff']:g}) | "
            f"{base['bw6']:.3f} | {base['euro']:.3f} | {base['savgol']:.3f} | "
            f"**{mine['acc']:.3f}** | {ratio:.2f} | {base['raw']['rmse']:.2f} | "
            f"{mine['rmse']:.2f} | {video_ratios[-1]:.2f} | {video['rmse']:.2f} |",
            flush=True,
        )
        del line
    ratios = np.array(ratios)
    print(
        f"\nDefault / best Butterworth: median {np.median(ratios):.2f}, worst "
        f"{ratios.max():.2f} over {ratios.size} takes (target: median <= 1.15, worst <= 1.5)."
    )
    for pipeline, values in by_pipeline.items():
        print(f"  {pipeline}: median {np.median(values):.2f}, worst {max(values):.2f}")
    print_rmse_above("RMSE above the raw input's", rmse_rows)
    video_ratios = np.array(video_ratios)
    print(
        f"\nWith the capture source given (`--source video`, the default's steps otherwise): "
        f"median {np.median(video_ratios):.2f}, worst {video_ratios.max():.2f}."
    )
    print_rmse_above("Its RMSE above the raw input's", video_rmse_rows)
    if smooth_rows:
        print("\nAlready smooth (theia-biorbd), default / input (target: within 2 %):\n")
        print("| task | AccErr | RMSE |\n|---|---:|---:|")
        for task, acc, rmse in smooth_rows:
            print(f"| {task} | {acc:.3f} | {rmse:.3f} |")
    if fill_default:
        mine_fill = math.sqrt(np.mean(np.concatenate(fill_default)))
        line_rms = math.sqrt(np.mean(np.concatenate(fill_line)))
        count = sum(part.size for part in fill_default)
        print(
            f"\nFilled dropouts ({count} samples): RMS error {mine_fill:.2f} deg, straight "
            f"line {line_rms:.2f} deg (ratio {mine_fill / line_rms:.2f}; target <= 1)."
        )
    if CORPUS.is_dir() and not args.takes:
        print("\nClean captures through the default, each its own truth (targets: rotation")
        print("change under 0.3 deg RMS, acceleration change under 2 %):\n")
        print(
            "| clip | source found (slope) | RMS change (deg) | largest (deg) | "
            "acceleration change |"
        )
        print("|---|---|---:|---:|---:|")
        rows = clean_rows()
        for label, source, rms, largest, acc in rows:
            print(f"| {label} | {source} | {rms:.3f} | {largest:.2f} | {acc:.1f} % |")
        worst = max(rows, key=lambda r: r[2])
        print(
            f"\nLargest RMS change {worst[2]:.3f} deg ({worst[0]}); acceleration change "
            f"{min(r[4] for r in rows):.1f}-{max(r[4] for r in rows):.1f} %; taken for markerless: "
            f"{sum(r[1].startswith('markerless') for r in rows)} of {len(rows)}."
        )
    print(f"\nBenchmark time: {time.perf_counter() - start:.0f} s.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
