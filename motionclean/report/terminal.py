"""The terminal's report: the per-joint table, and the lines on the noise model, the takes,
the rest frames, the repairs and each step's notes (``motionclean clean`` and ``report``
print them; the HTML page reuses the lines)."""

from __future__ import annotations

import json
import math
from collections import Counter
from typing import Any

from ..core.words import columns, length_word, pad, plural
from ..filters.auto import NEGLIGIBLE_DEG, describe_source, noted_slope
from ..steps import REGISTRY
from ..steps.base import brief_runs as summarised_runs
from ..steps.base import format_params, fps_text, held_at_mean
from .summary import (
    joint_count,
    json_safe,
    median_joint,
    noisiest,
    repaired_joints,
    resampled_to,
    translations,
    was_cleaned,
)
from .world import (
    format_contacts,
    format_world,
)

__all__ = ["figure_text", "format_table", "note_text"]


def figure_text(value: float | None, width: int, spec: str) -> str:
    """``value`` formatted by ``spec`` ("-" where nothing was measured: None or NaN),
    right-aligned in ``width`` characters."""
    unknown = value is None or math.isnan(value)
    return f"{'-' if unknown else format(value, spec):>{width}}"


#: Widest joint name the terminal table prints in full (characters); the column is as wide
#: as the longest name it lists, at least 21 characters.
NAME_WIDTH = 40


def short_name(name: str, width: int = NAME_WIDTH) -> str:
    """``name`` in at most ``width`` characters: a longer one keeps its start and its end,
    where names of one rig differ (``...LeftHandIndex1``, ``...Index2``), "..." between."""
    if len(name) <= width:
        return name
    end = (width - 3) // 2
    return f"{name[: width - 3 - end]}...{name[-end:]}"


def short_names(names: list[str], width: int = NAME_WIDTH) -> dict[str, str]:
    """Each of ``names`` as a table prints it: :func:`short_name`, or whole where another
    of them would print alike (names that differ only in the middle)."""
    shown = {name: short_name(name, width) for name in names}
    counts = Counter(shown.values())
    return {name: name if counts[short] > 1 else short for name, short in shown.items()}


def format_table(report: dict, limit: int = 10) -> str:
    """A readable table: the ``limit`` noisiest joints, then the totals."""
    cleaned = was_cleaned(report)
    estimated = any("auto" in entry for entry in report["joints"].values())
    names = noisiest(report)
    # (the rows count joints: the count is told where translations are not among them)
    counted = f", {joint_count(report)}" if translations(report) else ""
    shown = short_names(names[:limit])
    width = max([21, *map(columns, shown.values())]) + 1
    head = f"{'joint':<{width}}{'accel rms':>14}"
    if cleaned:
        head += f"{'after':>14}{'removed':>9}{'dev max':>9}"
    if estimated:
        head += f"{'noise est':>10}  filter chosen"
    lines = [
        f"{report['file']}: {report['frames']} frames at "
        f"{fps_text(report['frame_time'])} fps{resampled_to(report)}{counted}, numbered from 0 "
        "(angular acceleration in deg/s^2; deviation and estimated noise in deg)",
        head,
        "-" * len(head),
    ]

    def row(name: str, acc: dict, dev: float | None, auto: dict | None = None) -> str:
        before, after = acc["before"], acc["after"]
        text = pad(shown.get(name, name), width) + figure_text(before, 14, ",.0f")
        if cleaned:
            removed = None
            if before is not None and after is not None:
                removed = 1.0 - after / before if before > 0 else 0.0
            text += figure_text(after, 14, ",.0f") + figure_text(removed, 9, ".0%")
            text += figure_text(dev, 9, ".2f")
        if auto:
            shown_filter = (
                "held at its mean" if held_at_mean(auto) else format_params(auto["filter"])
            )
            text += f"{figure_text(auto['noise'], 10, '.2f')}  {shown_filter}"
        return text

    for name in names[:limit]:
        entry = report["joints"][name]
        dev = entry.get("deviation_deg", {}).get("max")
        lines.append(row(name, entry["angular_accel_rms"], dev, entry.get("auto")))
    if len(names) > limit:
        lines.append(f"... {len(names) - limit} more joints")
    lines.append("-" * len(head))
    summary = report["summary"]
    lines.append(row("all joints", summary["angular_accel_rms"], summary.get("deviation_deg_max")))
    if cleaned and repaired_joints(report):
        lines.append(
            "(figures with repairs included; the verdict's jitter and largest change leave "
            "them out)"
        )
    model = format_noise_model(report)
    if model:
        lines.append(model)
    rest = report.get("rest_frames") or {}
    if rest.get("leading") or rest.get("trailing"):
        lines.append(format_rest(rest, report["frames"]))
    if report.get("take_starts"):
        lines.append(format_takes(report["take_starts"], cleaned))
    lines.extend(f"note: {note}" for note in report.get("notes", ()))
    unit = length_word(report.get("length_unit"))
    if "world" in report:
        lines.append(format_world(report["world"], unit))
    if report.get("contacts"):
        lines.extend(format_contacts(report["contacts"], report["joints"], unit))
    lines.extend(format_repairs(report))
    if report.get("verdict"):
        lines.append(f"verdict: {report['verdict']['text']}")
    return "\n".join(lines)


def format_noise_model(report: dict) -> str:
    """Which capture system auto assumed and why (found from the clip, or given), and with
    the markerless model how much of the noise it found below the motion's top frequencies;
    without auto's notes, the report's ``capture_source`` (the ``report`` command's, whose
    ``wander`` is already the median joint's), read the same way into the same line; ""
    when there is neither."""
    notes = [e["auto"] for e in report["joints"].values() if "source" in e.get("auto", {})]
    if not notes and "capture_source" not in report:
        return ""
    first = notes[0] if notes else report["capture_source"]
    slope = noted_slope(first)
    seconds = report.get("frames", 0) * report.get("frame_time", 0.0)
    said = describe_source(first["model"], first["source"], slope, seconds or None)
    line = f"capture source: {said}"
    # (the moving joints': a video estimate's 150 still fingers and face joints had made the
    # median joint's wander none where the moving joints' is 5-12 degrees)
    wander = [
        n
        for n in (notes or [first])
        if n.get("model") == "markerless" and n.get("wander") is not None and not n.get("still")
    ]
    if not wander:
        return line
    edges = {n.get("wander_edge_hz") for n in wander}
    edge = edges.pop() if len(edges) == 1 else None
    below = "" if edge is None else f" below {edge:g} Hz"
    level = median_joint([n["wander"] for n in wander])
    hint = (
        " For an optical or inertial capture: --source optical or --source inertial."
        if first["source"] == "auto"
        else ""
    )
    found = (
        f"The noise wanders{below}, down where the motion is (median moving joint {level:.3g} deg)"
        if level >= NEGLIGIBLE_DEG
        else "No noise wandering among the motion's frequencies was found in the median "
        "moving joint"
    )
    each = "each joint gets the one filter of least expected error over the clip"
    return f"{line}. {found}; {each}.{hint}"


#: Cuts between takes a line names at most (the JSON's ``take_starts`` holds them all).
TAKES_NAMED = 8


def format_takes(starts: list[int], cleaned: bool = True) -> str:
    """The takes joined end to end in the clip (``cleaned``: each on its own); the first
    :data:`TAKES_NAMED` cuts named, so the line stays short on a clip of thousands."""
    if len(starts) > TAKES_NAMED:
        at = ", ".join(map(str, starts[: TAKES_NAMED - 1])) + f", ... {starts[-1]}"
    else:
        at = ", ".join(map(str, starts[:-1])) + (" and " if len(starts) > 1 else "")
        at += str(starts[-1])
    new = f"new ones at frames {at}" if len(starts) > 1 else f"the second at frame {at}"
    own = "each cleaned on its own, " if cleaned else ""
    return (
        f"takes: {len(starts) + 1} joined end to end, {new} (most joints jump at once): "
        f"{own}the steps across the cuts left out of the figures"
    )


def format_rest(rest: dict, frames: int) -> str:
    """The rest-pose frames left out of every step and every figure."""
    spans = []
    if rest["leading"]:
        spans.append((0, rest["leading"] - 1))
    if rest["trailing"]:
        spans.append((frames - rest["trailing"], frames - 1))
    parts = [f"{a}-{b}" if b > a else f"{a}" for a, b in spans]
    one = len(spans) == 1 and spans[0][0] == spans[0][1]
    return (
        f"rest pose: {'frame' if one else 'frames'} {' and '.join(parts)} kept as "
        f"{'it is' if one else 'they are'} and left out of the figures (a pose held before or "
        "after the motion)"
    )


def note_text(key: str, note: Any, brief: bool = False) -> str:
    """One readable line for a step's per-joint note (key ``despike``, ``position_auto``, ...):
    the step's own ``format_note`` (``format_brief`` when ``brief`` and it has one), or the
    note as JSON."""
    positions = key.startswith("position_")
    spec = REGISTRY.get(key.removeprefix("position_"))
    if spec is not None:
        formatter = (brief and spec.format_brief) or spec.format_note
        if formatter is not None:
            return formatter(note, positions)
    return json.dumps(json_safe(note))


#: Longest terminal line the repair list prints (characters).
LINE_LIMIT = 199


def format_repairs(report: dict, limit: int = 10) -> list[str]:
    """One line per joint a repairing step (despike) changed, at most ``limit`` joints: how,
    where (long frame lists summarised; the JSON report keeps them whole, the page names more),
    largest step. Lines are cut at :data:`LINE_LIMIT` characters."""
    keys = [
        prefix + name
        for name, spec in REGISTRY.items()
        if spec.lists_repairs
        for prefix in ("", "position_")
    ]
    lines = []
    repaired = repaired_joints(report)  # (the others' notes are dropouts found, none filled)
    for name, entry in report["joints"].items():
        texts = {key: note_text(key, entry[key], brief=True) for key in keys if entry.get(key)}
        lone = (entry.get("auto") or {}).get("outliers")
        if lone:  # (auto's repairs: its other notes are no repairs)
            texts["auto"] = f"took out {plural(len(lone), 'lone outlier')}: {summarised_runs(lone)}"
        if not texts:
            continue
        word = "repaired" if name in repaired else "dropouts"
        if len(texts) == 1:
            key, text = next(iter(texts.items()))
            line = f"{word} {name}{' (positions)' if key.startswith('position_') else ''}: {text}"
        else:
            line = f"{word} {name}: " + " | ".join(
                ("positions: " if key.startswith("position_") else "") + text
                for key, text in texts.items()
            )
        lines.append(line if len(line) <= LINE_LIMIT else line[: LINE_LIMIT - 3] + "...")
    if len(lines) > limit:
        lines[limit:] = [f"... {len(lines) - limit} more joints (full list in the report)"]
    return lines
