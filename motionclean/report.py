"""Reports: per-joint noise and deviation figures as JSON and as a terminal table.

The JSON schema is the one in DESIGN.md ("Report contract"). Joints with rotation channels
get angular figures (degrees of rotation per s^2, degrees); joints with position channels
get ``linear_accel_rms`` / ``linear_accel_max`` (length units per s^2) and
``deviation_length`` (length units). ``summary.noise_reduction`` is the fraction of the
RMS angular acceleration removed, ``1 - after / before``.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from . import metrics
from .motion import Motion

__all__ = ["build_report", "build_series", "format_table", "to_json"]


def _pair(before: float, after: float | None) -> dict:
    return {"before": float(before), "after": None if after is None else float(after)}


def _stats(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint RMS and max over axis 0 of ``(N, J)`` figures (zeros when N = 0)."""
    if values.shape[0] == 0:
        zeros = np.zeros(values.shape[1:])
        return zeros, zeros
    return metrics.rms(values), np.max(values, axis=0)


def build_series(before: Motion, after: Motion | None = None) -> dict[str, Any]:
    """Per-frame figures behind the report, per joint with rotation channels.

    Returns ``{"frame_time": dt, "joints": {name: {"accel_before": (F-2,),
    "accel_after": (F-2,) or None, "deviation": (F,) or None}}}``: angular acceleration
    magnitude in degrees of rotation per s^2 at frames 1..F-2 (000 Sec. VI-B) and the
    rotation angle between input and output in degrees at every frame. The HTML report
    plots them; the JSON report keeps only their RMS and maximum.
    """
    dt = before.frame_time
    rot = np.flatnonzero(before.layout.has_rotation)
    acc_b = metrics.angular_acceleration(before.rotations[:, rot], dt)
    acc_a = dev = None
    if after is not None:
        acc_a = metrics.angular_acceleration(after.rotations[:, rot], dt)
        dev = metrics.deviation_deg(before.rotations[:, rot], after.rotations[:, rot])
    joints = {}
    for n, j in enumerate(rot):
        joints[before.names[j]] = {
            "accel_before": acc_b[:, n],
            "accel_after": None if acc_a is None else acc_a[:, n],
            "deviation": None if dev is None else dev[:, n],
        }
    return {"frame_time": dt, "joints": joints}


def _stacked(series: dict, key: str, length: int) -> np.ndarray:
    """``(length, R)`` array of one figure of every joint in ``series``."""
    columns = [data[key] for data in series["joints"].values()]
    return np.stack(columns, axis=-1) if columns else np.zeros((length, 0))


def build_report(
    before: Motion,
    after: Motion | None = None,
    pipeline: list[dict] | None = None,
    notes: dict[str, dict] | None = None,
    file: str | None = None,
    series: dict | None = None,
) -> dict[str, Any]:
    """Figures for ``before`` alone, or before/after a cleaning when ``after`` is given.

    ``series`` is :func:`build_series` of the same clips when the caller already has it.
    """
    layout = before.layout
    dt = before.frame_time
    rot = np.flatnonzero(layout.has_rotation)
    pos = np.flatnonzero(layout.has_position)
    series = build_series(before, after) if series is None else series
    n_acc = max(before.n_frames - 2, 0)
    acc_b = _stacked(series, "accel_before", n_acc)
    rms_b, max_b = _stats(acc_b)
    lin_b = metrics.linear_acceleration(before.translations[:, pos], dt)
    lrms_b, lmax_b = _stats(lin_b)
    if after is not None:
        acc_a = _stacked(series, "accel_after", n_acc)
        rms_a, max_a = _stats(acc_a)
        dev = _stacked(series, "deviation", before.n_frames)
        dev_rms, dev_max = _stats(dev)
        lin_a = metrics.linear_acceleration(after.translations[:, pos], dt)
        lrms_a, lmax_a = _stats(lin_a)
        ldev = np.linalg.norm(after.translations[:, pos] - before.translations[:, pos], axis=-1)
        ldev_rms, ldev_max = _stats(ldev)

    joints: dict[str, dict] = {}
    for n, j in enumerate(rot):
        entry = joints.setdefault(before.names[j], {})
        a = after is not None
        entry["angular_accel_rms"] = _pair(rms_b[n], rms_a[n] if a else None)
        entry["angular_accel_max"] = _pair(max_b[n], max_a[n] if a else None)
        if a:
            entry["deviation_deg"] = {"rms": float(dev_rms[n]), "max": float(dev_max[n])}
    for n, j in enumerate(pos):
        entry = joints.setdefault(before.names[j], {})
        a = after is not None
        entry["linear_accel_rms"] = _pair(lrms_b[n], lrms_a[n] if a else None)
        entry["linear_accel_max"] = _pair(lmax_b[n], lmax_a[n] if a else None)
        if a:
            entry["deviation_length"] = {"rms": float(ldev_rms[n]), "max": float(ldev_max[n])}
    for name, note in (notes or {}).items():
        joints.setdefault(name, {}).update(note)

    total_b = float(metrics.rms(acc_b.ravel())) if acc_b.size else 0.0
    summary: dict[str, Any] = {
        "angular_accel_rms": _pair(total_b, None),
        "noise_reduction": None,
        "deviation_deg_max": None,
    }
    if after is not None:
        total_a = float(metrics.rms(acc_a.ravel())) if acc_a.size else 0.0
        summary["angular_accel_rms"]["after"] = total_a
        summary["noise_reduction"] = 1.0 - total_a / total_b if total_b > 0 else 0.0
        summary["deviation_deg_max"] = float(dev_max.max()) if dev_max.size else 0.0
    return {
        "file": file if file is not None else before.path,
        "frames": before.n_frames,
        "frame_time": before.frame_time,
        "pipeline": pipeline or [],
        "joints": joints,
        "summary": summary,
    }


def json_safe(value: Any) -> Any:
    """Non-finite numbers as the strings ``"inf"``, ``"-inf"``, ``"nan"`` (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return value


def to_json(report: dict) -> bytes:
    """UTF-8 JSON text, indented, strict (no ``Infinity`` / ``NaN`` tokens)."""
    return (json.dumps(json_safe(report), indent=2, allow_nan=False) + "\n").encode("utf-8")


def noisiest(report: dict) -> list[str]:
    """Joint names with angular figures, noisiest (largest RMS acceleration before) first."""
    rows = [
        (v["angular_accel_rms"]["before"], k)
        for k, v in report["joints"].items()
        if "angular_accel_rms" in v
    ]
    return [name for _, name in sorted(rows, key=lambda r: -r[0])]


def format_table(report: dict, limit: int = 10) -> str:
    """A readable table: the ``limit`` noisiest joints, then the totals."""
    cleaned = report["summary"].get("noise_reduction") is not None
    estimated = any("auto" in entry for entry in report["joints"].values())
    head = f"{'joint':<22}{'accel rms':>14}"
    if cleaned:
        head += f"{'after':>14}{'removed':>9}{'dev max':>9}"
    if estimated:
        head += f"{'noise est':>10}  filter chosen"
    lines = [
        f"{report['file']}: {report['frames']} frames at "
        f"{1.0 / report['frame_time']:.4g} fps (angular acceleration in deg/s^2; "
        "deviation and estimated noise in deg)",
        head,
        "-" * len(head),
    ]

    def row(name: str, acc: dict, dev: float | None, auto: dict | None = None) -> str:
        text = f"{name[:21]:<22}{acc['before']:>14,.0f}"
        if cleaned:
            removed = 1.0 - acc["after"] / acc["before"] if acc["before"] > 0 else 0.0
            text += f"{acc['after']:>14,.0f}{removed:>9.0%}{dev:>9.2f}"
        if auto:
            chosen = ", ".join(
                f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                for k, v in auto["filter"].items()
            )
            text += f"{auto['noise']:>10.2f}  {chosen}"
        return text

    names = noisiest(report)
    for name in names[:limit]:
        entry = report["joints"][name]
        dev = entry.get("deviation_deg", {}).get("max")
        lines.append(row(name, entry["angular_accel_rms"], dev, entry.get("auto")))
    if len(names) > limit:
        lines.append(f"... {len(names) - limit} more joints")
    lines.append("-" * len(head))
    summary = report["summary"]
    lines.append(row("all joints", summary["angular_accel_rms"], summary.get("deviation_deg_max")))
    lines.extend(format_repairs(report))
    return "\n".join(lines)


def _ranges(runs: list[list[int]]) -> str:
    """``[[198, 202], [214, 221]]`` (stop exclusive) -> ``"198-201, 214-220"``."""
    return ", ".join(f"{a}-{b - 1}" if b - a > 1 else f"{a}" for a, b in runs)


def note_text(key: str, note: Any) -> str:
    """One readable line for a step's per-joint note (``despike``, ``auto``, ...)."""
    if key.endswith("despike"):
        unit = "units" if key.startswith("position") else "deg"
        parts = [f"{note['frames_repaired']} frames repaired"]
        if note.get("unflipped"):
            parts.append(f"un-flipped {_ranges(note['unflipped'])}")
        if note["interpolated"]:
            parts.append(f"interpolated {_ranges(note['interpolated'])}")
        step = note["max_step"]
        parts.append(f"largest step {step['before']:.1f} -> {step['after']:.1f} {unit}")
        return "; ".join(parts)
    if key.endswith("auto"):
        unit = "deg" if note["unit"] == "deg" else "units"
        chosen = ", ".join(
            f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in note["filter"].items()
        )
        error = note["expected_error"]
        error = f"{error:.3g}" if error >= 0.01 else "< 0.01"  # SURE is rough near zero
        return (
            f"estimated noise {note['noise']:.3g} {unit}; chose {chosen}; "
            f"expected error {error} {unit}"
        )
    return json.dumps(json_safe(note))


def format_repairs(report: dict) -> list[str]:
    """Lines naming each joint the despike step repaired: how, where, largest step."""
    return [
        f"repaired {name}{' (positions)' if key.startswith('position') else ''}: "
        + note_text(key, entry[key])
        for name, entry in report["joints"].items()
        for key in ("despike", "position_despike")
        if entry.get(key)
    ]
