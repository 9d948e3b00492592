"""``motionclean batch``: every clip under a folder, in parallel, into a mirrored folder tree.

The per-clip work is :func:`motionclean.run.jobs.clean_file` (a picklable
:class:`~motionclean.run.jobs.Job` in, a small :class:`~motionclean.run.jobs.FileResult` out,
never raising for a bad clip), run on the local pool of :mod:`motionclean.run.pool`. The
command never writes inside IN_DIR, writes every file atomically, keeps going when a clip
fails, and exits 1 naming each failure.
"""

from __future__ import annotations

import dataclasses
import errno
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from fnmatch import fnmatchcase
from pathlib import Path, PurePosixPath
from typing import NamedTuple

import click

from ..core.errors import MotionError, UsageError
from ..core.words import columns, last_columns, pad, plural
from ..io import FORMATS, ReadOptions, atomic_write, remove_temporaries
from ..report.html import index_entries, page_carried, render_index
from ..report.terminal import figure_text
from ..run import cluster
from ..run.jobs import INDEX_FIGURES, WARNING, FileResult, Job, missing_folders, remove_empty
from ..run.pool import default_workers, input_size, run_jobs
from .options import (
    FOLDER_PATH,
    PIPE_OPTION,
    SOURCE_OPTION,
    STEP_OPTION,
    UP_OPTION,
    check_target,
    echo_warnings,
    pipeline_from_options,
    raise_failures,
    read_options,
    refuse_shared,
)

#: Clips ``batch`` takes when no ``--glob`` is given: every suffix motionclean reads.
DEFAULT_GLOBS = tuple(f"*{suffix}" for suffix in FORMATS)
#: Without ``--jobs``, a batch of less input than this (bytes; about 5,000 frames of a
#: 31-joint BVH) runs in this process: starting workers and handing clips out would cost
#: about what a second core gains on so little work.
SMALL_BATCH_BYTES = 4 << 20


def default_jobs(sizes: Sequence[int], cores: int) -> int:
    """Workers for clips of ``sizes`` bytes when ``--jobs`` is not given: one for a small
    batch (:data:`SMALL_BATCH_BYTES`), else one per core, at most one per clip."""
    if sum(sizes) < SMALL_BATCH_BYTES:
        return 1
    return max(1, min(cores, len(sizes)))


def cluster_note(started: float, results: Sequence[FileResult], workers: int) -> str | None:
    """A line saying so when starting a local cluster took longer than the cleaning it ran
    (``started`` seconds; the clips' own seconds spread over ``workers``), else None."""
    work = sum(r.seconds for r in results if r.status != "skipped")
    each = work / max(workers, 1)
    if started <= each:
        return None
    spent = f"{each:.1f} s each of its {workers} workers" if workers > 1 else f"{each:.1f} s it"
    return (
        f"note: starting the local Dask cluster took {started:.1f} s, longer than the "
        f"{spent} spent cleaning ({work:.1f} s of clips); on one machine --jobs (the default) "
        "does the same without it. A cluster pays off when the clips outgrow one machine's "
        "cores."
    )


# ----------------------------------------------------------------------------- the command


class Found(NamedTuple):
    """What :func:`find_clips` found under a folder, paths relative to it, sorted."""

    clips: list[PurePosixPath]
    linked: list[PurePosixPath]  # symbolic links to folders, not followed


def find_clips(root: Path, patterns: Sequence[str]) -> Found:
    """Clip paths under ``root``, relative to it, sorted: those whose relative path matches
    one of ``patterns`` (:func:`glob_match`). Hidden files and folders (name starting with
    ".") are left out; symbolic links to folders are not followed (a link may loop back,
    or lead to a folder twice): they are listed apart."""
    split = [glob_parts(p) for p in patterns]
    found, linked = [], []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        base = PurePosixPath(Path(folder).relative_to(root).as_posix())
        linked += [base / d for d in dirs if os.path.islink(os.path.join(folder, d))]
        for name in files:
            if name.startswith("."):
                continue
            rel = base / name
            lowered = tuple(part.lower() for part in rel.parts)
            if any(glob_match(lowered, p) for p in split):
                found.append(rel)
    return Found(sorted(found), sorted(linked))


def linked_note(root: str, linked: Sequence[PurePosixPath]) -> str:
    """The folders under ``root`` (as given) that are symbolic links, not followed, in a
    few words: ``; 1 linked folder not followed: in/ext (batch it on its own)``."""
    shown = ", ".join(os.fspath(Path(root) / rel) for rel in linked[:3])
    more = f" and {len(linked) - 3} more" if len(linked) > 3 else ""
    it = "it" if len(linked) == 1 else "each"
    return (
        f"{plural(len(linked), 'linked folder')} not followed: {shown}{more} (a link to a "
        f"folder may loop back; batch {it} on its own)"
    )


def glob_parts(pattern: str) -> tuple[str, ...]:
    """A ``--glob`` pattern as the path components it matches, lower case: one without "/"
    is the file name at any depth (``*.bvh`` is ``**/*.bvh``)."""
    pattern = pattern.lower()
    if "/" not in pattern:
        return ("**", pattern)
    return PurePosixPath(pattern).parts


def glob_match(parts: tuple[str, ...], pattern: tuple[str, ...]) -> bool:
    """Whether a relative path's components ``parts`` (lower case) match ``pattern``'s
    (:func:`glob_parts`) whole: ``*``, ``?`` and ``[...]`` within one component (fnmatch), a
    ``**`` component any number of folders, none included (last: everything below it)."""
    if not pattern:
        return not parts
    head, rest = pattern[0], pattern[1:]
    if head == "**":
        return bool(parts) and (
            not rest or any(glob_match(parts[k:], rest) for k in range(len(parts)))
        )
    return bool(parts) and fnmatchcase(parts[0], head) and glob_match(parts[1:], rest)


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or path.is_relative_to(folder)


def _check_folders(in_dir: Path, out_dir: Path, report_dir: Path | None) -> None:
    """Refuse any layout that could write inside IN_DIR (usage errors); nothing is made."""
    if not in_dir.exists():
        raise UsageError(f"{in_dir}: no such folder")
    if not in_dir.is_dir():
        raise UsageError(f"{in_dir}: not a folder")
    source = in_dir.resolve()
    for option, folder in (("-o", out_dir), ("--report-dir", report_dir)):
        if folder is None:
            continue
        if folder.exists() and not folder.is_dir():
            raise UsageError(f"{folder}: {option} must be a folder")
        if folder.is_symlink() and not folder.exists():  # its target's folders: not made
            raise UsageError(
                f"{folder}: {option} is a symbolic link to {os.readlink(folder)!r}, which "
                "does not exist"
            )
        _check_makeable(folder, option)

        if _inside(folder.resolve(), source):
            raise UsageError(
                f"{folder}: {option} is inside the input folder {in_dir}; "
                "batch never writes there, choose a folder outside it"
            )


def _check_makeable(folder: Path, option: str) -> None:
    """Refuse a folder that cannot be made (UsageError, as :func:`_make_folders` would say
    it), without making it: a file where a parent folder should be, or a parent that cannot
    be written. Checked up front, before a scheduler is asked for workers."""
    parent = folder
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if parent == folder:
        return  # (there: checked as a folder already)
    if not parent.is_dir():
        raise UsageError(f"{folder}: cannot create {option}: {os.strerror(errno.ENOTDIR)}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{folder}: cannot create {option}: {os.strerror(errno.EACCES)}")


def _make_folders(out_dir: Path, report_dir: Path | None) -> None:
    """Make OUT_DIR and the ``--report-dir``, once all is checked."""
    for option, folder in (("-o", out_dir), ("--report-dir", report_dir)):
        if folder is None:
            continue
        try:  # once, up front: a folder that cannot be made fails no clip after clip
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise UsageError(f"{folder}: cannot create {option}: {error.strerror}") from None


@contextmanager
def _progress(total: int) -> Iterator[Callable[[str], None]]:
    """A progress bar on stderr when it is a terminal; otherwise nothing is shown.

    Yields ``advance(name)``, called once per finished clip.
    """
    stream = sys.stderr
    if total == 0 or not stream.isatty():
        yield lambda _name: None
        return
    with click.progressbar(
        length=total, label="cleaning", file=stream, show_pos=True, item_show_func=lambda name: name
    ) as bar:
        yield lambda name: bar.update(1, name)


def format_summary(rows: Sequence[tuple[str, FileResult]], seconds: float, workers: int) -> str:
    """The end-of-run table: one line per clip, then the totals."""
    width = min(max((columns(name) for name, _ in rows), default=4) + 2, 60)
    head = (
        f"{'file':<{width}}{'frames':>8}{'noise before':>14}{'after':>12}{'removed':>9}"
        f"{'change':>9}  {'verdict':<14}status"
    )
    lines = [head, "-" * len(head)]
    for name, r in rows:
        shown = name if columns(name) < width - 1 else "..." + last_columns(name, width - 5)
        # (a skipped clip shows the figures its earlier run left, where they were found)
        if r.status == "ok" or (r.status == "skipped" and r.frames is not None):
            before, after = r.noise_before, r.noise_after
            removed = None  # (None: nothing measured, no three frames in a row known)
            if before is not None and after is not None:
                removed = 1.0 - after / before if before else 0.0
            if r.jitter_removed is not None:  # the verdict's figures, outside repairs
                before, after, removed = r.jitter_before, r.jitter_after, r.jitter_removed
            change = r.deviation_max if r.change_max is None else r.change_max
            lines.append(
                f"{pad(shown, width)}{r.frames:>8}{figure_text(before, 14, ',.0f')}"
                f"{figure_text(after, 12, ',.0f')}{figure_text(removed, 9, '.0%')}"
                f"{figure_text(change, 9, '.2f')}  {r.verdict_status or '-':<14}"
                + ("ok" if r.status == "ok" else r.status.upper())
            )
        else:
            blank = f"{'-':>8}{'-':>14}{'-':>12}{'-':>9}{'-':>9}  {'-':<14}"
            lines.append(f"{pad(shown, width)}{blank}{r.status.upper()}")
    counts = {s: sum(r.status == s for _, r in rows) for s in ("ok", "skipped", "failed")}
    lines.append("-" * len(head))
    lines += [f"{name}: {r.verdict}" for name, r in rows if r.verdict_status == "needs a look"]
    plural = "s" if len(rows) != 1 else ""
    lines.append(
        f"{len(rows)} clip{plural}: {counts['ok']} cleaned, {counts['skipped']} "
        f"skipped, {counts['failed']} failed in {seconds:.1f} s on {workers} worker"
        f"{'s' if workers != 1 else ''} (noise: RMS angular acceleration, deg/s^2; "
        "change: degrees; all outside repairs, as in each clip's verdict)"
    )
    return "\n".join(lines)


@click.command("batch")
@click.argument("in_dir", type=FOLDER_PATH)
@click.option(
    "-o",
    "--output",
    "out_dir",
    required=True,
    metavar="OUT_DIR",
    type=FOLDER_PATH,
    help="Folder for the cleaned clips; IN_DIR's tree is mirrored under it.",
)
@PIPE_OPTION
@STEP_OPTION
@click.option(
    "-j",
    "--jobs",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="Worker processes (default: the number of cores, or this process alone for a "
    "batch of less than 4 MiB of clips, where workers cost more than they gain).",
)
@click.option(
    "--glob",
    "patterns",
    multiple=True,
    metavar="PATTERN",
    help="Which files are clips, matched on the whole path relative to IN_DIR, "
    "case-insensitive: * and ? within a folder or file name, ** any number of folders "
    "(walk/**/*.bvh); a pattern without / matches the file name at any depth; repeatable "
    f"(default: every suffix motionclean reads, {' '.join(DEFAULT_GLOBS)}).",
)
@click.option(
    "--report-dir",
    type=FOLDER_PATH,
    metavar="DIR",
    help="Also write an HTML page per clip (mirrored tree) and index.html here.",
)
@click.option(
    "--skip-existing",
    is_flag=True,
    help="Leave clips whose output (and page) already exists: resumes a run.",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    default=None,
    help="Run the clips as tasks on a Dask cluster: a scheduler address such as "
    "tcp://HOST:8786 (workers read and write the same paths: shared storage), or local[:N] "
    "for a cluster of N processes on this machine. Needs the dask extra.",
)
@SOURCE_OPTION
@UP_OPTION
@click.option("-q", "--quiet", is_flag=True, help="Do not print the summary table.")
@read_options(each_file=True)
def batch_command(
    in_dir: str,
    out_dir: str,
    pipe: str | None,
    steps: tuple[str, ...],
    jobs: int | None,
    patterns: tuple[str, ...],
    report_dir: str | None,
    skip_existing: bool,
    scheduler: str | None,
    capture: str,
    up: str | None,
    quiet: bool,
    read: ReadOptions,
) -> None:
    """Clean every clip under IN_DIR into OUT_DIR, in parallel.

    Clips are found recursively; the folder tree is mirrored under OUT_DIR and nothing is
    ever written inside IN_DIR. A clip that fails is named on stderr and the others go on;
    the exit code is then 1. Without -p or -f the default pipeline runs.
    """
    pipeline = pipeline_from_options(pipe, steps, capture)
    source_root, out_root = Path(in_dir), Path(out_dir)
    pages = Path(report_dir) if report_dir else None
    _check_folders(source_root, out_root, pages)
    clips, linked = find_clips(source_root, patterns or DEFAULT_GLOBS)
    if not clips:
        shown = ", ".join(patterns or DEFAULT_GLOBS)
        if any("/" in p for p in patterns):
            shown += " (the whole path below it: * within one name, ** any number of folders)"
        if linked:
            shown += f"; {linked_note(in_dir, linked)}"
        raise UsageError(f"{in_dir}: no clips matching {shown}")
    read.refuse_unused(*(source_root / rel for rel in clips))  # (an option none of them uses)
    resolved_in = source_root.resolve()

    def check_written(written: Path) -> None:
        """Refuse an output that lands in IN_DIR (through a link too) and, where its folder
        exists (one of the mirrored tree still to be made holds nothing), what
        :func:`check_target` refuses of it alone: a folder (the files read are checked
        against every output at once, below)."""
        if _inside(written.resolve(), resolved_in):
            raise UsageError(f"{written}: would be written inside the input folder {in_dir}")
        if written.parent.exists():
            check_target(written)

    written_all: list[Path] = []  # every file the batch writes: none may be another
    if pages is not None:
        check_written(pages / "index.html")
        written_all.append(pages / "index.html")
    tables = tuple(pipeline.describe())
    work: list[Job] = []
    work_names: list[str] = []
    results: dict[str, FileResult] = {}
    for rel in clips:
        source, target = source_root / rel, out_root / rel
        page = None if pages is None else pages / f"{rel}.html"
        for written in (target, page):
            if written is not None:
                check_written(written)
                written_all.append(written)
        if skip_existing and target.exists() and (page is None or page.exists()):
            results[str(rel)] = FileResult(
                str(source), str(target), "skipped", report=None if page is None else str(page)
            )
            continue
        report_page = None if page is None else str(page)
        # (absolute: a Dask worker runs in a folder of its own)
        back = "../" * (len(Path(rel).parts) - 1) + "index.html"  # from the clip's page
        job = Job(str(source), str(target), tables, report_page, up, read, index=back)
        work.append(job.absolute())
        work_names.append(str(rel))

    if pages is not None:  # (a folder IN_DIR/index.html would make the index a folder)
        under = next((w for w in written_all if pages / "index.html" in w.parents), None)
        if under is not None:
            raise UsageError(
                f"{under}: would make {pages / 'index.html'}, the batch's index page, a "
                "folder (rename the input folder index.html, or give another --report-dir)"
            )
    read_too = [*read.files, *([pipe] if pipe is not None else [])]
    refuse_shared(written_all, [*(source_root / rel for rel in clips), *read_too])
    if scheduler is not None and jobs is not None:
        raise UsageError("use either --jobs N (local processes) or --scheduler, not both")
    if scheduler is not None:
        cluster.parse_scheduler(scheduler)  # a bad address fails before any work
    start = time.perf_counter()
    note = lost = None
    outputs = [path for job in work for path in (job.target, job.report) if path]
    made = missing_folders(Path(path).parent for path in outputs)  # (by the run: see finally)
    try:
        with _progress(len(work)) as advance:
            if scheduler is None or not work:  # nothing to send: no cluster to start
                _make_folders(out_root, pages)
                workers = min(
                    jobs or default_jobs(sizes(work), default_workers()), max(len(work), 1)
                )
                for index, result in run_jobs(work, workers):
                    results[work_names[index]] = result
                    advance(work_names[index])
            else:
                with cluster.connect(scheduler, default_workers(), len(work)) as (client, workers):
                    _make_folders(out_root, pages)  # (once the scheduler answered)
                    started = time.perf_counter() - start
                    if not quiet:
                        click.echo(f"Dask dashboard: {client.dashboard_link}")
                    for index, result in cluster.run_jobs_on(client, work):
                        results[work_names[index]] = result
                        advance(work_names[index])
                if cluster.parse_scheduler(scheduler)[0] == "local":
                    note = cluster_note(started, [results[n] for n in work_names], workers)
    except cluster.ClusterLost as error:  # one line for the clips not done, after the others
        lost = str(error)
        for index in error.not_done:  # named as the command line gave their folder
            lost = lost.replace(work[index].source, os.fspath(source_root / work_names[index]))
            results[work_names[index]] = FileResult(
                work[index].source, work[index].target, "failed"
            )
    finally:  # a worker killed while writing leaves its temporary file: none stays
        remove_temporaries(outputs)
        remove_empty(made)  # folders made for outputs not written (out/shoot_02/day 2/)
    seconds = time.perf_counter() - start

    others = 0
    if pages is not None and skip_existing:
        others = sum(_keep_figures(results, pages, tables).values())
    rows = [(str(rel), results[str(rel)]) for rel in clips]
    unwritten = None  # (the index's own failure, told after the clips', never instead)
    if pages is not None:
        try:
            _write_index(pages, rows, tables, in_dir)
        except (MotionError, OSError) as error:
            unwritten = str(error) if isinstance(error, MotionError) else f"{pages}: {error}"
    if not quiet:
        click.echo(format_summary(rows, seconds, workers))
        if note:
            click.echo(note)
        if linked:
            click.echo(f"note: {linked_note(in_dir, linked)}")
        if others:
            click.echo(
                f"{plural(others, 'clip')} kept from an earlier run with another pipeline "
                f"(rerun without --skip-existing to clean {'it' if others == 1 else 'them'} "
                "with this one)"
            )
    echo_warnings(
        WARNING + _as_given(line.removeprefix(WARNING), Path(in_dir) / name)
        for name, result in rows
        for line in result.warnings
    )
    failures = [
        _as_given(str(r.error), Path(in_dir) / name)
        for name, r in rows
        if r.status == "failed" and r.error
    ]
    raise_failures(failures + ([lost] if lost else []) + ([unwritten] if unwritten else []))


def _as_given(error: str, clip: Path) -> str:
    """A clip's error (or warning) line naming it as the command line gave its folder, not
    by the absolute path its job was given (a Dask worker runs in a folder of its own)."""
    absolute = os.fspath(clip.absolute())
    if error.startswith(absolute + ":"):
        return os.fspath(clip) + error[len(absolute) :]
    return error


def sizes(work: Sequence[Job]) -> list[int]:
    """Input sizes of the clips to clean, bytes."""
    return [input_size(job.source) for job in work]


def _kept(value, kind: type):
    """``value`` read from an index page or a clip's page if it is of ``kind`` (a whole
    number is a float too; a bool is no number), else None."""
    if isinstance(value, bool) or value is None:
        return None
    if kind is float and isinstance(value, int):
        return float(value)
    return value if isinstance(value, kind) else None


def _keep_figures(
    results: dict[str, FileResult], pages: Path, tables: Sequence[dict]
) -> dict[str, bool]:
    """Give each skipped clip, in place, the figures the run that cleaned it left (same
    pipeline): its entry in the index page, or, where that run wrote no index (it was
    interrupted) or the index lacks them, its own page's; so a resumed run's index and
    table stay whole. A clip neither holds keeps none (the index says so). Returns, per
    clip whose page was read, whether it says another pipeline made it."""
    try:
        earlier = index_entries((pages / "index.html").read_text(encoding="utf-8"), tables)
    except (OSError, UnicodeDecodeError):
        earlier = {}
    read = {}
    for name, result in results.items():
        if result.status != "skipped":
            continue
        entry = earlier.get(name)
        if not entry or entry.get("status") == "failed" or entry.get("frames") is None:
            entry, read[name] = page_carried(pages / f"{name}.html", tables)
        if entry:
            kept = {key: _kept(entry.get(key), kind) for key, kind in INDEX_FIGURES.items()}
            results[name] = dataclasses.replace(result, **kept)
    return read


def _write_index(
    pages: Path, rows: Sequence[tuple[str, FileResult]], tables: Sequence[dict], in_dir: str
) -> None:
    entries = []
    for name, r in rows:
        page = pages / f"{name}.html"
        href = f"{name}.html" if r.status != "failed" and page.exists() else None
        entries.append(
            {"file": name, "href": href, **r.index_figures(), "status": r.status, "error": r.error}
        )
    pages.mkdir(parents=True, exist_ok=True)
    index = render_index(entries, list(tables), f"motionclean batch: {in_dir}")
    atomic_write(pages / "index.html", index.encode("utf-8"))
