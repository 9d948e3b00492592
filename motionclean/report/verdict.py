"""The verdict: one line in plain words on what a clip was and what cleaning did to it.

It is read off the report's figures, with repairs (flips and spikes un-done by ``despike``,
gaps bridged by ``fill-gaps``) kept apart from smoothing: a repaired half-turn flip changes
a joint by 180 degrees on purpose, so "largest change" and "jitter removed" are measured
outside the repaired frames. The same line is printed under the terminal table, leads the
HTML page and fills the batch index's verdict column; the JSON report carries it as
``verdict`` with the figures it was read from.

Statuses, first that applies (thresholds below, documented in the README):

- ``input only``: a clip reported on its own, nothing cleaned: its noise without the steps
  over :data:`~motionclean.core.jumps.JUMP_DEG` it makes (a flip is no jitter).
- ``needs a look``: an up axis given that the motion contradicts (the ``world``
  section's ``up_axis_contradicted``: a clip reported on its own says so after its
  noise), ``auto`` or ``footlock`` after a ``resample`` that changed the rate (they read
  the noise in the band its low-pass removed, or its spline never made: :data:`READS_NOISE`),
  a gap left missing (longer than ``max_gap``) or a pose the capture held longer than it
  left as captured, smoothing that moved a
  joint more than :data:`LOOK_CHANGE_DEG` outside repairs and more than
  :data:`LOOK_CHANGE_SIGMAS` times the noise ``auto`` estimated in it (fast motion taken
  for noise?),
  a joint repaired on more than :data:`LOOK_REPAIRED_SHARE` of its frames (which pose is the
  flipped one?), a joint of the cleaned clip turning faster than a body can
  (:data:`FAST_DEG_PER_S`) on more than :data:`LOOK_FAST_SHARE` of its frames, one
  thrashing (turning fast back and forth: :mod:`~motionclean.report.thrash`) on more than
  :data:`LOOK_THRASH_S` seconds of any half minute, feet sliding faster than
  :data:`LOOK_SKATE` body heights per second, a foot the cleaning made clearly worse
  (:data:`LOOK_WORSE`: sliding faster or deeper below ground during its contacts), or
  smoothing that changed the clip by more than :data:`LOOK_CHANGE_NOISE` times its noise
  (motion taken for noise; a capture whose noise is under :data:`CLEAN_NOISE_DEG` is then
  called clean, "clean capture, smoothed").
- ``clean``: smoothing changed the clip by less than :data:`CLEAN_CHANGE_DEG` RMS and
  nothing was repaired; ``repaired``: the same, with repairs.

Position channels (a BVH root's position, a tracker's positions, SMPL's ``trans``) are
judged the same way in length units against the clip's scale (its body height, or where it
has none the range its positions travel): :data:`CLEAN_CHANGE_HEIGHTS` and
:data:`LOOK_CHANGE_HEIGHTS` of it. A clip is clean only where both are; "left as it was"
is said only where no position moved by more than :data:`UNCHANGED_LENGTH`. Positions are
told in the line where they change what the rotations alone would say (see
:func:`build_verdict`).
- ``cleaned``: a noisy capture, smoothed (and repaired, if it says so); "clean capture,
  smoothed" where its noise is under :data:`CLEAN_NOISE_DEG` or the smoothing took less
  than :data:`NEGLIGIBLE_JITTER` of its jitter (it found no noise to take).
- ``not smoothed``: the pipeline has no smoothing step (only steps of
  :data:`NOT_SMOOTHING`) and repaired nothing: what it planted or moved is told, the noise
  is not judged (with repairs the status is ``repaired``, the line led by "not smoothed").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core.jumps import JUMP_DEG
from ..core.motion import UNCHANGED_TOLERANCE
from ..core.rates import same_rate
from ..core.takes import LONGEST_SPIKE_S, MAX_DEG_PER_S
from ..core.words import length_word, percent, plural, significant
from ..filters.auto import MIN_FRAMES, noted_slope
from ..steps import REGISTRY
from ..steps.base import BRIEF_RUNS, format_runs, fps_text
from .thrash import THRASH_DEG_PER_S

__all__ = [
    "CLEAN_CHANGE_DEG",
    "CLEAN_CHANGE_HEIGHTS",
    "CLEAN_NOISE_DEG",
    "FAST_DEG_PER_S",
    "LOOK_CHANGE_DEG",
    "LOOK_CHANGE_SIGMAS",
    "LOOK_CHANGE_HEIGHTS",
    "LOOK_CHANGE_NOISE",
    "LOOK_FAST_SHARE",
    "LOOK_REPAIRED_SHARE",
    "LOOK_SANK_BY",
    "LOOK_SKATE",
    "LOOK_THRASH_S",
    "LOOK_WORSE",
    "NEGLIGIBLE_JITTER",
    "NOT_SMOOTHING",
    "PLANTED_SKATE",
    "UNCHANGED_LENGTH",
    "build_verdict",
    "removed_words",
    "repaired_frames",
    "repaired_positions",
]

#: Smoothing that changes a clip by less than this RMS angle (degrees, outside repairs)
#: left it as it was: a clean capture (the default moves clean 120 fps captures by about
#: 0.01 degrees RMS, noisy ones by tenths of a degree and more).
CLEAN_CHANGE_DEG = 0.05
#: A largest change below this many degrees is the rounding of the conversions: nothing
#: moved, and no joint is named for it.
UNCHANGED_DEG = 1e-6
#: A fall in jitter (the fraction of it removed) under this is none to speak of: twice the
#: half percent under which the line reads "no jitter removed". A clip the ``ground`` step
#: moved that lost less was only put on the floor (its root's levelling turn is not
#: smoothing); a capture that lost less had no noise for the smoothing to take, whatever
#: its noise estimate, and is not called noisy ("clean capture, smoothed": a clean 30 fps
#: Bandai Namco walk lost 0.2 %, its estimated 0.34 degrees of noise its own fast motion).
NEGLIGIBLE_JITTER = 0.01
#: The line gives the positions' share of jitter removed beside the rotations' where it
#: is this much larger (a tracker CSV: 6 % of the rotations', 46 % of the positions'), and
#: instead of theirs where the rotations lost none and the positions at least this much (a
#: clean 30 fps capture's root loses 1-2 %: no noise to speak of).
POSITIONS_APART = 0.2
#: Smoothing that moves any joint by more than this (degrees, outside repairs) needs a
#: look ...
LOOK_CHANGE_DEG = 10.0
#: ... where that is also more than this many times the noise ``auto`` estimated in the
#: joint (its RMS, degrees): removing noise of RMS s moves a joint by up to about 4 s
#: (the markerless takes of ../shared/realnoise: 4.1-4.8 s, 11-68 degrees, every one of
#: those joints closer to its truth after), so a change within it is the noise going.
LOOK_CHANGE_SIGMAS = 6.0
#: ... and so does smoothing that changes the clip by more than this many times its
#: estimated noise (RMS over joints and frames against the RMS of the joints' per-sample
#: noise): it took motion away. The default changes a clip by 0.3-0.9 times its noise
#: (the noisy sample 0.92, markerless takes 0.43-0.92); a Lee-Shin filter of k=2 run 3
#: times changed a clean capture whose noise is 0.01 degrees by 0.36 degrees RMS.
LOOK_CHANGE_NOISE = 3.0
#: A capture whose noise is under this many degrees (RMS over its joints) is clean, however
#: much a pipeline smoothed it (a clean optical capture: 0.01-0.05).
CLEAN_NOISE_DEG = 0.05
#: The position counterparts of :data:`CLEAN_CHANGE_DEG` and :data:`LOOK_CHANGE_DEG`, in
#: body heights (or, without one, of the range the clip's positions travel): the end of a
#: limb 0.57 body heights long (1 m of 1.75 m) turned by 0.05 degrees moves by 0.0005 body
#: heights (0.9 mm), turned by 10 degrees by 0.1.
CLEAN_CHANGE_HEIGHTS = 0.0005
LOOK_CHANGE_HEIGHTS = 0.1
#: A position that moved by no more than this (length units) is as the writers give it back:
#: closer values are written with the input's own text
#: (:data:`motionclean.core.motion.UNCHANGED_TOLERANCE`).
UNCHANGED_LENGTH = UNCHANGED_TOLERANCE
#: A joint repaired on more than this share of its frames needs a look.
LOOK_REPAIRED_SHARE = 0.5
#: A capture with a flip or a spike repaired on at least this share of its joints (and on
#: :data:`GLITCHY_JOINTS` or more) is no clean capture whatever its jitter: "glitchy
#: capture, repaired" (a network's 165-joint estimate of 63 frames, 64 repairs on 50
#: joints, had read "clean capture, smoothed").
GLITCHY_SHARE = 0.2
GLITCHY_JOINTS = 3
#: A joint of the cleaned clip turning faster than this between two frames (degrees per
#: second), or by more than :data:`~motionclean.core.jumps.JUMP_DEG` degrees in one (at 24
#: and 30 fps, where this is 150 and 120 degrees a frame), turns faster than a body can:
#: ``despike``'s cap (:data:`~motionclean.core.takes.MAX_DEG_PER_S`, 30 degrees a frame at
#: 120 fps). Clean captures stay under it after the default pipeline at 24 to 120 fps: the
#: fastest step of CMU 131_01-03 (at 120 fps and every 2nd, 4th and 5th frame), the sample
#: clips, the exporters' clips and two LaFAN1 and two MANN dog captures at 30 and 60 fps is
#: 3,483 deg/s (a dog's tail; 131_03's RightWrist 3,460 at 30 fps), and no joint takes such
#: a step on more than 1.4 % of its frames (3 of 220, 131_03's RightWrist at 24 fps; the
#: dog's tail 5 of 2,167 at 30 fps); marker-based captures of a dance, lifting, gait and
#: sit-to-stand turn no joint coordinate faster than 1,314 deg/s.
FAST_DEG_PER_S = MAX_DEG_PER_S
#: A position stepping faster than this many body heights per second (17.5 m/s for a 1.75
#: m body, of the positions' range of travel without one) jumped: a sprinter's hips move
#: at about 6, a tracker's teleport or a re-zeroed root (a root moved 0.41 body heights in
#: a frame at 120 fps, 49, and back 0.17 s later: longer than despike's spikes) far faster.
FAST_BODY_HEIGHTS_PER_S = 10.0
#: ... and it is this many times the step before it and the step after it: a teleport out
#: of a still pose, not a fast move (a serve's or a punch's hand passes 10 body heights/s
#: with steps that rise and fall around it).
JUMP_OVER_AROUND = 3.0
#: ... and a joint doing so on more than this share of its frames (steps within the motion)
#: needs a look: no motion keeps it up, a glitch (a twist flipping back and forth) does,
#: and ``despike`` leaves it where it spans more than a quarter of a joint's frames. Clean
#: captures: at most 1.4 % of a joint's frames (8.3 % of its worst second, 2 of 24, the
#: same wrist); the joint coordinates of markerless estimates that glitch up to 21,570
#: deg/s, as read: at most 0.75 %.
LOOK_FAST_SHARE = 0.1
#: A joint of the cleaned clip thrashing (:func:`~motionclean.report.thrash.thrash_frames`)
#: on more than this many seconds of some
#: :data:`~motionclean.report.thrash.THRASH_WINDOW_S` needs a look: the clean captures'
#: default outputs thrash on at most 2.0 s of theirs (CMU 131_03's RightWrist through its
#: hop at 24 fps; 1.5-1.8 s at 30 to 120 fps; MANN dogs' front legs 1.9 s), a glitching
#: optical take's wrists (LaFAN1's dance1_subject2) on 6.1 and 10.1 s: this lies 1.7
#: times above the one and under the other.
LOOK_THRASH_S = 3.5
#: Feet whose ankles slide no faster than this during contacts (body heights per second,
#: over 0.1 s, after cleaning) are planted; the value of ``footlock``'s ``min_skate``.
PLANTED_SKATE = 0.1
#: A foot whose skate after cleaning is above this many times its skate before ...
SLID_MORE = 1.25
#: ... and above it by more than this (body heights per second) slides more than it did.
SLID_MORE_BY = 0.01
#: Feet sliding faster than this after cleaning need a look (``footlock`` holds them).
LOOK_SKATE = 0.5
#: A foot the cleaning made clearly worse needs a look: its skate during contacts more than
#: this many times what it was ...
LOOK_WORSE = 2.0
#: ... and faster by more than :data:`SLID_MORE_BY` body heights per second, or its depth
#: below ground during contacts more than :data:`LOOK_WORSE` times and this many body
#: heights deeper (3.5 mm of a 1.75 m body). On the sample clips, the exporters', CMU
#: 131_01-03 (also at every 2nd, 4th and 5th frame and with 1-3 degrees of noise planted)
#: and Xsens takes the default raised a skate by at most 0.0002 body heights/s (1.01
#: times) and a depth by 0.00022 body heights (both a Mixamo foot); on a Perception Neuron
#: sit-to-stand read as markerless it made a foot slide 3.5 times as fast (0.005 -> 0.018)
#: and put the other 0.0035 body heights deeper (0.00012 -> 0.0036).
LOOK_SANK_BY = 0.002
#: Steps that repair, plant, put on the floor or resample a clip without smoothing it: a
#: pipeline of these alone gets no noise judgement (``StepSpec.smooths``).
NOT_SMOOTHING = frozenset(name for name, spec in REGISTRY.items() if not spec.smooths)
#: Steps that read the clip's noise (``auto`` in its band above 10 Hz, ``footlock`` from
#: ``auto``'s notes or the same estimate): after a resample to a lower rate, whose
#: anti-alias low-pass removed that band, they read only the noise it left; after one to a
#: higher rate, whose spline holds nothing above the old Nyquist frequency, none.
READS_NOISE = ("auto", "footlock")


def _runs(note: dict, key: str) -> list[list[int]]:
    return [list(r) for r in note.get(key) or []]


#: In a pair of clips (``report IN OUT``: no step's notes say what was repaired), a sample
#: whose rotation changed by more than this many degrees was repaired: un-flipping turns a
#: joint about half a turn (165-180 degrees on the noisy sample's RThumb), where smoothing
#: across the same flips (``multires:level=2,cut_deg=180``) leaves 60-150.
PAIR_REPAIR_DEG = 150.0
#: ... and a joint changed on no more than this many seconds in a row, a frame on each side
#: exactly as it was (no clip end), changed briefly, as a repair does (``despike``'s longest
#: spike, 0.07 s, widened by its cap a frame per side as many times), where its input
#: shows a repair: steps into and out of the run over ``despike``'s floor for a jump
#: (``MIN_DEG_PER_S``) or one inside it over its cap (``MAX_DEG_PER_S``). Told as such, not
#: as smoothing (an Xsens toe capped on 2 frames, entered at 3,601 deg/s and left at 1,483,
#: had read "smoothing changed it by 0.08 degrees RMS, more than 3 times its noise: motion
#: taken for noise"). Smoothing leaves a frame as it was only where the input holds still
#: around it, so it reaches still frames before and after a still joint's twitch: one of
#: 0.1 s and 25 degrees (steps up to 840 deg/s) smoothed by ``lee-shin:k=3`` changes a run
#: entered and left by input steps of 0, judged as smoothing.
PAIR_BRIEF_S = 3 * LONGEST_SPIKE_S
#: The notes that say which frames a repairing step changed: (step, key) of its runs.
_ROTATION_REPAIRS = (
    ("despike", "unflipped"),
    ("despike", "interpolated"),
    ("auto", "outliers"),  # (lone one-frame spikes auto took out before smoothing)
    ("fill-gaps", "filled"),
    ("turned", "runs"),  # (two clips compared: the frames turned over PAIR_REPAIR_DEG)
    ("brief_change", "runs"),  # (two clips compared: joints changed briefly)
)
_POSITION_REPAIRS = (("position_despike", "interpolated"), ("fill-gaps", "filled"))


def _mask(runs: list[list[int]], n_frames: int) -> np.ndarray:
    """``(n_frames,)`` bool: the frames of ``[start, stop)`` runs."""
    mask = np.zeros(n_frames, dtype=bool)
    for start, stop in runs:
        mask[max(start, 0) : max(stop, 0)] = True
    return mask


def _repaired(joints: dict[str, dict], n_frames: int, notes) -> dict[str, np.ndarray]:
    """Per joint with any of the runs ``notes`` names, the mask of their frames."""
    masks = {}
    for name, entry in joints.items():
        runs = [run for step, key in notes for run in _runs(entry.get(step) or {}, key)]
        if runs:
            masks[name] = _mask(runs, n_frames)
    return masks


def repaired_frames(joints: dict[str, dict], n_frames: int) -> dict[str, np.ndarray]:
    """Per joint whose rotations a repairing step changed, the ``(n_frames,)`` mask of the
    frames it repaired: ``despike``'s un-flipped and interpolated runs and ``fill-gaps``'
    filled gaps (``[start, stop)`` file frames, from the joints' report notes)."""
    return _repaired(joints, n_frames, _ROTATION_REPAIRS)


def repaired_positions(joints: dict[str, dict], n_frames: int) -> dict[str, np.ndarray]:
    """:func:`repaired_frames` of the position channels: ``despike``'s interpolated runs of a
    joint's positions (its ``position_despike`` note) and ``fill-gaps``' filled gaps."""
    return _repaired(joints, n_frames, _POSITION_REPAIRS)


def _changed_far(joints: dict, changes: dict[str, float]) -> tuple[str, float] | None:
    """The joint changed most of those whose largest change outside repairs (``changes``,
    degrees) is over :data:`LOOK_CHANGE_DEG` and over :data:`LOOK_CHANGE_SIGMAS` times the
    noise ``auto`` estimated in it (``joints``' notes), with its change; None: none is."""

    def noise(name: str) -> float:  # (degrees; 0 without an auto note)
        return ((joints.get(name) or {}).get("auto") or {}).get("noise") or 0.0

    far = [
        (change, name)
        for name, change in changes.items()
        if change > max(LOOK_CHANGE_DEG, LOOK_CHANGE_SIGMAS * noise(name))
    ]
    if not far:
        return None
    change, name = max(far)
    return name, change


def _repairs(joints: dict[str, dict]) -> dict[str, dict[str, int]]:
    """Per joint with a repair: flips, spikes and steps capped (over ``despike``'s cap,
    runs without a spike; of its rotations and positions), gaps filled and left, frames
    repaired."""
    found = {}
    for name, entry in joints.items():
        despike = entry.get("despike") or {}
        position = entry.get("position_despike") or {}
        moved = _runs(position, "interpolated")
        # (the capped runs are some of the interpolated ones)
        capped = len(_runs(despike, "capped")) + len(_runs(position, "capped"))
        gaps = entry.get("fill-gaps") or {}
        turned = _runs(entry.get("turned") or {}, "runs")
        brief = _runs(entry.get("brief_change") or {}, "runs")
        lone = _runs(entry.get("auto") or {}, "outliers")
        counts = {
            "flips": len(_runs(despike, "unflipped")),
            "spikes": len(_runs(despike, "interpolated")) + len(moved) + len(lone) - capped,
            "capped": capped,
            "gaps_filled": len(_runs(gaps, "filled")) - len(_runs(gaps, "held")),
            "gaps_left": len(_runs(gaps, "missing")),
        }
        if turned:  # (two clips compared)
            counts = {"turned": len(turned)} | counts
        if brief:  # (two clips compared)
            counts = counts | {"brief": len(brief)}
        if gaps.get("held"):  # (poses the capture held, bridged: a subset of the filled)
            counts = counts | {"held": len(gaps["held"])}
        if any(counts.values()):
            frames = int(despike.get("frames_repaired", 0))
            frames += sum(b - a for a, b in _runs(gaps, "filled") + turned + brief + lone)
            if moved:  # the position repairs' frames the rotations' left out
                told = [
                    run
                    for step, key in _ROTATION_REPAIRS
                    for run in _runs(entry.get(step) or {}, key)
                ]
                stop = max(max(b for _, b in moved + told), 0)
                frames += int((_mask(moved, stop) & ~_mask(told, stop)).sum())
            found[name] = counts | {"frames": frames}
    return found


def listed(names: list[str], limit: int = 2) -> str:
    """``"A, B and 3 more"``: the first ``limit`` of ``names``, and how many others."""
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")


#: Joints a repair phrase names with their counts; the others are counted together.
REPAIRS_NAMED = 3


def held_poses(joints: dict[str, dict]) -> int:
    """How many poses the capture held ``fill-gaps`` bridged: the distinct frame runs of
    its notes' ``held`` over every joint (one recorder's dropout holds many joints)."""
    return len(
        {
            tuple(run)
            for entry in joints.values()
            for run in _runs(entry.get("fill-gaps") or {}, "held")
        }
    )


def _repair_words(repairs: dict[str, dict[str, int]], poses: int = 0) -> list[str]:
    """ "2 flips repaired on RThumb", "14 flips repaired (RThumb 13, LeftElbow 1)": one
    phrase per kind, several joints each with its count, most first (the first
    :data:`REPAIRS_NAMED`, then how many more joints); held poses as ``poses`` distinct
    runs on how many joints ("2 held poses bridged on 23 joints")."""
    words = []
    for key, noun, verb in (
        ("turned", "repair", f"(a turn over {PAIR_REPAIR_DEG:g} degrees)"),
        ("flips", "flip", "repaired"),
        ("spikes", "spike", "repaired"),
        ("capped", "too-fast step", "capped"),
        ("gaps_filled", "gap", "filled"),
        ("held", "held pose", "bridged"),
    ):
        counts = sorted(
            ((counts[key], name) for name, counts in repairs.items() if counts.get(key)),
            key=lambda pair: -pair[0],
        )
        if not counts:
            continue
        total = f"{plural(sum(n for n, _ in counts), noun)} {verb}"
        if key == "held" and len(counts) > 1:  # (``poses``: the distinct runs held)
            words.append(f"{plural(poses, noun)} {verb} on {plural(len(counts), 'joint')}")
            continue
        if len(counts) == 1:
            words.append(f"{total} on {counts[0][1]}")
            continue
        words.append(f"{total} ({_per_joint(counts)})")
    return words


def _per_joint(counts: list[tuple[int, str]]) -> str:
    """ "RThumb 13, LeftElbow 1": ``(count, joint)`` pairs, most first, the first
    :data:`REPAIRS_NAMED` named, then how many more joints."""
    each = [f"{name} {n:,}" for n, name in counts[:REPAIRS_NAMED]]
    if len(counts) > REPAIRS_NAMED:
        each[-1] += f" and {plural(len(counts) - REPAIRS_NAMED, 'more joint')}"
    return ", ".join(each)


def _brief_words(joints: dict[str, dict]) -> list[str]:
    """ "changed by up to 5.1 degrees on RightToe (frames 64-65)": the joints two clips
    compared show changed briefly (their ``brief_change`` notes), as a repair does; several
    counted per joint, most runs first ("changed by up to 11.1 degrees in 9 brief runs
    (RightToe 5, LeftToe 4)")."""
    notes = {name: e["brief_change"] for name, e in joints.items() if e.get("brief_change")}
    if not notes:
        return []
    peak = f"changed by up to {max(n['max_deg'] for n in notes.values()):.1f} degrees"
    if len(notes) == 1:
        name, note = next(iter(notes.items()))
        runs = note["runs"]
        if len(runs) <= BRIEF_RUNS:
            return [f"{peak} on {name} (frames {format_runs(runs)})"]
        return [f"{peak} on {name} in {len(runs):,} brief runs (first {format_runs(runs[:1])})"]
    counts = sorted(((len(n["runs"]), name) for name, n in notes.items()), key=lambda p: -p[0])
    total = plural(sum(n for n, _ in counts), "brief run")
    return [f"{peak} in {total} ({_per_joint(counts)})"]


def _too_fast(smoothing: dict) -> dict[str, dict[str, float]]:
    """Per joint of the cleaned clip turning faster than :data:`FAST_DEG_PER_S` (or over
    :data:`~motionclean.core.jumps.JUMP_DEG` degrees a frame) on more than
    :data:`LOOK_FAST_SHARE` of its frames (``smoothing["fast_steps"]``: per joint, its
    steps within the motion doing so and all of them), most frames first: ``frames`` and
    ``share``."""
    found = {
        name: {"frames": int(frames), "share": frames / steps}
        for name, (frames, steps) in (smoothing.get("fast_steps") or {}).items()
        if steps and frames > LOOK_FAST_SHARE * steps
    }
    return dict(sorted(found.items(), key=lambda item: -item[1]["frames"]))


def _fast_words(fast: dict[str, dict[str, float]]) -> str:
    """ "RightHand turns faster than a body can (over 3,600 deg/s, or 90 degrees in a frame)
    on 77 frames (26 %)"; several joints each with their frames and share, most first (the
    first :data:`REPAIRS_NAMED`, then how many more joints)."""
    limit = f"(over {FAST_DEG_PER_S:,.0f} deg/s, or {JUMP_DEG:g} degrees in a frame)"
    if len(fast) == 1:
        name, found = next(iter(fast.items()))
        where = f"{plural(int(found['frames']), 'frame')} ({percent(found['share'])})"
        return f"{name} turns faster than a body can {limit} on {where}"
    each = [
        f"{name} ({found['frames']:,}{' frames' if not k else ''}, {percent(found['share'])})"
        for k, (name, found) in enumerate(list(fast.items())[:REPAIRS_NAMED])
    ]
    if len(fast) > REPAIRS_NAMED:
        each.append(plural(len(fast) - REPAIRS_NAMED, "more joint"))
    return f"{', '.join(each[:-1])} and {each[-1]} turn faster than a body can {limit}"


def _jump_words(jumped: dict[str, tuple[int, float, int]], per: str) -> str:
    """ "Hips's position jumps (steps over 10 body heights/s, 3 times the steps beside them: a
    tracker's teleport?) on 2 frames, up to 49.5 body heights/s at frame 620"; several
    joints named, the most jumps first, with the fastest jump's joint (``jumped``: joint ->
    jumps, fastest speed in ``per`` per second, its frame)."""
    order = sorted(jumped, key=lambda name: -jumped[name][0])
    if per.startswith("body height"):  # "body height" or "body height (1.75 m)"
        unit = "body heights/s" + per[len("body height") :]
    else:
        unit = f"times {per} per second"
    limit = (
        f"(steps over {FAST_BODY_HEIGHTS_PER_S:g} {unit}, {JUMP_OVER_AROUND:g} times the "
        "steps beside them: a tracker's teleport?)"
    )
    frames = sum(jumped[name][0] for name in order)
    name, (_, fastest, at) = max(jumped.items(), key=lambda item: item[1][1])
    if len(order) == 1:
        return (
            f"{name}'s position jumps {limit} on {plural(frames, 'frame')}, up to "
            f"{fastest:.3g} {unit} at frame {at}"
        )
    return (
        f"the positions of {listed(order)} jump {limit} on {plural(frames, 'frame')}, "
        f"fastest {name}'s: {fastest:.3g} {unit} at frame {at}"
    )


def _thrashing(smoothing: dict, fast: dict) -> dict[str, dict[str, float]]:
    """Per joint of the cleaned clip thrashing on more than :data:`LOOK_THRASH_S` seconds of
    some :data:`~motionclean.report.thrash.THRASH_WINDOW_S` (``smoothing["thrash"]``: per
    joint, its thrash frames and those seconds), most frames first: ``frames`` and
    ``window_seconds``; a joint in ``fast`` (:func:`_too_fast`) is told there."""
    found = {
        name: {"frames": int(frames), "window_seconds": seconds}
        for name, (frames, seconds) in (smoothing.get("thrash") or {}).items()
        if seconds > LOOK_THRASH_S and name not in fast
    }
    return dict(sorted(found.items(), key=lambda item: -item[1]["frames"]))


def _thrash_words(thrash: dict[str, dict[str, float]], report: dict) -> str:
    """ "LeftWrist thrashes (turns back and forth at over 700 deg/s) on 241 frames (8.0 s),
    left as it was"; several joints each with their frames and seconds, most first (the first
    :data:`REPAIRS_NAMED`, then how many more joints); "left as it was" / "left as they
    were" where the cleaning changed none of them by :data:`CLEAN_CHANGE_DEG`."""
    dt = float(report["frame_time"])
    limit = f"back and forth at over {THRASH_DEG_PER_S:,.0f} deg/s"
    changed = [
        ((report["joints"].get(name) or {}).get("deviation_deg") or {}).get("max")
        for name in thrash
    ]
    left = all(peak is not None and peak < CLEAN_CHANGE_DEG for peak in changed)
    if len(thrash) == 1:
        name, found = next(iter(thrash.items()))
        frames = int(found["frames"])
        tail = ", left as it was" if left else ""
        return (
            f"{name} thrashes (turns {limit}) on {plural(frames, 'frame')} "
            f"({frames * dt:.1f} s){tail}"
        )
    each = [
        f"{name} ({found['frames']:,}{' frames' if not k else ''}, {found['frames'] * dt:.1f} s)"
        for k, (name, found) in enumerate(list(thrash.items())[:REPAIRS_NAMED])
    ]
    if len(thrash) > REPAIRS_NAMED:
        each.append(plural(len(thrash) - REPAIRS_NAMED, "more joint"))
    tail = ", left as they were" if left else ""
    return f"{', '.join(each[:-1])} and {each[-1]} thrash (turn {limit}){tail}"


def _feet(contacts: dict | None) -> tuple[str | None, float | None]:
    """ "feet planted", "feet slide 0.20 body heights/s" or, where cleaning made a foot slide
    more than it did (:data:`SLID_MORE`), "feet slide more than before: 0.043 -> 0.065
    body heights/s" after cleaning, and the fastest foot's skate (body heights per
    second); None without feet in contact."""
    feet = (contacts or {}).get("feet") or {}
    pairs = [
        (foot["skate_body_heights"].get("before"), foot["skate_body_heights"]["after"])
        for foot in feet.values()
        if foot.get("contacts") and foot["skate_body_heights"].get("after") is not None
    ]
    pairs = [(b, a) for b, a in pairs if math.isfinite(a)]
    if not pairs:
        return None, None
    fastest = max(a for _, a in pairs)
    more = [
        (b, a)
        for b, a in pairs
        if b is not None and math.isfinite(b) and a > SLID_MORE * b and a - b > SLID_MORE_BY
    ]
    if more:
        b, a = max(more, key=lambda pair: pair[1] - pair[0])
        return f"feet slide more than before: {b:.3f} -> {a:.3f} body heights/s", fastest
    if fastest <= PLANTED_SKATE:
        return "feet planted", fastest
    return f"feet slide {_over(fastest, PLANTED_SKATE)} body heights/s", fastest


def _unplanted(report: dict) -> str:
    """Why footlock planted no foot: none was in contact, or none could be looked for, the
    clip having no joint positions (the world figures' reason, e.g. SMPL parameters read
    without a body model)."""
    skipped = (report.get("world") or {}).get("skipped")
    if skipped:
        return f"no feet looked for, nothing planted ({skipped})"
    return "no foot in contact found, nothing planted"


def _feet_worse(report: dict) -> dict[str, dict[str, dict[str, float]]]:
    """Per foot in contact that the cleaning made clearly worse (:data:`LOOK_WORSE`), its
    ``skate`` (body heights per second) and ``depth`` below ground during contacts (body
    heights) ``before`` and ``after``, those that rose so."""
    feet = ((report.get("contacts") or {}).get("feet")) or {}
    height = (report.get("world") or {}).get("body_height")
    scale = float(height) if isinstance(height, float | int) and height > 0 else math.nan
    found = {}
    for name, foot in feet.items():
        if not foot.get("contacts"):
            continue
        pairs = {
            "skate": (foot.get("skate_body_heights"), 1.0, SLID_MORE_BY),
            "depth": (foot.get("penetration_during_contacts"), scale, LOOK_SANK_BY),
        }
        worse = {}
        for key, (pair, per, by) in pairs.items():
            before, after = (pair or {}).get("before"), (pair or {}).get("after")
            if before is None or after is None:
                continue
            before, after = before / per, after / per
            if after > LOOK_WORSE * before and after - before > by:  # (False for NaN)
                worse[key] = {"before": before, "after": after}
        if worse:
            found[name] = worse
    return found


def _worse_words(worse: dict[str, dict[str, dict[str, float]]]) -> str:
    """ "the cleaning made the feet worse during contacts: RightFoot slides 0.005 -> 0.018
    body heights/s, LeftFoot below ground 0.00012 -> 0.0036 body heights"."""
    each = []
    for name, found in worse.items():
        if "skate" in found:
            b, a = found["skate"]["before"], found["skate"]["after"]
            each.append(f"{name} slides {b:.3f} -> {a:.3f} body heights/s")
        if "depth" in found:
            b, a = found["depth"]["before"], found["depth"]["after"]
            each.append(f"{name} below ground {significant(b)} -> {significant(a)} body heights")
    return f"the cleaning made the feet worse during contacts: {', '.join(each)}"


def _over(value: float, limit: float) -> str:
    """``value``, over ``limit``, in two decimals, or three where two would read as the
    limit itself ("feet slide 0.10" where up to 0.1 is planted: 0.102)."""
    return f"{value:.2f}" if round(value, 2) > limit else f"{value:.3f}"


def _ground_words(joints: dict[str, dict], unit: str) -> tuple[list[str], list[str]]:
    """ "put on the floor: 1.06 units down, levelled from 0.67 deg": what the ``ground`` step
    did to the whole clip (its note on the root's positions), and what it left: "not put
    on the floor: no foot in contact found"; lengths in ``unit``."""
    words, left = [], []
    for entry in joints.values():
        note = entry.get("position_ground")
        if not note:
            continue
        if "why" in note:
            left.append(f"not put on the floor: {note['why']}")
            continue
        height = note["height"]
        way = "down" if height > 0 else "up"
        resting = note.get("resting")
        if resting:
            text = (
                f"put on the floor by its lowest point: {abs(height):.3g} {unit} {way} (the "
                f"body rests below its feet: {resting['point']} {resting['below']:.3g} {unit} "
                "under their floor)"
            )
        else:
            text = f"put on the floor: {abs(height):.3g} {unit} {way}"
        if note.get("levelled", True) and note["tilt_deg"] > 0:
            text += f", levelled from {note['tilt_deg']:.2f} deg"
        elif not resting and note.get("unsupported") and note["tilt_deg"] > 0:
            text += (
                f", not levelled (a tilt of {note['tilt_deg']:.2f} deg through soles at "
                f"{note['places']:.2g} places)"
            )
        words.append(text)
    return words, left


def removed_words(
    fraction: float, what: str = "jitter", shown: Callable[[float], str] = percent
) -> str:
    """ "86 % of the jitter removed", "no jitter removed" (under half a percent either way) or
    "jitter up 3 %" (``what``: "position jitter", of the position channels; ``shown``
    writes a share, the HTML page's with a thin space)."""
    if fraction >= 0.005:
        return f"{shown(fraction)} of the {what} removed"
    if fraction > -0.005:
        return f"no {what} removed"
    return f"{what} up {shown(-fraction)}"


#: The line adds what the end effectors' world acceleration says where it is under this
#: share of the jitter removed (and that is at least :data:`NEGLIGIBLE_JITTER`): a video
#: estimate's joint angles, fitted to keypoints, jitter against each other (a hip's noise
#: undone by the knee's), so smoothing them took a third of their jitter while its hands,
#: feet and head, what the eye sees, lost 2 % of their acceleration.
WORLD_SHARE = 0.5


def _world_removed(report: dict) -> float | None:
    """The fraction of the end effectors' RMS world acceleration the cleaning removed,
    pooled over the effectors (the report's ``world.effectors``, every frame: the verdict
    takes it only where nothing was repaired); None without them."""
    effectors = ((report.get("world") or {}).get("effectors") or {}).values()
    pairs = [
        (e["linear_accel_rms"]["before"], e["linear_accel_rms"]["after"])
        for e in effectors
        if e.get("linear_accel_rms")
        and e["linear_accel_rms"].get("before")
        and e["linear_accel_rms"].get("after") is not None
    ]
    before = sum(b * b for b, _ in pairs)
    if not before:
        return None
    return 1.0 - math.sqrt(sum(a * a for _, a in pairs) / before)


def _unseen(removed: float, world: float) -> bool:
    """Whether the end effectors' world acceleration fell by much less than the joints'
    jitter (:data:`WORLD_SHARE`): the line then says so."""
    return removed >= NEGLIGIBLE_JITTER and world < WORLD_SHARE * removed


def _under(value: float) -> str:
    """A bound above ``value`` (> 0) in one significant figure, rounded up, without an
    exponent: "0.0001" for 8.7e-05, "0.2" for 0.115 (the power of ten above, "1", had
    read "moved by under 1 units")."""
    power = 10.0 ** math.floor(math.log10(value))
    return significant(math.ceil(value / power * (1 - 1e-12)) * power, 1)


def _scale(report: dict, smoothing: dict) -> tuple[float, str]:
    """The length the position thresholds are shares of, and what it is: the body height
    where the clip has one, else the range its positions travel (a tracked body on its
    own); 0 where neither is known."""
    height = (report.get("world") or {}).get("body_height")
    if isinstance(height, float | int) and math.isfinite(height) and height > 0:
        return float(height), "body height"
    travel = smoothing.get("travel")
    if travel is not None and math.isfinite(travel) and travel > 0:
        return float(travel), "the positions' range of travel"
    return 0.0, ""


def _untold(joints: dict[str, dict]) -> str:
    """``" (as optical: its source not told; ...)"`` where ``auto`` took the clip for an
    optical capture because the clip could not tell its source (too few joints move above
    the noise over 2-8 Hz), else "". A video estimate's noise wanders in the motion's band,
    where the optical model does not look: two knee angles of VideoPose3D walks read "clean
    capture: left as it was" at 2-7 times a tuned Butterworth's acceleration error (1.0-1.8
    with ``--source video``)."""
    notes = ((entry.get("auto") or {}) for entry in joints.values())
    untold = any(
        note.get("source") == "auto"
        and note.get("model") == "optical"
        and math.isnan(noted_slope(note) or 0.0)
        for note in notes
    )
    return " (as optical: its source not told; for video, --source video)" if untold else ""


def _missing_words(joints: dict[str, dict]) -> list[str]:
    """ "NAME missing on frames ..." per set of runs left missing, and "a pose the capture
    held left as captured on NAME, frames ..." per set of held runs longer than
    ``fill-gaps``' ``max_gap``; the joints that share one named together (three at most,
    then how many more)."""
    words = []
    for key, said in (
        ("missing", "{who} missing on frames {spans}"),
        (
            "held_left",
            "a pose the capture held left as captured on {who}, frames {spans} "
            "(longer than fill-gaps' max_gap)",
        ),
    ):
        by_runs: dict[str, list[str]] = {}
        for name, entry in joints.items():
            runs = _runs(entry.get("fill-gaps") or {}, key)
            if runs:
                more = f" and {len(runs) - 3} more" if len(runs) > 3 else ""
                by_runs.setdefault(f"{format_runs(runs[:3])}{more}", []).append(name)
        for spans, names in by_runs.items():
            who = ", ".join(names[:3])
            if len(names) > 3:
                who += f" and {plural(len(names) - 3, 'more joint')}"
            words.append(said.format(who=who, spans=spans))
    return words


def _across_defects(smoothing: dict, joint: str, change: float, filters: list) -> str:
    """Why smoothing moved ``joint`` by ``change`` degrees, where that largest change lies
    near (:data:`~motionclean.report.summary.NEAR_JUMP_S`) a step of its input over
    :data:`~motionclean.core.jumps.JUMP_DEG` that nothing repaired ("" elsewhere: a flip
    kept as a flip 260 frames away had been blamed)."""
    count = (smoothing.get("unrepaired_jumps") or {}).get(joint, 0)
    near = (smoothing.get("changed_near_jumps") or {}).get(joint, 0.0)
    if not count or near < change:
        return ""
    what = "despike left them" if "despike" in filters else "despike repairs them first"
    return (
        f" across {plural(count, 'step')} of over {JUMP_DEG:g} degrees in the input "
        f"(flips or glitches: {what})"
    )


def jumps_left_out(count: int) -> str:
    """ ", without 10 steps over 90 degrees (flips or glitches)": what a noise figure leaves
    out (``count`` steps of the input over :data:`~motionclean.core.jumps.JUMP_DEG`); ""
    without any."""
    if not count:
        return ""
    return f", without {plural(count, 'step')} over {JUMP_DEG:g} degrees (flips or glitches)"


def _up_words(report: dict) -> list[str]:
    """The up axis given that the motion contradicts (the ``world`` section's
    ``up_axis_contradicted``), as a reason to look: every world figure, the feet and
    ``footlock`` and ``ground`` used it; and each step's own ``up`` that it contradicts
    (``steps_up_contradicted``: that step used it)."""
    world = report.get("world") or {}
    shown = world.get("up_axis_contradicted")
    said = [
        f"the up axis given to {step['filter']} ({step['up_axis']}) contradicts the motion "
        f"({step['shown']['up_axis']})"
        for step in world.get("steps_up_contradicted") or []
    ]
    if not shown:
        return said
    how = "assumed" if world.get("up_axis_source") == "assumed" else "given"
    return [
        f"the up axis {how} ({world['up_axis']}) contradicts the motion ({shown['up_axis']})",
        *said,
    ]


def _order_words(report: dict) -> list[str]:
    """The steps of :data:`READS_NOISE` placed after a ``resample`` that changed the rate,
    as a reason to look: "auto after resample to 30 fps reads only the noise the
    resample's low-pass left: put auto before resample" (up: where the spline left none);
    none where each reads the clip's own rate."""
    steps = report.get("pipeline") or []
    if not any(step.get("filter") == "resample" for step in steps):
        return []
    frame_time, changed = float(report["frame_time"]), ""
    late: list[str] = []
    for step in steps:
        name = step.get("filter")
        if name == "resample":
            new = 1.0 / step["fps"] if step.get("fps") else float(step["frame_time"])
            if not same_rate(frame_time, new):
                above = f"above {0.5 / frame_time:.3g} Hz"
                changed = f"to {fps_text(new)} fps " + (
                    "reads only the noise the resample's low-pass left"
                    if new > frame_time
                    else f"reads the noise where its spline left none ({above})"
                )
            frame_time = new
        elif name in READS_NOISE and changed and name not in late:
            late.append(name)
    if not late:
        return []
    named = " and ".join(late)
    reads = changed if len(late) == 1 else changed.replace(" reads ", " read ", 1)
    return [f"{named} after resample {reads}: put {named} before resample"]


def _input_only(report: dict, alone: dict | None) -> dict[str, Any]:
    """The verdict of a clip reported on its own: its noise, without the steps over
    :data:`~motionclean.core.jumps.JUMP_DEG` where ``alone`` (:func:`build_verdict`) counts
    them."""
    if alone is None:  # (figures without the series: the summary's total)
        alone = {"noise_before": report["summary"]["angular_accel_rms"]["before"]}
    noise = alone["noise_before"]
    jumps = sum((alone.get("unrepaired_jumps") or {}).values())
    measured = (
        "no noise measured (no three frames in a row known)"
        if noise is None
        else f"noise {noise:,.0f} deg/s\u00b2 RMS angular acceleration{jumps_left_out(jumps)}"
    )
    thrash = _thrashing(alone, {})
    looks = [*_up_words(report), *([_thrash_words(thrash, report)] if thrash else [])]
    look = "".join(f"; needs a look: {words}" for words in looks)
    return {
        "status": "input only",
        "text": f"input only, not cleaned: {measured}{look}",
        "noise_before": noise,
        "noise_weighting": alone.get("noise_weighting", "equal"),
        "unrepaired_jumps": jumps,
        "thrash": thrash,
    }


def build_verdict(
    report: dict, smoothing: dict | None, alone: dict | None = None
) -> dict[str, Any]:
    """The verdict of a report (:func:`motionclean.report.summary.build_report`'s dict, before
    its ``verdict`` key): ``status``, ``text`` and the figures behind them.

    ``smoothing`` holds the figures outside repairs (None for a clip reported on its own):
    ``noise_before`` and ``noise_after`` (RMS angular acceleration, deg/s^2),
    ``noise_removed`` (the fraction of it removed, each joint's weighted by its reach
    squared: :func:`~motionclean.report.summary.build_series`' ``reaches``), ``change_deg_max`` and
    ``change_deg_rms`` (rotation angle between input and output, degrees),
    ``change_joint`` (where the largest change is) and ``noise_level`` (the input's
    per-sample rotation noise, RMS over joints, degrees; None where the change is under
    :data:`CLEAN_CHANGE_DEG`: not needed), ``fast_steps`` (per joint of the cleaned clip,
    its steps faster than :data:`FAST_DEG_PER_S` and all its steps within the motion),
    ``thrash`` (per joint of the cleaned clip that thrashes, its thrash frames and their
    seconds in its worst :data:`~motionclean.report.thrash.THRASH_WINDOW_S`); of
    the position channels (None each
    without any) ``position_noise_before``, ``position_noise_after`` (RMS linear
    acceleration, length units/s^2), ``position_noise_removed``, ``change_length_max``,
    ``change_length_rms`` (length units), ``change_length_joint``, ``position_moved``
    (``(name, largest distance)`` of the joints that moved, largest first) and ``travel``.
    ``alone`` holds the figures of a clip reported on its own: ``noise_before`` (deg/s^2,
    without the steps over :data:`~motionclean.core.jumps.JUMP_DEG`) and ``unrepaired_jumps``
    (per joint, how many such steps); without it the line gives the summary's total.

    Positions are told in the line where they say what the rotations alone do not: where
    the rotations were left (nearly) as they were (below :data:`CLEAN_CHANGE_DEG` RMS) and a
    position moved by more than :data:`UNCHANGED_LENGTH` (not by ``ground`` alone), or a
    position moved by more than :data:`LOOK_CHANGE_HEIGHTS` of the clip's scale. Where the
    rotations were smoothed the line is theirs, positions told only where their jitter rose.
    """
    joints = report["joints"]
    if smoothing is None:
        return _input_only(report, alone)
    repairs = _repairs(joints)
    feet, skate = _feet(report.get("contacts"))
    reasons = _up_words(report) + _order_words(report) + _missing_words(joints)
    change, joint = smoothing["change_deg_max"], smoothing["change_joint"]
    filters = [step.get("filter") for step in report.get("pipeline") or []]
    rest = report.get("rest_frames") or {}
    motion_frames = int(report["frames"]) - rest.get("leading", 0) - rest.get("trailing", 0)
    too_short = motion_frames < MIN_FRAMES  # no step can tell noise in so few frames
    rotations_unmeasured = smoothing["noise_removed"] is None
    position_removed = smoothing.get("position_noise_removed")
    # no three frames in a row known, of rotations or positions
    unmeasured = rotations_unmeasured and position_removed is None
    smoothed = (
        not too_short
        and not unmeasured
        and (not filters or any(n not in NOT_SMOOTHING for n in filters))
    )
    what = "smoothing moved" if filters and smoothed else "the cleaning moved"
    # a new rate's anti-alias low-pass takes what the new rate cannot hold: that change is
    # the resample's, told as the cleaning's, and no sign of motion taken for noise
    resampled = "resample" in filters
    if resampled:
        what = "the cleaning (its resample included) moved"
    far = _changed_far(joints, smoothing.get("joint_changes") or {joint: change})
    if far is not None:
        reasons.append(
            f"{what} {far[0]} by {far[1]:.1f} degrees"
            + _across_defects(smoothing, far[0], far[1], filters)
        )
    noise = smoothing.get("noise_level")
    # (away from the input's flips and glitches no step repaired: a smoother across them
    # moves the frames near them, told above, not motion taken for noise)
    rms = smoothing.get("change_deg_rms_away", smoothing["change_deg_rms"])
    over_noise = (
        smoothed
        and not resampled
        and noise is not None
        and rms >= CLEAN_CHANGE_DEG
        and rms > LOOK_CHANGE_NOISE * noise
    )
    if over_noise:
        reasons.append(
            f"smoothing changed it by {rms:.2f} degrees RMS, more than {LOOK_CHANGE_NOISE:g} "
            f"times its noise ({noise:.2g} degrees): motion taken for noise"
        )
    unit = length_word(report.get("length_unit"))
    grounded, not_grounded = _ground_words(joints, unit)
    # positions: moved beyond the writers' rounding, and not by the ground step alone
    # (which moves and levels the whole clip without smoothing it)
    moved = [n for n, peak in smoothing.get("position_moved") or [] if peak > UNCHANGED_LENGTH]
    length = smoothing.get("change_length_max") or 0.0
    position_joint = smoothing.get("change_length_joint")
    scale, per = _scale(report, smoothing)
    told = bool(moved) and not (
        grounded and (position_removed is None or position_removed < NEGLIGIBLE_JITTER)
    )
    if grounded:  # (the distances hold the ground's move: only the jitter tells smoothing)
        positions_clean = not told
    else:
        positions_clean = not told or (
            scale > 0 and smoothing["change_length_rms"] < CLEAN_CHANGE_HEIGHTS * scale
        )
        # (as for a joint's rotation: a move the noise auto found there explains is none)
        own = ((joints.get(position_joint) or {}).get("position_auto") or {}).get("noise")
        reach = max(LOOK_CHANGE_HEIGHTS * scale, LOOK_CHANGE_SIGMAS * (own or 0.0))
        if told and scale > 0 and length > reach:
            share = percent(length / scale)
            reasons.append(
                f"{what} {position_joint}'s position by {significant(length)} {unit} "
                f"({share} of {per})"
            )
    frames = max(int(report["frames"]), 1)
    for name, counts in repairs.items():
        # (a brief change, two clips compared, claims no repair)
        brief = _runs(joints[name].get("brief_change") or {}, "runs")
        repaired = counts["frames"] - sum(b - a for a, b in brief)
        if repaired > LOOK_REPAIRED_SHARE * frames:
            reasons.append(f"{name} repaired on {repaired / frames:.0%} of its frames")
    too_fast = _too_fast(smoothing)
    if too_fast:
        reasons.append(_fast_words(too_fast))
    jumped = smoothing.get("fast_positions") or {}
    if jumped:
        reasons.append(_jump_words(jumped, smoothing["fast_positions_per"]))
    thrash = _thrashing(smoothing, too_fast)
    if thrash:
        reasons.append(_thrash_words(thrash, report))
    if skate is not None and skate > LOOK_SKATE:
        hint = "" if "footlock" in filters else " (footlock holds them)"
        reasons.append(f"feet slide {_over(skate, LOOK_SKATE)} body heights/s{hint}")
    worse = _feet_worse(report)
    if worse:
        reasons.append(_worse_words(worse))
    done = _repair_words(repairs, held_poses(joints))
    glitched = sum(1 for counts in repairs.values() if counts["flips"] or counts["spikes"])
    glitchy = glitched >= max(GLITCHY_JOINTS, GLITCHY_SHARE * len(joints))
    briefly = _brief_words(joints)  # (two clips compared: no repair claimed)
    # a clip only put on the floor (levelling turns the root) removed no jitter: still clean
    rotations_clean = smoothing["change_deg_rms"] < CLEAN_CHANGE_DEG or bool(
        grounded and not rotations_unmeasured and smoothing["noise_removed"] < NEGLIGIBLE_JITTER
    )
    clean = rotations_clean and positions_clean
    # the positions say what the rotations do not: the clip changed where they left it, or
    # their jitter fell where the rotations' did not (noise on an all-position skeleton's
    # joints, 94 % of it removed, had read "clean capture, smoothed: no jitter removed")
    rotations_quiet = rotations_unmeasured or abs(smoothing["noise_removed"]) < NEGLIGIBLE_JITTER
    positions_lead = told and (
        rotations_clean
        or (
            rotations_quiet and position_removed is not None and position_removed >= POSITIONS_APART
        )
    )
    removed = "" if rotations_unmeasured else removed_words(smoothing["noise_removed"])
    # (the effectors' figures hold every frame: with repairs they would count them)
    world = None if repairs else _world_removed(report)
    if removed and world is not None and _unseen(smoothing["noise_removed"], world):
        removed += " (" + removed_words(world, "end effectors' world acceleration") + ")"
    # (the feet said among the reasons: too fast, or sliding clearly more than before)
    looking = skate is not None and skate > LOOK_SKATE
    looking = looking or any("skate" in found for found in worse.values())
    shown_feet = None if looking else feet
    if not smoothed:
        parts = done + briefly + grounded
        if too_short:
            parts.insert(0, f"too short to judge ({plural(motion_frames, 'frame')})")
        elif unmeasured:
            parts.insert(0, "no noise to judge (no three frames in a row known)")
        if not feet and "footlock" in filters:
            parts.append(_unplanted(report))
        if not parts and not shown_feet:
            parts.append("nothing repaired")
        lead = "not smoothed"
    elif clean:
        parts = done + briefly + grounded
        # (below CLEAN_CHANGE_DEG RMS, its largest change may still be a few tenths)
        left = "left as it was" if change < CLEAN_CHANGE_DEG else "barely moved"
        if positions_lead:  # "left as it was" only where no value moved
            who = f"{moved[0]} position" if len(moved) == 1 else f"positions of {listed(moved)}"
            little = f"{who} moved by under {_under(length)} {unit}"
            left = little if change < CLEAN_CHANGE_DEG else f"{left}, {little}"
        parts.append(f"otherwise {left}" if parts else left)
        lead = "clean capture, repaired" if done else "clean capture"
        if glitchy:
            lead = "glitchy capture, repaired"
        lead += _untold(joints)
    else:
        parts = [removed] + done + briefly + grounded
        if positions_lead and position_removed is not None:
            parts[0] = removed_words(position_removed, "position jitter")
        elif (
            told
            and position_removed is not None
            and not rotations_unmeasured
            and (
                position_removed <= -0.005
                or position_removed >= smoothing["noise_removed"] + POSITIONS_APART
            )
        ):  # (up, or well beyond the rotations' share: trackers' 6 % and 46 %)
            parts.insert(1, removed_words(position_removed, "position jitter"))
        parts = [part for part in parts if part]
        # (a capture whose noise is too small for the smoothing to tell, or of whose jitter
        # (the share the line gives) it took none to speak of: it was clean)
        shown_removed = (
            position_removed
            if positions_lead and position_removed is not None
            else smoothing["noise_removed"]
        )
        quiet = (noise is not None and noise < CLEAN_NOISE_DEG) or (
            shown_removed is not None and abs(shown_removed) < NEGLIGIBLE_JITTER
        )
        lead = "clean capture, smoothed" if quiet else "noisy capture, cleaned"
        if quiet and glitchy:
            lead = "glitchy capture, repaired and smoothed"
        if quiet:
            lead += _untold(joints)
    parts += not_grounded
    if shown_feet:
        parts.append(shown_feet)
    # without the pipeline (two clips compared as given) no step says what it repaired
    where = " (steps not recorded: repairs not told apart)"
    turned = any(counts.get("turned") for counts in repairs.values())  # (two clips compared)
    if report.get("pipeline"):
        where = " outside repairs"
    elif turned or briefly:
        left = " and ".join(w for w, on in (("repairs", turned), ("brief changes", briefly)) if on)
        why = f"turns over {PAIR_REPAIR_DEG:g} degrees: " if turned else ""
        where = f" outside {left} ({why}steps not recorded)"
    tail = f"largest change {change:.1f} degrees{where}"
    if change < 0.05:
        tail = f"largest change {change:.2g} degrees{where}"
    if change < UNCHANGED_DEG:
        tail = f"no rotation changed{where}"
    if positions_lead and not grounded and not clean:
        tail = f"largest position change {significant(length)} {unit} on {position_joint}, {tail}"
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
        # (a clip too short to judge has no jitter removed to show, as one unmeasured)
        "noise_removed": None if too_short else smoothing["noise_removed"],
        "noise_weighting": smoothing.get("noise_weighting", "equal"),
        "world_removed": None if too_short else world,
        "change_deg_max": change,
        "change_deg_rms": smoothing["change_deg_rms"],
        # (away from the input's unrepaired flips and glitches: what "motion taken for
        # noise" is judged on)
        "change_deg_rms_away": smoothing.get("change_deg_rms_away", smoothing["change_deg_rms"]),
        "change_joint": joint if change >= UNCHANGED_DEG else None,
        "noise_level_deg": smoothing.get("noise_level"),
        "position_noise_before": smoothing.get("position_noise_before"),
        "position_noise_after": smoothing.get("position_noise_after"),
        "position_noise_removed": position_removed,
        # (the line gives the positions' share: they said what the rotations did not)
        "positions_lead": bool(positions_lead and position_removed is not None),
        "change_length_max": smoothing.get("change_length_max"),
        "change_length_rms": smoothing.get("change_length_rms"),
        "change_length_joint": position_joint if moved else None,
        "length_scale": scale if scale > 0 else None,
        "length_scale_of": per or None,
        "repairs": repairs,
        "too_fast": too_fast,
        "position_jumps": {
            name: {"frames": steps, "fastest": fastest, "at": at}
            for name, (steps, fastest, at) in jumped.items()
        },
        "thrash": thrash,
        "feet": feet,
        "feet_worse": worse,
    }
