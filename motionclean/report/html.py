"""HTML reports: one self-contained page per clip, and an index page for a batch run.

A page holds everything inline (CSS, SVG plots); it loads no script, font, image or
stylesheet and links nowhere outside itself except, on the index page, to the sibling
clip pages by relative path. It shows the pipeline, the summary figures, a table of every
joint (noisiest first) and, per joint, the magnitude of angular acceleration over time
before and after cleaning (as in Fig. 5 of 000) with the deviation from the input below it.

The figures come from :func:`motionclean.report.summary.build_report`; the time series, which the
JSON report leaves out, from :func:`motionclean.report.summary.build_series`, already reduced to a
min/max envelope per plot column (:mod:`motionclean.report.traces`), so neither the page size nor
the memory behind it grows with the clip length.
"""

from __future__ import annotations

import html
import json
import math
import os
import urllib.parse
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..core.version import __version__
from ..core.words import length_word, plural, significant, whole_percent
from ..filters import noise
from ..steps.base import fps_text
from .html_world import world_section
from .summary import (
    joint_count,
    json_safe,
    noisiest,
    repaired_joints,
    resampled_to,
    same_pipeline,
    was_cleaned,
)
from .terminal import format_noise_model, format_rest, format_takes, note_text
from .traces import COLUMNS, Trace, trace
from .verdict import held_poses, jumps_left_out, removed_words
from .world import depth_text, format_floor, found_on_cleaned

__all__ = ["index_entries", "page_carried", "render_html", "render_index"]

#: Plot geometry in SVG user units (the SVG scales to the card width); the plot area is
#: one unit per plot column (:data:`motionclean.report.traces.COLUMNS`).
LEFT, RIGHT = 54, 12
WIDTH = LEFT + COLUMNS + RIGHT
ACCEL_TOP, ACCEL_HEIGHT = 20, 120
DEV_TOP, DEV_HEIGHT = 172, 56
SVG_HEIGHT = 250

#: A panel's y axis stops near the 99.5th percentile when the peak is SPIKE times above it.
SPIKE = 4.0

#: Deviation plots reach at least this (degrees): an untouched joint's rounding-level
#: differences (1e-15 degrees) draw as the flat line they are.
DEVIATION_FLOOR = 0.01
BEFORE, AFTER, DEVIATION = "#e0892b", "#1f57b8", "#7b3fa8"

CSS = """
*{box-sizing:border-box}
body{margin:0;font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,
sans-serif;color:#1c2230;background:#f3f4f7}
main{max-width:1320px;margin:0 auto;padding:18px 24px 40px}
h1{font-size:21px;margin:0 0 2px;word-break:break-all}
h2{font-size:16px;margin:26px 0 10px}
.meta{color:#5a6272}
.stats{display:flex;flex-wrap:wrap;gap:12px;margin:16px 0 4px}
.stat{background:#fff;border:1px solid #dde1e8;border-radius:8px;padding:10px 16px;
min-width:190px}
.stat b{display:block;font-size:22px;font-weight:600}
.stat span{color:#5a6272;font-size:12.5px}
p.verdict{font-size:16px;font-weight:600;margin:14px 0 0;padding:10px 14px;border-radius:8px;
border:1px solid #b9d7b0;background:#eef7ea}
p.verdict.needs-a-look{border-color:#e6c07a;background:#fdf5e3}
ol.pipeline{margin:0;padding-left:22px}
ol.pipeline code{background:#fff;border:1px solid #dde1e8;border-radius:4px;padding:1px 6px}
table{border-collapse:collapse;background:#fff;border:1px solid #dde1e8;font-size:13px}
th,td{padding:3px 10px;text-align:right;white-space:nowrap}
th{background:#e9ecf2;font-weight:600;position:sticky;top:0}
td:first-child,th:first-child{text-align:left}
tr:nth-child(even) td{background:#f8f9fb}
tr.failed td{background:#fdeaea;color:#8a1c1c}
td.error{text-align:left;white-space:normal}
table.index td:nth-child(2),table.index th:nth-child(2){text-align:left;white-space:normal;
min-width:320px}
tr.look td{background:#fdf5e3}
a{color:#1f57b8;text-decoration:none}
a:hover{text-decoration:underline}
.legend{display:flex;flex-wrap:wrap;gap:4px 18px;color:#5a6272;font-size:13px;margin-bottom:8px}
.key{display:inline-block;width:22px;height:4px;vertical-align:middle;margin-right:6px}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(min(560px,100%),1fr));gap:14px}
.card{background:#fff;border:1px solid #dde1e8;border-radius:8px;padding:8px 10px 4px}
.card h3{font-size:15px;margin:0;display:flex;justify-content:space-between;gap:10px}
.card h3 small{font-weight:400;color:#5a6272;font-size:12.5px}
.card .figures{font-size:12.5px;color:#2c3445}
.card .notes{color:#5a6272;font-size:12px}
svg.plot,svg.foot{display:block;width:100%;height:auto}
svg text{font-size:11px;fill:#5a6272}
svg .axis{stroke:#9aa2b1;stroke-width:1}
svg .gridline{stroke:#e6e9ef;stroke-width:1}
svg .series{fill:none;stroke-width:1;stroke-linejoin:round}
.note{color:#5a6272;font-size:12.5px}
details{margin:22px 0 0;overflow-x:auto}
.wide{overflow-x:auto}
summary{cursor:pointer;font-weight:600;font-size:15px;margin-bottom:10px}
details table{margin-bottom:12px}
"""


# ----------------------------------------------------------------------------- formatting


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _num(value: float | None, digits: int = 0) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:,.{digits}f}"


def _short(value: float) -> str:
    """Compact label, three significant digits: 0, 250, 12.5k, 1.5M."""
    magnitude = abs(value)
    for limit, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if magnitude >= limit:
            return f"{value / limit:.3g}{suffix}"
    return f"{value:.3g}"


def _percent(before: float | None, after: float | None) -> str:
    if after is None or before is None or before <= 0:
        return "-"
    return whole_percent(1.0 - after / before)


def _nice_step(span: float, count: int) -> float:
    """A step of 1, 2 or 5 times a power of ten giving about ``count`` intervals."""
    if span <= 0 or not math.isfinite(span):
        return 1.0
    raw = span / count
    power = 10.0 ** math.floor(math.log10(raw))
    return next(m * power for m in (1, 2, 5, 10) if m * power >= raw)


def _anchor(name: str) -> str:
    """A joint's card id: its letters, digits and hyphens, every other character as its
    code point between underscores (``Hip<L`` ``j-Hip_3c_L``), so two names never share
    one (``Hip<L`` and ``Hip>L`` had both been ``j-Hip_L``)."""
    return "j-" + "".join(c if c.isalnum() or c == "-" else f"_{ord(c):x}_" for c in name)


# ----------------------------------------------------------------------------- plots


def _path(
    position: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    x_scale: float,
    y0: float,
    y_scale: float,
    top: float,
    bottom: float = 0.0,
) -> str:
    """SVG path data tracing an envelope as a zig-zag (min then max, then max then min),
    values clipped to ``bottom..top`` (``y0`` is where ``bottom`` is drawn).

    Columns whose min and max are within half a unit get a single point. NaN columns
    (rest-pose frames, missing samples) break the path: each run of known columns is a
    subpath of its own, so a gap is drawn as a gap, never as zero.
    """
    known = ~(np.isnan(low) | np.isnan(high))
    parts = []
    edges = np.diff(np.concatenate([[0], known.astype(np.int8), [0]]))
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        rows = slice(start, stop)
        parts.append(
            _subpath(
                position[rows], low[rows], high[rows], x_scale, y0, y_scale, top, bottom, int(start)
            )
        )
    return "".join(parts)


def _subpath(position, low, high, x_scale, y0, y_scale, top, bottom, first: int) -> str:
    """One run of known columns of :func:`_path` (``first``: its first column's index, which
    sets where the zig-zag starts)."""
    x = LEFT + position * x_scale
    lo = y0 - (np.clip(low, bottom, top) - bottom) * y_scale
    hi = y0 - (np.clip(high, bottom, top) - bottom) * y_scale
    even = (np.arange(x.size) + first) % 2 == 0
    first_y = np.where(even, lo, hi)
    second = np.where(even, hi, lo)
    double = np.abs(lo - hi) >= 0.5
    xs = np.repeat(x, 1 + double)
    ys = np.empty(xs.size)
    starts = np.cumsum(1 + double) - (1 + double)
    ys[starts] = np.where(double, first_y, (lo + hi) / 2)
    ys[starts[double] + 1] = second[double]
    points = [f"{a:.1f} {b:.1f}" for a, b in zip(xs.tolist(), ys.tolist(), strict=True)]
    return "M" + points[0] + ("L" + " ".join(points[1:]) if len(points) > 1 else "")


def _panel(
    series: list[tuple[Trace, str, str]],
    offset: int,
    frames: int,
    top_y: float,
    height: float,
    label: str,
    floor: float = 0.0,
    signed: bool = False,
) -> list[str]:
    """One plot panel: grid, axes, ticks and the series ``(trace, colour, name)``.

    Sample ``k`` of a trace belongs to frame ``offset + k``; the x axis spans frames
    0..frames-1. The y axis reaches at least ``floor``, so rounding-level values stay flat
    at the bottom. It starts at 0, or with ``signed`` at the lowest value when that is
    negative (a foot below the ground), with a line at 0.
    """
    out: list[str] = []
    span = max(frames - 1, 1)
    x_scale = COLUMNS / span
    peak = max((t.peak for t, _, _ in series if t.size), default=0.0)
    robust = max((t.robust for t, _, _ in series if t.size), default=0.0)
    deepest = min(  # (NaN: samples left out, such as a foot's on rest-pose frames)
        (float(np.nanmin(t.low)) for t, _, _ in series if np.isfinite(t.low).any()),
        default=0.0,
    )
    depth = max(-deepest, 0.0) if signed else 0.0
    # A few samples far above the rest (a glitch) would flatten the plot: clip them.
    limit = max(1.2 * robust if peak > SPIKE * robust > 0 else peak, floor)
    reach = limit + depth
    step = _nice_step(reach, 4 if height >= 100 else 2) if reach > 0 else 1.0
    top = step * max(math.ceil(limit / step - 1e-9), 0 if depth else 1)
    bottom = -step * math.ceil(depth / step - 1e-9)
    clipped = peak > top
    y0 = top_y + height
    y_scale = height / (top - bottom)
    below = int(round(-bottom / step))
    for k in range(-below, int(round(top / step)) + 1):
        y = y0 - (k * step - bottom) * y_scale
        out.append(
            f'<line class="gridline" x1="{LEFT}" x2="{WIDTH - RIGHT}" y1="{y:.1f}" y2="{y:.1f}"/>'
        )
        out.append(
            f'<text x="{LEFT - 5}" y="{y + 4:.1f}" text-anchor="end">{_short(k * step)}</text>'
        )
    out.append(f'<text x="{LEFT}" y="{top_y - 6:.1f}">{_e(label)}</text>')
    if clipped:
        out.append(
            f'<text x="{WIDTH - RIGHT}" y="{top_y - 6:.1f}" text-anchor="end">'
            f"clipped at {_short(top)}, peak {_short(peak)}</text>"
        )
    for drawn, colour, name in series:
        if not drawn.size:
            continue
        data = _path(
            drawn.position + offset, drawn.low, drawn.high, x_scale, y0, y_scale, top, bottom
        )
        if data:
            out.append(
                f'<path class="series" data-series="{_e(name)}" stroke="{colour}" d="{data}"/>'
            )
    zero = y0 + bottom * y_scale
    out.append(f'<line class="axis" x1="{LEFT}" x2="{WIDTH - RIGHT}" y1="{zero}" y2="{zero}"/>')
    out.append(f'<line class="axis" x1="{LEFT}" x2="{LEFT}" y1="{top_y}" y2="{y0}"/>')
    return out


def _frame_ticks(frames: int, y: float) -> list[str]:
    span = max(frames - 1, 1)
    step = max(_nice_step(span, 8), 1.0)
    out = [f'<text x="{LEFT - 9}" y="{y + 15}" text-anchor="end">frame</text>']
    for k in range(int(span // step) + 1):
        frame = k * step
        x = LEFT + frame * COLUMNS / span
        out.append(f'<line class="axis" x1="{x:.1f}" x2="{x:.1f}" y1="{y}" y2="{y + 4}"/>')
        out.append(f'<text x="{x:.1f}" y="{y + 15}" text-anchor="middle">{frame:.0f}</text>')
    return out


def _joint_svg(name: str, data: dict, frames: int) -> str:
    """One SVG per joint: acceleration before/after on top, deviation below."""
    accel = [(data["accel_before"], BEFORE, "before")]
    if data.get("accel_after") is not None:
        accel.append((data["accel_after"], AFTER, "after"))
    parts = _panel(accel, 1, frames, ACCEL_TOP, ACCEL_HEIGHT, "angular acceleration, deg/s\u00b2")
    height = ACCEL_TOP + ACCEL_HEIGHT + 22
    if data.get("deviation") is not None:
        parts += _panel(
            [(data["deviation"], DEVIATION, "deviation")],
            0,
            frames,
            DEV_TOP,
            DEV_HEIGHT,
            "deviation from the input, deg",
            floor=DEVIATION_FLOOR,
        )
        height = SVG_HEIGHT
    parts += _frame_ticks(frames, height - 22)
    return (
        f'<svg class="plot" data-joint="{_e(name)}" viewBox="0 0 {WIDTH} {height}" '
        f'role="img" aria-label="{_e(name)}: angular acceleration over frames">'
        f"<title>{_e(name)}</title>" + "".join(parts) + "</svg>"
    )


# ----------------------------------------------------------------------------- page parts


def _page(title: str, body: list[str], head: str = "") -> str:
    """A whole page: ``body``'s elements, and ``head`` (a data block) in its head."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(title)}</title>{head}<style>{CSS}</style></head><body><main>\n"
        + "\n".join(body)
        + f'\n<p class="note">motionclean {_e(__version__)}. Angular acceleration is '
        "2|w<sub>i</sub> &minus; w<sub>i&minus;1</sub>|/&Delta;t&sup2; with "
        "w<sub>i</sub> = log(q<sub>i</sub><sup>&minus;1</sup>q<sub>i+1</sub>), in degrees "
        "of rotation per s&sup2;; deviation is the rotation angle between the input and "
        "the cleaned sample, in degrees.</p>\n</main></body></html>\n"
    )


def _pipeline(steps: Sequence[dict], cleaned: bool = True) -> str:
    if not steps:
        return (
            '<p class="note">Not recorded: the two clips were compared as given.</p>'
            if cleaned
            else '<p class="note">No pipeline: figures of the input only.</p>'
        )
    items = []
    for step in steps:
        params = " ".join(
            f"{k}={_e(_value(v)).replace(', ', ',')}" for k, v in step.items() if k != "filter"
        )
        items.append(f"<li><code>{_e(step.get('filter', '?'))}</code> {params}</li>")
    return '<ol class="pipeline">' + "".join(items) + "</ol>"


def _value(value: Any) -> str:
    """A parameter or note value as short text (lists of more than 8 items shortened)."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, dict):
        return ", ".join(f"{k} {_nested(v)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        if not value:
            return "none"
        items = [_value(v) for v in value[:8]]
        more = f", +{len(value) - 8} more" if len(value) > 8 else ""
        return "[" + ", ".join(items) + more + "]"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _nested(value: Any) -> str:
    return f"({_value(value)})" if isinstance(value, dict) else _value(value)


def _stat(value: str, label: str) -> str:
    return f'<div class="stat"><b>{value}</b><span>{label}</span></div>'


def _noise_stat(total: float | None, verdict: dict) -> str:
    """The headline of a clip not compared with a cleaning: its noise, without the steps
    over 90 degrees where the verdict left them out (a clip reported alone), as its line."""
    label = "noise: RMS angular acceleration, deg/s\u00b2"
    if verdict.get("status") != "input only":
        return _stat(_num(total), label)
    left = jumps_left_out(verdict.get("unrepaired_jumps") or 0)
    return _stat(
        _num(verdict.get("noise_before")),
        _e(label + _weighted(verdict, ", weighted by reach") + left),
    )


def _weighted(verdict: dict, words: str) -> str:
    """``words`` where the verdict's noise weights each joint by its reach, else nothing
    (tracked bodies, pooled equally)."""
    return words if verdict.get("noise_weighting") == "reach" else ""


def _share(share: float) -> str:
    """``0.93`` as ``93 %`` (a thin space before the sign)."""
    return whole_percent(share).replace("%", "\u2009%")


def _headline(report: dict) -> list[str]:
    """The page's headline figures: smoothing first (jitter removed and the largest change,
    both outside the repaired frames), then the repairs, then the totals with repairs."""
    summary = report["summary"]
    acc = summary["angular_accel_rms"]
    verdict = report.get("verdict") or {}
    if (
        summary.get("noise_reduction") is None
        or verdict.get("noise_removed") is None
        or "change_deg_max" not in verdict
    ):
        return [_noise_stat(acc["before"], verdict)]
    repairs = repaired_joints(report)
    world = verdict.get("world_removed")
    # (as the terminal says it: "up 12 %" where it rose, not "-12 % removed")
    seen = (
        ""
        if world is None
        else "; " + removed_words(world, "end effectors' world acceleration", _share)
    )
    stats = [
        _stat(
            _share(verdict["noise_removed"]),
            "jitter removed"
            + (" outside repairs" if repairs else "")
            + " (RMS angular acceleration"
            + _weighted(verdict, ", each joint weighted by its reach")
            + ": "
            + f"{_num(verdict['noise_before'])} \u2192 {_num(verdict['noise_after'])} "
            + f"deg/s\u00b2{seen})",
        ),
        _stat(
            _num(verdict["change_deg_max"], 2) + "\u00b0",
            "largest change"
            + (" outside repairs" if repairs else "")
            + (f" ({_e(verdict['change_joint'])})" if verdict["change_joint"] else ""),
        ),
    ]
    if verdict.get("positions_lead"):  # (the line's figures: the positions')
        unit = length_word(report.get("length_unit"))
        stats[:0] = [
            _stat(
                _share(verdict["position_noise_removed"]),
                "position jitter removed"
                + (" outside repairs" if repairs else "")
                + f" (RMS linear acceleration: {_num(verdict['position_noise_before'])} \u2192 "
                + f"{_num(verdict['position_noise_after'])} {_e(unit)}/s\u00b2)",
            ),
            _stat(
                _e(significant(verdict["change_length_max"])) + f" {_e(unit)}",
                "largest position change"
                + (
                    f" ({_e(verdict['change_length_joint'])})"
                    if verdict.get("change_length_joint")
                    else ""
                ),
            ),
        ]
    if repairs:
        kinds = {
            "turned": "turn",
            "flips": "flip",
            "spikes": "spike",
            "capped": "capped step",
            "gaps_filled": "gap",
            "held": "held pose",
            "brief": "brief change",
        }
        counts = {k: sum(r.get(k, 0) for r in repairs.values()) for k in kinds}
        counts["held"] = held_poses(report["joints"])  # (distinct runs, as the line says)
        done = (
            ", ".join(
                plural(n, word)
                for n, word in zip(counts.values(), kinds.values(), strict=True)
                if n
            )
            or "none"
        )
        frames = sum(r["frames"] for r in repairs.values())
        stats.append(
            _stat(
                _e(done),
                f"{'changed' if counts['brief'] else 'repaired'} on {plural(frames, 'frame')} "
                f"of {_e(', '.join(repairs))}",
            )
        )
    stats.append(
        _stat(
            f"{_num(acc['before'])} \u2192 {_num(acc['after'])}",
            "RMS angular acceleration, deg/s\u00b2"
            + (", repairs included" if repairs else "")
            + f" ({summary['noise_reduction']:.1%} removed)",
        )
    )
    if repairs:
        stats.append(
            _stat(
                _num(summary["deviation_deg_max"], 2) + "\u00b0",
                "largest change, repairs included",
            )
        )
    return stats


STANDARD_KEYS = {
    "angular_accel_rms",
    "angular_accel_max",
    "deviation_deg",
    "linear_accel_rms",
    "linear_accel_max",
    "deviation_length",
}


def render_html(report: dict, series: dict | None = None, carried: dict | None = None) -> str:
    """The report page of one clip, from a :func:`build_report` dict and optional series.

    Without ``series`` (see :func:`build_series`) the page has the tables but no plots.
    Joints whose acceleration is zero before and after get no plot; they are listed.
    ``carried`` (a batch's ``pipeline`` and the clip's index ``figures``) goes in the
    page's head as JSON, for :func:`page_carried` to read back; its ``index``, the batch's
    index page relative to this one, is linked above the title.
    """
    cleaned = was_cleaned(report)
    frames = int(report["frames"])
    dt = float(report["frame_time"])
    index = (carried or {}).get("index")
    body = [
        *(
            [f'<p class="note"><a href="{_e(index)}">all clips of the batch</a></p>']
            if index
            else []
        ),
        f"<h1>{_e(report['file'])}</h1>",
        f'<div class="meta">{plural(frames, "frame")} at {fps_text(dt)} fps '
        f"({frames * dt:.3f} s){_e(resampled_to(report))}, {joint_count(report)}; "
        "frames are numbered from 0</div>",
    ]
    verdict = report.get("verdict")
    if verdict:
        status = verdict["status"].replace(" ", "-")
        body.append(f'<p class="verdict {status}">{_e(verdict["text"])}</p>')
    body.append('<div class="stats">' + "".join(_headline(report)) + "</div>")
    rest = report.get("rest_frames") or {}
    if rest.get("leading") or rest.get("trailing"):
        body.append(f'<p class="note">{_e(format_rest(rest, frames))}.</p>')
    if report.get("take_starts"):
        text = format_takes(report["take_starts"], cleaned)
        body.append(f'<p class="note">{_e(text)}.</p>')
    body += ["<h2>Pipeline</h2>", _pipeline(report.get("pipeline") or [], cleaned)]

    names = noisiest(report)
    joints = report["joints"]
    plotted = [
        n
        for n in names
        if series is not None
        and n in series["joints"]
        and (
            (joints[n]["angular_accel_rms"]["before"] or 0) > 0
            or (joints[n]["angular_accel_rms"]["after"] or 0) > 0
        )
    ]
    drawn = set(plotted)
    tables = _joint_table(joints, names, drawn, cleaned)
    positions = [n for n in joints if "linear_accel_rms" in joints[n]]
    if positions:
        tables += _position_table(joints, positions, cleaned, report.get("length_unit"))
    body.append(
        f"<details><summary>Figures of all {joint_count(report)}, noisiest first"
        f"</summary>{tables}</details>"
    )
    body += world_section(report, series)
    body += _feet_section(report, series)
    if series is None:
        body.append('<p class="note">No time series were given: plots left out.</p>')
    elif plotted:
        body.append(
            f"<h2>Angular acceleration{' and deviation' if cleaned else ''} over "
            "frames, noisiest joint first</h2>"
        )
        keys = [("before", BEFORE)] + (
            [("after", AFTER), ("deviation", DEVIATION)] if cleaned else []
        )
        body.append(
            '<div class="legend">'
            + "".join(
                f'<span><i class="key" style="background:{c}"></i>{k}</span>' for k, c in keys
            )
            + (
                f"<span>{frames:,} frames: min and max per plot column</span>"
                if frames > COLUMNS
                else ""
            )
            + "</div>"
        )
        correlation, own_rho = noise_correlation(joints, report["frame_time"])
        source = format_noise_model(report)
        if source:
            body.append(f'<p class="note">auto: {_e(source.rstrip("."))}.</p>')
        if correlation:
            body.append(f'<p class="note">auto: {_e(correlation)}.</p>')
        body.append('<div class="grid">')
        for name in plotted:
            body.append(
                _joint_card(
                    name,
                    joints[name],
                    series["joints"][name],
                    frames,
                    {key for key, joint in own_rho if joint == name},
                )
            )
        body.append("</div>")
    still = [n for n in names if n not in drawn and series is not None]
    unmeasured = [n for n in still if joints[n]["angular_accel_rms"]["before"] is None]
    for listed, why in (
        ([n for n in still if n not in unmeasured], "no angular acceleration"),
        (unmeasured, "nothing measured: no three frames in a row known"),
    ):
        if listed:
            body.append(
                f'<p class="note">Not plotted ({why}): ' + ", ".join(_e(n) for n in listed) + "</p>"
            )
    head = "" if carried is None else _data_block(CLIP_DATA, carried)
    return _page(f"motionclean report: {report['file']}", body, head)


def _joint_table(joints: dict, names: list[str], plotted: set[str], cleaned: bool) -> str:
    head = ["joint", "accel RMS, deg/s\u00b2"]
    if cleaned:
        head += ["after", "removed"]
    head.append("accel max")
    if cleaned:
        head += ["after", "deviation RMS, \u00b0", "max, \u00b0"]
    rows = ["<tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>"]
    for name in names:
        entry = joints[name]
        rms, peak = entry["angular_accel_rms"], entry["angular_accel_max"]
        label = f'<a href="#{_anchor(name)}">{_e(name)}</a>' if name in plotted else _e(name)
        cells = [label, _num(rms["before"])]
        if cleaned:
            cells += [_num(rms["after"]), _percent(rms["before"], rms["after"])]
        cells.append(_num(peak["before"]))
        if cleaned:
            dev = entry.get("deviation_deg", {})
            cells += [_num(peak["after"]), _num(dev.get("rms"), 2), _num(dev.get("max"), 2)]
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return "<table>" + "".join(rows) + "</table>"


#: What the page calls lengths whose unit the format fixes (``report["length_unit"]``).
UNIT_NAMES = {"m": "metres", "cm": "centimetres", "mm": "millimetres"}


def _position_table(joints: dict, names: list[str], cleaned: bool, unit: str | None) -> str:
    head = ["joint", "linear accel RMS"] + (["after"] if cleaned else []) + ["max"]
    head += ["after", "deviation RMS", "max"] if cleaned else []
    rows = ["<tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>"]
    for name in names:
        entry = joints[name]
        rms, peak = entry["linear_accel_rms"], entry["linear_accel_max"]
        cells = [_e(name), _num(rms["before"], 1)] + ([_num(rms["after"], 1)] if cleaned else [])
        cells.append(_num(peak["before"], 1))
        if cleaned:
            dev = entry.get("deviation_length", {})
            cells += [_num(peak["after"], 1), _num(dev.get("rms"), 3), _num(dev.get("max"), 3)]
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    name = UNIT_NAMES.get(unit or "", "length units of the file")
    return (
        "<table>" + "".join(rows) + f'</table><p class="note">{name.capitalize()} per s\u00b2; '
        f"deviation in {name}.</p>"
    )


#: A joint's noise correlation (AR(1) rho of ``auto``) is shown where it differs from the
#: clip's median by at least this much; the median is shown once.
RHO_APART = 0.2


def noise_correlation(joints: dict, frame_time: float) -> tuple[str | None, set[tuple[str, str]]]:
    """What the page says about ``auto``'s noise correlation: one line for the clip (None
    without ``auto`` notes) and the ``(note key, joint)`` pairs whose own rho says something
    about the joint (the markerless model's notes have none to say). Below about 57 fps
    (``frame_time`` seconds per frame) the model takes every joint's noise as white (rho 0,
    not fitted): no joint shows it. Otherwise the clip's median (rotations and positions
    each) is shown once, and a joint's rho where it differs from it by :data:`RHO_APART` or
    more."""
    fitted = noise.correlation_fitted(frame_time)
    said, apart = [], set()
    for key, what in (("auto", "rotations"), ("position_auto", "positions")):
        notes = {n: e.get(key) or {} for n, e in joints.items()}
        # the markerless model has no AR(1) correlation: its wander is said on its own line
        rhos = {
            n: v["rho"]
            for n, v in notes.items()
            if v.get("rho") is not None and v.get("model") != "markerless"
        }
        if not rhos:
            continue
        if not any(rhos.values()):
            said.append(
                f"{what}: noise white (AR(1) rho 0 on every joint)"
                if fitted
                else f"{what}: noise taken as white (its correlation is not fitted at this rate)"
            )
            continue
        typical = float(np.median(list(rhos.values())))
        own = {(key, n) for n, r in rhos.items() if abs(r - typical) >= RHO_APART}
        apart |= own
        said.append(
            f"{what}: noise correlation AR(1) rho {typical:.2f} (median; {len(own)} of "
            f"{len(rhos)} joints differ by {RHO_APART:g} or more and show their own)"
        )
    return ("; ".join(said) if said else None), apart


def _joint_card(
    name: str, entry: dict, data: dict, frames: int, own_rho: set[str] | None = None
) -> str:
    rms, peak = entry["angular_accel_rms"], entry["angular_accel_max"]
    if rms["after"] is not None:
        removed = f"{_percent(rms['before'], rms['after'])} of the noise removed"
        figures = (
            f"RMS {_num(rms['before'])} \u2192 {_num(rms['after'])}, max "
            f"{_short(peak['before'])} \u2192 {_short(peak['after'])} deg/s\u00b2"
        )
        dev = entry.get("deviation_deg")
        if dev:
            figures += (
                f"; deviation RMS {_num(dev['rms'], 2)}\u00b0, max {_num(dev['max'], 2)}\u00b0"
            )
    else:
        removed = ""
        figures = f"RMS {_num(rms['before'])}, max {_short(peak['before'])} deg/s\u00b2"
    notes = [
        f"<b>{_e(k.replace('_', ' '))}</b> {_e(note_text(k, _shown(k, v, own_rho)))}"
        for k, v in entry.items()
        if k not in STANDARD_KEYS
    ]
    return (
        f'<section class="card" id="{_anchor(name)}"><h3>{_e(name)}<small>{removed}'
        f'</small></h3><div class="figures">{figures}</div>'
        + "".join(f'<div class="notes">{n}</div>' for n in notes)
        + _joint_svg(name, data, frames)
        + "</section>"
    )


def _shown(key: str, note: Any, own_rho: set[str] | None) -> Any:
    """``note`` as the page shows it: ``auto``'s without its rho where that says nothing
    about the joint (``own_rho``: the note keys whose rho does, None: all;
    :func:`noise_correlation`)."""
    if key.endswith("auto") and own_rho is not None and key not in own_rho:
        return {k: v for k, v in note.items() if k != "rho"}
    return note


# ----------------------------------------------------------------------------- feet


CONTACT = "#d8e8d0"


def _shaded(runs, x_scale: float) -> list[tuple[float, float]]:
    """The plot's x spans of ``[first, stop)`` frame runs, each at least a unit wide,
    those that touch within a unit merged: as many as the plot can show, however many
    contacts a long clip has (one per contact had grown the page with its length)."""
    spans: list[tuple[float, float]] = []
    for first, stop in runs:
        x0 = LEFT + first * x_scale
        x1 = x0 + max((stop - 1 - first) * x_scale, 1.0)
        if spans and x0 <= spans[-1][1] + 1.0:
            spans[-1] = (spans[-1][0], max(spans[-1][1], x1))
        else:
            spans.append((x0, x1))
    return spans


def _foot_card(name: str, figures: dict, data: dict, frames: int, unit: str) -> str:
    """A foot: its contacts and skate, and its lowest point above the ground over frames
    with the contacts shaded; lengths in ``unit`` (``core.words.length_word``)."""
    skate, pen = figures["skate_body_heights"], figures["penetration"]
    text = f"{plural(len(figures['contacts']), 'contact')}, {plural(figures['frames'], 'frame')}"
    if skate["before"] is not None and math.isfinite(skate["before"]):
        text += f"; skate {skate['before']:.3f}"
        text += f" \u2192 {skate['after']:.3f}" if skate["after"] is not None else ""
        text += " body heights/s"
    if pen["before"] is None or data["height_before"] is None:
        text += "; ground not found (needs at least 2 frames)"
        return (
            f'<section class="card"><h3>{_e(name)}</h3><div class="figures">{_e(text)}</div>'
            "</section>"
        )
    text += "; below ground " + depth_text(figures, "\u2192", _short, unit)
    series = [(trace(data["height_before"]), BEFORE, "height before")]
    if data["height_after"] is not None:
        series.append((trace(data["height_after"]), AFTER, "height after"))
    x_scale = COLUMNS / max(frames - 1, 1)
    shades = [  # from a contact's first frame to its last (``stop - 1``)
        f'<rect class="contact" x="{x0:.1f}" y="{ACCEL_TOP}" width="{x1 - x0:.1f}" '
        f'height="{ACCEL_HEIGHT}" fill="{CONTACT}"/>'
        for x0, x1 in _shaded(data["contacts"], x_scale)
    ]
    height = ACCEL_TOP + ACCEL_HEIGHT + 30
    parts = shades + _panel(
        series,
        0,
        frames,
        ACCEL_TOP,
        ACCEL_HEIGHT,
        f"lowest point above the ground (below it: negative), {unit}",
        signed=True,
    )
    parts += _frame_ticks(frames, ACCEL_TOP + ACCEL_HEIGHT + 4)
    svg = (
        f'<svg class="foot" data-foot="{_e(name)}" viewBox="0 0 {WIDTH} {height}" role="img" '
        f'aria-label="{_e(name)}: height above the ground over frames">'
        f"<title>{_e(name)}</title>" + "".join(parts) + "</svg>"
    )
    return (
        f'<section class="card"><h3>{_e(name)}</h3><div class="figures">{_e(text)}</div>'
        + svg
        + "</section>"
    )


def _feet_section(report: dict, series: dict | None) -> list[str]:
    contacts = report.get("contacts")
    if not contacts or series is None or not series.get("feet"):
        return []
    frames = int(report["frames"])
    unit = length_word(report.get("length_unit"))
    cleaned = found_on_cleaned(contacts)
    on = "the cleaned clip" if cleaned else "the input"
    return [
        "<h2>Feet on the ground</h2>",
        '<div class="legend">'
        f'<span><i class="key" style="background:{CONTACT}"></i>contact (found on {on})'
        "</span>"
        f'<span><i class="key" style="background:{BEFORE}"></i>before</span>'
        + (
            f'<span><i class="key" style="background:{AFTER}"></i>after</span>'
            if was_cleaned(report)
            else ""
        )
        + "<span>skate: mean horizontal ankle speed during contacts, over 0.1 s</span></div>",
        *_ground_lines(contacts, unit),
        *(
            [
                '<p class="meta">No contact is found on the input: those shaded are found '
                "on the cleaned clip, as its ground and floor, and both clips' skate and depth "
                "are measured on them.</p>"
            ]
            if cleaned
            else []
        ),
        *(
            [
                f'<p class="meta">The contacts shaded are found on {on} by the report\'s '
                "thresholds; footlock holds its own (its joint cards), found after smoothing, "
                "at a start speed the noise allows: they can begin earlier or end later.</p>"
            ]
            if any("footlock" in joint for joint in (report.get("joints") or {}).values())
            else []
        ),
        '<div class="grid">',
        *(
            _foot_card(name, contacts["feet"][name], series["feet"][name], frames, unit)
            for name in contacts["feet"]
        ),
        "</div>",
    ]


def _ground_lines(contacts: dict, unit: str = "units") -> list[str]:
    """The floor (as the terminal says it) and what the plots' 0 is, lengths in ``unit``."""
    lines = []
    floor = format_floor(contacts, unit)
    if floor is not None:
        lines.append(f'<p class="meta">{_e(floor[0].upper() + floor[1:])}.</p>')
    if contacts.get("ground") is not None:
        where = (
            "above the tilted floor, above which contacts are found"
            if (contacts.get("floor") or {}).get("contacts_found_above_it")
            else f"along the up axis ({_e(contacts['up_axis'])})"
        )
        lines.append(
            f'<p class="meta">The plots\' 0 is the ground, at {contacts["ground"]:.4g} {unit} '
            f"{where}: the 5th percentile of the feet's lowest points over the clip"
            + ("" if "tilted" in where else ", above which contacts are found")
            + ".</p>"
        )
    return lines


# ----------------------------------------------------------------------------- batch index


#: The verdict cell of a clip skipped as done whose figures no earlier index or page holds.
UNKNOWN_FIGURES = (
    "figures not known: cleaned by an earlier run that left none (no index of it, a page "
    "without them, or another pipeline)"
)


def render_index(entries: Sequence[dict], pipeline: Sequence[dict], title: str) -> str:
    """The index page of a batch run.

    ``entries`` are dicts with ``file`` (shown), ``href`` (relative link to the clip page
    or None), ``frames``, ``noise_before``, ``noise_after``, ``deviation_max`` (repairs
    included), ``jitter_before``, ``jitter_after``, ``jitter_removed`` and ``change_max`` (the
    verdict's, outside repairs),
    ``verdict`` (the clip's verdict line, :mod:`.verdict`) and ``verdict_status``,
    ``status`` ("ok", "skipped", "failed") and ``error``.
    """
    counts = {s: sum(e["status"] == s for e in entries) for s in ("ok", "skipped", "failed")}
    body = [
        f"<h1>{_e(title)}</h1>",
        f'<div class="meta">{len(entries)} clips: {counts["ok"]} cleaned, '
        f"{counts['skipped']} skipped (already done), {counts['failed']} failed</div>",
        "<h2>Pipeline</h2>",
        _pipeline(pipeline),
        "<h2>Clips</h2>",
    ]
    head = [
        "clip",
        "verdict",
        "frames",
        "noise before",
        "after",
        "jitter removed",
        "largest change, \u00b0",
        "status",
    ]
    rows = ["<tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>"]
    for e in entries:
        name = _e(e["file"])
        href = urllib.parse.quote(e["href"]) if e.get("href") else None
        link = f'<a href="{_e(href)}">{name}</a>' if href else name
        if e["status"] == "failed":
            rows.append(
                f'<tr class="failed"><td>{link}</td>'
                f'<td class="error" colspan="7">failed: {_e(e["error"])}</td></tr>'
            )
            continue
        unknown = e["status"] == "skipped" and e.get("frames") is None
        cells = [
            link,
            _e(e.get("verdict") or (UNKNOWN_FIGURES if unknown else "-")),
            _num(e.get("frames")),
            _num(e.get("noise_before") if e.get("jitter_before") is None else e["jitter_before"]),
            _num(e.get("noise_after") if e.get("jitter_after") is None else e["jitter_after"]),
            _percent(e.get("noise_before"), e.get("noise_after"))
            if e.get("jitter_removed") is None
            else whole_percent(e["jitter_removed"]),
            _num(e.get("deviation_max") if e.get("change_max") is None else e["change_max"], 2),
            _e(e.get("verdict_status") or e["status"])
            + (" (an earlier run)" if e["status"] == "skipped" and e.get("verdict_status") else ""),
        ]
        look = ' class="look"' if e.get("verdict_status") == "needs a look" else ""
        rows.append(f"<tr{look}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    body.append('<div class="wide"><table class="index">' + "".join(rows) + "</table></div>")
    body.append(
        '<p class="note">Noise: RMS angular acceleration over all joints and frames, each '
        "joint weighted by its reach (how far its rotation moves the body; tracked bodies "
        "equally), deg/s\u00b2; "
        "noise, jitter removed and largest change are measured outside the frames that "
        "were repaired (flips, spikes, gaps), as in each clip's verdict and its page's "
        "first figure.</p>"
    )
    # (read back by a resumed batch: the clips it skips keep their figures)
    body.append(_data_block(INDEX_DATA, {"pipeline": list(pipeline), "clips": list(entries)}))
    return _page(title, body)


#: The id of the index page's block of clip figures (:func:`index_entries`).
INDEX_DATA = "mc-batch"
#: The id of a clip page's block of its batch figures (:func:`page_carried`).
CLIP_DATA = "mc-clip"


def _data_block(name: str, data: dict) -> str:
    """``data`` as a JSON block of a page, ``<script type="application/json" id=name>``."""
    text = json.dumps(json_safe(data)).replace("</", "<\\/")
    return f'<script type="application/json" id="{name}">{text}</script>'


def _block(page: str, name: str) -> dict | None:
    """The JSON block ``name`` of a page (:func:`_data_block`); None without one, or for
    any other text."""
    start = page.find(f'<script type="application/json" id="{name}">')
    stop = page.find("</script>", start)
    if start < 0 or stop < 0:
        return None
    try:
        data = json.loads(page[page.index(">", start) + 1 : stop])
    except ValueError:
        return None
    return data if isinstance(data, dict) else None


def _read_block(page: str, name: str, pipeline: Sequence[dict]) -> dict | None:
    """The JSON block ``name`` of a page (:func:`_block`) when it was written for the same
    ``pipeline``; None without one, for another pipeline, or for any other text."""
    data = _block(page, name)
    return data if data is not None and same_pipeline(data.get("pipeline"), pipeline) else None


def index_entries(page: str, pipeline: Sequence[dict]) -> dict[str, dict]:
    """The clip entries (by ``file``) of an index page :func:`render_index` wrote for the
    same ``pipeline``; none from another pipeline's page or any other text."""
    data = _read_block(page, INDEX_DATA, pipeline)
    try:
        return {e["file"]: e for e in data["clips"] if isinstance(e, dict)} if data else {}
    except (KeyError, TypeError):
        return {}


def _carried(path: str | os.PathLike) -> dict | None:
    """What a clip page carries in its head (:func:`render_html`'s ``carried``: the batch's
    pipeline and the clip's index figures); None for a page without it, or one that cannot
    be read. Only the page's head is read."""
    head = bytearray()
    try:
        with open(path, "rb") as page:
            while b"</head>" not in head and (chunk := page.read(1 << 16)):
                head += chunk
    except OSError:
        return None
    return _block(head.decode("utf-8", "replace"), CLIP_DATA)


def page_carried(path: str | os.PathLike, pipeline: Sequence[dict]) -> tuple[dict | None, bool]:
    """What a clip page carries (:func:`_carried`), read once: its index figures where it
    was written for the same ``pipeline`` (else None), and whether it says it was written
    for another (and so was its clip: a batch writes them together; False for a page that
    does not say, written before pages carried it, or one that cannot be read)."""
    data = _carried(path)
    if data is None:
        return None, False
    if not same_pipeline(data.get("pipeline"), pipeline):
        return None, True
    figures = data.get("figures")
    return (figures if isinstance(figures, dict) else None), False
