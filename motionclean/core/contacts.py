"""Foot contacts: which points are feet, when each foot is on the ground, and skate figures.

Functions on world-space arrays (see :mod:`motionclean.core.kinematics`), those that find
contacts and floors on a clip's :class:`FootScene` (its positions, feet, up axis, body height
and frame time, gathered once), and :func:`skeleton_feet`, which finds the feet on a clip;
the footlock step and the report both use this module. Every threshold is relative to the
body height ``H`` (file length units) and in seconds, never in frames or file units, so a
skeleton in metres or inches, at 24 or 120 fps, behaves the same.

Points are the skeleton's joints followed by its end sites: ``parents`` ``(P,)`` gives each
point's parent point (-1 for a root) and ``positions`` are ``(F, P, 3)``.
"""

from __future__ import annotations

import fnmatch
import math
import re
from dataclasses import dataclass, replace

import numpy as np

from . import kinematics
from .motion import Motion, run_labels
from .rates import whole_frames

#: Bones at least this long (fraction of the body height) are thigh and shin.
LONG_BONE = 0.12
#: Leaves this close to the lowest rest point (fraction of body height) are toes or heels.
FOOT_ZONE = 0.2
#: Thigh + shin at least this long (fraction of body height): a leg, not a finger.
LEG_LENGTH = 0.4


@dataclass(frozen=True)
class Foot:
    """One leg: the IK chain ``hip -> knee -> ankle`` and the points of the foot.

    ``points`` are the ankle and every point below it (toes, end sites): the foot's lowest
    point touches the ground, the ankle is what a foot lock holds.
    """

    name: str
    hip: int
    knee: int
    ankle: int
    points: tuple[int, ...]


@dataclass(frozen=True)
class ContactParams:
    """Contact thresholds, in body heights ``H`` and seconds."""

    height: float = 0.06  # lowest foot point within this of the ground to start (H)
    height_off: float = 0.08  # ... and to stay (H)
    speed: float = 0.15  # ankle speed below this to start (H/s)
    speed_off: float = 0.25  # ... and to stay (H/s)
    min_duration: float = 0.1  # shorter contacts are dropped (s)
    smoothing: float = 0.2  # positions averaged over this window before speeds (s)

    @classmethod
    def starting_at(cls, height: float, speed: float, min_duration: float) -> ContactParams:
        """Thresholds that start a contact at ``height`` (H) and ``speed`` (H/s); the ones
        that keep it going are looser by :data:`HEIGHT_HYSTERESIS` and
        :data:`SPEED_HYSTERESIS`."""
        return cls(
            height=height,
            height_off=height * HEIGHT_HYSTERESIS,
            speed=speed,
            speed_off=speed * SPEED_HYSTERESIS,
            min_duration=min_duration,
        )


@dataclass(frozen=True, eq=False)
class FootScene:
    """A clip's feet in world space, as contacts and floors are found on them.

    ``positions`` ``(F, P, 3)``: the points' world positions (length units, turned
    :func:`~motionclean.core.kinematics.upright`); ``feet`` the feet among them (indices
    into ``positions``' points), ``up`` the up axis (0, 1, 2), ``height`` the body height
    ``H`` (length units), ``frame_time`` seconds; ``unknown`` ``(F, n_feet)``: frames where
    a foot's place is not known (:func:`feet_unknown`: a tracker's dropout, its samples
    held; None: known throughout); ``sideways`` ``(3,)``: the body's sideways lean a
    floor's prior follows (:func:`fit_floor`; None: a level prior).
    """

    positions: np.ndarray
    feet: list[Foot]
    up: int
    height: float
    frame_time: float
    unknown: np.ndarray | None = None
    sideways: np.ndarray | None = None

    @classmethod
    def of_motion(
        cls,
        motion: Motion,
        feet: list[Foot],
        up: int,
        height: float,
        given: str | None = None,
        positions: np.ndarray | None = None,
        unknown: np.ndarray | None = None,
    ) -> FootScene:
        """The scene of ``motion``'s ``feet``: ``positions`` (default: every joint and end
        site, turned :func:`~motionclean.core.kinematics.upright` by the up axis
        ``given``, e.g. ``"-y"``, else the one found), its frame time, ``unknown`` as given
        and the sideways lean its trunk and legs share (the floor's prior)."""
        return cls(
            kinematics.upright_positions(motion, given) if positions is None else positions,
            feet,
            up,
            height,
            motion.frame_time,
            unknown=unknown,
            sideways=kinematics.sideways_lean(motion, given),
        )

    def of_feet(self, kept: list[int]) -> FootScene:
        """The scene of the feet ``kept`` (indices into ``feet``) alone."""
        unknown = None if self.unknown is None else self.unknown[:, kept]
        return replace(self, feet=[self.feet[k] for k in kept], unknown=unknown)


#: Seconds over which a contact's ankle speed is averaged to tell whether it slides.
SLIDE_WINDOW = 0.3
#: A contact the cleaning before made slide (:func:`sliding_contacts` given ``before``):
#: its fastest window faster than this many times the captured clip's fastest window in
#: the same contact (the two may lie at different frames) ...
SLIDE_GROWTH = 2.0
#: ... and than this many body heights per second (a still foot's sub-millimetre jitter,
#: doubled, is no slide): a Perception Neuron sit-to-stand whose legs the markerless model
#: smoothed, its root left as captured, had its standing foot slide at 0.018 body heights/s
#: where the capture's stood at 0.005, under the 0.1 a capture's own slide is judged by.
SLIDE_ADDED = 0.01
#: A contact this close to the clip's first or last frame (seconds) reaches it where the
#: foot stays low and slower than :data:`EDGE_SPEED` times the staying speed in between
#: (twice it when the speeds there were read at half; after ``auto``, a standing ankle of
#: a corpus walk at 30 fps with 3 degrees of noise reads 3.1 times it there, a foot
#: landing at 0.5 body heights/s 2.6 times: the speed alone cannot tell them apart) ...
EDGE_SECONDS = 0.25
EDGE_SPEED = 4.0
#: ... and its ankle no more than this (body heights) above its median height in the
#: contact: a heel that rises is lifting off, one coming down is landing. Contacts inside
#: a clip end by their speed with the ankle 0.002 above its lowest (median; 90 % under
#: 0.009, 6 of 218 over 0.015; clean walks: the corpus, PyMO's, game walks at 24-100
#: fps); toe-offs at a clip's end rise 0.03-0.06. 0.01 left standing feet of noisy clips
#: unheld at the ends (a corpus walk at 30 fps: its skate there 2.8 -> 15 times its
#: capture's); 0.02 held a game walk's heel-strike landing from the first frame.
EDGE_RISE = 0.015
#: Loose thresholds that keep a contact going, relative to the ones that start it.
HEIGHT_HYSTERESIS = 4.0 / 3.0
SPEED_HYSTERESIS = 5.0 / 3.0


def find_feet(
    parents: np.ndarray,
    rest: np.ndarray,
    up: int,
    height: float,
    names: list[str],
    patterns: list[str] | None = None,
    elevation: np.ndarray | None = None,
) -> list[Foot]:
    """The feet of a skeleton, found from its bones and poses (or named by ``patterns``).

    ``rest`` ``(P, 3)`` are the rest-pose world positions of the points (their bone lengths
    count), ``up`` the up axis (0, 1, 2) and ``height`` the body height; ``elevation``
    ``(P,)`` each point's typical height above the lowest point of its pose (default: in
    the rest pose). Without ``patterns``, a foot is the chain above a leaf near the lowest
    point: walking up from the leaf, the ankle is the first point hanging from a long bone
    (the shin) whose parent hangs from one too (the thigh: a long toe end site is not a
    shin), or that point's parent where its two bones are longer and it is as low (a long
    foot bone and the shin are not the shin and the thigh), the knee its parent and the
    hip the knee's parent. Whatever the joint names, and
    none on a skeleton with no legs; on a body (a trunk above legs,
    :func:`~motionclean.core.kinematics.trunk_split`) never in its upper body, whose hands
    may hang lowest. ``patterns`` (fnmatch on joint names, e.g. ``["*Foot"]``) name the
    ankles instead.
    """
    parents = np.asarray(parents)
    n_joints = len(names)
    children = kinematics.child_lists(parents)
    bone = np.zeros(len(parents))
    has_parent = parents >= 0
    bone[has_parent] = np.linalg.norm(rest[has_parent] - rest[parents[has_parent]], axis=1)
    long_bone = bone > LONG_BONE * height

    split = None
    if patterns is not None:
        ankles = [
            j for j in range(n_joints) if any(fnmatch.fnmatchcase(names[j], p) for p in patterns)
        ]
    else:
        if elevation is None:
            elevation = rest[:, up] - rest[:, up].min()
        low = elevation < FOOT_ZONE * height
        split = kinematics.trunk_split(parents)
        if split is not None:  # a body: feet hang from the legs, never from the upper body
            low[split[0]] = False
        else:  # a limb alone: an arm (by its names) has no foot, a leg has one
            low &= ~_arm_points(parents, names)
        leaves = [j for j in range(len(parents)) if not children[j] and low[j]]
        ankles = []

        def two_long(j: int) -> bool:  # hangs from two long bones (shin and thigh)
            return bool(long_bone[j] and parents[j] >= 0 and long_bone[parents[j]])

        for leaf in leaves:
            j = leaf  # up to the first point hanging from two long bones ...
            while j >= 0 and not two_long(j):
                j = parents[j]
            # ... or its parent, where that one's two are longer (a long foot bone and the
            # shin above it are not the shin and the thigh)
            if j >= 0 and two_long(parents[j]) and low[parents[j]]:  # (an ankle is low)
                knee = parents[j]
                if bone[knee] + bone[parents[knee]] > bone[j] + bone[knee]:
                    j = knee
            if j >= 0 and j < n_joints and j not in ankles:
                ankles.append(j)
    leg = None if split is None else _below_trunk(parents, split[0])  # a knee lies in one
    feet = []
    for ankle in sorted(ankles):
        knee = parents[ankle]
        hip = parents[knee] if knee >= 0 else -1
        if hip < 0 or not (long_bone[ankle] and long_bone[knee]):
            continue
        if leg is not None and not leg[knee]:
            continue
        if _leg_length(parents, bone, ankle, leg) < LEG_LENGTH * height:
            continue
        feet.append(
            Foot(
                names[ankle],
                int(hip),
                int(knee),
                int(ankle),
                tuple(kinematics.subtree(children, ankle)),
            )
        )
    return _one_per_knee(feet, rest)


def _below_trunk(parents: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``(P,)`` bool: the points of a body outside its ``upper`` body and off the chain from
    its pelvis up to the root (a leg's, a second figure's or a prop's). A cat whose feet
    are IK targets hung from the root had its hip taken for an ankle, the pelvis for its
    knee."""
    inside = np.zeros(len(parents), dtype=bool)
    inside[upper] = True
    point = int(parents[next(p for p in upper.tolist() if not inside[parents[p]])])
    while point >= 0:  # the pelvis and what stands above it
        inside[point] = True
        point = int(parents[point])
    return ~inside


def _leg_length(parents: np.ndarray, bone: np.ndarray, ankle: int, leg: np.ndarray | None) -> float:
    """The length of the leg above ``ankle`` (``bone``: each point's bone length): its shin
    and thigh, and on a body (``leg``: its leg points) every bone above them up to the
    trunk. A shin split in two bones (MakeHuman's lowerleg01 and lowerleg02) makes the
    mid-shin the knee: its shin and thigh had measured 4.08 of a 16.5 body, its leg 9.1."""
    knee = int(parents[ankle])
    length, point = bone[ankle] + bone[knee], int(parents[knee])
    while leg is not None and point >= 0 and leg[point]:
        length += bone[point]
        point = int(parents[point])
    return float(length)


#: Words of arm joints' names in every exporter's naming (CMU's LeftWrist, Mixamo's
#: LeftForeArm, SMPL's left_elbow, Bandai Namco's LowerArm_L, Rigify's hand.L ...).
ARM_WORDS = ("arm", "hand", "wrist", "elbow", "shoulder", "finger", "thumb", "clavicle", "collar")


def _words(name: str) -> list[str]:
    """A joint name's words, lower case: split at case changes and non-letters
    ("LeftForeArm": left, fore, arm; "hand.L": hand, l; "Armature": armature)."""
    return [w.lower() for w in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])", name)]


def _arm_points(parents: np.ndarray, names: list[str]) -> np.ndarray:
    """``(P,)`` bool: the points (joints, then end sites) at or below a joint named as an
    arm's (a word of its name ending in one of :data:`ARM_WORDS`: "forearm", "lhand";
    not "Armature", Blender's root), where a skeleton without a trunk has no upper body to
    leave out: an arm alone (shoulder, elbow, wrist) hangs from two long bones as a leg
    does, and its wrist had been taken for a foot and held by footlock."""
    parents = np.asarray(parents, dtype=np.intp)
    named = np.zeros(len(parents), dtype=bool)
    named[: len(names)] = [
        any(token.endswith(ARM_WORDS) for token in _words(name)) for name in names
    ]
    arm, above = named.copy(), parents.copy()
    while np.any(above >= 0):  # up the tree, every point at once (depth steps)
        up = above >= 0
        arm[up] |= named[above[up]]
        above[up] = parents[above[up]]
    return arm


def _one_per_knee(feet: list[Foot], rest: np.ndarray) -> list[Foot]:
    """``feet`` with one foot per knee: of two chains below one shin (Rigify's heel beside
    its foot: foot.L -> toe.L and heel.L -> heel.02.L), the one whose points reach farthest
    from its ankle in the rest pose ``(P, 3)`` (the toes, not the heel)."""

    def reach(foot: Foot) -> float:
        return float(np.linalg.norm(rest[list(foot.points)] - rest[foot.ankle], axis=1).max())

    best: dict[int, Foot] = {}
    for foot in feet:
        if foot.knee not in best or reach(foot) > reach(best[foot.knee]):
            best[foot.knee] = foot
    return [foot for foot in feet if best[foot.knee] is foot]


def skeleton_feet(
    motion: Motion, patterns: list[str] | None = None, up: str | None = None
) -> tuple[list[Foot], int, float]:
    """Feet, up axis (0, 1, 2) and body height of ``motion``: :func:`find_feet` with the
    up axis named by ``up`` (``"x"`` ... ``"-z"``) or found
    (:func:`~motionclean.core.kinematics.up_direction`), and each point's height above the
    lowest point of its frame, median over the clip's sampled poses
    (:func:`~motionclean.core.kinematics.sample_poses`): the rest pose may face another
    way than the motion. Contacts and floors are found on world positions turned
    :func:`~motionclean.core.kinematics.upright` (a figure head down stands on them)."""
    axis, sign = kinematics.up_direction(motion, up)
    height = kinematics.body_height(motion, axis)
    poses, _ = kinematics.sample_poses(motion)
    elevation = None
    if poses.shape[0]:
        heights = sign * poses[..., axis]  # (a figure head down stands toward -axis)
        elevation = np.median(heights - heights.min(axis=1, keepdims=True), 0)
    feet = find_feet(
        kinematics.point_parents(motion),
        kinematics.rest_pose(motion),
        axis,
        height,
        motion.names,
        patterns,
        elevation,
    )
    return feet, axis, height


def has_body(motion: Motion) -> bool:
    """Whether ``motion``'s skeleton is a body: a trunk
    (:func:`~motionclean.core.kinematics.trunk_split`) or feet (:func:`skeleton_feet`: legs
    alone). A hand, a head, a camera or tracked bodies are none: their size is no body
    height."""
    parents = kinematics.point_parents(motion)
    return kinematics.trunk_split(parents) is not None or bool(skeleton_feet(motion)[0])


def no_feet_words(motion: Motion) -> str:
    """Why :func:`skeleton_feet` finds no feet on ``motion``: where it holds no joint
    positions, why (:func:`~motionclean.core.kinematics.world_note`: OpenSim coordinates,
    SMPL parameters without a body model); ``"no feet in this skeleton"`` where it has no
    trunk (:func:`~motionclean.core.kinematics.trunk_split`: a hand, a head, a camera,
    tracked bodies), else ``"no leg ends near the ground"``."""
    unseen = kinematics.world_note(motion)
    if unseen is not None:
        return f"no joint positions ({unseen})"
    if kinematics.trunk_split(kinematics.point_parents(motion)) is None:
        return "no feet in this skeleton"
    return "no leg ends near the ground"


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) frames of the runs of True in a 1-D bool array."""
    edges = np.diff(np.concatenate(([0], mask.view(np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def _filled(n: int, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """``(n,)`` bool, True on the runs ``starts[i] .. ends[i] - 1`` (:func:`_runs`' form)."""
    delta = np.zeros(n + 1, dtype=np.int64)
    delta[starts] += 1
    delta[ends] -= 1
    return np.cumsum(delta[:-1]) > 0


def _moving_average(x: np.ndarray, half: int) -> np.ndarray:
    """Centred moving average over ``2 half + 1`` frames along axis 0, window shrunk at ends
    (``half < len(x)``). Differences of running sums, taken from views of them: no
    clip-long temporary besides the sums."""
    if half == 0:
        return x
    n = x.shape[0]
    c = np.empty((n + 1, *x.shape[1:]))  # running sums from 0
    c[0] = 0.0
    np.cumsum(x, axis=0, out=c[1:])
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    out = np.empty_like(c[1:])
    width = 2 * half + 1
    if n >= width:  # every frame from half to n - half - 1 has the whole window
        np.subtract(c[width:], c[: n + 1 - width], out=out[half : n - half])
    ends = np.flatnonzero((hi - lo) < width) if n >= width else np.arange(n)
    out[ends] = c[hi[ends]] - c[lo[ends]]
    out /= (hi - lo).reshape((-1,) + (1,) * (x.ndim - 1))
    return out


def ankle_tracks(
    positions: np.ndarray, feet: list[Foot], frame_time: float, smoothing: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(F, n_feet, 3)`` each ankle's position after a centred moving average of
    ``smoothing`` seconds (capped by the clip's length) and ``(F, n_feet)`` its speed
    (length units / s); within half the window of the clip's first or last frame, where
    the clip cuts the average, the least-squares line through what there is of the window,
    at the frame, and its slope (:func:`_edge_lines`). A foot at a time: temporaries of
    one ankle's track."""
    n = positions.shape[0]
    smooth = np.zeros((n, len(feet), 3))
    speed = np.zeros((n, len(feet)))
    if n < 2:
        return positions[:, [f.ankle for f in feet]].astype(np.float64), speed
    half = min(int(round(0.5 * smoothing / frame_time)), max(n // 2 - 1, 0))
    edges = np.flatnonzero((np.arange(n) <= half) | (np.arange(n) >= n - 1 - half))
    if half == 0:  # no average: the track and its differences between frames, as they are
        edges = edges[:0]
    for k, foot in enumerate(feet):
        track = positions[:, foot.ankle]
        smooth[:, k] = _moving_average(track, half)
        velocity = np.gradient(smooth[:, k], frame_time, axis=0)
        smooth[edges, k], velocity[edges] = _edge_lines(track, edges, half)
        velocity[edges] /= frame_time
        speed[:, k] = np.linalg.norm(velocity, axis=-1)
    return smooth, speed


def _edge_lines(track: np.ndarray, frames: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares line through ``track`` ``(F, 3)`` over frames ``i - half .. i +
    half`` cut to the clip, for each frame ``i`` of ``frames``: its value at ``i`` and its
    slope per frame, ``(len(frames), 3)`` each. A moving average cut at the clip's end
    lags the track and moves at half its speed (its window's centre moves half a frame
    per frame): an ankle lifting off in a clip's last frames read as standing and was
    held through its toe-off; the line follows the track's slope in any window."""
    n = len(track)
    lo = np.maximum(frames - half, 0)
    hi = np.minimum(frames + half, n - 1)
    at = lo[:, None] + np.arange(2 * half + 1)  # (E, W): each window's frames, padded
    inside = at <= hi[:, None]
    count = inside.sum(axis=1, keepdims=True)
    t = np.where(inside, at - frames[:, None], 0).astype(np.float64)
    t_mean = t.sum(axis=1, keepdims=True) / count
    t = np.where(inside, t - t_mean, 0.0)
    points = track[np.minimum(at, n - 1)] * inside[..., None]
    mean = points.sum(axis=1) / count
    slope = np.einsum("ew,ewc->ec", t, points) / np.maximum(np.sum(t * t, axis=1), 1e-300)[:, None]
    return mean - slope * t_mean, slope


def lowest_points(
    positions: np.ndarray, feet: list[Foot], up: int, floor: Floor | None = None
) -> np.ndarray:
    """``(F, n_feet)`` height of each foot's lowest point along the up axis, or with a
    ``floor`` above that plane (length units)."""
    if floor is None:
        return np.stack([positions[:, list(f.points), up].min(axis=1) for f in feet], axis=1)
    return np.stack([floor.above(positions[:, list(f.points)]).min(axis=1) for f in feet], axis=1)


@dataclass(frozen=True)
class Floor:
    """A ground plane: ``normal`` ``(3,)`` (unit, pointing up) and ``offset``, so a point
    ``p`` stands ``normal . p - offset`` above it (length units); ``up`` is the clip's up
    axis."""

    normal: np.ndarray
    offset: float
    up: int

    @classmethod
    def level(cls, height: float, up: int) -> Floor:
        """The level floor at ``height`` along the up axis ``up``."""
        return cls(np.eye(3)[up], float(height), up)

    def above(self, points: np.ndarray) -> np.ndarray:
        """Height of ``points`` ``(..., 3)`` above the floor (negative below it)."""
        return points @ self.normal - self.offset

    @property
    def tilt_deg(self) -> float:
        """Angle between the floor and the level plane, degrees."""
        return float(np.degrees(np.arccos(np.clip(self.normal[self.up], -1.0, 1.0))))

    def height_at(self, point: np.ndarray) -> float:
        """The floor's height along the up axis below ``point`` ``(3,)``."""
        return float(self.heights_at(point))

    def heights_at(self, points: np.ndarray) -> np.ndarray:
        """The floor's heights along the up axis below ``points`` ``(..., 3)``."""
        horizontal = points @ self.normal - points[..., self.up] * self.normal[self.up]
        return (self.offset - horizontal) / self.normal[self.up]

    def rise(self, points: np.ndarray) -> float:
        """How far the floor's height changes below ``points`` ``(n, 3)`` (length units; 0
        for a level floor or fewer than two points)."""
        return float(np.ptp(self.heights_at(points))) if len(points) > 1 else 0.0


#: Floors are fitted with this prior spread of the slope (rise per unit run, about 6
#: degrees) ...
FLOOR_SLOPE_PRIOR = 0.1
#: ... against this spread of the contacts' soles about the plane (body heights): a slope
#: is believed where the soles span a few body heights (a walk across a tilted floor),
#: not from the hand's breadth between a left and a right footprint.
FLOOR_SPREAD = 0.03
#: ... and each sole counts with its share of the soles within this distance of it (body
#: heights: 3.4 cm on a body 1.7 m tall, itself included): their errors are mostly the
#: feet's own (a left sole lower than the right, a heel than a toe), which a footprint
#: stepped on again repeats rather than averages away; a take walking the same 7
#: footprints again and again had tilted its floor with its length (1.0 degrees; walked 4
#: and 16 times: 3.1 and 4.4; 10 and 30 copies of the noisy sample joined end to end 3.8
#: and 5.0). Distances between soles do not depend on where the clip sits or how it turns.
FLOOR_PLACE = 0.02


#: A foot's lowest point more than this (body heights) below its height on both
#: neighbouring frames is a glitch (a one-frame drop of the root or of a marker), not where
#: the sole meets the floor.
SOLE_GLITCH = 0.02


def contact_soles(scene: FootScene, contacts: np.ndarray) -> np.ndarray:
    """``(n, 3)``: for each contact (of every foot; ``contacts`` ``(F, n_feet)``), the
    foot's lowest point on the frame where it is lowest, a one-frame glitch
    (:data:`SOLE_GLITCH`) passed over: where the sole meets the floor."""
    positions, up = scene.positions, scene.up
    soles = []
    for k, foot in enumerate(scene.feet):  # a handful of feet; one contact's frames at once
        points = np.array(foot.points, dtype=np.intp)
        lowest = points[positions[:, points, up].argmin(axis=1)]  # (heights alone gathered)
        sole = positions[np.arange(len(positions)), lowest]
        level = sole[:, up].copy()
        glitch = np.minimum(level[:-2], level[2:]) - SOLE_GLITCH * scene.height
        level[1:-1][level[1:-1] < glitch] = np.inf
        for first, stop in contact_runs(contacts[:, [k]])[0]:
            soles.append(sole[first + int(level[first:stop].argmin())])
    return np.array(soles, dtype=np.float64).reshape(-1, 3)


def fit_floor(
    soles: np.ndarray,
    up: int,
    height: float,
    quantile: float = 0.5,
    sideways: np.ndarray | None = None,
) -> Floor | None:
    """The plane through the contacts' soles ``(n, 3)`` (:func:`contact_soles`): height
    along the up axis as a linear function of the horizontal position, least squares with
    a prior on the slope (:data:`FLOOR_SLOPE_PRIOR`, :data:`FLOOR_SPREAD`), centred on
    level or, where the body leans sideways past :data:`SIDEWAYS_TILT` (``sideways``:
    :func:`~motionclean.core.kinematics.sideways_lean`), toward the plane tilted with it
    (a camera's roll, which footprints along one line cannot show). Soles more than 3
    robust deviations (1.4826 MAD) from the level plane or the prior's, whichever they
    scatter less about, then from the first fit, are left out (a foot on a step, a
    misplaced contact; a wrong prior does not leave out the soles that contradict it).
    The plane is then moved
    along the up axis to the ``quantile`` of the kept soles' heights above it (0.5:
    through the middle of them, 0: under every one). None without soles."""
    if soles.shape[0] == 0:
        return None
    across = [a for a in range(3) if a != up]
    ridge = (FLOOR_SPREAD * height / FLOOR_SLOPE_PRIOR) ** 2
    prior = _prior_slope(sideways, up, across)
    slope = min((np.zeros(2), prior), key=lambda s: _spread(soles[:, up] - soles[:, across] @ s))
    level = float(np.median(soles[:, up] - soles[:, across] @ slope))
    keep = np.ones(soles.shape[0], dtype=bool)
    for _ in range(2):
        residual = soles[:, up] - level - soles[:, across] @ slope
        centre = np.median(residual[keep])
        keep = np.abs(residual - centre) <= 3.0 * _spread(residual[keep]) + 1e-9 * height
        x, h = soles[keep][:, across], soles[keep][:, up]
        share = _place_shares(x, FLOOR_PLACE * height)
        centre_x, centre_h = share @ x / share.sum(), float(share @ h / share.sum())
        dx = x - centre_x
        slope = np.linalg.solve(
            (dx.T * share) @ dx + ridge * np.eye(2),
            (dx.T * share) @ (h - centre_h) + ridge * prior,
        )
        level = float(centre_h - slope @ centre_x)
    residual = soles[keep, up] - level - soles[keep][:, across] @ slope
    level += float(np.quantile(residual, quantile))
    normal = np.zeros(3)
    normal[up] = 1.0
    normal[across] = -slope
    scale = float(np.linalg.norm(normal))
    return Floor(normal / scale, level / scale, up)


def _place_shares(x: np.ndarray, radius: float) -> np.ndarray:
    """``(n,)``: each of the horizontal positions ``x`` ``(n, 2)`` weighted by one over the
    number of them within ``radius`` (length units) of it, itself included: every place
    counts once, however often it is stepped on. Soles are sorted along one axis and
    compared a block at a time with those within ``radius`` along it (bounded
    temporaries)."""
    axis = int(np.argmax(np.ptp(x, axis=0))) if len(x) else 0
    order = np.argsort(x[:, axis], kind="stable")
    xs = x[order]
    lo = np.searchsorted(xs[:, axis], xs[:, axis] - radius, side="left")
    hi = np.searchsorted(xs[:, axis], xs[:, axis] + radius, side="right")
    counts = np.empty(len(x))
    for first in range(0, len(x), PLACE_BLOCK):
        stop = min(first + PLACE_BLOCK, len(x))
        window = xs[lo[first] : hi[stop - 1]]
        near = np.sum((xs[first:stop, None, :] - window[None]) ** 2, axis=-1) <= radius**2
        counts[first:stop] = np.count_nonzero(near, axis=1)
    shares = np.empty(len(x))
    shares[order] = 1.0 / counts
    return shares


#: Soles compared at a time by :func:`_place_shares`.
PLACE_BLOCK = 256


def sole_places(soles: np.ndarray, up: int, height: float) -> float:
    """How many places the soles ``(n, 3)`` stand at: each counts once however often it is
    stepped on (the sum of :func:`_place_shares` over :data:`FLOOR_PLACE` body heights
    ``height``, horizontally; fractional where places overlap, 0 without soles)."""
    across = [a for a in range(3) if a != up]
    return float(_place_shares(soles[:, across], FLOOR_PLACE * height).sum())


def _spread(residual: np.ndarray) -> float:
    """1.4826 MAD of ``residual``: a robust standard deviation."""
    return float(1.4826 * np.median(np.abs(residual - np.median(residual))))


#: A body leaning sideways (trunk and legs alike, along the hips' left-right axis,
#: averaged over the clip) by more than the first of these (degrees) tilts the floor's
#: prior with it, in full from the second on (a ramp between: no jump of the floor for a
#: lean a degree apart): the capture is rolled about the way the body faces (a camera
#: pitched down at a walk across its view), which a floor fitted through footprints along
#: one line cannot show (such a walk rolled 20 degrees had been levelled to 20). Over 711
#: clips (the corpus, the exporters', game, Bandai Namco, LaFAN1, Rokoko, Xsens clips and
#: video estimates) the lean is at most 4.2 degrees on walks, 6.5-7.8 on kicks on one leg,
#: 8.6 on VIBE estimates: under the first, the prior stays level, as a lean of the body's
#: own.
SIDEWAYS_TILT = (10.0, 15.0)


def _prior_slope(sideways: np.ndarray | None, up: int, across: list[int]) -> np.ndarray:
    """``(2,)`` the floor's prior slope along ``across``: level, or tilted toward a body
    that leans ``sideways`` ``(3,)`` past :data:`SIDEWAYS_TILT`."""
    if sideways is None:
        return np.zeros(2)
    lean = float(np.linalg.norm(sideways))
    if not 0.0 < lean < 1.0:
        return np.zeros(2)
    first, full = SIDEWAYS_TILT
    share = min(max((math.degrees(math.asin(lean)) - first) / (full - first), 0.0), 1.0)
    return -share * sideways[across] / math.sqrt(1.0 - lean * lean)


def floor_of_contacts(
    scene: FootScene, contacts: np.ndarray, quantile: float = 0.5
) -> tuple[Floor | None, np.ndarray]:
    """The floor :func:`fit_floor` fits through the soles of ``contacts`` ``(F, n_feet)``
    (its prior following ``scene.sideways``, its height at ``quantile`` of them), and those
    soles ``(n, 3)`` (:func:`contact_soles`)."""
    soles = contact_soles(scene, contacts)
    return fit_floor(soles, scene.up, scene.height, quantile, scene.sideways), soles


#: Passes of contacts found above the floor and the floor fitted again (a tilted floor's
#: high side joins the contacts a pass at a time).
FLOOR_PASSES = 4


#: Contacts are found above the floor, not above a level ground, where the floor's height
#: changes across the soles it rests on by more than this share of the contact height
#: (``ContactParams.height``): there a level ground misses the contacts on its high side
#: (a walk up a floor tilted 5 degrees, 0.13-0.15 body heights of rise, had 2 of its 5
#: contacts found; at 2 degrees, 0.046-0.060, one contact was missed); a capture's own
#: floor keeps the level ground's contacts (the corpus walks' floors, fitted through the
#: soles of noisy copies, rise by at most 0.037 body heights).
FLOOR_RISE = 0.75


def find_floor(
    scene: FootScene, params: ContactParams = ContactParams(), contacts: np.ndarray | None = None
) -> tuple[Floor | None, np.ndarray, np.ndarray]:
    """The floor (:func:`floor_of_contacts`), the soles ``(n, 3)`` it rests on and the
    contacts ``(F, n_feet)`` found above it: contacts found above a level ground
    (``contacts``, when the caller has found them so with the same ``params``), a plane
    fitted through their soles, then contacts found again above that plane (on a tilted
    floor the first pass misses the feet on its high side) and the plane fitted again, up
    to :data:`FLOOR_PASSES` times; a pass that finds no contact keeps the last floor, its
    soles and contacts."""
    if contacts is None:
        contacts, _ = detect(scene, params)
    floor, soles = floor_of_contacts(scene, contacts)
    for _ in range(FLOOR_PASSES):
        if floor is None:
            break
        found, _ = detect(scene, params, floor=floor)
        if np.array_equal(found, contacts):
            break
        refit, on_refit = floor_of_contacts(scene, found)
        if on_refit.shape[0] == 0:  # no contact above this floor: it stays, with its soles
            break
        contacts, soles, floor = found, on_refit, refit
    return floor, soles, contacts


@dataclass(frozen=True)
class Ground:
    """Where a clip's feet stand: ``contacts`` ``(F, n_feet)``, the ``floor`` found from
    them and its ``soles`` ``(n, 3)`` (:func:`find_floor`), whether the contacts were
    found above that floor (``tilted``: it rises across its soles by more than
    :data:`FLOOR_RISE` of the contact height) or above a level ground, ``height`` the
    ground's height (:func:`estimate_ground`) along the up axis, or above the tilted
    floor (NaN without two frames), and ``resting`` ``(F, n_feet)``: the contacts whose
    soles the floor rests on (``contacts`` where ``tilted``)."""

    contacts: np.ndarray
    floor: Floor | None
    soles: np.ndarray
    height: float
    tilted: bool
    resting: np.ndarray


def find_ground(scene: FootScene, params: ContactParams = ContactParams()) -> Ground:
    """:func:`detect`'s contacts above a level ground and :func:`find_floor`'s floor; where
    the floor rises across its soles by more than :data:`FLOOR_RISE` of ``params.height``
    body heights, the contacts found above it and heights taken above it instead."""
    contacts, level = detect(scene, params)
    if math.isnan(level):
        return Ground(contacts, None, np.zeros((0, 3)), level, False, contacts)
    floor, soles, on_floor = find_floor(scene, params, contacts)
    rise = FLOOR_RISE * params.height * scene.height
    if not _rises(floor, soles, rise):
        # the feet on a short slope's high side may all stand beyond a level ground's reach
        seed = _contacts_under_still_feet(scene, params, rise)
        uphill = None if seed is None else find_floor(scene, params, seed)
        if uphill is None or not _rises(uphill[0], uphill[1], rise):
            return Ground(contacts, floor, soles, level, False, on_floor)
        floor, soles, on_floor = uphill
    lowest = lowest_points(scene.positions, scene.feet, scene.up, floor)
    above = estimate_ground(lowest, scene.unknown)
    return Ground(on_floor, floor, soles, above, True, on_floor)


def _rises(floor: Floor | None, soles: np.ndarray, rise: float) -> bool:
    """Whether ``floor``'s height changes by more than ``rise`` across ``soles``."""
    return floor is not None and floor.rise(soles) > rise


def _contacts_under_still_feet(
    scene: FootScene, params: ContactParams, rise: float
) -> np.ndarray | None:
    """Contacts above the plane through the soles of the feet wherever they stand still
    (no height limit), to start :func:`find_floor` from where a floor's high side lies
    wholly beyond a level ground's reach; None where that plane does not rise by more than
    ``rise`` (length units) across those soles."""
    anywhere = replace(params, height=np.inf, height_off=np.inf)
    still, _ = detect(scene, anywhere)
    under, soles = floor_of_contacts(scene, still)
    if not _rises(under, soles, rise):
        return None
    return detect(scene, params, floor=under)[0]


#: A floor is the ground's own slope (stairs, a ramp, a hill), not the capture's tilt, where
#: it tilts by more than this (degrees) from the way the body's trunk points on average
#: (:func:`~motionclean.core.kinematics.body_up`) and the trunk points at most half as far
#: from the up axis: a camera's tilt turns the body with the floor, a slope does not. A
#: walk's forward lean is 1.5-9 degrees on every clip measured (the corpus, the exporters'
#: walks, game walks and a run: 6.5); a stair climb's floor (0.17 m steps, 0.3 m apart)
#: tilts 19-20 degrees from its trunk, which stands 2.5-2.9 degrees off the up axis; the
#: test's staircase 22.3 from its trunk, 4.0 off the axis.
TERRAIN_TILT = 12.0


def terrain(floor: Floor, body: np.ndarray | None) -> bool:
    """Whether ``floor`` is the ground's own slope rather than the capture's tilt
    (:data:`TERRAIN_TILT`), given ``body`` ``(3,)``, the trunk's mean direction (unit, in
    the floor's axes; None: not known, False)."""
    if body is None:
        return False
    from_floor = math.degrees(math.acos(float(np.clip(body @ floor.normal, -1.0, 1.0))))
    from_axis = math.degrees(math.acos(float(np.clip(body[floor.up], -1.0, 1.0))))
    return from_floor > TERRAIN_TILT and from_axis <= 0.5 * from_floor


def estimate_ground(lowest: np.ndarray, unknown: np.ndarray | None = None) -> float:
    """The ground height: the 5th percentile of the feet's lowest points ``(F, n_feet)``
    over the clip, those ``unknown`` (the same shape: a dropout's held samples) left out
    (NaN without any)."""
    known = lowest if unknown is None else lowest[~unknown]
    return float(np.percentile(known, 5.0)) if known.size else float("nan")


def feet_unknown(unknown_points: np.ndarray | None, feet: list[Foot]) -> np.ndarray | None:
    """``(F, n_feet)``: frames where any point of a foot is unknown, from the points'
    ``(F, P)`` (:func:`~motionclean.core.kinematics.missing_points`, the feet's point
    indices its columns; None: every point known, and None back)."""
    if unknown_points is None or not feet:
        return None
    return np.stack([unknown_points[:, list(f.points)].any(axis=1) for f in feet], axis=1)


def _close_gaps(loose: np.ndarray, low: np.ndarray, shortest: int) -> np.ndarray:
    """``loose`` ``(F,)`` with each gap between two of its runs filled where the gap is no
    longer than ``shortest`` frames and the foot stays ``low`` throughout it: a foot that
    stays on the ground through a blip of speed of a few frames (noise, or the jitter a
    filter leaves) stands on; a step takes longer than a contact's minimum. No longer, not
    shorter: at 30 fps a 0.1 s minimum is 3 frames, and a rule of fewer frames would close
    no gap over 0.067 s where one at 120 fps closes 0.092 s."""
    starts, ends = _runs(loose)
    if starts.size < 2:
        return loose
    gap_from, gap_to = ends[:-1], starts[1:]  # each gap: frames gap_from .. gap_to - 1
    low_sum = np.concatenate(([0], np.cumsum(low)))
    closed = (gap_to - gap_from <= shortest) & (
        low_sum[gap_to] - low_sum[gap_from] == gap_to - gap_from
    )
    if not closed.any():
        return loose
    return loose | _filled(loose.size, gap_from[closed], gap_to[closed])


def _to_the_edges(
    loose: np.ndarray, steady: np.ndarray, ankle: np.ndarray, rise: float, edge: int
) -> np.ndarray:
    """``loose`` ``(F,)`` with its first run reaching back to the clip's first frame, and its
    last run on to the last, where the run begins (ends) within ``edge`` frames of it and
    on every frame in between the foot is ``steady`` (low, and not much faster than a
    contact allows) and its ankle (smoothed heights ``(F,)``) no more than ``rise`` above
    its median height over the run: the filter's edge transient and the speed read over
    fewer frames make a standing foot's first and last frames look fast, but a heel that
    rises is lifting off (or coming down at the first frames), which no transient does."""
    n = loose.size
    if not loose.any():
        return loose
    out = loose.copy()
    starts, ends = _runs(loose)
    first, stop = int(starts[0]), int(ends[-1])  # the first run's start, the last's end
    for gap, run in (  # the frames up to the clip's edge, the run beside them
        (slice(0, first), slice(first, ends[0])),
        (slice(stop, n), slice(starts[-1], stop)),
    ):
        near = 0 < gap.stop - gap.start <= edge
        if near and steady[gap].all() and ankle[gap].max() <= np.median(ankle[run]) + rise:
            out[gap] = True
    return out


def detect(
    scene: FootScene,
    params: ContactParams = ContactParams(),
    ground: float | None = None,
    floor: Floor | None = None,
) -> tuple[np.ndarray, float]:
    """Frames where each foot of ``scene`` is on the ground: ``(F, n_feet)`` bool, and the
    ground height.

    A contact starts where the foot's lowest point is within ``params.height`` body heights of
    the ground and the ankle moves slower than ``params.speed`` body heights per second; it
    lasts while the looser ``height_off`` / ``speed_off`` hold (hysteresis), and through a
    speed blip no longer than ``min_duration`` while the foot stays that low; one within
    :data:`EDGE_SECONDS` of the clip's first or last frame reaches it where the foot stays
    low, slower than :data:`EDGE_SPEED` times ``speed_off`` and its ankle no more than
    :data:`EDGE_RISE` above its median height in the contact; contacts shorter than
    ``min_duration`` seconds are dropped. ``ground`` defaults to :func:`estimate_ground`;
    with a ``floor`` (a plane, tilted or not) heights are taken above it instead, and the
    ground returned is ``ground`` as given (NaN for None). Frames where a foot's place is
    not known (``scene.unknown``) have no contact, and the ground is found from the others.
    """
    positions, feet, up, height = scene.positions, scene.feet, scene.up, scene.height
    frame_time, unknown = scene.frame_time, scene.unknown
    n_frames = positions.shape[0]
    contacts = np.zeros((n_frames, len(feet)), dtype=bool)
    if not feet or n_frames < 2:
        return contacts, float("nan") if ground is None else ground
    if floor is None:
        lowest = lowest_points(positions, feet, up)
        if ground is None:
            ground = estimate_ground(lowest, unknown)
        above = (lowest - ground) / height
    else:  # (the ground is not read: heights above the floor)
        above = lowest_points(positions, feet, up, floor) / height
        ground = float("nan") if ground is None else ground
    ankles, speed = ankle_tracks(positions, feet, frame_time, params.smoothing)
    speed /= height
    ankle = ankles[..., up] if floor is None else floor.above(ankles)  # (F, n_feet)
    low = above < params.height_off
    if unknown is not None:
        low &= ~unknown
    strict = low & (above < params.height) & (speed < params.speed)
    loose = low & (speed < params.speed_off)
    # a contact lasts at most the clip: a longer minimum (up to inf) keeps none; a file's
    # frame time is rounded (0.0083333 for 120 fps): 0.1 s is 12 frames, not 12.00005
    shortest = whole_frames(params.min_duration / frame_time)
    min_frames = max(math.ceil(shortest), 1) if shortest <= n_frames else n_frames + 1
    edge = int(round(EDGE_SECONDS / frame_time))
    steady = low & (speed < EDGE_SPEED * params.speed_off)
    for k in range(len(feet)):  # a handful of feet; each column is vectorised
        closed = _close_gaps(loose[:, k], low[:, k], min_frames)
        kept = _to_the_edges(closed, steady[:, k], ankle[:, k], EDGE_RISE * height, edge)
        starts, ends = _runs(kept)
        strict_sum = np.concatenate(([0], np.cumsum(strict[:, k])))
        keep = (strict_sum[ends] > strict_sum[starts]) & (ends - starts >= min_frames)
        contacts[:, k] = _filled(n_frames, starts[keep], ends[keep])
    return contacts, ground


def point_contacts(
    scene: FootScene,
    points: list[int],
    params: ContactParams,
    ground: float,
    floor: Floor | None = None,
) -> np.ndarray:
    """``(F, n_points)``: frames where each of ``points`` (indices into the scene's
    positions) is itself planted, by :func:`detect`'s rules applied to the point alone (its
    own height above ``ground``, or above a tilted ``floor``, and its own speed; the
    scene's feet and unknown frames not read): a toe is planted from the foot flat through
    the heel rising, not while the foot rolls onto it or pivots about the heel."""
    alone = [Foot(str(p), -1, -1, p, (p,)) for p in points]
    return detect(replace(scene, feet=alone, unknown=None), params, ground, floor)[0]


def contact_runs(contacts: np.ndarray) -> list[list[tuple[int, int]]]:
    """Per foot (column), its runs of True as ``(first, stop)`` frames: ``first`` in the
    run, ``stop`` after its last (a contact on the last of ``F`` frames stops at ``F``)."""
    runs = []
    for k in range(contacts.shape[1]):
        starts, ends = _runs(contacts[:, k])
        runs.append([(int(a), int(b)) for a, b in zip(starts, ends, strict=True)])
    return runs


#: Time over which :func:`skate` measures a foot's speed when asked to (seconds): its
#: drift, not its jitter, which the speed between consecutive frames multiplies by the
#: frame rate (white noise of 1 degree on every joint read 2.35, 1.15 and 0.56 body
#: heights/s at 120, 60 and 30 fps between frames; over 0.1 s 0.2 at every rate).
DRIFT_SECONDS = 0.1


def skate(
    positions: np.ndarray,
    feet: list[Foot],
    contacts: np.ndarray,
    up: int,
    frame_time: float,
    cuts: np.ndarray | None = None,
    over_seconds: float = 0.0,
) -> np.ndarray:
    """``(n_feet,)`` mean horizontal ankle speed during contacts (length units / s; NaN for a
    foot without contacts). Speeds are taken between consecutive contact frames (or, with
    ``over_seconds``, between frames that many seconds apart in one contact, whole frames,
    at least one: a contact shorter than that by its net move over its length), but for
    the steps into the frames ``cuts`` (a new take's first: no motion between them)."""
    gap = max(1, round(over_seconds / frame_time)) if over_seconds > 0 else 1
    cut = np.zeros(positions.shape[0], dtype=bool)
    if cuts is not None and cuts.size:
        cut[cuts] = True
    out = np.full(len(feet), np.nan)
    for k, foot in enumerate(feet):  # a foot at a time: temporaries of one ankle's track
        track = positions[:, foot.ankle].copy()
        track[:, up] = 0.0
        begin, end = _runs_cut(contacts[:, k], cut)
        steps = end - 1 - begin  # frame steps inside each contact
        # every frame with one ``gap`` frames later in its contact; a contact of no more
        # steps than that, once, by its net move, counted as its share of a gap
        first = np.flatnonzero(contacts[:, k])  # (in the order of the runs, which are sorted)
        first = first[first + gap < np.repeat(end, end - begin)]
        short = (steps >= 1) & (steps < gap)
        a, b = begin[short], end[short] - 1
        to, since = np.concatenate([first + gap, b]), np.concatenate([first, a])
        moved = np.linalg.norm(track[to] - track[since], axis=-1)
        time = (to - since) * frame_time
        weight = np.concatenate([np.ones(first.size), (b - a) / gap])
        if weight.sum() > 0:
            out[k] = float(weight @ (moved / time) / weight.sum())
    return out


def _runs_cut(mask: np.ndarray, cut: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_runs` of ``mask`` with a run also broken before every frame of ``cut``."""
    starts = mask & (~np.concatenate(([False], mask[:-1])) | cut)
    ends = mask & ~np.concatenate((mask[1:] & ~starts[1:], [False]))
    return np.flatnonzero(starts), np.flatnonzero(ends) + 1


def penetration(lowest: np.ndarray, ground: float) -> np.ndarray:
    """``(n_feet,)`` deepest point of each foot below the ground (length units, >= 0), from
    the feet's lowest points ``(F, n_feet)`` (:func:`lowest_points`)."""
    if lowest.shape[0] == 0:
        return np.zeros(lowest.shape[1])
    return np.maximum(ground - lowest.min(axis=0), 0.0)


def sliding_contacts(
    scene: FootScene,
    contacts: np.ndarray,
    speed: float,
    window: float = SLIDE_WINDOW,
    before: np.ndarray | None = None,
) -> np.ndarray:
    """The ``contacts`` ``(F, n_feet)`` whose horizontal ankle speed, averaged over some
    ``window`` seconds of them (over what there is of them where the clip or the contact is
    shorter), exceeds ``speed`` (length units/s): ``(F, n_feet)`` bool, the other contacts
    cleared. A capture's own feet slide a little (CMU walks: 0.02-0.08 body heights/s);
    contacts within that are left as they are. A long stance that stands still but for a
    slide at its end (a VR take's legs smoothed while its root moved) slides: its mean over
    the whole stance had hidden it. With ``before`` (the scene's points as captured, ``(F,
    P, 3)``), a contact slides too where its fastest window is :data:`SLIDE_GROWTH` times
    the capture's fastest in it and over :data:`SLIDE_ADDED` body heights/s: cleaning made
    it slide."""
    label = run_labels(contacts)  # (every foot's contacts numbered apart)
    fastest = _fastest(_windowed_speeds(scene, scene.positions, contacts, window), label)
    slides = fastest > speed
    if before is not None:
        captured = _fastest(_windowed_speeds(scene, before, contacts, window), label)
        slides |= (fastest > SLIDE_GROWTH * captured) & (fastest > SLIDE_ADDED * scene.height)
    return contacts & slides[label]


def _windowed_speeds(
    scene: FootScene, positions: np.ndarray, contacts: np.ndarray, window: float
) -> np.ndarray:
    """``(F, n_feet)``: each ankle's horizontal speed in ``positions`` (the scene's points)
    averaged over ``window`` seconds of its steps within a contact, centred on each frame
    (windows cut at the clip's ends)."""
    feet, up, frame_time = scene.feet, scene.up, scene.frame_time
    step = np.diff(positions[:, [f.ankle for f in feet]], axis=0)
    step[..., up] = 0.0
    speeds = np.vstack([np.zeros((1, len(feet))), np.linalg.norm(step, axis=-1) / frame_time])
    moving = np.vstack([np.zeros((1, len(feet)), bool), contacts[1:] & contacts[:-1]])
    half = min(int(round(window / frame_time / 2)), speeds.shape[0] - 1)
    total = _moving_average(np.where(moving, speeds, 0.0), half)
    count = _moving_average(moving.astype(np.float64), half)
    return total / np.maximum(count, 1e-12)


def _fastest(windowed: np.ndarray, label: np.ndarray) -> np.ndarray:
    """``(n_runs + 1,)``: the fastest of ``windowed`` ``(F, n_feet)`` in each contact run
    (``label``: :func:`~motionclean.core.motion.run_labels`; entry 0, off the runs, is 0)."""
    fastest = np.zeros(int(label.max(initial=0)) + 1)
    np.maximum.at(fastest, label, np.where(label > 0, windowed, 0.0))
    return fastest
