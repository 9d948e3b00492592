"""The verdict: one line in plain words on what a clip was and what cleaning did to it.

It is read off the report's figures, with repairs (flips and spikes un-done by ``despike``,
gaps bridged by ``fill-gaps``) kept apart from smoothing: a repaired half-turn flip changes
a joint by 180 degrees on purpose, so "largest change" and "jitter removed" are measured
outside the repaired frames. The same line is printed under the terminal table, leads the
HTML page and fills the batch index's verdict column; the JSON report carries it as
``verdict`` with the figures it was read from.

Statuses, first that applies (thresholds below, documented in the README):

- ``input only``: a clip reported on its own, nothing cleaned.
- ``needs a look``: a gap left missing (longer than ``max_gap``), smoothing that moved a
  joint more than :data:`LOOK_CHANGE_DEG` outside repairs (fast motion taken for noise?),
  a joint repaired on more than :data:`LOOK_REPAIRED_SHARE` of its frames (which pose is the
  flipped one?), or feet sliding faster than :data:`LOOK_SKATE` body heights per second.
- ``clean``: smoothing changed the clip by less than :data:`CLEAN_CHANGE_DEG` RMS and
  nothing was repaired; ``repaired``: the same, with repairs.
- ``cleaned``: a noisy capture, smoothed (and repaired, if it says so).
- ``not smoothed``: the pipeline has no smoothing step (only steps of
  :data:`NOT_SMOOTHING`) and repaired nothing: what it planted or moved is told, the noise
  is not judged (with repairs the status is ``repaired``, the line led by "not smoothed").
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..filters.auto import MIN_FRAMES
from ..steps import REGISTRY
from ..steps.base import format_runs, plural

__all__ = [
    "CLEAN_CHANGE_DEG",
    "LOOK_CHANGE_DEG",
    "LOOK_REPAIRED_SHARE",
    "LOOK_SKATE",
    "NOT_SMOOTHING",
    "PLANTED_SKATE",
    "build_verdict",
    "repaired_frames",
]

#: Smoothing that changes a clip by less than this RMS angle (degrees, outside repairs)
#: left it as it was: a clean capture (the default moves clean 120 fps captures by about
#: 0.01 degrees RMS, noisy ones by tenths of a degree and more).
CLEAN_CHANGE_DEG = 0.05
#: A largest change below this many degrees is the rounding of the conversions: nothing
#: moved, and no joint is named for it.
UNCHANGED_DEG = 1e-6
#: A clip the ``ground`` step moved and whose jitter fell by less than this fraction was
#: only put on the floor: its root's levelling turn is not smoothing.
GROUNDED_JITTER = 0.01
#: Smoothing that moves any joint by more than this (degrees, outside repairs) needs a look.
LOOK_CHANGE_DEG = 10.0
#: A joint repaired on more than this share of its frames needs a look.
LOOK_REPAIRED_SHARE = 0.5
#: Feet whose ankles slide no faster than this during contacts (body heights per second,
#: after cleaning) are planted; ``footlock``'s own threshold.
PLANTED_SKATE = 0.1
#: Feet sliding faster than this after cleaning need a look (``footlock`` holds them).
LOOK_SKATE = 0.5
#: Steps that repair, plant, put on the floor or resample a clip without smoothing it: a
#: pipeline of these alone gets no noise judgement (``StepSpec.smooths``).
NOT_SMOOTHING = frozenset(name for name, spec in REGISTRY.items() if not spec.smooths)


def _runs(note: dict, key: str) -> list[list[int]]:
    return [list(r) for r in note.get(key) or []]


def repaired_frames(joints: dict[str, dict], n_frames: int) -> dict[str, np.ndarray]:
    """Per joint whose rotations a repairing step changed, the ``(n_frames,)`` mask of the
    frames it repaired: ``despike``'s un-flipped and interpolated runs and ``fill-gaps``'
    filled gaps (``[start, stop)`` file frames, from the joints' report notes)."""
    masks = {}
    for name, entry in joints.items():
        runs = _runs(entry.get("despike") or {}, "unflipped")
        runs += _runs(entry.get("despike") or {}, "interpolated")
        runs += _runs(entry.get("fill-gaps") or {}, "filled")
        if not runs:
            continue
        mask = np.zeros(n_frames, dtype=bool)
        for start, stop in runs:
            mask[max(start, 0) : max(stop, 0)] = True
        masks[name] = mask
    return masks


def _repairs(joints: dict[str, dict]) -> dict[str, dict[str, int]]:
    """Per joint with a repair: flips, spikes, gaps filled and left, frames repaired."""
    found = {}
    for name, entry in joints.items():
        despike = entry.get("despike") or {}
        gaps = entry.get("fill-gaps") or {}
        counts = {
            "flips": len(_runs(despike, "unflipped")),
            "spikes": len(_runs(despike, "interpolated")),
            "gaps_filled": len(_runs(gaps, "filled")),
            "gaps_left": len(_runs(gaps, "missing")),
        }
        if any(counts.values()):
            frames = int(despike.get("frames_repaired", 0))
            frames += sum(b - a for a, b in _runs(gaps, "filled"))
            found[name] = counts | {"frames": frames}
    return found


def _plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _names(names: list[str], limit: int = 2) -> str:
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


def _repair_words(repairs: dict[str, dict[str, int]]) -> list[str]:
    """ "2 flips repaired on RThumb", "3 gaps filled on LeftWrist, Head": one phrase per kind."""
    words = []
    for key, noun, verb in (
        ("flips", "flip", "repaired"),
        ("spikes", "spike", "repaired"),
        ("gaps_filled", "gap", "filled"),
    ):
        where = [name for name, counts in repairs.items() if counts[key]]
        if where:
            total = sum(repairs[name][key] for name in where)
            words.append(f"{_plural(total, noun)} {verb} on {_names(where)}")
    return words


def _feet(contacts: dict | None) -> tuple[str | None, float | None]:
    """ "feet planted" or "feet slide 0.20 body heights/s" after cleaning, and the fastest
    foot's skate (body heights per second); None without feet in contact."""
    feet = (contacts or {}).get("feet") or {}
    skates = [
        foot["skate_body_heights"]["after"]
        for foot in feet.values()
        if foot.get("contacts") and foot["skate_body_heights"].get("after") is not None
    ]
    skates = [s for s in skates if math.isfinite(s)]
    if not skates:
        return None, None
    fastest = max(skates)
    if fastest <= PLANTED_SKATE:
        return "feet planted", fastest
    return f"feet slide {fastest:.2f} body heights/s", fastest


def _ground_words(joints: dict[str, dict]) -> list[str]:
    """ "put on the floor: 1.06 units down, levelled from 0.67 deg": what the ``ground`` step
    did to the whole clip (its note on the root's positions)."""
    words = []
    for entry in joints.values():
        note = entry.get("position_ground")
        if note:
            height = note["height"]
            way = "down" if height > 0 else "up"
            text = f"put on the floor: {abs(height):.3g} units {way}"
            if note.get("levelled", True) and note["tilt_deg"] > 0:
                text += f", levelled from {note['tilt_deg']:.2f} deg"
            words.append(text)
    return words


def _removed_words(fraction: float) -> str:
    """ "86 % of the jitter removed", "no jitter removed" (under half a percent either way) or
    "jitter up 3 %"."""
    if fraction >= 0.005:
        return f"{fraction:.0%} of the jitter removed".replace("%", " %")
    if fraction > -0.005:
        return "no jitter removed"
    return f"jitter up {-fraction:.0%}".replace("%", " %")


def _missing_words(joints: dict[str, dict]) -> list[str]:
    """ "NAME missing on frames ..." per set of runs left missing, the joints that share
    one named together (three at most, then how many more)."""
    by_runs: dict[str, list[str]] = {}
    for name, entry in joints.items():
        runs = _runs(entry.get("fill-gaps") or {}, "missing")
        if runs:
            more = f" and {len(runs) - 3} more" if len(runs) > 3 else ""
            by_runs.setdefault(f"{format_runs(runs[:3])}{more}", []).append(name)
    words = []
    for spans, names in by_runs.items():
        who = ", ".join(names[:3])
        if len(names) > 3:
            who += f" and {plural(len(names) - 3, 'more joint')}"
        words.append(f"{who} missing on frames {spans}")
    return words


def build_verdict(report: dict, smoothing: dict | None) -> dict[str, Any]:
    """The verdict of a report (:func:`motionclean.report.summary.build_report`'s dict, before
    its ``verdict`` key): ``status``, ``text`` and the figures behind them.

    ``smoothing`` holds the figures outside repairs (None for a clip reported on its own):
    ``noise_before`` and ``noise_after`` (RMS angular acceleration, deg/s^2),
    ``noise_removed`` (the fraction of it removed), ``change_deg_max`` and
    ``change_deg_rms`` (rotation angle between input and output, degrees) and
    ``change_joint`` (where the largest change is).
    """
    joints = report["joints"]
    if smoothing is None:
        noise = report["summary"]["angular_accel_rms"]["before"]
        measured = (
            "no noise measured (no three frames in a row known)"
            if noise is None
            else f"noise {noise:,.0f} deg/s\u00b2 RMS angular acceleration"
        )
        return {"status": "input only", "text": f"input only, not cleaned: {measured}"}
    repairs = _repairs(joints)
    feet, skate = _feet(report.get("contacts"))
    reasons = _missing_words(joints)
    change, joint = smoothing["change_deg_max"], smoothing["change_joint"]
    filters = [step.get("filter") for step in report.get("pipeline") or []]
    rest = report.get("rest_frames") or {}
    motion_frames = int(report["frames"]) - rest.get("leading", 0) - rest.get("trailing", 0)
    too_short = motion_frames < MIN_FRAMES  # no step can tell noise in so few frames
    unmeasured = smoothing["noise_removed"] is None  # no three frames in a row known
    smoothed = (
        not too_short
        and not unmeasured
        and (not filters or any(n not in NOT_SMOOTHING for n in filters))
    )
    if change > LOOK_CHANGE_DEG:
        what = "smoothing moved" if filters and smoothed else "the cleaning moved"
        reasons.append(f"{what} {joint} by {change:.1f} degrees")
    frames = max(int(report["frames"]), 1)
    for name, counts in repairs.items():
        if counts["frames"] > LOOK_REPAIRED_SHARE * frames:
            reasons.append(f"{name} repaired on {counts['frames'] / frames:.0%} of its frames")
    if skate is not None and skate > LOOK_SKATE:
        hint = "" if "footlock" in filters else " (footlock holds them)"
        reasons.append(f"feet slide {skate:.2f} body heights/s{hint}")
    done = _repair_words(repairs)
    grounded = _ground_words(joints)
    # a clip only put on the floor (levelling turns the root) removed no jitter: still clean
    clean = smoothing["change_deg_rms"] < CLEAN_CHANGE_DEG or bool(
        grounded and not unmeasured and smoothing["noise_removed"] < GROUNDED_JITTER
    )
    removed = "" if unmeasured else _removed_words(smoothing["noise_removed"])
    looking = skate is not None and skate > LOOK_SKATE  # (the feet said among the reasons)
    shown_feet = None if looking else feet
    if not smoothed:
        parts = done + grounded
        if too_short:
            parts.insert(0, f"too short to judge ({plural(motion_frames, 'frame')})")
        elif unmeasured:
            parts.insert(0, "no noise to judge (no three frames in a row known)")
        if not feet and "footlock" in filters:
            parts.append("no foot in contact found, nothing planted")
        if not parts and not shown_feet:
            parts.append("nothing repaired")
        lead = "not smoothed"
    elif clean:
        parts = done + grounded
        # (below CLEAN_CHANGE_DEG RMS, its largest change may still be a few tenths)
        left = "left as it was" if change < CLEAN_CHANGE_DEG else "barely moved"
        parts.append(f"otherwise {left}" if parts else left)
        lead = "clean capture, repaired" if done else "clean capture"
    else:
        parts = [removed] + done + grounded
        lead = "noisy capture, cleaned"
    if shown_feet:
        parts.append(shown_feet)
    # without the pipeline (two clips compared as given) no step says what it repaired
    where = (
        " outside repairs"
        if report.get("pipeline")
        else " (steps not recorded: repairs not told apart)"
    )
    tail = f"largest change {change:.1f} degrees{where}"
    if change < 0.05:
        tail = f"largest change {change:.2g} degrees{where}"
    if change < UNCHANGED_DEG:
        tail = f"no rotation changed{where}"
    text = f"{lead}: {', '.join(parts)}; {tail}"
    status = "repaired" if clean and done else "clean" if clean else "cleaned"
    if not smoothed:
        status = "repaired" if done else "not smoothed"
    if reasons:
        status = "needs a look"
        text = f"needs a look: {'; '.join(reasons)}. {lead[0].upper()}{lead[1:]}: " + (
            f"{', '.join(parts)}; {tail}"
        )
    return {
        "status": status,
        "text": text,
        "noise_before": smoothing.get("noise_before"),
        "noise_after": smoothing.get("noise_after"),
        "noise_removed": smoothing["noise_removed"],
        "change_deg_max": change,
        "change_deg_rms": smoothing["change_deg_rms"],
        "change_joint": joint if change >= UNCHANGED_DEG else None,
        "repairs": repairs,
        "feet": feet,
    }
