"""Pipelines: a validated list of steps (:mod:`.definition`) run on a Motion.

A pipeline is an ordered list of steps. Each step names a filter from :data:`REGISTRY`, its
parameters, the joints it applies to (fnmatch patterns, ``!`` excludes) and whether
translation channels are filtered too. This module is the only place that maps joint names
to array columns; filters only ever see arrays.

Everything is validated before any clip is read (:mod:`.definition`): an unknown filter,
an unknown or missing parameter, a wrong type or a value out of range raises
:class:`UsageError` naming the step, the key and what is allowed.
"""

from __future__ import annotations

import copy
import fnmatch
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..core import checks
from ..core.errors import MotionError, UsageError
from ..core.jumps import jump_steps
from ..core.motion import Motion, sparse_copy
from ..core.restpose import held_end_follows, rest_frames, splice, trim
from ..core.takes import take_spans, take_starts
from ..filters.gaps import Gaps
from . import REGISTRY, StepData, StepSpec
from .definition import STEP_HEADER, Step, key_lines, make_step, parse_inline, table_of, toml_error
from .ranges import blend_positions, blend_rotations, weights
from .resampling import rest_rows

__all__ = ["DEFAULT_STEPS", "REGISTRY", "Pipeline", "Step", "StepLog", "make_step"]

# ----------------------------------------------------------------------------- steps


def select_joints(names: list[str], patterns: tuple[str, ...]) -> np.ndarray:
    """``(J,)`` bool: joints matched by the patterns, applied in order.

    A pattern adds the joints it matches (``fnmatch``, case sensitive); ``!pattern`` removes
    them. When every pattern is an exclusion, selection starts from all joints.
    """
    selected = np.full(len(names), all(p.startswith("!") for p in patterns))
    for pattern in patterns:
        exclude = pattern.startswith("!")
        hits = np.array([fnmatch.fnmatchcase(n, pattern[exclude:]) for n in names], dtype=bool)
        selected = selected & ~hits if exclude else selected | hits
    return selected


def unmatched_patterns(names: list[str], patterns: tuple[str, ...]) -> list[str]:
    """The patterns that match none of ``names``, an exclusion's (``!``) too: likely typos
    (``!Rthumb`` would leave RThumb in)."""
    return [
        p
        for p in patterns
        if not any(fnmatch.fnmatchcase(n, p[p.startswith("!") :]) for n in names)
    ]


@dataclass
class StepLog:
    """What one step did: the step, the joints it touched, per-joint notes."""

    step: Step
    rotation_joints: list[str]
    translation_joints: list[str]
    notes: dict[str, dict]
    # (parameter, pattern): the patterns that matched no joint of this clip
    unmatched: list[tuple[str, str]]
    # frames a ranged step changed, blends included: (first, stop), file frames
    touched: tuple[int, int] | None = None
    # a ranged step's range as file frames: (first, last), inclusive (seconds made frames)
    frames: tuple[int, int] | None = None
    # the clip after the step, rest frames included: the frames its notes number
    n_frames: int = 0
    frame_time: float = 0.0


@dataclass
class Pipeline:
    """An ordered list of validated steps that cleans a :class:`Motion`.

    Build one with :meth:`default` (what ``clean`` runs without ``-p``/``-f``),
    :meth:`from_toml` (a file of ``[[step]]`` tables), :meth:`from_inline` (``-f`` texts
    such as ``"lee-shin:k=3,iterations=2"``) or :meth:`from_tables` (dicts). Every step is
    validated when the pipeline is built (unknown filters and parameters, types, ranges,
    keys given twice: :class:`UsageError` naming the step and the key); what depends on a
    clip (a frame range, a cutoff against its Nyquist frequency) is checked by :meth:`run`
    before any step runs. :meth:`run` returns the cleaned copy and a :class:`StepLog` per
    step; :meth:`describe` the steps as plain dicts.

    Attributes
    ----------
    steps : list of Step
        The validated steps, in the order they run.
    origin : str
        Where they came from (a file's path, ``"-f"``, ``"default pipeline"``), for
        messages.
    """

    steps: list[Step]
    origin: str = "pipeline"

    def __post_init__(self) -> None:
        """TypeError for ``steps`` that are not a list of :class:`Step` (made by
        :func:`make_step`, or by the class methods from tables, TOML or ``-f`` texts)."""
        if not isinstance(self.steps, list | tuple):
            raise TypeError(f"steps: expected a list of Step, got {type(self.steps).__name__}")
        odd = [type(step).__name__ for step in self.steps if not isinstance(step, Step)]
        if odd:
            raise TypeError(
                f"steps: expected a list of Step (Pipeline.from_tables, from_toml and "
                f"from_inline make them), got a {type(self.steps).__name__} holding {odd[0]}"
            )
        # a Step made by hand is validated (and its defaults filled) as a table would be
        self.steps = [
            make_step(table_of(step), f"{self.origin}: step {number}")
            for number, step in enumerate(self.steps, 1)
        ]

    @classmethod
    def from_tables(
        cls,
        tables: list,
        origin: str,
        lines: list[int] | None = None,
        key_lines: list[dict[str, int]] | None = None,
    ) -> Pipeline:
        """Steps from tables (dicts); a table's errors name ``origin`` and its number, and
        its line in the file when ``lines`` gives each table's first line (``key_lines``:
        each key's line, for an error about that key)."""
        if not tables:
            raise UsageError(f"{origin}: the pipeline has no steps")
        places = [f"{origin}:{line}" for line in lines] if lines else [origin] * len(tables)
        keys = key_lines or [{} for _ in tables]
        return cls(
            [
                make_step(
                    t,
                    f"{place}: step {i}",
                    {key: f"{origin}:{line}: step {i}" for key, line in by_key.items()},
                )
                for i, (t, place, by_key) in enumerate(zip(tables, places, keys, strict=True), 1)
            ],
            origin,
        )

    @classmethod
    def from_toml(cls, path: str | Path) -> Pipeline:
        """Read ``[[step]]`` tables from a TOML file (UTF-8, a byte-order mark allowed);
        ``path`` is the file's path (TOML text itself: ``from_tables(tomllib.loads(text)
        ["step"])``). TypeError for anything but a path, UsageError for a file that is no
        pipeline."""
        path = Path(checks.path(path, "path"))
        try:
            data = path.read_bytes()
            text = data.decode("utf-8-sig")
            document = tomllib.loads(text)
        except FileNotFoundError:
            if "\n" in str(path):  # (TOML text given for a path: one line says so)
                raise UsageError(
                    "from_toml takes a pipeline file's path, not TOML text (read the text "
                    "with tomllib.loads and give its 'step' tables to Pipeline.from_tables)"
                ) from None
            raise UsageError(f"{path}: no such pipeline file") from None
        except OSError as error:
            raise UsageError(f"{path}: cannot read pipeline: {error}") from None
        except UnicodeDecodeError as error:
            line = data.count(b"\n", 0, error.start) + 1
            raise UsageError(f"{path}:{line}: not UTF-8 text (a TOML file must be UTF-8)") from None
        except tomllib.TOMLDecodeError as error:
            raise UsageError(toml_error(path, str(error), text)) from None
        except RecursionError:
            raise UsageError(f"{path}: invalid TOML: arrays or tables nested too deeply") from None
        except ValueError:  # an integer of more digits than Python converts
            raise UsageError(f"{path}: a number with too many digits (out of range)") from None
        unknown = set(document) - {"step"}
        if unknown:
            raise UsageError(
                f"{path}: unknown top-level key {sorted(unknown)[0]!r}; steps are [[step]] tables"
            )
        steps = document.get("step", [])
        if not isinstance(steps, list):
            raise UsageError(f"{path}: 'step' must be an array of tables ([[step]])")
        rows = text.splitlines()
        lines = [i for i, row in enumerate(rows, 1) if STEP_HEADER.match(row)]
        if len(lines) != len(steps):  # (steps written otherwise: step = [{...}])
            return cls.from_tables(steps, str(path))
        return cls.from_tables(steps, str(path), lines, key_lines(rows, lines))

    @classmethod
    def from_inline(cls, texts: list[str]) -> Pipeline:
        """Steps given as ``-f NAME:key=value,...`` options, in order (a list of str)."""
        if not isinstance(texts, list | tuple) or not all(isinstance(t, str) for t in texts):
            raise TypeError(
                f"from_inline takes a list of step strings, e.g. ['lee-shin:k=3'], got {texts!r}"
            )
        return cls.from_tables([parse_inline(t) for t in texts], "-f")

    @classmethod
    def default(cls) -> Pipeline:
        """The pipeline ``clean`` uses when none is given (see README, "Default pipeline")."""
        return cls.from_tables(DEFAULT_STEPS, "default pipeline")

    def describe(self) -> list[dict]:
        """The steps as plain dicts, one per step in order (the report's ``pipeline`` and
        the TOML form): ``filter``, the parameters that matter for it with defaults filled
        in (units as ``motionclean filters`` gives them), ``joints`` and ``positions``
        (but for whole-clip steps), and for a ranged step ``frames`` or ``seconds`` as
        given and ``blend`` (frames). ``Pipeline.from_tables(p.describe(), ...)`` builds
        the same pipeline, as it does from the JSON form, which writes inf as null."""
        return [step.describe() for step in self.steps]

    def run(self, motion: Motion) -> tuple[Motion, list[StepLog]]:
        """Run every step on ``motion``; return the cleaned copy and what each step did.

        ``motion`` is not changed. Rest-pose frames at either end (:mod:`motionclean.core.restpose`)
        are left out of every step and come back bit for bit; takes joined end to end
        (:mod:`motionclean.core.takes`) are cleaned each on its own. A whole-clip step
        (``run_motion``) replaces the clip between them, so the steps after it see its frame
        count and rate. TypeError for anything but a :class:`Motion`.
        """
        if not isinstance(motion, Motion):
            raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
        lead, trail = rest_frames(motion)
        entered = trim(motion, lead, trail)  # (what footlock compares the feet with)
        # A shallow copy: steps replace its arrays, never write into the input's.
        current = copy.copy(entered)
        starts = take_starts(motion) - lead  # (frames of ``current``)
        # what the steps so far noted on each take, by joint (a take's own, not the merge)
        by_take: list[dict[str, dict]] = [{} for _ in range(starts.size + 1)]
        spans, checked = _checked_up_front(self.steps, motion)
        made = _Made(motion)
        logs: list[StepLog] = []
        outer = motion  # the clip whose rest frames surround ``current``
        earlier: dict[str, dict] = {}  # what the steps so far noted, by joint
        for number, step in enumerate(self.steps, 1):
            if number > checked:  # after a whole-clip step: the rate it made
                _check_rate(step, number, current.frame_time, motion.path)
            try:
                whole_clip = step.spec.keeps_rest and bool(lead or trail) and not starts.size
                if step.spec.keeps_rest and starts.size:
                    # a step that remakes the frames (a new rate): each take on its own,
                    # joined; rest frames, if any, come back one for one around them
                    current, log, starts = _remade_by_takes(step, current, starts)
                elif whole_clip:
                    # the step keeps the rest frames itself: it gets them, and says how many
                    # frames they take in its result
                    whole = splice(outer, current, lead, trail)
                    outer, log = _run_step(step, number, whole, 0, None, motion.path, made, earlier)
                    if outer.n_frames != whole.n_frames:
                        ratio = outer.frame_time / whole.frame_time
                        lead, trail = rest_rows(whole.n_frames, lead, trail, ratio, outer.n_frames)
                    current = copy.copy(trim(outer, lead, trail))
                else:
                    current, log = _run_step(
                        step,
                        number,
                        current,
                        lead,
                        spans.get(number),
                        motion.path,
                        made,
                        earlier,
                        starts,
                        by_take,
                        entered if _same_frames(entered, current) else None,
                    )
            except UsageError as error:  # what the step was asked cannot be done on a clip
                if error.path is not None:
                    raise
                named = f"step {number} ({step.spec.name})"
                if error.message.startswith(f"{named}: "):  # (a range's: it names its step)
                    raise UsageError(error.message, motion.path) from None
                raise UsageError(f"{named}: {error}", motion.path) from None
            except (ValueError, FloatingPointError, np.linalg.LinAlgError) as error:
                raise MotionError(
                    f"step {number} ({step.spec.name}) failed: {error}", motion.path
                ) from None
            _check_result(current, step, number, motion.path)
            for joint, note in log.notes.items():
                earlier.setdefault(joint, {}).update(note)
            if lead and not whole_clip:  # numbered as the file's frames
                log.notes = {
                    j: _shifted(step.spec, n, lead, current.frame_time)
                    for j, n in log.notes.items()
                }
            log.n_frames, log.frame_time = current.n_frames + lead + trail, current.frame_time
            logs.append(log)
        result = held_end_follows(outer, splice(outer, current, lead, trail), trail)
        if starts.size:  # the takes as cleaned (a new rate moved them), for the report
            result.derived("take_starts", lambda _: starts + lead)
        return result, logs


def _check_result(motion: Motion, step: Step, number: int, path: str | None) -> None:
    """Refuse a step's result that no file holds: a rotation or position that is not a
    finite number, or a position beyond :data:`~motionclean.core.checks.MAX_MAGNITUDE` (a
    filter that diverged: many passes of a sharpening mask, gains far above 1). Two
    reductions per array: no array-sized temporary."""
    bad = None
    if not checks.within_magnitude(motion.rotations):  # (unit quaternions: NaN or inf)
        bad = "rotations that are not finite"
    elif not checks.within_magnitude(motion.translations):
        bad = f"positions that are not finite numbers of at most {checks.MAX_MAGNITUDE:g}"
    if bad is not None:
        raise MotionError(
            f"step {number} ({step.spec.name}) made {bad} (the filter diverged: fewer passes, "
            "a gentler mask or gains nearer 1)",
            path,
        )


def _checked_up_front(steps: list[Step], motion: Motion) -> tuple[dict[int, tuple[int, int]], int]:
    """The steps checked against the clip before any runs: each ranged step's ``(first,
    last)`` frames (by step number from 1) and the parameters that depend on the clip's
    frame rate (``StepSpec.check_rate``), UsageError naming the step; and the number of
    the last step checked. Steps after a whole-clip step are checked against that step's
    result when they run (a new rate, a new frame count)."""
    spans: dict[int, tuple[int, int]] = {}
    for number, step in enumerate(steps, 1):
        _check_rate(step, number, motion.frame_time, motion.path)
        if step.spec.run_motion is not None:
            return spans, number
        if step.span is not None:
            spans[number] = _frame_span(
                step, number, motion.n_frames, motion.frame_time, motion.path
            )
    return spans, len(steps)


def _where(step: Step, number: int, path: str | None) -> str:
    """``FILE: step N (name)``: a step in a message (a step listed twice: which one)."""
    named = f"step {number} ({step.spec.name})"
    return f"{path}: {named}" if path else named


def _check_rate(step: Step, number: int, frame_time: float, path: str | None) -> None:
    """The step's parameters against a clip of ``frame_time`` seconds per frame."""
    if step.spec.check_rate is not None:
        step.spec.check_rate(step.params, frame_time, _where(step, number, path))


def _frame_span(
    step: Step, number: int, n_frames: int, frame_time: float, path: str | None
) -> tuple[int, int]:
    assert step.span is not None
    return step.span.frame_span(n_frames, frame_time, _where(step, number, path))


def _same_frames(a: Motion, b: Motion) -> bool:
    """Whether two clips hold the same frames: their count and their rate (a resample to
    119.9 fps keeps a 300-frame clip's count)."""
    return a.n_frames == b.n_frames and a.frame_time == b.frame_time


def _run_step(
    step: Step,
    number: int,
    motion: Motion,
    offset: int,
    span: tuple[int, int] | None,
    path: str | None,
    made: _Made,
    earlier: dict[str, dict] | None = None,
    starts: np.ndarray | None = None,
    by_take: list[dict[str, dict]] | None = None,
    entered: Motion | None = None,
) -> tuple[Motion, StepLog]:
    """One step on ``motion`` (a shallow copy the pipeline owns: its arrays are replaced,
    and written into only where ``made`` copied them).

    ``number`` counts the step from 1 (for messages). ``motion`` starts at frame ``offset``
    of the file (rest-pose frames left out); a step's
    frame range ``span`` counts the file's frames (None: not checked yet). A clip of several
    takes (``starts``: the frames where each after the first begins) has the step run on
    each take (:func:`_run_by_takes`), which sees what earlier steps noted on that take
    (``by_take``, updated). A ranged step's
    notes keep only what lies within the frames it touched (``StepSpec.crop_note``).
    ``entered``: the clip as it entered the pipeline, on ``motion``'s frames (``StepData``).
    """
    unmatched = _unmatched(step, motion.names)
    if step.spec.run_motion is not None:
        result, whole_notes = step.spec.run_motion(motion, step.params)
        return result, StepLog(step, list(motion.names), [], whole_notes, unmatched)
    assert step.spec.run is not None
    layout = motion.layout
    chosen = select_joints(motion.names, step.joints)
    rot_idx = np.flatnonzero(chosen & layout.has_rotation)
    pos_idx = np.flatnonzero(chosen & layout.has_position) if step.positions else np.zeros(0, int)
    every = rot_idx.size == motion.n_joints  # all columns: no copy in
    data = StepData(
        motion.rotations if every else motion.rotations[:, rot_idx],
        motion.translations[:, pos_idx] if len(pos_idx) else None,
        motion.frame_time,
        motion=motion,
        rotation_joints=rot_idx,
        translation_joints=pos_idx,
        # a ranged step's result is blended with the clip as it was: nothing in place
        owned=step.span is None and (not every or made.owns(motion.rotations)),
        earlier=earlier or {},
        entered=entered,
    )
    if step.span is not None and span is None:
        # (named without the file: the pipeline's run adds it, as to the step's own errors)
        span = _frame_span(step, number, motion.n_frames + offset, motion.frame_time, None)
    if starts is not None and starts.size:  # (a clip with dropouts has no takes)
        assert by_take is not None
        data = _run_by_takes(step, data, motion, starts, by_take)
    elif motion.missing is None or step.spec.sees_missing:
        data = _call(step, data)
    else:
        data = _run_on_known(step, data, motion)
    touched = None
    new_rotations, new_translations = data.rotations, data.translations
    if step.span is not None and span is not None:
        first, last = span
        share = weights(motion.n_frames, first - offset, last - offset, step.span.blend)
        new_rotations = blend_rotations(motion.rotations[:, rot_idx], data.rotations, share)
        if data.translations is not None:
            new_translations = blend_positions(
                motion.translations[:, pos_idx], data.translations, share
            )
        moved = np.flatnonzero(share > 0.0)
        inside = (int(moved[0]), int(moved[-1]) + 1) if moved.size else None
        _crop_notes(step.spec, data.rotation_notes, inside)
        _crop_notes(step.spec, data.translation_notes, inside)
        touched = (inside[0] + offset, inside[1] + offset) if inside else None
    motion.rotations = made.placed("rotations", motion.rotations, rot_idx, new_rotations)
    if new_translations is not None:
        motion.translations = made.placed(
            "translations", motion.translations, pos_idx, new_translations
        )
    notes = _named_notes(data, motion.names)
    rotated = [motion.names[i] for i in rot_idx]
    moved_joints = [motion.names[i] for i in pos_idx]
    frames = (int(span[0]), int(span[1])) if step.span is not None and span else None
    return motion, StepLog(step, rotated, moved_joints, notes, unmatched, touched, frames)


def _unmatched(step: Step, names: list[str]) -> list[tuple[str, str]]:
    """``(parameter, pattern)``: the step's patterns that match no joint."""
    return [
        (name, pattern)
        for name, patterns in (
            ("joints", step.joints),
            *((n, tuple(step.params[n] or ())) for n in step.spec.name_patterns),
        )
        for pattern in unmatched_patterns(names, patterns)
    ]


class _Made:
    """The clip arrays the pipeline copied during a run (never the input's own, nor a step's
    result): the only ones it writes into. Steps may write into any array the input clip
    does not hold (:meth:`owns`)."""

    def __init__(self, clip: Motion) -> None:
        self.arrays: dict[str, np.ndarray | None] = {}
        self.inputs = [
            a for a in (clip.rotations, clip.translations, clip.source_rotations) if a is not None
        ]

    def owns(self, array: np.ndarray) -> bool:
        """True when ``array`` shares no memory with the input clip's arrays: a copy made
        here or a step's result, which a later step may overwrite."""
        return not any(np.may_share_memory(array, a) for a in self.inputs)

    def placed(
        self, field: str, array: np.ndarray, columns: np.ndarray, values: np.ndarray
    ) -> np.ndarray:
        """``array`` (the clip's ``field``) with ``values`` in ``columns`` (axis 1):
        ``values`` itself when they are every column, else a copy of ``array`` made once and
        written in place by the steps after (one root's translations do not copy every
        joint's at every step; translations are copied as :func:`sparse_copy`, so the
        zeros of joints without position channels take no memory)."""
        if columns.size == array.shape[1]:
            self.arrays[field] = None  # a step's own result: not ours to write into
            return values
        if self.arrays.get(field) is not array:
            array = sparse_copy(array) if field == "translations" else array.copy()
            self.arrays[field] = array
        array[:, columns] = values
        return array


def _run_on_known(step: Step, data: StepData, motion: Motion) -> StepData:
    """``step`` on a clip with missing samples: the columns without gaps in one call; the
    known stretches (2 frames or more) of the columns with gaps, of a ``column_wise`` step
    as columns of one array (:meth:`_Outputs.run_stretches`), of any other each on its own
    (with the clip cut to it as context); missing samples are left as they are. A column's
    notes from several stretches are merged (:func:`_merged`)."""
    missing = motion.missing_mask()
    has_positions = data.translations is not None
    gaps_r = missing[:, data.rotation_joints].any(axis=0)
    gaps_p: np.ndarray = np.zeros(0, dtype=bool)
    if has_positions:
        gaps_p = np.any(missing[:, data.translation_joints], axis=0)
    out = _Outputs(data, step.spec)
    out.run(step, motion, np.flatnonzero(~gaps_r), np.flatnonzero(~gaps_p))
    for positions, joints, gappy in (
        (False, data.rotation_joints, gaps_r),
        (True, data.translation_joints, gaps_p),
    ):
        if not gappy.any():
            continue
        stretches = _known_stretches(missing[:, joints], np.flatnonzero(gappy))
        if step.spec.column_wise:
            out.run_stretches(step, stretches, positions)
            continue
        for c, first, length in zip(*stretches, strict=True):
            picked = np.array([c])
            empty = np.zeros(0, np.intp)
            rot, pos = (empty, picked) if positions else (picked, empty)
            out.run(step, motion, rot, pos, slice(int(first), int(first + length)))
    return out.finish()


def _known_stretches(
    missing: np.ndarray, columns: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The known stretches of 2 frames or more of ``missing``'s ``(F, C)`` ``columns``:
    ``(column, first, length)``, ``(S,)`` each, by column, then frame."""
    known = Gaps.of(~missing[:, columns])
    kept = known.lengths >= 2
    return columns[known.joint[kept]], known.first[kept], known.lengths[kept]


def _call(step: Step, data: StepData) -> StepData:
    """``step`` run on ``data``: in one call, or for a step that cuts at flips
    (``StepSpec.cuts_at_flips``, ``cut_deg`` below 180) stretch by stretch
    (:func:`_run_between_flips`)."""
    assert step.spec.run is not None
    if step.spec.cuts_at_flips and step.params["cut_deg"] < 180.0:
        return _run_between_flips(step, data)
    return step.spec.run(data, step.params)


def _run_between_flips(step: Step, data: StepData) -> StepData:
    """``step`` on ``data`` with each rotation column cut at the steps between two frames
    that turn by more than ``cut_deg`` degrees (:func:`~motionclean.core.jumps.jump_steps`):
    the columns without such a step and the translations in one call, as uncut; the
    stretches between cuts each on its own (:func:`_run_stretches`)."""
    assert step.spec.run is not None
    cuts = jump_steps(data.rotations, step.params["cut_deg"])  # (F-1, C)
    flipped = cuts.any(axis=0)
    if not flipped.any():
        return step.spec.run(data, step.params)
    plain = np.flatnonzero(~flipped)
    whole = step.spec.run(
        replace(
            data,
            rotations=data.rotations[:, plain],
            rotation_joints=data.rotation_joints[plain],
            rotation_notes={},
            translation_notes={},
        ),
        step.params,
    )
    rotations = data.rotations if data.owned else data.rotations.copy()  # (written into)
    rotations[:, plain] = whole.rotations
    notes = {int(plain[c]): note for c, note in whole.rotation_notes.items()}
    parts = _run_stretches(step, data, _stretches(cuts), rotations)
    notes.update({c: _merged(step.spec, found) for c, found in parts.items()})
    return replace(
        data,
        rotations=rotations,
        translations=whole.translations,
        rotation_notes=notes,
        translation_notes=whole.translation_notes,
    )


def _run_stretches(
    step: Step,
    data: StepData,
    stretches: tuple[np.ndarray, np.ndarray, np.ndarray],
    out: np.ndarray,
    positions: bool = False,
) -> dict[int, list[tuple[dict, int]]]:
    """``step`` (``column_wise``) on each stretch ``(column, first, length)`` (``(S,)`` each,
    2 frames or more) of ``data``'s rotation columns (``positions``: translation columns) as
    a column of its own, cut at its own flips (:func:`_call`; a stretch between flips has
    none): the stretches of one length in one call, a loop over lengths, not over
    stretches or frames. Written into ``out`` (which may be ``data``'s own array: no two
    stretches share a sample). Returns each column's notes as parts ``(note, frames)`` in
    frame order, numbered as the clip (for :func:`_merged`)."""
    parts: dict[int, list[tuple[int, dict, int]]] = {}  # column -> (first, note, frames)
    column, first, length = stretches
    values = data.translations if positions else data.rotations
    assert values is not None
    joints = data.translation_joints if positions else data.rotation_joints
    none = np.zeros(0, np.intp)
    for group in _by_length(length):
        frames = first[group] + np.arange(length[group[0]])[:, None]  # (L, n)
        columns = column[group]
        cut = values[frames, columns]
        result = _call(
            step,
            StepData(
                np.zeros((cut.shape[0], 0, 4)) if positions else cut,
                cut if positions else None,
                data.frame_time,
                rotation_joints=none if positions else joints[columns],
                translation_joints=joints[columns] if positions else none,
                owned=True,
                earlier=data.earlier,
            ),
        )
        out[frames, columns] = result.translations if positions else result.rotations
        for c, note in (result.translation_notes if positions else result.rotation_notes).items():
            at, n = int(first[group[c]]), int(length[group[c]])
            shifted = _shifted(step.spec, note, at, data.frame_time)
            parts.setdefault(int(columns[c]), []).append((at, shifted, n))
    return {
        c: [(note, n) for _, note, n in sorted(found, key=lambda p: p[0])]
        for c, found in parts.items()
    }


def _stretches(cuts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stretches of 2 frames or more between ``cuts`` ``(F-1, C)`` (True: a cut
    between frames ``i`` and ``i+1``) of the columns with any: ``(column, first, length)``,
    ``(S,)`` each."""
    n_frames = cuts.shape[0] + 1
    columns = np.flatnonzero(cuts.any(axis=0))
    cut_column, cut_at = np.nonzero(cuts.T)  # by column, then frame
    owner = np.concatenate([columns, cut_column])
    first = np.concatenate([np.zeros(columns.size, np.intp), cut_at + 1])
    stop = np.concatenate([cut_at + 1, np.full(columns.size, n_frames)])
    by_first = np.lexsort((first, owner))
    by_stop = np.lexsort((stop, np.concatenate([cut_column, columns])))
    owner, first = owner[by_first], first[by_first]
    length = stop[by_stop] - first
    kept = length >= 2
    return owner[kept], first[kept], length[kept]


def _by_length(length: np.ndarray) -> list[np.ndarray]:
    """Indices of ``length`` grouped by value, each group in index order."""
    order = np.argsort(length, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(length[order])) + 1) if order.size else []


def _remade_by_takes(
    step: Step, motion: Motion, starts: np.ndarray
) -> tuple[Motion, StepLog, np.ndarray]:
    """A whole-clip step that remakes the frames (``keeps_rest``: a new frame rate) on each
    take of ``motion`` (``starts``: where each after the first begins), the results joined:
    no new frame blends two takes. The clip, the log (notes: the longest take's) and where
    each take after the first now begins."""
    assert step.spec.run_motion is not None
    if step.spec.run_takes is not None:
        joined, notes, new_starts = step.spec.run_takes(motion, step.params, starts)
        log = StepLog(step, list(motion.names), [], notes, _unmatched(step, motion.names))
        return joined, log, new_starts
    parts, notes, longest = [], {}, 0
    for take in take_spans(starts, motion.n_frames):
        part, part_notes = step.spec.run_motion(motion.at_frames(take), step.params)
        parts.append(part)
        if take.stop - take.start > longest:
            notes, longest = part_notes, take.stop - take.start
    joined = Motion.joined_frames(parts)
    lengths = np.cumsum([part.n_frames for part in parts])
    log = StepLog(step, list(motion.names), [], notes, _unmatched(step, motion.names))
    return joined, log, lengths[:-1].astype(np.intp)


def _run_by_takes(
    step: Step,
    data: StepData,
    motion: Motion,
    starts: np.ndarray,
    by_take: list[dict[str, dict]],
) -> StepData:
    """``step`` on each take of a clip of several (``starts``: where each after the first
    begins), the clip cut to it as context and what earlier steps noted on it
    (``by_take[k]``, which takes this step's notes): nothing is smoothed, repaired or held
    across a cut. A take of one frame is left as it is; notes are merged for the log
    (:func:`_merged`)."""
    out = _Outputs(data, step.spec)
    rot = np.arange(data.rotations.shape[1])
    pos = np.arange(0 if data.translations is None else data.translations.shape[1])
    for take, own in zip(take_spans(starts, motion.n_frames), by_take, strict=True):
        if take.stop - take.start >= 2:
            noted = out.run(step, motion, rot, pos, take, own)
            for joint, note in _named_notes(noted, motion.names).items():
                own.setdefault(joint, {}).update(note)
    return out.finish()


def _named_notes(data: StepData, names: list[str]) -> dict[str, dict]:
    """A step's notes by joint name (position notes' keys prefixed ``position_``)."""
    notes: dict[str, dict] = {}
    for column, note in data.rotation_notes.items():
        notes.setdefault(names[data.rotation_joints[column]], {}).update(note)
    for column, note in data.translation_notes.items():
        notes.setdefault(names[data.translation_joints[column]], {}).update(
            {f"position_{k}": v for k, v in note.items()}
        )
    return notes


class _Outputs:
    """Step results gathered column by column and stretch by stretch."""

    def __init__(self, data: StepData, spec: StepSpec):
        self.data, self.spec = data, spec
        self.rotations = data.rotations.copy()
        self.translations = None if data.translations is None else data.translations.copy()
        self.notes: tuple[dict, dict] = ({}, {})  # column -> [(note, frames), ...]

    def run(self, step, motion, rot, pos, rows: slice = slice(None), earlier=None) -> StepData:
        """``step`` on the columns ``rot`` and ``pos`` of the frames ``rows``, with what
        earlier steps noted (``earlier``: the run's own, default the step's); its result."""
        data = self.data
        whole = rows == slice(None)
        # One known stretch: the clip cut to it, with nothing missing, is its context.
        context = motion if whole else motion.at_frames(rows).replace(missing=None)
        entered = data.entered
        if entered is not None and not whole:
            entered = entered.at_frames(rows).replace(missing=None)
        result = _call(
            step,
            StepData(
                data.rotations[rows][:, rot],
                None if data.translations is None else data.translations[rows][:, pos],
                data.frame_time,
                motion=context,
                rotation_joints=data.rotation_joints[rot],
                translation_joints=data.translation_joints[pos],
                earlier=data.earlier if earlier is None else earlier,
                entered=entered,
            ),
        )
        self.rotations[rows, rot] = result.rotations
        if self.translations is not None and result.translations is not None:
            self.translations[rows, pos] = result.translations
        start = 0 if whole else rows.start
        for book, found, columns in (
            (self.notes[0], result.rotation_notes, rot),
            (self.notes[1], result.translation_notes, pos),
        ):
            for c, note in found.items():
                shifted = _shifted(step.spec, note, start, data.frame_time)
                book.setdefault(int(columns[c]), []).append((shifted, context.n_frames))
        return result

    def run_stretches(
        self, step: Step, stretches: tuple[np.ndarray, np.ndarray, np.ndarray], positions: bool
    ) -> None:
        """``step`` (``column_wise``) on stretches ``(column, first, length)`` of the
        rotation columns (``positions``: translation columns), those of one length in one
        call (:func:`_run_stretches`)."""
        out = self.translations if positions else self.rotations
        assert out is not None
        found = _run_stretches(step, self.data, stretches, out, positions)
        for c, parts in found.items():
            self.notes[int(positions)].setdefault(c, []).extend(parts)

    def finish(self) -> StepData:
        data = self.data
        data.rotations, data.translations = self.rotations, self.translations
        data.rotation_notes = {c: _merged(self.spec, n) for c, n in self.notes[0].items()}
        data.translation_notes = {c: _merged(self.spec, n) for c, n in self.notes[1].items()}
        return data


def _shifted(spec: StepSpec, note: dict, frames: int, frame_time: float) -> dict:
    """A note (``{key: value}``, keys the step's name or ``position_`` + it) with its frame
    numbers moved by ``frames`` (its times by as many frames of ``frame_time`` seconds)."""
    if spec.shift_note is None or not frames:
        return note
    return {
        k: spec.shift_note(v, frames, frame_time) if k.endswith(spec.name) else v
        for k, v in note.items()
    }


def _merged(spec: StepSpec, parts: list[tuple[dict, int]]) -> dict:
    """One column's notes from its parts (takes or known stretches) ``(note, frames)`` as
    one: frame lists joined in order, every other value from the longest part, then what
    the step's ``merge_note`` says of the parts (counts added up, maxima over all)."""
    if len(parts) == 1:
        return parts[0][0]
    longest = max(parts, key=lambda part: part[1])[0]
    merged = {}
    for key, value in longest.items():
        if not isinstance(value, dict):
            merged[key] = value
            continue
        own = [(note[key], frames) for note, frames in parts if key in note]
        merged[key] = {
            k: sum((note.get(k, []) for note, _ in own), []) if isinstance(v, list) else v
            for k, v in value.items()
        }
        if spec.merge_note is not None:  # (a value None drops its key)
            for name, value in spec.merge_note(own).items():
                if value is None:
                    merged[key].pop(name, None)
                else:
                    merged[key][name] = value
    return merged


def _crop_notes(spec: StepSpec, notes: dict[int, dict], inside: tuple[int, int] | None) -> None:
    """Keep, in place, what ``notes`` say about frames ``inside`` (``(start, stop)``; None:
    none)."""
    if spec.crop_note is None:
        return
    for column in list(notes):
        note = notes[column]
        if spec.name not in note:
            continue
        value = spec.crop_note(note[spec.name], *inside) if inside else None
        if value is None:
            del note[spec.name]
        else:
            note[spec.name] = value
        if not note:
            del notes[column]


#: The default pipeline (README, "Default pipeline").
DEFAULT_STEPS: list[dict] = [
    {"filter": "despike"},
    {"filter": "fill-gaps"},
    {"filter": "auto"},
    {"filter": "footlock"},
]


def as_default_auto_sees(motion: Motion) -> Motion:
    """``motion`` as the default pipeline's ``auto`` step is given it: cleaned by the steps
    before it (despike, fill-gaps), its rest-pose frames left out; of a clip of several
    takes, the longest (whose note a joint's merged notes show)."""
    default = Pipeline.default()
    names = [step.spec.name for step in default.steps]
    before = Pipeline(default.steps[: names.index("auto")], default.origin)
    lead, trail = rest_frames(motion)
    seen = trim(before.run(motion)[0], lead, trail)
    starts = take_starts(motion) - lead
    if not starts.size:
        return seen
    return seen.at_frames(max(take_spans(starts, seen.n_frames), key=lambda t: t.stop - t.start))
