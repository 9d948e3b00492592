"""Regression check for CI: clean sample clips and compare their figures with a baseline.

``motionclean check CLIP... --baseline FILE.json`` runs the pipeline on each clip (nothing is
written) and compares, per clip, the figures of :class:`~motionclean.cli.batch.FileResult`:

- ``noise_after``: RMS angular acceleration after cleaning, all joints (deg/s^2);
- ``deviation_max`` / ``deviation_rms``: rotation angle between input and output (degrees);
- ``frames``, ``noise_before`` and ``content`` (a digest of the clip's values as read,
  :func:`~motionclean.run.jobs.content_digest`) guard the input: when they differ the clip
  itself changed. A baseline recorded before ``content`` existed is checked without it, as
  is one of format 3 (:data:`ROUNDED_DIGESTS`) until ``--update`` records it anew.

A figure is worse when ``now > baseline * (1 + T) + ABSOLUTE`` (relative tolerance ``T``,
default :data:`DEFAULT_TOLERANCE` = 1 %; ``ABSOLUTE`` keeps figures at zero from failing on
round-off). Lower is better for all three. The same limits apply per joint to the noise
after cleaning and the largest deviation, so a regression on one joint fails even when the
clip's maximum is another joint's. ``--update`` records figures instead (merged into the
baseline; ``--replace`` starts a new one). A baseline records one pipeline, the one of every
clip's figures: an update under another pipeline must record every clip it holds. Clips
are keyed by their path relative to the baseline's folder.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import click

from ..core.errors import MotionError, UsageError
from ..core.version import __version__
from ..core.words import plural
from ..io import ReadOptions, atomic_write
from ..report.summary import same_pipeline, to_json
from ..report.verdict import listed
from ..run.jobs import FileResult, Job
from ..run.pool import default_workers, run_jobs
from ..steps.base import is_number
from .options import (
    PATH,
    PIPE_OPTION,
    SOURCE_OPTION,
    STEP_OPTION,
    UP_OPTION,
    FiniteRange,
    check_output,
    echo_warnings,
    pipeline_from_options,
    raise_failures,
    read_options,
)

__all__ = ["DEFAULT_TOLERANCE", "FIGURES", "check_command", "compare", "read_baseline"]

#: Default relative tolerance of ``--tolerance``.
DEFAULT_TOLERANCE = 0.01
#: Absolute slack added to every limit (units of the figure).
ABSOLUTE = 1e-9
#: Relative slack of the figures of the clip itself (the noise before cleaning): rounding
#: between machines only (the tolerance for the cleaning's figures had let a half-degree
#: edit of one frame pass); an edit below it shows in the content digest.
SAME_CLIP = 1e-7
#: Figures compared: key, label, and whether only a rise fails (else any change does).
FIGURES = (
    ("noise_before", "noise before, deg/s^2", False),
    ("noise_after", "noise after, deg/s^2", True),
    ("deviation_max", "deviation max, deg", True),
    ("deviation_rms", "deviation RMS, deg", True),
)
#: Per-joint figures compared (lower is better): key, label.
JOINT_FIGURES = (
    ("noise_after", "noise after, deg/s^2"),
    ("deviation_max", "deviation max, deg"),
)
#: What the baseline's ``content`` of a clip holds: a SHA-256 digest in hex.
DIGEST = re.compile(r"[0-9a-f]{64}")
FORMAT = 4
#: The format whose digests hashed the parsed values as float32 (an edit of 2e-6 of
#: 117.056789 passed): not comparable with today's, so not compared.
ROUNDED_DIGESTS = 3


def clip_key(path: str, baseline: Path) -> str:
    """The baseline key of a clip: its path as given, relative to the baseline's folder
    (symbolic links are not followed), so a baseline committed beside its clips works on
    every machine and in every working folder."""
    folder = os.path.abspath(baseline.parent)
    return Path(os.path.relpath(os.path.abspath(path), folder)).as_posix()


def read_baseline(path: Path) -> dict[str, Any]:
    """Load a baseline file written by ``--update``."""
    if not path.exists():
        raise UsageError(f"{path}: no such baseline; create it with --update")
    if path.is_dir():
        raise UsageError(f"{path}: is a directory, not a baseline")
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise MotionError(f"not a readable baseline: {error}", path) from None
    if not (isinstance(document, dict) and isinstance(document.get("clips"), dict)):
        raise MotionError('not a motionclean baseline (no "clips" table)', path)
    for key, entry in document["clips"].items():
        problem = _entry_problem(entry)
        if problem:
            raise MotionError(f"not a motionclean baseline: clip {key[:80]!r}: {problem}", path)
    return document


def _drop_rounded_digests(document: dict[str, Any]) -> bool:
    """Drop, in place, the ``content`` of the clips of a baseline of format
    :data:`ROUNDED_DIGESTS` (its clips are checked on their figures, as one recorded
    without digests); True when there was any."""
    if document.get("format") != ROUNDED_DIGESTS:
        return False
    dropped = [entry.pop("content", None) for entry in document["clips"].values()]
    return any(content is not None for content in dropped)


def _figure(value: Any) -> bool:
    """Whether ``value`` is a recorded figure: a finite number, not negative, or null."""
    if value is None:
        return True
    if not is_number(value):
        return False
    try:
        return math.isfinite(value) and value >= 0
    except OverflowError:  # an integer beyond any float
        return False


def _entry_problem(entry: Any) -> str | None:
    """What is wrong with a baseline's clip entry (None: nothing), as ``--update`` writes
    them: a table of figures, each a number of at least 0 or null, ``frames`` a whole
    number, ``joints`` a table of such tables."""
    if not isinstance(entry, dict):
        return "not a table of figures"
    frames = entry.get("frames")
    if not (is_number(frames) and isinstance(frames, int) and frames >= 0):
        return f"frames {str(frames)[:20]!r} is not a whole number"
    content = entry.get("content")
    if content is not None and not (isinstance(content, str) and DIGEST.fullmatch(content)):
        return f"content {str(content)[:20]!r} is not a SHA-256 digest"
    joints = entry.get("joints", {})
    if not isinstance(joints, dict):
        return "joints is not a table"
    tables = [("", entry, [key for key, _, _ in FIGURES])]
    tables += [
        (f"joint {j[:40]!r}: ", f, [key for key, _ in JOINT_FIGURES]) for j, f in joints.items()
    ]
    for where, table, keys in tables:
        if not isinstance(table, dict):
            return f"{where}not a table of figures"
        for key in keys:
            if not _figure(table.get(key)):
                return f"{where}{key} {str(table.get(key))[:20]!r} is not a number of at least 0"
    return None


def _figures(result: FileResult) -> dict[str, Any]:
    out: dict[str, Any] = {"frames": result.frames}
    out.update({key: getattr(result, key) for key, _, _ in FIGURES})
    out["joints"] = result.joints
    out["content"] = result.content
    return out


def _worse(value: float | None, ref: Any, tolerance: float) -> bool:
    return (
        isinstance(ref, int | float)
        and value is not None
        and value > ref * (1 + tolerance) + ABSOLUTE
    )


def compare_joints(
    now: dict[str, Any], base: dict[str, Any], tolerance: float
) -> list[tuple[str, str, float, float]]:
    """Per joint, the figures that got worse: ``(joint, label, baseline, now)`` rows. A
    smoothing regression on one joint shows here even when the clip's maximum is another
    joint's (a repaired flip, say)."""
    rows = []
    for joint, figures in (now.get("joints") or {}).items():
        ref = (base.get("joints") or {}).get(joint) or {}
        for key, label in JOINT_FIGURES:
            if _worse(figures.get(key), ref.get(key), tolerance):
                rows.append((joint, label, float(ref[key]), float(figures[key])))
    return rows


def compare(
    now: dict[str, Any], base: dict[str, Any], tolerance: float
) -> list[tuple[str, Any, Any, str]]:
    """Rows ``(label, baseline, now, verdict)``; verdict is ok, better, WORSE or CHANGED.
    A baseline without ``content`` (recorded before it was) is compared on the figures."""
    rows: list[tuple[str, Any, Any, str]] = []
    if now.get("frames") != base.get("frames"):
        rows.append(("frames", base.get("frames"), now.get("frames"), "CHANGED"))
    if base.get("content") is not None and now.get("content") != base["content"]:
        rows.append(("content digest", base["content"], now.get("content"), "CHANGED"))
    for key, label, rise_only in FIGURES:
        value, ref = now.get(key), base.get(key)
        if ref is None and value is None:  # nothing measured, then or now (no 3 frames known)
            rows.append((label, None, None, "ok"))
            continue
        if not isinstance(ref, int | float) or value is None:
            rows.append((label, None, value, "CHANGED"))
            continue
        slack = abs(ref) * (tolerance if rise_only else SAME_CLIP) + ABSOLUTE
        if value > ref + slack:
            verdict = "WORSE" if rise_only else "CHANGED"
        elif value < ref - slack:
            verdict = "better" if rise_only else "CHANGED"
        else:
            verdict = "ok"
        rows.append((label, float(ref), value, verdict))
    return rows


def _fmt(value: float | str | None) -> str:
    """A figure as the table shows it; a digest by its first 12 characters."""
    if isinstance(value, str):
        return value[:12]
    return "-" if value is None else f"{value:,.6g}"


def _pair(ref: Any, value: Any) -> tuple[str, str]:
    """A baseline figure and the one now as shown: 6 significant digits, more (up to the
    17 that tell any two floats apart) where 6 would print two different figures alike."""
    if not (is_number(ref) and is_number(value)):
        return _fmt(ref), _fmt(value)
    if float(ref).is_integer() and float(value).is_integer() and max(abs(ref), abs(value)) < 1e15:
        return f"{int(ref):,}", f"{int(value):,}"  # (frames: 2,000,001, not 2,000,001.)
    digits = next(
        (d for d in range(6, 18) if ref == value or f"{ref:.{d}g}" != f"{value:.{d}g}"), 17
    )
    kind = "#," if digits > 6 else ","  # (#: 147,966.0 beside 147,965.5, not 147,966)
    return f"{ref:{kind}.{digits}g}", f"{value:{kind}.{digits}g}"


def _change(ref: Any, value: Any) -> str:
    """The relative change in percent; one that 0.1 % would show as 0 in two digits."""
    if not (is_number(ref) and is_number(value)) or abs(ref) <= ABSOLUTE:  # (no ratio)
        return "-"
    ratio = value / ref - 1
    shown = f"{ratio:+.1%}"
    return f"{ratio * 100:+.1e}%" if ratio and shown in ("+0.0%", "-0.0%") else shown


#: The widest a clip's key is shown in the table (longer ones: "..." and their end).
KEY_WIDTH = 58


def format_check(table: Sequence[tuple[str, list[tuple]]], recorded: bool = False) -> str:
    """The comparison table: one line per clip and figure (``recorded``: values only)."""
    heads = ("recorded",) if recorded else ("baseline", "now", "change", "result")
    rows: list[tuple[str, ...]] = [("clip", "figure", *heads)]
    for key, entries in table:
        shown = key if len(key) <= KEY_WIDTH else "..." + key[3 - KEY_WIDTH :]
        for n, (label, ref, value, verdict) in enumerate(entries):
            base, now = _pair(ref, value)
            cells = (now,) if recorded else (base, now, _change(ref, value), verdict)
            rows.append((shown if n == 0 else "", label, *cells))
    lines = _columns(rows, "<<>" if recorded else "<<>>><")
    return "\n".join([lines[0], "-" * max(map(len, lines)), *lines[1:]])


def _columns(rows: Sequence[Sequence[str]], align: str) -> list[str]:
    """``rows`` of cells as lines of columns two spaces apart, each as wide as its longest
    cell, aligned as ``align`` says ("<" left, ">" right: one per column)."""
    widths = [max(len(row[c]) for row in rows) for c in range(len(align))]
    return [
        "  ".join(f"{cell:{a}{w}}" for cell, a, w in zip(row, align, widths, strict=True)).rstrip()
        for row in rows
    ]


def _percent(tolerance: float) -> str:
    return f"{tolerance * 100:g}%"


def _why(key: str, label: str, ref: Any, value: Any, verdict: str, tolerance: float) -> str:
    base, now = _pair(ref, value)
    if verdict == "WORSE":
        return (
            f"{key}: {label.split(',')[0]} got worse: {base} -> {now} "
            f"({_change(ref, value)}, tolerance {_percent(tolerance)})"
        )
    return (
        f"{key}: {label.split(',')[0]} changed from {base} to {now}: the "
        "clip is not the one of the baseline; rerun with --update if that is intended"
    )


def unchecked_line(baseline: Path, keys: Sequence[str]) -> str:
    """The failure line for the baseline's clips not checked (deleted, or left out of the
    command): a regression check passes only on every clip it recorded."""
    them = "it" if len(keys) == 1 else "them"
    return (
        f"{baseline}: {plural(len(keys), 'recorded clip')} not checked: {listed(list(keys), 3)}; "
        f"check {them} too, or record the baseline without {them} (--update --replace with "
        "the clips to keep)"
    )


def refuse_mixed(
    document: dict[str, Any], tables: Sequence[dict], keys: Sequence[str], baseline: Path
) -> None:
    """Refuse an ``--update`` under another pipeline than the baseline's that leaves some of
    its clips out: the baseline records one pipeline, which every clip's figures are of."""
    kept = sorted(set(document["clips"]) - set(keys))
    if kept and not same_pipeline(document.get("pipeline"), tables):
        raise UsageError(
            f"{baseline}: recorded with another pipeline, which {plural(len(kept), 'clip')} "
            f"not given would keep ({listed(kept, 3)}); to change the pipeline, update every "
            "clip in it, or start a new baseline (--replace, or another file)"
        )


@click.command("check")
@click.argument("clips", nargs=-1, required=True, type=PATH)
@PIPE_OPTION
@STEP_OPTION
@click.option(
    "--baseline",
    required=True,
    type=PATH,
    help="Baseline JSON file with the expected figures per clip.",
)
@click.option(
    "--update",
    is_flag=True,
    help="Record these clips' figures in the baseline (other clips in it are kept; "
    "under another pipeline every clip in it must be given) instead of checking.",
)
@click.option(
    "--replace",
    is_flag=True,
    help="With --update: write a new baseline holding only these clips.",
)
@click.option(
    "--tolerance",
    type=FiniteRange(min=0.0),
    default=DEFAULT_TOLERANCE,
    metavar="T",
    show_default=True,
    help="Relative tolerance: a figure fails above baseline x (1 + T).",
)
@SOURCE_OPTION
@UP_OPTION
@read_options(each_file=True)
def check_command(
    clips: tuple[str, ...],
    pipe: str | None,
    steps: tuple[str, ...],
    baseline: str,
    update: bool,
    replace: bool,
    tolerance: float,
    capture: str,
    up: str | None,
    read: ReadOptions,
) -> None:
    """Clean CLIPs and compare their figures with a baseline, for CI.

    Exit 0 when every clip's noise after cleaning and deviation are within the tolerance
    of the baseline, 1 naming each clip and figure that got worse, and the baseline's clips
    not checked. Nothing is written except the baseline with --update.
    """
    pipeline = pipeline_from_options(pipe, steps, capture)
    baseline_path = Path(baseline)
    if replace and not update:
        raise UsageError("--replace goes with --update")
    if update:
        check_output(baseline, (".json",), "a baseline", (*clips, pipe, *read.files))
    read.refuse_unused(*clips)  # (an option that none of them uses)
    fresh = update and (replace or not baseline_path.exists())
    document = {} if fresh else read_baseline(baseline_path)  # a missing one fails first
    rounded = not fresh and _drop_rounded_digests(document)
    named: dict[str, str] = {}  # a clip named twice is checked once
    for clip in clips:
        named.setdefault(clip_key(clip, baseline_path), clip)
    keys, clips = list(named), tuple(named.values())
    tables = tuple(pipeline.describe())
    if update and not fresh:
        refuse_mixed(document, tables, keys, baseline_path)
    jobs = [Job(os.fspath(c), None, tables, up=up, read=read) for c in clips]
    results: dict[int, FileResult] = dict(run_jobs(jobs, default_workers()))
    echo_warnings(line for result in results.values() for line in result.warnings)
    failures = [str(results[i].error) for i in range(len(jobs)) if results[i].status == "failed"]

    if update:
        raise_failures(failures)  # never write a baseline from a partial run
        kept = {} if fresh else dict(document["clips"])
        kept.update({k: _figures(results[i]) for i, k in enumerate(keys)})
        record = {
            "motionclean": __version__,
            "format": FORMAT,
            "pipeline": list(tables),
            "clips": kept,
        }
        atomic_write(baseline_path, to_json(record))
        recorded = [
            (k, [(label, None, getattr(results[i], key), "recorded") for key, label, _ in FIGURES])
            for i, k in enumerate(keys)
        ]
        click.echo(format_check(recorded, recorded=True))
        others = len(kept) - len(set(keys))
        click.echo(
            f"baseline written: {baseline_path} ({plural(len(keys), 'clip')} recorded"
            + (f", {others} others kept)" if others else ")")
        )
        return

    table: list[tuple[str, list[tuple]]] = []
    problems = list(failures)
    for i, key in enumerate(keys):
        if results[i].status != "ok":
            continue
        given = os.fspath(named[key])  # (errors name the clip as given, the table its key)
        base = document["clips"].get(key)
        if base is None:
            problems.append(
                f"{given}: not in the baseline {baseline_path}; record it with --update "
                "(the other clips in it are kept)"
            )
            continue
        now = _figures(results[i])
        rows = compare(now, base, tolerance)
        table.append((key, rows))
        problems += [
            _why(given, label, ref, value, verdict, tolerance)
            for label, ref, value, verdict in rows
            if verdict in ("WORSE", "CHANGED")
        ]
        if any(verdict == "CHANGED" for *_, verdict in rows):
            continue  # another clip: its joints' figures say nothing of the cleaning
        joints = compare_joints(now, base, tolerance)
        rows += [(f"{joint}: {label}", ref, value, "WORSE") for joint, label, ref, value in joints]
        if joints:
            shown = ", ".join(
                f"{joint} {label.split(',')[0]} {' -> '.join(_pair(ref, value))}"
                for joint, label, ref, value in joints[:3]
            )
            more = f" and {plural(len(joints) - 3, 'more figure')}" if len(joints) > 3 else ""
            problems.append(
                f"{given}: {plural(len(joints), 'figure')} of "
                f"{plural(len({j for j, *_ in joints}), 'joint')} got worse "
                f"(tolerance {_percent(tolerance)}): {shown}{more}"
            )
    unchecked = sorted(set(document["clips"]) - set(keys))
    if unchecked:
        problems.append(unchecked_line(baseline_path, unchecked))
    if table:
        click.echo(format_check(table))
    if not same_pipeline(document.get("pipeline"), tables):
        click.echo("note: the pipeline differs from the one the baseline was recorded with")
    if rounded:
        click.echo(
            f"note: the baseline's content digests are of format {ROUNDED_DIGESTS}, not "
            "compared (the clips are checked on their figures); --update records them anew"
        )
    if not problems:
        click.echo(
            f"check passed: {len(keys)} clip{'s' if len(keys) != 1 else ''} within "
            f"{_percent(tolerance)} of {baseline_path}"
        )
    raise_failures(problems)
