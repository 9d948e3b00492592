"""Clip-level services, free of the command line: clean a clip with its report, the
picklable per-clip job every batch worker runs, and blending or stitching two clips.

This is what ``clean``, ``batch`` and ``check`` call, and what Python users call::

    from motionclean.run.jobs import clean_clip, clean_file, stitch_clips
    result = clean_clip("take.bvh", "take_clean.bvh", Pipeline.default())
    record = clean_file("take.bvh", "out/take.bvh", Pipeline.default(), report="take.html")
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
import warnings
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..core import kinematics, quat
from ..core.errors import MotionError
from ..core.motion import Motion, joint_major_zeros, written_joints
from ..core.rates import same_rate
from ..core.reserve import keep_reserve, let_go
from ..filters import multires
from ..io import ReadOptions, declare_up, encode, ensure_folder, write_together
from ..report.html import render_html
from ..report.summary import build_report, build_series, gap_notes, to_json
from ..report.verdict import repaired_frames, repaired_positions
from ..steps.pipeline import Pipeline, StepLog
from ..steps.resampling import on_input_frames
from .memory import return_free_memory

__all__ = [
    "CleanedClip",
    "FileResult",
    "INDEX_FIGURES",
    "Job",
    "blend_clips",
    "check_compatible",
    "pattern_warnings",
    "clean_clip",
    "clean_file",
    "clean_motion",
    "content_digest",
    "folders_for",
    "missing_folders",
    "notes_by_joint",
    "remove_empty",
    "run_job",
    "stitch_clips",
]


def render_report(
    report: dict,
    path: str | os.PathLike,
    series: dict | None = None,
    carried: dict | None = None,
) -> bytes:
    """A report's file content: JSON for ``.json``, else the HTML page (``series`` feeds its
    plots, ``carried`` goes in its head: :func:`~motionclean.report.html.render_html`)."""
    if Path(path).suffix.lower() == ".json":
        return to_json(report)
    return render_html(report, series, carried).encode("utf-8")


def write_outputs(
    clip: Motion, target: str | os.PathLike | None, reports: dict[str, bytes], tidy: bool = True
) -> None:
    """Write the cleaned clip and its reports together (:func:`~motionclean.io.write_together`):
    every one is rendered and written to a temporary file first, then all are renamed; when
    one cannot be written none is, and an existing output (the input itself with
    ``--in-place``) is replaced only when all are ready. Missing folders are made, and
    removed again if they stay empty (``tidy``, :func:`folders_for`)."""
    return_free_memory()  # what the report's work freed: the clip's text starts afresh
    files: dict[str | os.PathLike, bytes | Iterable[bytes | memoryview]] = {}
    if target is not None:
        files[target] = encode(clip, target)
    files.update(reports)
    with folders_for(files, tidy):
        write_together(files, make_folders=True)  # (again, when a concurrent write tidied)


@contextmanager
def folders_for(paths: Iterable[str | os.PathLike], tidy: bool = True) -> Iterator[None]:
    """Make the folders of ``paths`` (:func:`make_folder`) for the body, which writes them;
    when making one or the body fails, those made here that are still empty are removed
    (with ``tidy``; a batch does it once its workers are done), as a failed write had left
    them (``out/shoot_02/day 2/``). A concurrent writer about to write into one makes it
    again (:func:`write_outputs`, :data:`~motionclean.io.FOLDER_TRIES`)."""
    folders = list(dict.fromkeys(Path(path).parent for path in paths))  # (a clip and its page)
    made = missing_folders(folders) if tidy else []
    try:
        for folder in folders:
            make_folder(folder)
        yield
    except BaseException:
        remove_empty(made)
        raise


def missing_folders(folders: Iterable[str | os.PathLike]) -> list[Path]:
    """Those of ``folders`` and their parents that are not there (making them makes them),
    deepest first."""
    missing: set[Path] = set()
    for folder in set(map(Path, folders)):  # (a batch's thousand clips share a few)
        while folder not in missing and folder != folder.parent and not os.path.lexists(folder):
            missing.add(folder)
            folder = folder.parent
    return sorted(missing, key=lambda folder: len(folder.parts), reverse=True)


def remove_empty(folders: Iterable[Path]) -> None:
    """Remove each of ``folders``, in turn, that is an empty folder (deepest first, a parent
    its emptied children leave empty goes too); any other stays."""
    for folder in folders:
        with suppress(OSError):  # not empty, not there, not a folder: left as it is
            folder.rmdir()


def make_folder(folder: Path) -> None:
    """Make ``folder`` and its missing parents; one that cannot be made raises
    :class:`OSError` naming it and saying so (the bare error had read only
    "FOLDER: Operation not permitted")."""
    try:
        ensure_folder(folder)  # (again, when a concurrent write removed it meanwhile)
    except OSError as error:
        raise OSError(
            error.errno, f"cannot create this folder: {error.strerror}", error.filename or folder
        ) from None


@dataclass
class CleanedClip:
    """One clip before and after a pipeline, what each step did, and the report figures."""

    before: Motion
    after: Motion
    logs: list[StepLog]
    report: dict
    series: dict


def notes_by_joint(logs: Sequence[StepLog]) -> dict[str, dict]:
    """Merge each step's per-joint notes into one dict for the report."""
    merged: dict[str, dict] = {}
    for log in logs:
        for joint, note in log.notes.items():
            merged.setdefault(joint, {}).update(note)
    return merged


def _repaired_input_frames(
    logs: Sequence[StepLog], before: Motion, positions: bool = False
) -> dict[str, np.ndarray]:
    """Per joint, the ``(F,)`` mask of the input's frames a repairing step changed
    (:func:`~motionclean.report.verdict.repaired_frames`; ``positions``: of its position
    channels, :func:`~motionclean.report.verdict.repaired_positions`), so the report tells
    repairs apart from smoothing. A step after a change of frame rate numbers the frames of
    its clip: an input frame counts as repaired where either of the step's frames around its
    time was."""
    masks: dict[str, np.ndarray] = {}
    read = repaired_positions if positions else repaired_frames
    for log in logs:
        found = read(log.notes, log.n_frames)
        if found and (log.n_frames, log.frame_time) != (before.n_frames, before.frame_time):
            at = np.arange(before.n_frames) * (before.frame_time / log.frame_time)
            below = np.minimum(np.floor(at).astype(np.intp), log.n_frames - 1)
            above = np.minimum(below + 1, log.n_frames - 1)
            found = {name: mask[below] | mask[above] for name, mask in found.items()}
        for name, mask in found.items():
            masks[name] = masks[name] | mask if name in masks else mask
    return masks


def clean_clip(
    source: str | os.PathLike,
    target: str | os.PathLike | None,
    pipeline: Pipeline,
    up: str | None = None,
    read: ReadOptions | None = None,
) -> CleanedClip:
    """Load ``source``, run ``pipeline`` (:func:`clean_motion`), and write ``target``
    (atomically; its folder is created) unless it is None. Nothing is written when the
    report cannot be made. ``up`` (``"x"``, ``"y"``, ``"z"``) declares the clip's up axis
    (:attr:`Motion.up`; default: found from the motion); ``read`` says how to read files
    that need more than themselves (a skeleton, a body model, excluded columns)."""
    before = (read or ReadOptions()).load(source)
    before = declare_up(before, up)
    try:
        result = clean_motion(before, pipeline, os.fspath(source))
        if target is not None:
            write_outputs(result.after, target, {})
    except MemoryError as error:
        let_go(error)  # room to travel up
        raise
    return result


def clean_motion(before: Motion, pipeline: Pipeline, file: str) -> CleanedClip:
    """Run ``pipeline`` on ``before`` and compute the report (named after ``file``) and its
    time series: what ``clean`` does between reading and writing, and what the Blender
    extension does to an action. A resampled clip is compared with the input on the
    input's frames (:func:`motionclean.steps.resampling.on_input_frames`); the report's
    ``output`` then gives the written frame count and frame time."""
    after, logs = pipeline.run(before)
    return_free_memory()  # the pipeline's freed blocks: the report's work starts afresh
    compared = on_input_frames(before, after)
    notes = notes_by_joint(logs)
    if compared is after:  # dropouts no step filled (on the input's frames only)
        for joint, note in gap_notes(before, after).items():
            notes.setdefault(joint, {}).setdefault("fill-gaps", note["fill-gaps"])
    repairs = _repaired_input_frames(logs, before)
    position_repairs = _repaired_input_frames(logs, before, positions=True)
    series = build_series(before, compared, repairs, position_repairs, _level_turn(logs))
    return_free_memory()  # the series' per-frame tables
    described = pipeline.describe()
    for entry, log in zip(described, logs, strict=True):
        if log.frames is not None:  # the range as frames (seconds=[1, 2]: [120, 240])
            entry["frames"] = list(log.frames)
        if log.touched is not None:
            entry["touched"] = list(log.touched)
    report = build_report(before, compared, described, notes, file, series=series)
    if compared is not after:
        report["output"] = {"frames": after.n_frames, "frame_time": after.frame_time}
    return CleanedClip(before, after, logs, report, series)


def _level_turn(logs: Sequence[StepLog]) -> np.ndarray | None:
    """The turn one ``ground`` step gave the roots of the whole clip to level the floor
    (its note's ``turn``, ``(w, x, y, z)``), or None: no floor levelled, or levelled other
    than by one turn of every frame (each take its own, a range, two ``ground`` steps),
    whose roots' change is then told as the cleaning's."""
    turns = [
        (log, note["position_ground"]["turn"])
        for log in logs
        if log.step.spec.name == "ground"
        for note in log.notes.values()
        if "turn" in note.get("position_ground", {})
    ]
    if len(turns) != 1 or turns[0][0].frames is not None or len(turns[0][1]) != 4:
        return None
    return np.asarray(turns[0][1], dtype=np.float64)


#: The figures of a cleaned clip a batch index shows, and the type of each: what the clip's
#: page carries (:func:`clean_file`) for a resumed batch, which takes values of that type.
INDEX_FIGURES: dict[str, type] = {
    "frames": int,
    "noise_before": float,
    "noise_after": float,
    "deviation_max": float,
    "jitter_before": float,
    "jitter_after": float,
    "jitter_removed": float,
    "change_max": float,
    "verdict": str,
    "verdict_status": str,
}


@dataclass(frozen=True)
class FileResult:
    """What happened to one clip. Figures are ``None`` unless the clip was cleaned.

    ``noise_*``: RMS angular acceleration over all joints and frames (deg/s^2);
    ``deviation_*``: rotation angle between input and output over all joints (degrees).
    ``error`` is the one-line ``FILE[:LINE]: reason`` of a failure.
    """

    source: str
    target: str | None
    status: str  # "ok", "skipped" or "failed"
    frames: int | None = None
    noise_before: float | None = None
    noise_after: float | None = None
    deviation_max: float | None = None
    deviation_rms: float | None = None
    report: str | None = None
    error: str | None = None
    seconds: float = 0.0
    joints: dict[str, dict[str, float]] | None = None  # per joint: noise_after, deviation_max
    verdict: str | None = None  # the report's verdict line (motionclean.report.verdict)
    verdict_status: str | None = None  # clean, repaired, cleaned or needs a look
    # the verdict's figures, outside repairs: RMS angular acceleration before and after
    # (deg/s^2), the fraction removed, the largest change (degrees)
    jitter_before: float | None = None
    jitter_after: float | None = None
    jitter_removed: float | None = None
    change_max: float | None = None
    warnings: tuple[str, ...] = ()  # one line each: motionclean: warning: FILE: ...
    content: str | None = None  # the input's content_digest

    def index_figures(self) -> dict[str, Any]:
        """The :data:`INDEX_FIGURES` of this clip."""
        return {key: getattr(self, key) for key in INDEX_FIGURES}


def content_digest(motion: Motion) -> str:
    """SHA-256 (hex) of what a clip holds as read: joints, tree, channels, offsets and end
    sites (with their joints), frame time, every frame's values and its dropouts. The
    values are the file's channel values as parsed where the reader keeps them (text
    formats: the same on every machine), hashed as float64, so any edit of one counts
    (``check`` tells an edited clip by it); else the rotations (sign made canonical,
    w >= 0) and translations, which the reader computes, hashed as float32 as the offsets,
    end sites and frame time are, so the last bits of one machine's maths against
    another's do not count (nor does an edit below float32's resolution there)."""
    tree = {
        "names": motion.names,
        "channels": motion.channels,
        "parents": motion.parents,
        "ends": sorted(motion.end_sites),
        "frames": motion.n_frames,
    }
    digest = hashlib.sha256(json.dumps(tree, default=np.ndarray.tolist).encode())
    ends = [motion.end_sites[j] for j in sorted(motion.end_sites)]
    hashed: list[tuple[Any, str]] = [
        (np.asarray(v), "<f4") for v in (motion.offsets, *ends, [motion.frame_time])
    ]
    if motion.source_values is None:
        hashed += [(_canonical(motion.rotations), "<f4"), (motion.translations, "<f4")]
    else:
        hashed.append((motion.source_values, "<f8"))
    for values, kind in hashed:
        for first in range(0, max(len(values), 1), DIGEST_ROWS):  # blocks: no clip-sized copy
            block = values[first : first + DIGEST_ROWS]
            digest.update(np.asarray(block, kind).tobytes())
    digest.update(np.packbits(motion.missing_mask()).tobytes())
    return digest.hexdigest()


class _canonical:
    """Rows of unit quaternions ``(F, J, 4)`` with the sign that makes ``w >= 0``, made
    when sliced (no clip-sized copy)."""

    def __init__(self, q: np.ndarray):
        self.q = q

    def __len__(self) -> int:
        return len(self.q)

    def __getitem__(self, rows: slice) -> np.ndarray:
        block = self.q[rows]
        return np.where(block[..., :1] < 0.0, -block, block)


#: Frames hashed at a time by :func:`content_digest` (a block of a 31-joint clip's
#: rotations: 2 MB as float32).
DIGEST_ROWS = 4096


#: How a warning line begins (the command line prints it on stderr).
WARNING = "motionclean: warning: "


def pattern_warnings(source: str, logs: Sequence[StepLog]) -> tuple[str, ...]:
    """The warning lines of a cleaning: each step's ``joints`` (or ``feet``) pattern that
    matched no joint of the clip (a likely typo),
    ``motionclean: warning: FILE: step N (name): ...``."""
    return tuple(
        f"{WARNING}{source}: step {number} ({log.step.spec.name}): "
        f"{param} pattern {pattern!r} matches no joint"
        for number, log in enumerate(logs, 1)
        for param, pattern in log.unmatched
    )


@dataclass(frozen=True)
class Job:
    """The arguments of one :func:`clean_file` call: paths and the step tables only."""

    source: str
    target: str | None
    steps: tuple[dict, ...]
    report: str | None = None
    up: str | None = None  # the clips' up axis, when the user gives it
    read: ReadOptions = ReadOptions()
    shown: str | None = None  # the clip's name on its page (default: ``source``)
    index: str | None = None  # a batch's index page, as a link from the clip's page

    def absolute(self) -> Job:
        """This job with every path (clip, output, report, skeleton, body model) made
        absolute from this process's working folder, links kept as they are: a worker
        started in another folder (a Dask worker) reads and writes the files meant here.
        The clip's page keeps naming it as given (no machine's folders on a published
        page)."""

        def whole(path: str | None) -> str | None:
            return None if path is None else os.fspath(Path(path).absolute())

        read = self.read
        return replace(
            self,
            shown=self.shown or self.source,
            source=os.fspath(Path(self.source).absolute()),
            target=whole(self.target),
            report=whole(self.report),
            read=replace(read, skeleton=whole(read.skeleton), body_model=whole(read.body_model)),
        )


def _failure(source: str, target: str | None, error: BaseException, start: float) -> FileResult:
    if isinstance(error, MotionError):
        message = str(error)
    elif isinstance(error, OSError):
        message = f"{error.filename or source}: {error.strerror}"
    elif isinstance(error, MemoryError):
        message = f"{source}: out of memory ({error or 'an allocation failed'})"
    else:  # a bug must not stop the other clips
        message = f"{source}: internal error: {type(error).__name__}: {error}"
    return FileResult(source, target, "failed", error=message, seconds=time.perf_counter() - start)


def _success(result: CleanedClip, job: Job) -> FileResult:
    """The figures of a cleaned clip (its ``seconds`` are set once it is written)."""
    summary = result.report["summary"]
    deviations = [
        j["deviation_deg"]["rms"]
        for j in result.report["joints"].values()
        if j.get("deviation_deg", {}).get("rms") is not None  # (None: every sample missing)
    ]
    # every joint has the same frame count: the RMS over all is the RMS of the RMSs
    deviation_rms = (
        math.sqrt(sum(d * d for d in deviations) / len(deviations)) if deviations else 0.0
    )
    verdict = result.report.get("verdict") or {}
    return FileResult(
        job.source,
        job.target,
        "ok",
        verdict=verdict.get("text"),
        verdict_status=verdict.get("status"),
        jitter_before=verdict.get("noise_before"),
        jitter_after=verdict.get("noise_after"),
        jitter_removed=verdict.get("noise_removed"),
        change_max=verdict.get("change_deg_max"),
        frames=result.before.n_frames,
        noise_before=summary["angular_accel_rms"]["before"],
        noise_after=summary["angular_accel_rms"]["after"],
        deviation_max=summary["deviation_deg_max"],
        deviation_rms=deviation_rms,
        report=job.report,
        warnings=pattern_warnings(job.source, result.logs),
        content=content_digest(result.before),
        joints={
            name: {
                "noise_after": entry["angular_accel_rms"]["after"],
                "deviation_max": entry["deviation_deg"]["max"],
            }
            for name, entry in result.report["joints"].items()
            if "deviation_deg" in entry
        },
    )


def clean_file(
    source: str | os.PathLike,
    target: str | os.PathLike | None,
    pipeline: Pipeline | Sequence[dict],
    report: str | os.PathLike | None = None,
    up: str | None = None,
    read: ReadOptions | None = None,
    shown: str | None = None,
    index: str | None = None,
    tidy: bool = True,
) -> FileResult:
    """Clean ``source`` into ``target`` (atomically) and return the figures; never raises.

    ``pipeline`` is a :class:`Pipeline` or its ``describe()`` tables. ``target=None``
    computes the figures without writing; ``report`` also writes the clip's HTML page,
    which carries the tables and the clip's :meth:`FileResult.index_figures` for a batch
    resumed without an index (:func:`~motionclean.report.html.page_carried`).
    Parent folders of ``target`` and ``report`` are created, and removed again when they
    stay empty (``tidy``: :func:`folders_for`). ``up`` declares the clip's up
    axis (as in :func:`clean_clip`); ``shown`` names the clip on its page (default
    ``source``) and ``index`` links its page to a batch's index page (a path relative to
    the page). A bad clip or failed step gives ``status="failed"`` with the reason
    instead of raising.
    """
    start = time.perf_counter()
    keep_reserve()  # (again, after a clip that ran out of memory)
    job = Job(
        os.fspath(source),
        None if target is None else os.fspath(target),
        (),
        None if report is None else os.fspath(report),
        up,
        read or ReadOptions(),
        index=index,
    )
    try:
        if isinstance(pipeline, Pipeline):
            tables = pipeline.describe()
        else:
            tables = list(pipeline)
            pipeline = Pipeline.from_tables([dict(t) for t in tables], "pipeline")
        result = clean_clip(job.source, None, pipeline, job.up, job.read)
        after, done = result.after, _success(result, job)
        pages = {}
        if job.report is not None:
            if shown is not None:
                result.report["file"] = shown
            carried = {"pipeline": tables, "figures": done.index_figures()}
            if job.index is not None:
                carried["index"] = job.index
            pages[job.report] = render_report(result.report, job.report, result.series, carried)
        del result  # the input's arrays and the plot series go before the clip is written
        write_outputs(after, job.target, pages, tidy)
    except Exception as error:
        let_go(error)
        return _failure(job.source, job.target, error, start)
    return replace(done, seconds=time.perf_counter() - start)


def run_job(job: Job) -> FileResult:
    """Run one :class:`Job` (what a batch worker process or Dask task calls), numpy's
    RuntimeWarnings kept off the worker's stderr while it runs, as the command keeps them
    off its own (what they warn of is checked and said in one line). Folders it makes and
    leaves empty are the batch's to remove, once every worker is done (:func:`folders_for`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return clean_file(
            job.source,
            job.target,
            job.steps,
            job.report,
            job.up,
            job.read,
            job.shown,
            job.index,
            tidy=False,
        )


# ----------------------------------------------------------------------------- two clips


def check_compatible(
    a: Motion, b: Motion, same_length: bool = True, compared: bool = False
) -> None:
    """Raise :class:`MotionError` unless ``a`` and ``b`` share the skeleton, channels, frame
    rate and (optionally) length. Clips to join (blend, stitch) have no missing samples and
    offsets within 1e-6 of the skeleton's size; clips only ``compared`` may have gaps, and
    offsets within 1e-3 (a round trip through Blender's FBX moves a finger's by 1.3e-4)."""
    for clip in (a, b):
        if clip.has_gaps and not compared:
            raise MotionError(
                "has missing samples (tracker dropouts): fill them first "
                "(motionclean clean CLIP -o FILLED -f fill-gaps)",
                clip.path,
            )
    if a.names != b.names or not np.array_equal(a.parents, b.parents):
        raise MotionError(
            f"skeleton differs from {a.path}'s ({_skeleton_difference(a, b)})", b.path
        )
    if a.channels != b.channels:
        raise MotionError(f"channels differ from {a.path}'s", b.path)
    if not same_rate(a.frame_time, b.frame_time):
        hint = (
            " (a clip resampled by its cleaning: `clean --report` compares it on the input's "
            "frames; or resample one to the other's rate first)"
            if compared
            else ""
        )
        raise MotionError(
            f"frame time {b.frame_time:g} s differs from {a.path}'s {a.frame_time:g} s{hint}",
            b.path,
        )
    if same_length and a.n_frames != b.n_frames:
        raise MotionError(
            f"{b.n_frames} frames, {a.path} has {a.n_frames}: the clips must be as long (cut "
            "them to the frames they share, or join them with stitch)",
            b.path,
        )
    scale = (1e-3 if compared else 1e-6) * max(float(np.abs(a.offsets).max(initial=0.0)), 1.0)
    if a.offsets.shape != b.offsets.shape or not np.allclose(a.offsets, b.offsets, atol=scale):
        worst = int(np.argmax(np.abs(a.offsets - b.offsets).max(axis=1)))
        raise MotionError(
            f"skeleton differs from {a.path}'s: joint {b.names[worst]!r} has another OFFSET",
            b.path,
        )


def blend_clips(
    a: Motion,
    b: Motion,
    levels: int = 4,
    weight: float = 0.5,
    detail_weights: Sequence[float] | None = None,
) -> Motion:
    """Blend two time-aligned clips level by level (003 Eq. 20); ``weight`` is ``b``'s share
    of the coarsest level, ``detail_weights`` its share per detail level, finest first.

    Raises :class:`MotionError` for incompatible clips, ValueError for bad weights or levels.
    """
    check_compatible(a, b)
    if a.n_frames == 0:
        raise MotionError("cannot blend a clip without frames", a.path)
    q, p = _with_positions(
        lambda q_a, q_b, p_a=None, p_b=None: multires.blend(
            q_a, q_b, levels, weight, detail_weights, p_a, p_b
        ),
        a,
        b,
    )
    # all of B at every level: written back with B's text, as all of A is with A's
    shares = {float(weight), *(float(w) for w in detail_weights or ())}
    return (b if shares == {1.0} else a).replace(rotations=q, translations=p)


def _with_positions(run, a: Motion, b: Motion) -> tuple[np.ndarray, np.ndarray]:
    """``run(q_a, q_b, p_a, p_b) -> (q, p)`` (a multiresolution operation on two clips) on
    every joint's rotations, and again, with translations, on the joints that have any
    (position channels, or a non-zero value in either clip). The rotations never depend on
    the positions (003 Eq. 2-3); the other joints' translations are zero in both clips and
    stay so, without arrays for them."""
    q, _ = run(a.rotations, b.rotations)
    joints = np.union1d(
        np.flatnonzero(a.layout.has_position | b.layout.has_position),
        written_joints(a.translations, b.translations),
    )
    p = joint_major_zeros(q.shape[0], a.n_joints)
    if joints.size:
        _, p[:, joints] = run(
            a.rotations[:, joints],
            b.rotations[:, joints],
            a.translations[:, joints],
            b.translations[:, joints],
        )
    return q, p


def _skeleton_difference(a: Motion, b: Motion) -> str:
    """How ``b``'s skeleton differs from ``a``'s, in a few words naming a joint."""
    if sorted(a.names) == sorted(b.names):
        if a.names != b.names:  # (the sorted lists are equal: one name differs in place)
            moved = next(n for n, m in zip(a.names, b.names, strict=True) if n != m)
            return (
                f"the same joints in another order: {moved} is joint {b.names.index(moved) + 1} "
                f"here, {a.names.index(moved) + 1} there"
            )
        child = next((j for j in range(a.n_joints) if a.parents[j] != b.parents[j]), 0)
        return f"{a.names[child]} hangs from another joint"
    extra = [n for n in b.names if n not in set(a.names)]
    if extra:
        return f"{len(b.names)} joints, {extra[0]} not among its {len(a.names)}"
    absent = next((n for n in a.names if n not in set(b.names)), a.names[0])
    return f"{len(b.names)} joints, without its {absent}"


def align_roots(a: Motion, b: Motion) -> Motion:
    """``b`` moved so that its first frame's roots stand where ``a``'s last frame's stand:
    the same horizontal position and heading (a turn about the up axis), its own height.

    As fairmotion's append-and-blend: the whole of ``b`` is turned about the up axis and
    shifted horizontally; nothing else changes. Roots without position channels are only
    turned.
    """
    if a.n_frames == 0 or b.n_frames == 0:
        return b
    up = kinematics.up_axis(a)
    roots = np.flatnonzero(b.parents < 0)
    local_a = kinematics.local_translations(a)[-1, roots]
    local_b = kinematics.local_translations(b)
    heading = _heading(a.rotations[-1, roots[0]], up) - _heading(b.rotations[0, roots[0]], up)
    axis = np.zeros(3)
    axis[up] = 1.0
    turn = quat.from_axis_angle(axis, heading)
    rotations = b.rotations.copy()
    rotations[:, roots] = quat.make_continuous(quat.multiply(turn, rotations[:, roots]), axis=0)
    translations = b.translations.copy()
    moved = quat.rotate(turn, local_b[:, roots] - local_b[0, roots]) + local_a
    moved[..., up] = local_b[:, roots, up]  # each clip keeps its own height
    has_axis = b.layout.position_columns[roots] >= 0
    translations[:, roots] = np.where(has_axis, moved, translations[:, roots])
    return b.replace(rotations=rotations, translations=translations)


def _heading(q: np.ndarray, up: int) -> float:
    """Angle (rad, right-handed about the up axis ``up``) of a root's facing: the
    horizontal axis that stays most horizontal under ``q``, turned by ``q`` and projected
    on the ground, measured from the axis after ``up`` toward the one after that (a turn
    by ``t`` about ``up`` adds ``t``)."""
    horizontal = [k for k in range(3) if k != up]
    axes = np.eye(3)[horizontal]
    turned = quat.rotate(q, axes)
    pick = int(np.argmin(np.abs(turned[:, up])))
    first, second = (up + 1) % 3, (up + 2) % 3
    vector, reference = turned[pick], axes[pick]
    return math.atan2(vector[second], vector[first]) - math.atan2(
        reference[second], reference[first]
    )


def stitch_clips(a: Motion, b: Motion, levels: int = 4, align: bool = True) -> Motion:
    """Join the end of ``a`` to the start of ``b`` with a seamless transition (003 Eq. 21).

    With ``align`` ``b`` first stands where ``a`` ends (:func:`align_roots`), so the root
    does not slide across the room. The result has ``len(a) + len(b) - 1`` frames; only
    frames within ``3 (2^levels - 1)`` of the seam change beyond that move. Written back,
    every frame keeps its own clip's Euler branch.
    """
    check_compatible(a, b, same_length=False)
    if a.n_frames == 0 or b.n_frames == 0:
        raise MotionError("cannot stitch a clip without frames", (b if b.n_frames == 0 else a).path)
    if align:
        b = align_roots(a, b)
    q, p = _with_positions(
        lambda q_a, q_b, p_a=None, p_b=None: multires.stitch(q_a, q_b, levels, p_a, p_b), a, b
    )
    joined: dict = {"source_values": None, "source_rotations": None}
    if a.has_source_frames() and b.has_source_frames():
        assert a.source_values is not None and b.source_values is not None
        kept = a.source_rotations is not None or b.source_rotations is not None
        joined = {  # rotations read follow from the values when neither clip kept them
            "source_values": np.concatenate([a.source_values, b.source_values[1:]]),
            "source_rotations": np.concatenate(
                [a.read_rotations(slice(None)), b.read_rotations(slice(1, None))]
            )
            if kept
            else None,
        }
    return a.replace(rotations=q, translations=p, **joined)
