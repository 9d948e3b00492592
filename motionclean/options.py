"""Command-line pieces shared by the commands: pipeline options, output checks, cleaning
one clip, reports."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import click

from .errors import UsageError
from .html import render_html
from .io import FORMATS, atomic_write, load, save
from .motion import Motion
from .pipeline import Pipeline, StepLog
from .report import build_report, build_series, to_json

REPORT_SUFFIXES = (".json", ".html", ".htm")


def pipeline_from_options(pipe: str | None, steps: tuple[str, ...]) -> Pipeline:
    """The pipeline from ``-p`` or ``-f``, or the default one; validated, no clip read."""
    if pipe and steps:
        raise UsageError("use either -p PIPE.toml or -f STEP, not both")
    if pipe:
        return Pipeline.from_toml(pipe)
    if steps:
        return Pipeline.from_inline(list(steps))
    return Pipeline.default()


def refuse_overwrite(source: Path, target: Path, in_place: bool) -> None:
    """Raise unless ``target`` is a different file from ``source`` or ``in_place`` is set."""
    same = target.exists() and source.exists() and target.resolve() == source.resolve()
    if same and not in_place:
        raise UsageError(f"{target}: refusing to overwrite the input; pass --in-place to do so")


def check_output(path: str | Path, suffixes: tuple[str, ...], what: str) -> Path:
    """Refuse, before any work is done, an output with another suffix or in no folder."""
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise UsageError(f"{path}: {what} must end in {' or '.join(suffixes)}")
    if not path.parent.is_dir():
        raise UsageError(f"{path}: no folder {str(path.parent)!r} to write into")
    return path


def check_clip_output(path: str | Path) -> Path:
    return check_output(path, FORMATS, "a clip")


def check_report_output(path: str | Path) -> Path:
    return check_output(path, REPORT_SUFFIXES, "a report")


def write_report(report: dict, path: Path, series: dict | None = None) -> None:
    """Write a report as JSON or HTML, by extension; ``series`` feeds the HTML plots."""
    if check_report_output(path).suffix.lower() == ".json":
        atomic_write(path, to_json(report))
    else:
        atomic_write(path, render_html(report, series).encode("utf-8"))


@dataclass
class CleanedClip:
    """One clip before and after a pipeline, what each step did, and the report figures."""

    before: Motion
    after: Motion
    logs: list[StepLog]
    report: dict
    series: dict


def clean_clip(
    source: str | os.PathLike, target: str | os.PathLike | None, pipeline: Pipeline
) -> CleanedClip:
    """Load ``source``, run ``pipeline``, write ``target`` (atomically; its folder is
    created) unless it is None, and compute the report and its time series."""
    before = load(source)
    after, logs = pipeline.run(before)
    if target is not None:
        Path(target).parent.mkdir(parents=True, exist_ok=True)
        save(after, target)
    series = build_series(before, after)
    report = build_report(
        before, after, pipeline.describe(), notes_by_joint(logs), os.fspath(source), series=series
    )
    return CleanedClip(before, after, logs, report, series)


def notes_by_joint(logs) -> dict[str, dict]:
    """Merge each step's per-joint notes into one dict for the report."""
    merged: dict[str, dict] = {}
    for log in logs:
        for joint, note in log.notes.items():
            merged.setdefault(joint, {}).update(note)
    return merged


PIPE_OPTION = click.option(
    "-p",
    "--pipeline",
    "pipe",
    type=click.Path(dir_okay=False),
    help="Pipeline TOML file with [[step]] tables (see README).",
)
STEP_OPTION = click.option(
    "-f",
    "--filter",
    "steps",
    multiple=True,
    metavar="STEP",
    help="Inline step NAME:key=value,...; repeatable, applied in order.",
)
