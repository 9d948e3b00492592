"""What every step module declares: its parameters (:class:`Param`), what it is given to
run on (:class:`StepData`) and its registration (:class:`StepSpec`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import UsageError
from ..core.jumps import JUMP_DEG
from ..core.motion import UP_AXES, Motion
from ..core.words import plural


@dataclass(frozen=True)
class Param:
    """One step parameter: its type, default, allowed range and a help line with units."""

    name: str
    type: str  # "int", "float", "bool", "str", "floats" (list of numbers), "strs"
    default: Any
    help: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    choices: tuple[str, ...] | None = None
    infinite_ok: bool = False
    nonempty: bool = False  # a list must hold at least one item

    def allowed(self) -> str:
        """What values are allowed, for error messages and the catalogue."""
        if self.choices:
            return "one of " + ", ".join(self.choices)
        kind = {
            "int": "an integer",
            "float": "a number",
            "bool": "true or false",
            "str": "a string",
            "floats": "a list of numbers",
            "strs": "a list of strings",
        }[self.type]
        if self.nonempty:
            kind = kind.replace("a list", "a non-empty list")
        bounds = []
        if self.minimum is not None:
            bounds.append(f"{'>' if self.exclusive_minimum else '>='} {self.minimum:g}")
        if self.maximum is not None:
            bounds.append(f"<= {self.maximum:g}")
        text = kind + (" " + " and ".join(bounds) if bounds else "")
        return text + (" (inf allowed)" if self.infinite_ok else "")

    def coerce(self, value: Any, where: str) -> Any:
        """Check ``value`` against the type and range; return it in canonical form."""
        shown = repr(value)
        if len(shown) > 60:  # a number of thousands of digits, a deep list: its two ends
            shown = f"{shown[:30]}...{shown[-15:]} ({len(shown)} characters)"
        bad = UsageError(f"{where}: {self.name} must be {self.allowed()}, got {shown}")
        if isinstance(value, np.generic):  # numpy's scalars, from Python callers: as Python's
            value = value.item()
        if value is None and self.infinite_ok:  # (JSON's null: inf, as reports write it)
            return math.inf
        if self.type in ("strs", "floats") and isinstance(value, tuple | np.ndarray):
            value = value.tolist() if isinstance(value, np.ndarray) else list(value)
        if self.type == "bool":
            if not isinstance(value, bool):
                raise bad
            return value
        if self.type in ("str", "strs"):
            if self.type == "strs" and isinstance(value, str):
                value = [value]
            items = value if self.type == "strs" else [value]
            if not isinstance(items, list) or not all(isinstance(v, str) for v in items):
                raise bad
            if self.nonempty and not items:
                raise bad
            if self.choices and value not in self.choices:
                raise bad
            return value
        if self.type == "floats":
            if not isinstance(value, list) or not all(is_number(v) for v in value):
                raise bad
            if not all(self._in_range(_as_float(v)) for v in value):
                raise bad
            return [float(v) for v in value]
        if not is_number(value):
            raise bad
        if self.type == "int":
            if isinstance(value, int) and math.isinf(_as_float(value)):
                raise bad  # more digits than any count
            if not float(value).is_integer():
                raise bad
            value = int(value)
        else:
            value = _as_float(value)
        if not self._in_range(value):
            raise bad
        return value

    def _in_range(self, value: float) -> bool:
        if math.isnan(value) or (math.isinf(value) and not (self.infinite_ok and value > 0)):
            return False
        below = self.minimum is not None and (
            value < self.minimum or (self.exclusive_minimum and value == self.minimum)
        )
        return not below and (self.maximum is None or value <= self.maximum)


def _as_float(value: int | float) -> float:
    """``float(value)``, an integer beyond the float range as an infinity of its sign (then
    refused as out of range unless inf is allowed)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


#: The ``up`` parameter of the steps that work in world space.
UP_PARAM = Param(
    "up",
    "str",
    "auto",
    "up axis (-y: the figure stands head down along y; auto: found from the motion)",
    choices=("auto", *UP_AXES),
)


def cut_param(printed: str) -> Param:
    """The ``cut_deg`` parameter of a step that smooths each stretch between flips on its
    own (``StepSpec.cuts_at_flips``, lee-shin's filter): degrees, default
    :data:`~motionclean.core.jumps.JUMP_DEG`; 180 is the method as its paper prints it
    (``printed`` names it)."""
    return Param(
        "cut_deg",
        "float",
        JUMP_DEG,
        "a step between two frames that turns by more than this (degrees) is a flip or "
        "a glitch, not motion: each stretch between such steps is smoothed on its own "
        "(rotations; positions are not cut), so a flip stays a flip (despike repairs it) "
        "instead of becoming a fast turn; "
        f"180 smooths across every step ({printed})",
        minimum=0.0,
        exclusive_minimum=True,
        maximum=180.0,
    )


def given_up(params: dict) -> str | None:
    """The up axis a step's :data:`UP_PARAM` gives, None for ``auto``."""
    return None if params["up"] == "auto" else params["up"]


@dataclass
class StepData:
    """What a step sees: the selected joints' arrays, the clip's frame time and the clip.

    ``rotations`` ``(F, Jr, 4)`` and ``translations`` ``(F, Jp, 3)`` (None when positions
    are off or absent) are the selected columns, read-only unless ``owned`` (a step returns
    new arrays, as ``rotations`` may be the clip's own array); ``owned`` says they are
    copies the pipeline made or an earlier step's results, which the step may write into
    and return. ``rotation_joints`` / ``translation_joints`` give each column's index in
    ``motion.names``. ``motion`` is the whole clip as it enters the step (read-only
    context: skeleton, every joint's arrays). Notes are per column. ``earlier`` holds
    what the steps before this one noted, by joint name (``{"LeftKnee": {"auto": {...},
    "position_auto": {...}}}``, later steps' notes over earlier ones): a step may read
    them (footlock weighs each joint by the error ``auto`` expects in it). ``entered`` is
    the clip as it entered the pipeline on the frames of ``motion`` (rest-pose frames left
    out, cut as ``motion`` is; None where a step before remade the frames): what the steps
    so far changed (footlock holds a contact they made slide).
    """

    rotations: np.ndarray
    translations: np.ndarray | None
    frame_time: float
    motion: Motion | None = None
    rotation_joints: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    translation_joints: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    rotation_notes: dict[int, dict] = field(default_factory=dict)
    translation_notes: dict[int, dict] = field(default_factory=dict)
    owned: bool = False
    earlier: dict[str, dict] = field(default_factory=dict)
    entered: Motion | None = None


@dataclass(frozen=True)
class StepSpec:
    """A registered step: its pipeline name, parameters and how to run it.

    ``run`` maps the selected joints' arrays to new ones (:class:`StepData`). A whole-clip
    step (one that changes the frame count) gives ``run_motion(motion, params)`` instead,
    returning the new clip and notes keyed by joint name; with ``keeps_rest`` it is given
    the clip with its rest-pose frames and keeps them itself (a new frame rate changes how
    many frames they take). ``format_note(note, positions)``
    is how one joint's note reads in the HTML report (None: shown as JSON; long frame lists
    capped at :data:`PAGE_RUNS` runs, the JSON keeps them whole);
    ``format_brief(note, positions)``, if given, is its shorter terminal form (long frame
    lists summarised to their first run); ``lists_repairs`` puts its notes under the
    terminal table as repairs; ``smooths`` False: the step repairs, plants, moves or
    resamples a clip without smoothing it (a pipeline of such steps alone gets no noise
    judgement);
    ``shift_note(note, frames, frame_time)`` moves the frame numbers a note holds, and its
    times in seconds by as many frames (the pipeline runs steps without a clip's rest-pose
    frames, and on each take of joined takes, and numbers frames as the file does);
    ``crop_note(note, start, stop)`` keeps what a note says about frames ``[start, stop)``
    or gives None (nothing there): a step run on a frame range reports only what it
    changed; a joint's notes from parts of the clip run on their own (takes or known
    stretches) are merged with their frame lists joined and every other value the longest
    part's, then ``merge_note(parts)`` gives the values it sums or takes the maximum of
    (``(note, frames)`` per part, in frame order, numbered as the clip). Frame runs in notes are
    ``[first, stop)``: ``stop`` is the frame after the run's last.
    """

    name: str
    summary: str
    paper: str
    params: tuple[Param, ...]
    run: Callable[[StepData, dict], StepData] | None = None
    run_motion: Callable[[Motion, dict], tuple[Motion, dict[str, dict]]] | None = None
    # A clip of several takes joined end to end: ``run_takes(motion, params, starts)``
    # gives the new clip, notes and where each take after the first now begins, when the
    # step remakes the takes together (a new rate keeps them on one grid); else
    # ``run_motion`` runs on each take.
    run_takes: (
        Callable[[Motion, dict, np.ndarray], tuple[Motion, dict[str, dict], np.ndarray]] | None
    ) = None
    keeps_rest: bool = False
    positions_default: bool = True
    format_note: Callable[[dict, bool], str] | None = None
    format_brief: Callable[[dict, bool], str] | None = None
    lists_repairs: bool = False
    smooths: bool = True
    shift_note: Callable[[dict, int, float], dict] | None = None
    crop_note: Callable[[dict, int, int], dict | None] | None = None
    merge_note: Callable[[list[tuple[dict, int]]], dict] | None = None
    # Cross-parameter rules; may fill defaults that depend on other parameters.
    # ``resolve(params, at)``: ``at(*keys)`` is where an error about those keys starts (the
    # first given one's line in a pipeline file, else the step's place).
    resolve: Callable[[dict, Callable[..., str]], None] | None = None
    # Checks that need the clip's frame time (s): ``check_rate(params, frame_time, where)``
    # raises UsageError (a cutoff above the Nyquist frequency). The pipeline calls it with
    # the clip's rate before any step runs (a step after a whole-clip step: with the rate
    # that step made, before it runs), as it checks frame ranges.
    check_rate: Callable[[dict, float, str], None] | None = None
    # Names of the parameters that matter for these values (default: all of them).
    relevant: Callable[[dict], tuple[str, ...]] | None = None
    # True: the step runs on whole columns of a clip with missing samples and reads the mask
    # itself (``StepData.motion.missing``, placeholders held); False: each known stretch of
    # a column with gaps is run on its own (see ``column_wise``).
    sees_missing: bool = False
    # True: ``run`` treats every column as a signal of its own and reads only the arrays,
    # the frame time and the parameters (not ``motion``, ``entered`` or ``earlier``): the
    # known stretches of a clip with dropouts come as columns of one array, those of one
    # length together, with ``motion`` None. False: each stretch is run alone, with the
    # clip cut to it as ``motion``.
    column_wise: bool = False
    # Parameters besides ``joints`` that name joints by fnmatch patterns (footlock's
    # ``feet``): a pattern that matches no joint of a clip is warned of.
    name_patterns: tuple[str, ...] = ()
    # True: the step has a ``cut_deg`` parameter (:func:`cut_param`) and the pipeline runs
    # it on each stretch of a rotation column between steps that turn by more than that
    # (translations uncut), so a flip nothing repaired stays a flip. The step must be
    # ``column_wise``: the stretches come as columns of one array, with ``motion`` None (no
    # clip frames match them).
    cuts_at_flips: bool = False


COMMON_PARAMS = (
    Param(
        "joints",
        "strs",
        ["*"],
        "fnmatch patterns on joint names; a leading '!' excludes",
        nonempty=True,
    ),
    Param("positions", "bool", True, "also filter translation channels (vector counterpart)"),
    Param(
        "frames",
        "floats",
        None,
        "apply only to frames [first, last] (0-based, inclusive); elsewhere the input is kept",
        minimum=0.0,
    ),
    Param("seconds", "floats", None, "the same range in seconds from the first frame", minimum=0.0),
    Param(
        "blend",
        "int",
        5,
        "frames on each side of a range over which the result eases in and out (slerp)",
        minimum=0,
        maximum=100000,
    ),
)


def shift_runs(runs: list[list[int]], frames: int) -> list[list[int]]:
    """Frame runs ``[[first, stop], ...]`` moved by ``frames``."""
    return [[a + frames, b + frames] for a, b in runs]


def crop_runs(runs: list[list[int]], start: int, stop: int) -> list[list[int]]:
    """Frame runs ``[[first, stop], ...]`` (``stop`` exclusive) cut to frames
    ``[start, stop)``; runs outside are dropped."""
    cut = [[max(a, start), min(b, stop)] for a, b in runs]
    return [[a, b] for a, b in cut if a < b]


def held_at_mean(note: dict) -> bool:
    """Whether an ``auto`` note (a joint's rotations or positions) says the column was held
    at its mean over the clip (no mask: no motion above the noise)."""
    return note.get("filter", {}).get("mask") == "mean"


def format_params(params: dict) -> str:
    """A step's parameters as ``mask=binomial, k=3`` (floats in ``%g``)."""
    return ", ".join(
        f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in params.items()
    )


def fps_text(frame_time: float) -> str:
    """A frame rate as every message writes it: a whole number when the frame time is one
    rounded (0.008333 s is ``"120"``, within 1e-4), else six significant digits."""
    rate = 1.0 / frame_time
    whole = round(rate)
    if whole >= 1 and abs(rate - whole) <= 1e-4 * rate:
        return f"{whole:d}"
    return f"{rate:.6g}"


def format_runs(runs: list[list[int]]) -> str:
    """``[[198, 202], [214, 221]]`` (stop exclusive) -> ``"198-201, 214-220"``."""
    return ", ".join(f"{a}-{b - 1}" if b - a > 1 else f"{a}" for a, b in runs)


#: Runs listed in full in the terminal; longer lists are summarised, the first run named.
BRIEF_RUNS = 3
#: Runs the HTML page names of a longer list (the JSON report keeps every run).
PAGE_RUNS = 8


def brief_runs(runs: list[list[int]], first: int = 1) -> str:
    """At most ``max(BRIEF_RUNS, first)`` runs in full, else the total and the ``first``
    runs: ``"281 frames in 38 runs, first 198-201 and 37 more"``."""
    if len(runs) <= max(BRIEF_RUNS, first):
        return format_runs(runs)
    frames = sum(b - a for a, b in runs)
    return (
        f"{plural(frames, 'frame')} in {len(runs):,} runs, first {format_runs(runs[:first])} "
        f"and {len(runs) - first:,} more"
    )


def page_runs(runs: list[list[int]]) -> str:
    """:func:`brief_runs` as the HTML page lists runs: the first :data:`PAGE_RUNS` named."""
    return brief_runs(runs, PAGE_RUNS)
