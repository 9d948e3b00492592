"""The in-memory clip: skeleton, channel layout and time-major motion arrays.

A :class:`Motion` is format independent. Rotations are ``(F, J, 4)`` unit quaternions
``(w, x, y, z)`` local to the parent joint and sign-continuous in time; translations are
``(F, J, 3)`` position channels in the file's length unit (zero where a joint has none).
What a writer needs to reproduce the input (the original channel values and the
quaternions read from them, plus format text in ``source``) travels along, so that
unchanged samples are written back exactly as they were read.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import checks, quat
from .errors import InvalidMotion, MotionError
from .eulerjoin import JUMP_MARGIN, settle, unwrap_turns
from .threads import MIN_SHARED_SIZE, in_parts, run_parts
from .tree import Cycle, ancestor_jumps

#: The axes a clip may declare as up (:attr:`Motion.up`): the figure's head toward the
#: axis, or toward its negative side (a camera's y-down coordinates).
UP_AXES = ("x", "y", "z", "-x", "-y", "-z")

ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
KNOWN_CHANNELS = frozenset(ROTATION_CHANNELS + POSITION_CHANNELS)
#: Channel names as BVH spells them, by their lower-case spelling: exporters also write
#: ``ZPosition`` or ``XROTATION`` (read as the same channel; a file keeps its own text).
CHANNEL_SPELLING = {name.lower(): name for name in KNOWN_CHANNELS}

#: Frame times outside these (seconds, both taken) give rates no capture has: refused.
MIN_FRAME_TIME = 1e-6
MAX_FRAME_TIME = 3600.0
#: How readers' messages state that range.
RATES_ACCEPTED = f"expected between {1.0 / MAX_FRAME_TIME:g} and {1.0 / MIN_FRAME_TIME:g} fps"

#: Channel values closer than this to the value read (degrees or length units) are
#: written back with the input's own text.
UNCHANGED_TOLERANCE = 1e-9


#: Quaternion components closer than this to the ones read count as unchanged (rounding).
SAME_ROTATION = 1e-12
#: Largest difference of the middle Euler angle's sine between the same rotations: 4
#: SAME_ROTATION, with room for the rounding of the two ways it is computed.
MIDDLE_SINE_SLACK = 1e-10
#: Frames per block in the Euler <-> quaternion conversions of every joint (temporaries
#: stay in cache) ...
BLOCK_FRAMES = 512
#: ... and in the write-back Euler filter, which works on groups of PART_JOINTS joints.
FILTER_BLOCK_FRAMES = 2048
#: Frames per part of a clip-long pass run on a thread of its own.
PART_FRAMES = 64 * BLOCK_FRAMES
#: Joints per part of the write-back Euler filter run on a thread of its own.
PART_JOINTS = 8


def joint_major_zeros(n_frames: int, n_joints: int, width: int = 3) -> np.ndarray:
    """``(F, J, width)`` float64 zeros stored joint by joint (a transposed ``(J, F, width)``
    block): the columns of joints never written, such as the translations of joints without
    position channels, stay zero pages the system has not handed out, so they take no
    memory however long the clip."""
    return np.zeros((n_joints, n_frames, width)).transpose(1, 0, 2)


def written_joints(*arrays: np.ndarray) -> np.ndarray:
    """Indices of the joints (axis 1) that hold a non-zero value in any of the
    ``(F, J, width)`` ``arrays``."""
    return np.flatnonzero(np.any([np.any(a != 0.0, axis=(0, 2)) for a in arrays], axis=0))


def sparse_concatenate(parts: list[np.ndarray]) -> np.ndarray:
    """``(F, J, width)`` arrays joined along the frames in :func:`joint_major_zeros`
    storage, with only the :func:`written_joints` copied."""
    first = parts[0]
    out = joint_major_zeros(sum(len(part) for part in parts), first.shape[1], first.shape[2])
    joints = written_joints(*parts)
    at = 0
    for part in parts:  # each straight into place: no temporary of the joined joints
        out[at : at + len(part), joints] = part[:, joints]
        at += len(part)
    return out


def sparse_copy(array: np.ndarray) -> np.ndarray:
    """A copy of ``(F, J, width)`` ``array`` in :func:`joint_major_zeros` storage, with only
    the joints that hold a non-zero value written."""
    return sparse_concatenate([array])


def _as_slice(index: np.ndarray) -> slice | np.ndarray:
    """``index`` (ints, raveled) as the slice it spans when its items follow one another in
    ascending order (indexing with it gives a view, not a copy), else the raveled ints."""
    flat = np.asarray(index).ravel()
    if flat.size and flat[-1] - flat[0] == flat.size - 1 and (np.diff(flat) == 1).all():
        return slice(int(flat[0]), int(flat[-1]) + 1)
    return flat


def _euler_quaternions(values: np.ndarray, layout: ChannelLayout, out: np.ndarray) -> None:
    """Quaternions of the Euler channels in ``values`` ``(B, C)`` into ``out`` ``(B, J, 4)``
    (identity for joints without rotation channels; signs as :func:`quat.from_euler` gives
    them)."""
    out[:, ~layout.has_rotation] = (1.0, 0.0, 0.0, 0.0)
    for order, group in layout.groups:
        angles = values[:, _as_slice(layout.rotation_columns[group])]
        out[:, _as_slice(group)] = quat.from_euler(angles.reshape(-1, group.size, 3), order)


def _rotations_from_values(values: np.ndarray, layout: ChannelLayout) -> np.ndarray:
    """``(F, J, 4)`` sign-continuous quaternions of the Euler channels in ``values`` ``(F, C)``
    (identity for joints without rotation channels), built :data:`BLOCK_FRAMES` frames at a
    time in parts of :data:`PART_FRAMES` run on threads: the signs come out exactly as
    :func:`quat.make_continuous` would make them over the whole clip."""
    rotations = np.empty((values.shape[0], len(layout.rotation_orders), 4))

    def build(span: slice) -> None:  # signs continuous within the part, from its first frame
        previous = None  # the last sign-corrected sample of the block before
        for at in range(span.start, span.stop, BLOCK_FRAMES):
            rows = slice(at, min(at + BLOCK_FRAMES, span.stop))
            block = rotations[rows]
            _euler_quaternions(values[rows], layout, block)
            before = block[:1] if previous is None else previous[None]
            dots = np.einsum("fji,fji->fj", block, np.concatenate([before, block[:-1]]))
            signs = np.cumprod(np.where(dots < 0.0, -1.0, 1.0), axis=0)
            block *= signs[..., None]
            previous = block[-1]

    spans = in_parts(values.shape[0], PART_FRAMES)
    run_parts(build, spans)
    # Each part continues the one before: flip its joints whose first sample turned away.
    sign = np.ones(rotations.shape[1])
    flips = []
    for span in spans[1:]:
        dots = np.einsum("ji,ji->j", rotations[span.start - 1], rotations[span.start])
        sign = sign * np.where(dots < 0.0, -1.0, 1.0)
        flips.append((span, sign))
    run_parts(lambda flip: _flip(rotations[flip[0]], flip[1]), flips)
    return rotations


def _flip(block: np.ndarray, sign: np.ndarray) -> None:
    """Negate the joints of ``block`` ``(B, J, 4)`` whose ``sign`` ``(J,)`` is -1, in place."""
    joints = np.flatnonzero(sign < 0.0)
    if joints.size:
        block[:, joints] *= -1.0


@dataclass(frozen=True)
class ChannelLayout:
    """Where each joint's channels sit in a frame row of ``C`` values.

    ``rotation_columns[j]`` lists the columns of joint ``j``'s rotation channels in file
    order (``-1`` when it has none) and ``rotation_orders[j]`` their axes, e.g. ``"ZYX"``;
    ``position_columns[j, a]`` is the column of axis ``a`` (X, Y, Z) or ``-1``.
    """

    n_channels: int
    rotation_columns: np.ndarray  # (J, 3) int
    rotation_orders: tuple[str | None, ...]
    position_columns: np.ndarray  # (J, 3) int

    @classmethod
    def from_channels(cls, names: list[str], channels: list[tuple[str, ...]]) -> ChannelLayout:
        n_joints = len(channels)
        rot_cols = np.full((n_joints, 3), -1, dtype=np.intp)
        pos_cols = np.full((n_joints, 3), -1, dtype=np.intp)
        orders: list[str | None] = []
        column = 0
        for j, joint_channels in enumerate(channels):
            rot_axes, rot_at = "", []
            for name in joint_channels:
                if name in ROTATION_CHANNELS:
                    rot_axes += name[0]
                    rot_at.append(column)
                elif name in POSITION_CHANNELS:
                    pos_cols[j, "XYZ".index(name[0])] = column
                else:
                    raise MotionError(f"joint {names[j]!r}: unknown channel {name!r}")
                column += 1
            if rot_axes and sorted(rot_axes) != ["X", "Y", "Z"]:
                raise MotionError(
                    f"joint {names[j]!r}: rotation channels {rot_axes!r} are not one each of "
                    "X, Y and Z; only three-axis rotations are supported"
                )
            if rot_at:
                rot_cols[j] = rot_at
            orders.append(rot_axes or None)
        return cls(column, rot_cols, tuple(orders), pos_cols)

    @property
    def has_rotation(self) -> np.ndarray:
        """``(J,)`` bool: joints with rotation channels."""
        return self.rotation_columns[:, 0] >= 0

    @property
    def has_position(self) -> np.ndarray:
        """``(J,)`` bool: joints with at least one position channel."""
        return np.any(self.position_columns >= 0, axis=1)

    @functools.cached_property
    def groups(self) -> tuple[tuple[str, np.ndarray], ...]:
        """:meth:`order_groups` as ``(order, joints)`` pairs, computed once."""
        return tuple(self.order_groups().items())

    def order_groups(self) -> dict[str, np.ndarray]:
        """Joint indices grouped by rotation order (at most six groups)."""
        groups: dict[str, list[int]] = {}
        for j, order in enumerate(self.rotation_orders):
            if order is not None:
                groups.setdefault(order, []).append(j)
        return {order: np.array(idx, dtype=np.intp) for order, idx in groups.items()}


#: The fields of a :class:`Motion` that what :meth:`Motion.derived` keeps is derived from.
DERIVED_FROM = frozenset({"rotations", "translations", "offsets", "end_sites", "missing", "up"})


@dataclass(eq=False)
class Motion:
    """A motion clip: skeleton, channel layout and ``(F, J, ...)`` float64 motion arrays.

    Attributes
    ----------
    names : list of str
        Joint names, in file order (``J`` joints).
    parents : (J,) int array
        Parent index of each joint, ``-1`` for a root.
    offsets : (J, 3) array
        Joint offsets from the parent in the file's length unit.
    channels : list of tuple of str
        Each joint's channel names in file order (``Xposition`` ... ``Zrotation``).
    end_sites : dict
        Joint index -> ``(3,)`` end-site offset.
    frame_time : float
        Seconds per frame.
    rotations : (F, J, 4) array
        Local unit quaternions ``(w, x, y, z)``, sign-continuous; identity where a joint has
        no rotation channels.
    translations : (F, J, 3) array
        Position channels in length units; zero where a joint has none.
    source_values : (F, C) array or None
        The channel values as read (degrees, length units); guides write-back.
    source_rotations : (F, J, 4) array or None
        The quaternions read (a rigid-body or Motive CSV); None when they follow from
        ``source_values`` (Euler channels: :meth:`read_rotations` computes them).
    source : object or None
        Format-specific text a writer reuses (hierarchy, line endings, tokens).
    path : str or None
        The file the clip was read from, for error messages.
    missing : (F, J) bool array or None
        True where a joint's sample is unknown (a tracker dropout: blank cells in a CSV).
        The arrays hold placeholders there (the nearest known sample of the joint, see
        :func:`hold_missing`), so they stay finite and unit; None when nothing is missing.
    up : str or None
        The up axis the clip is declared to have (``"x"``, ``"y"`` or ``"z"``: given by the
        user, or known from the format); None lets world-space code find it from the
        motion (:func:`motionclean.core.kinematics.up_axis`).
    """

    names: list[str]
    parents: np.ndarray
    offsets: np.ndarray
    channels: list[tuple[str, ...]]
    frame_time: float
    rotations: np.ndarray
    translations: np.ndarray
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)
    source_values: np.ndarray | None = None
    source_rotations: np.ndarray | None = None
    source: Any = None
    path: str | None = None
    missing: np.ndarray | None = None
    up: str | None = None

    def __post_init__(self) -> None:
        self.check()

    def check(self) -> None:
        """Refuse motion arrays that describe no clip: :class:`InvalidMotion` (a ValueError)
        for no joints, a wrong shape, NaN/inf, or a rotation whose norm is not 1 within
        :data:`checks.UNIT_TOLERANCE` (zero included); TypeError for non-numbers. Run at
        construction and again by ``save`` (the arrays may be changed in place)."""
        n = len(self.names)
        if n == 0:  # (every writer indexes a joint; no reader makes such a clip)
            raise InvalidMotion("names: a clip needs at least one joint, got none")
        odd = next((name for name in self.names if not isinstance(name, str)), None)
        if odd is not None:
            raise InvalidMotion(f"names: expected strings, got {type(odd).__name__} {odd!r}")
        if len(self.channels) != n:
            raise InvalidMotion(
                f"channels: expected {n} tuples of channel names (one per joint), got "
                f"{len(self.channels)}"
            )
        for name, own in zip(self.names, self.channels, strict=True):
            if not isinstance(own, tuple | list) or not all(isinstance(c, str) for c in own):
                raise InvalidMotion(f"channels: {name!r}'s are not a tuple of channel names")
        self.rotations = checks.as_float_array(self.rotations, "rotations")
        self.translations = checks.as_float_array(self.translations, "translations")
        frames = self.rotations.shape[0] if self.rotations.ndim else 0
        for name, values, width in (
            ("rotations", self.rotations, 4),
            ("translations", self.translations, 3),
        ):
            if values.shape != (frames, n, width):
                raise InvalidMotion(
                    f"{name}: expected shape (F, {n}, {width}) with F = {frames} frames (the "
                    f"rotations') and {n} joints (the names'), got {values.shape}"
                )
            with np.errstate(over="ignore", invalid="ignore"):
                if np.isfinite(np.sum(values)):
                    continue
            frame, joint = np.argwhere(~np.isfinite(values).all(axis=-1))[0]
            raise InvalidMotion(
                f"{name}: joint {self.names[joint]!r} has a non-finite value at frame {frame}"
            )
        self._check_missing(frames, n)
        self._check_skeleton(n)
        if isinstance(self.frame_time, bool) or not isinstance(
            self.frame_time, int | float | np.integer | np.floating
        ):
            raise InvalidMotion(
                f"frame_time: expected seconds as a number, got {type(self.frame_time).__name__}"
            )
        if not MIN_FRAME_TIME <= self.frame_time <= MAX_FRAME_TIME:  # (False for NaN too)
            raise InvalidMotion(
                f"frame_time must be from {MIN_FRAME_TIME:g} s to {MAX_FRAME_TIME:g} s, "
                f"got {self.frame_time!r} (no reader takes it)"
            )
        if self.up is not None and (not isinstance(self.up, str) or self.up not in UP_AXES):
            raise InvalidMotion(f"up: expected one of x, y, z, -x, -y, -z or None, got {self.up!r}")
        if checks.all_unit(self.rotations):
            return
        with np.errstate(over="ignore"):  # a huge quaternion has norm inf: refused too
            error = np.abs(np.einsum("...i,...i->...", self.rotations, self.rotations) - 1.0)
        if np.any(error > 2.0 * checks.UNIT_TOLERANCE):
            frame, joint = np.argwhere(error > 2.0 * checks.UNIT_TOLERANCE)[0]
            q = self.rotations[frame, joint]
            largest = float(np.max(np.abs(q)))  # scaled: the norm of (1e200, 0, 0, 0) is 1e200
            norm = largest * float(np.linalg.norm(q / largest)) if largest > 0 else 0.0
            raise InvalidMotion(
                f"rotations: joint {self.names[joint]!r} at frame {frame} is not a unit "
                f"quaternion (norm {checks.norm_text(norm)}); normalise with "
                "motionclean.core.quat.normalize"
            )

    def _check_skeleton(self, n_joints: int) -> None:
        """Refuse parents that are no tree of the joints (a shape other than ``(J,)``, an
        index out of range, a joint its own ancestor) and offsets or end sites that are no
        finite 3-vectors of the joints: no file written from them reads back."""
        parents = np.asarray(self.parents)
        if parents.shape != (n_joints,) or parents.dtype.kind not in "iu":
            raise InvalidMotion(
                f"parents: expected {n_joints} integers, got {parents.dtype} {parents.shape}"
            )
        if parents.size and not (parents.min() >= -1 and parents.max() < n_joints):
            raise InvalidMotion(
                f"parents: each must be -1 (a root) or a joint from 0 to {n_joints - 1}"
            )
        try:
            for _ in ancestor_jumps(parents):
                pass
        except Cycle as cycle:
            raise InvalidMotion(
                f"parents: joint {self.names[cycle.joint]!r} is its own ancestor (a cycle)"
            ) from None
        offsets = np.asarray(self.offsets)
        if offsets.shape != (n_joints, 3) or not np.isfinite(offsets).all():
            raise InvalidMotion(
                f"offsets: expected finite values of shape ({n_joints}, 3), got {offsets.shape}"
            )
        for joint, site in self.end_sites.items():
            if not (isinstance(joint, int | np.integer) and 0 <= joint < n_joints):
                raise InvalidMotion(f"end_sites: {joint!r} is not a joint from 0 to {n_joints - 1}")
            if np.shape(site) != (3,) or not np.isfinite(site).all():
                raise InvalidMotion(
                    f"end_sites: joint {self.names[joint]!r}'s is not a finite 3-vector"
                )

    def _check_missing(self, frames: int, n_joints: int) -> None:
        if self.missing is None:
            return
        missing = checks.bool_mask(self.missing, "missing", (frames, n_joints), InvalidMotion)
        self.missing = missing if missing.any() else None

    @property
    def has_gaps(self) -> bool:
        """True when some joint has missing samples (:attr:`missing`)."""
        return self.missing is not None

    @classmethod
    def from_channel_values(
        cls,
        names: list[str],
        parents,
        offsets,
        channels: list[tuple[str, ...]],
        frame_time: float,
        values: np.ndarray,
        **kwargs,
    ) -> Motion:
        """Build a Motion from a ``(F, C)`` array of channel values (degrees, length units)."""
        layout = ChannelLayout.from_channels(names, channels)
        values = np.asarray(values, dtype=np.float64)
        n_frames = values.shape[0]
        rotations = _rotations_from_values(values, layout)
        translations = joint_major_zeros(n_frames, len(names))
        has = layout.position_columns >= 0
        translations[:, has] = values[:, layout.position_columns[has]]
        return cls(
            names=list(names),
            parents=np.asarray(parents, dtype=np.intp),
            offsets=np.asarray(offsets, dtype=np.float64).reshape(len(names), 3),
            channels=[tuple(c) for c in channels],
            frame_time=float(frame_time),
            rotations=rotations,
            translations=translations,
            source_values=values,
            **kwargs,
        )

    @functools.cached_property
    def layout(self) -> ChannelLayout:
        """Where each joint's channels sit (computed once per Motion)."""
        return ChannelLayout.from_channels(self.names, self.channels)

    @property
    def n_frames(self) -> int:
        return int(self.rotations.shape[0])

    @property
    def n_joints(self) -> int:
        return len(self.names)

    @property
    def frame_rate(self) -> float:
        """Frames per second."""
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds the clip covers: frames x frame time (as DCC tools count frames / fps)."""
        return self.n_frames * self.frame_time

    def derived(self, name: str, compute: Callable[[Motion], Any]) -> Any:
        """``compute(self)``, kept with the clip for its current arrays: what several
        stages derive from them and ask for again (its rest-pose frames, its found up
        direction). Dropped when an array is replaced (:data:`DERIVED_FROM`); a caller that
        writes into the clip's arrays in place says so with :meth:`edited`."""
        kept = self.__dict__.setdefault("_derived", {})
        if name not in kept:
            kept[name] = compute(self)
        return kept[name]

    def edited(self) -> None:
        """Say the clip's arrays were written in place: what :meth:`derived` kept goes."""
        self.__dict__.pop("_derived", None)

    def __setattr__(self, name: str, value: Any) -> None:
        if name in DERIVED_FROM:  # a new array: what was derived from the old one goes
            self.__dict__.pop("_derived", None)
        object.__setattr__(self, name, value)

    def __copy__(self) -> Motion:
        """A shallow copy (the same arrays) with a cache of its own: each clip's entries
        go when its own arrays are replaced."""
        new = self.__class__.__new__(self.__class__)
        new.__dict__.update({k: v for k, v in self.__dict__.items() if k != "_derived"})
        return new

    def replace(self, **changes) -> Motion:
        """A copy with some fields replaced (``rotations=``, ``translations=``, ...); the
        channel layout, once computed, goes with it unless ``channels`` change (computing
        it is a Python loop over the joints: seconds for 100,000 of them)."""
        copy = dataclasses.replace(self, **changes)
        if "layout" in self.__dict__ and "channels" not in changes:
            copy.__dict__["layout"] = self.__dict__["layout"]
        return copy

    def __eq__(self, other: object) -> bool:
        """Same skeleton, channels, frame time and motion arrays (exactly); the source text
        and path are not compared."""
        if not isinstance(other, Motion):
            return NotImplemented
        return (
            self.names == other.names
            and self.channels == other.channels
            and self.frame_time == other.frame_time
            and np.array_equal(self.parents, other.parents)
            and np.array_equal(self.offsets, other.offsets)
            and self.end_sites.keys() == other.end_sites.keys()
            and all(np.array_equal(v, other.end_sites[k]) for k, v in self.end_sites.items())
            and np.array_equal(self.rotations, other.rotations)
            and np.array_equal(self.translations, other.translations)
            and np.array_equal(self.missing_mask(), other.missing_mask())
        )

    __hash__ = None  # type: ignore[assignment]  # mutable arrays

    def missing_mask(self) -> np.ndarray:
        """``(F, J)`` bool: :attr:`missing`, all False when nothing is missing."""
        if self.missing is None:
            return np.zeros((self.n_frames, self.n_joints), dtype=bool)
        return self.missing

    def at_frames(self, frames) -> Motion:
        """The clip at ``frames`` only (a slice, an index array, or one index: a clip of
        that one frame): skeleton, rotations, translations and missing samples; the source
        values no longer describe it. A slice gives views of the arrays, as numpy's do."""
        if isinstance(frames, int | np.integer):  # (numpy's a[5] would drop the time axis)
            frames = [int(frames)]
        return self.replace(
            rotations=self.rotations[frames],
            translations=self.translations[frames],
            source_values=None,
            source_rotations=None,
            missing=None if self.missing is None else self.missing[frames],
        )

    @staticmethod
    def joined_frames(parts: list[Motion]) -> Motion:
        """The clips ``parts`` (one skeleton and frame time) one after the other: the
        first's skeleton, every part's rotations and translations; nothing missing, and no
        source values (they describe none of the parts' frames as joined)."""
        return parts[0].replace(
            rotations=np.concatenate([part.rotations for part in parts]),
            translations=sparse_concatenate([part.translations for part in parts]),
            missing=None,
            source_values=None,
            source_rotations=None,
        )

    def joint_index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise MotionError(f"no joint named {name!r}", self.path) from None

    def has_source_frames(self) -> bool:
        """True when the source values still describe the same frames."""
        values, rotations = self.source_values, self.source_rotations
        return (
            values is not None
            and values.shape[0] == self.n_frames
            and (rotations is None or rotations.shape[0] == self.n_frames)
        )

    def read_rotations(self, rows: slice) -> np.ndarray:
        """The quaternions read for frames ``rows``, up to sign (``q`` and ``-q`` are the same
        rotation): the kept ones, or computed from the source values. Only for a clip with
        source frames (:meth:`has_source_frames`)."""
        if self.source_rotations is not None:
            return self.source_rotations[rows]
        assert self.source_values is not None
        values = self.source_values[rows]
        out = np.empty((values.shape[0], self.n_joints, 4))
        _euler_quaternions(values, self.layout, out)
        return out

    def channel_values(self) -> np.ndarray:
        """``(F, C)`` channel values for the current motion (degrees, length units).

        Rotations go back to Euler angles in each joint's own channel order. Where the
        source values describe the same frames, samples whose quaternion did not change (up
        to sign: ``q`` and ``-q`` are the same rotation; within :data:`SAME_ROTATION` per
        component, rounding) keep their original values bit for bit, and changed ones
        continue the curve from the last unchanged frame (:func:`continuous_euler`), on the
        representations that rejoin the unchanged frames after them without a jump the
        input lacks (:func:`motionclean.core.eulerjoin.rejoin`), moved back onto the
        input's own whole turns where they then wrap where it wraps
        (:func:`~motionclean.core.eulerjoin.follow_wraps`: a run to the clip's end has no
        unchanged frame to rejoin); elsewhere a changed value may lie whole turns or the
        other Euler solution from the input's. Otherwise (new frames: resampled, stitched,
        another format's rotations) the first frame takes the principal angles and each
        frame after it the Euler solution and whole turns nearest the frame before, as a
        changed run does: a middle angle that passes +-90 degrees
        goes on past it instead of the other two angles jumping by half a turn. Groups of
        joints run on threads.
        """
        layout = self.layout
        fresh = not self.has_source_frames()
        values = np.empty((self.n_frames, layout.n_channels))  # every column is written below
        shared = values.size >= MIN_SHARED_SIZE  # else one part per group: less overhead
        parts = [
            (order, group[span])
            for order, group in layout.groups
            for span in in_parts(group.size, PART_JOINTS if shared else group.size)
        ]
        run_parts(lambda part: self._write_euler(values, *part), parts, values.size)
        if not fresh:
            assert self.source_values is not None
            settle(values, self.source_values, layout.rotation_columns)  # no jump the input lacks
        has = layout.position_columns >= 0
        values[:, layout.position_columns[has]] = self.translations[:, has]
        return values

    def _write_euler(self, values: np.ndarray, order: str, joints: np.ndarray) -> None:
        """Write the Euler angles of ``joints`` (all of rotation order ``order``) into their
        columns of ``values``, block by block, continuing the source values (new frames,
        without them: the first frame's principal angles, then each frame continuing)."""
        fresh = not self.has_source_frames()
        cols = _as_slice(self.layout.rotation_columns[joints])  # (3 n) columns
        chosen = _as_slice(joints)
        carry = turns = last = None
        for at in range(0, self.n_frames, FILTER_BLOCK_FRAMES):  # temporaries stay small
            block = slice(at, at + FILTER_BLOCK_FRAMES)
            q = np.ascontiguousarray(self.rotations[block, chosen])  # (faster to read)
            # the principal angles and the middle angle's sine, made once for both uses
            principal, sine = quat.euler_and_middle_sine(q, order)
            if fresh:  # nothing kept: every frame continues the one before
                read, kept = principal, np.zeros(principal.shape[:2], dtype=bool)
            else:
                assert self.source_values is not None
                read = self.source_values[block, cols].reshape(q.shape[0], -1, 3)
                if self.source_rotations is not None:
                    kept = same_rotations(q, self.source_rotations[block, chosen])
                else:
                    kept = _same_as_angles(q, order, read, sine)
            angles, carry = _continue_block(
                q, order, read, kept, carry, principal, backward=not fresh
            )
            if fresh:  # (nothing read to follow: no channel steps half a turn or more)
                turns = unwrap_turns(angles, turns, _leaps(q, last))
                last = q[-1]
            values[block, cols] = angles.reshape(q.shape[0], -1)


def _leaps(q: np.ndarray, before: np.ndarray | None) -> np.ndarray:
    """``(F, J)``: the frames of ``q`` ``(F, J, 4)`` whose rotation turns by more than 90
    degrees from the frame before (``before`` ``(J, 4)``, the block's; None at the clip's
    first frame, which leaps from nothing), where a written chain restarts."""
    dots = np.empty(q.shape[:-1])
    dots[0] = 1.0 if before is None else np.einsum("ji,ji->j", before, q[0])
    dots[1:] = np.einsum("fji,fji->fj", q[:-1], q[1:])
    return np.abs(dots) < math.sqrt(0.5)


def as_motion(value: Any, name: str = "motion") -> Motion:
    """``value`` when it is a :class:`Motion`, else TypeError naming the argument ``name``."""
    if not isinstance(value, Motion):
        raise TypeError(f"{name}: expected a Motion, got {type(value).__name__}")
    return value


def missing_before(missing: np.ndarray) -> np.ndarray:
    """``(F + 1, J)``: the running count of missing samples (``missing`` ``(F, J)`` bool)
    before each frame, per joint (row 0: none): rows ``a .. b - 1`` of joint ``j`` are all
    known where ``count[b, j] == count[a, j]``."""
    return np.concatenate(
        [np.zeros((1, missing.shape[1]), np.intp), np.cumsum(missing, axis=0, dtype=np.intp)]
    )


def run_labels(mask: np.ndarray) -> np.ndarray:
    """``(F, C)`` int: each run of True frames of ``mask`` ``(F, C)`` bool, per column,
    labelled ``1, 2, ...`` (over all columns: no two runs share a label), 0 outside them."""
    n_frames, n_cols = mask.shape
    # columns end to end, each closed by a False row: no run crosses into the next
    flat = np.concatenate([mask, np.zeros((1, n_cols), dtype=bool)]).ravel(order="F")
    starts = flat & ~np.concatenate([[False], flat[:-1]])
    labels = np.cumsum(starts) * flat
    return labels.reshape(n_frames + 1, n_cols, order="F")[:-1]


def mask_runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``column``, ``first`` and ``stop`` (rows ``first .. stop-1``) of every run of True
    rows of ``mask`` ``(R, C)``, column by column."""
    padded = np.zeros((mask.shape[0] + 2, mask.shape[1]), dtype=np.int8)
    padded[1:-1] = mask
    change = np.diff(padded, axis=0).T  # (C, R + 1): +1 where a run starts, -1 after it
    column, first = np.nonzero(change == 1)
    _, stop = np.nonzero(change == -1)
    return column, first, stop


def hold_missing(values: np.ndarray, missing: np.ndarray) -> np.ndarray:
    """``values`` ``(F, J, ...)`` with each missing sample (``missing`` ``(F, J)`` bool)
    replaced by the joint's last known sample before it, or the first known one after it
    for a gap at the start; a joint with no known sample keeps its values. A new array."""
    n_frames = values.shape[0]
    frames = np.arange(n_frames)[:, None]
    known = ~missing
    last = np.maximum.accumulate(np.where(known, frames, -1), axis=0)
    first = np.minimum.accumulate(np.where(known, frames, n_frames)[::-1], axis=0)[::-1]
    source = np.where(last >= 0, last, np.where(first < n_frames, first, frames))
    return np.take_along_axis(values, source.reshape(source.shape + (1,) * (values.ndim - 2)), 0)


def same_rotations(q: np.ndarray, read: np.ndarray) -> np.ndarray:
    """``(F, J)``: samples of ``q`` within :data:`SAME_ROTATION` per component of ``read``
    or of ``-read`` (the same rotation). Only samples whose dot product is within 1e-12 of
    +-1 can be (a component off by 1e-12 moves it by far less), so the others are not
    compared component by component; and only with ``read`` where it is near +1, with
    ``-read`` where it is near -1 (``q`` within 1e-12 of ``-read`` has a dot product near
    -1)."""
    kept = np.zeros(q.shape[:-1], dtype=bool)
    dots = np.einsum("...i,...i->...", q, read)
    close = np.abs(dots) > 1.0 - 1e-12
    if close.any():
        a, b = q[close], read[close]
        b *= np.where(dots[close] < 0.0, -1.0, 1.0)[:, None]
        d = np.abs(np.subtract(a, b, out=a), out=a)  # largest component: 3 maxima, no reduce
        largest = np.maximum(np.maximum(d[:, 0], d[:, 1]), np.maximum(d[:, 2], d[:, 3]))
        kept[close] = largest < SAME_ROTATION
    return kept


def _same_as_angles(
    q: np.ndarray, order: str, angles: np.ndarray, sine: np.ndarray | None = None
) -> np.ndarray:
    """:func:`same_rotations` of ``q`` ``(F, J, 4)`` and the rotations of Euler ``angles``
    ``(F, J, 3)`` (degrees, in ``order``), converted only where the middle angle's sine
    allows the same rotation: a sample within :data:`SAME_ROTATION` per component moves
    it by at most ``4 SAME_ROTATION`` (:func:`quat.euler_middle_sine`, or ``sine`` when
    given), so one further off than :data:`MIDDLE_SINE_SLACK` has changed (most changed
    samples are)."""
    kept = np.zeros(q.shape[:-1], dtype=bool)
    if sine is None:
        sine = quat.euler_middle_sine(q, order)
    maybe = np.sin(np.deg2rad(angles[..., 1]))
    np.subtract(sine, maybe, out=maybe)
    maybe = np.abs(maybe, out=maybe) <= MIDDLE_SINE_SLACK
    if maybe.any():
        kept[maybe] = same_rotations(q[maybe], quat.from_euler(angles[maybe], order))
    return kept


def continuous_euler(
    q: np.ndarray, order: str, reference: np.ndarray, kept: np.ndarray
) -> np.ndarray:
    """Euler angles ``(F, J, 3)`` (degrees) of ``q`` ``(F, J, 4)`` that keep the written
    curves continuous: an Euler filter on the changed samples.

    ``reference`` holds the original angles and ``kept`` ``(F, J)`` marks the samples that
    did not change; those keep their original angles bit for bit. A run of changed samples
    continues from the sample before it (its anchor: a kept sample, the first frame, a
    frame that turns more than 90 degrees from the one before, or one the input writes on
    the other Euler solution than the frame before, :func:`_switches`; a changed anchor is
    written as the equivalent triple nearest to its original angles): each frame on the Euler
    solution nearest the frame before (so a middle angle that passes +-90 degrees goes on
    past it), each angle unwrapped by whole turns toward the previous frame's.
    """
    n_frames, n_joints = q.shape[:2]
    out = np.empty((n_frames, n_joints, 3))
    # What a block needs of the frames before it, per joint: the last rotation and principal
    # angles, the last start angles, the angles of the last anchor and the switches and
    # whole turns counted since it.
    carry = None
    for at in range(0, n_frames, BLOCK_FRAMES):
        block = slice(at, at + BLOCK_FRAMES)
        out[block], carry = _continue_block(q[block], order, reference[block], kept[block], carry)
    return out


#: Degrees a read channel steps, whole turns aside, where the input switches Euler solution
#: (half a turn on two channels at once, as through gimbal lock) rather than moving.
SWITCH_DEG = 90.0


def _switches(reference: np.ndarray, order: str, before: np.ndarray | None) -> np.ndarray:
    """``(F, J)`` bool: the frames into which the read angles ``reference`` ``(F, J, 3)``
    (rotation order ``order``) step by more than :data:`SWITCH_DEG` on a channel, whole
    turns aside, while the rotation read turns by less than that: the input writes that
    frame on the other Euler solution. A changed run anchored there (written as the triple
    nearest the frame's own angles) switches where the input does: continued through, a
    run crossing gimbal lock arrived at the kept frames after it on the other solution,
    and the switch moved to the run's start (a hip stepping 167 degrees where the input
    stepped 13). ``before`` ``(J, 3)``: the read angles of the frame before the block
    (None at the clip's first frame, which steps from nothing)."""
    rows = reference if before is None else np.concatenate([before[None], reference])
    out = np.zeros(reference.shape[:2], dtype=bool)
    if rows.shape[0] > 1:
        step = np.diff(rows, axis=0)
        step -= 360.0 * np.round(step / 360.0)
        frame, joint = np.nonzero(np.abs(step).max(axis=-1) > SWITCH_DEG)  # (few)
        turn = quat.angle_between(
            quat.from_euler(rows[frame, joint], order),
            quat.from_euler(rows[frame + 1, joint], order),
        )
        small = turn < math.radians(SWITCH_DEG)
        out[frame[small] + (1 if before is None else 0), joint[small]] = True
    return out


def _continue_block(q, order, reference, kept, carry, principal=None, backward=True):
    """:func:`continuous_euler` of a block of frames, continuing from ``carry`` (None for
    the clip's first block); returns the block's angles and the carry for the next one.
    ``principal``: ``quat.to_euler(q, order)`` when the caller has it. ``backward``: changed
    runs may be written back from the kept sample after them (:func:`_continue_backward`)."""
    frame = np.arange(q.shape[0])[:, None]
    columns = np.arange(q.shape[1])[None, :]
    # The chain restarts where the rotation itself turns by more than a quarter turn in one
    # frame (a cut, or data that is no motion): there is no curve to continue.
    # (A turn of more than 90 degrees: |q_{i-1} . q_i| = cos(angle / 2) below cos 45.)
    dots = np.empty(q.shape[:-1])
    dots[:1] = np.einsum("fji,fji->fj", q[:1] if carry is None else carry[0][None], q[:1])
    dots[1:] = np.einsum("fji,fji->fj", q[:-1], q[1:])
    leap = np.abs(dots, out=dots) < math.sqrt(0.5)
    is_anchor = kept | leap
    if backward:  # (angles read: where the input switches solution, the curve does too)
        is_anchor |= _switches(reference, order, None if carry is None else carry[6])
    if carry is None:
        is_anchor[0] = True  # the clip's first frame
    elif not is_anchor.any():
        angles, last = _continue_run(q, order, carry, principal)
        return angles, (*last, reference[-1])
    # A changed anchor is written as the triple nearest its original angles (computed for
    # those samples only: the others never read it).
    anchor_values = reference
    changed_anchor = is_anchor & ~kept
    if changed_anchor.any():  # (most blocks have none: no copy)
        anchor_values = reference.copy()
        anchor_values[changed_anchor] = quat.to_euler(
            q[changed_anchor], order, reference=reference[changed_anchor]
        )
    anchor = np.maximum.accumulate(np.where(is_anchor, frame, -1), axis=0)  # (F, J), -1: before
    local = anchor >= 0
    # each sample's anchor as an index into the block's (F * J) samples
    anchor_at = np.maximum(anchor, 0)
    anchor_at *= q.shape[1]
    anchor_at += columns
    # whether each anchor is on the other Euler solution (cos of its middle angle < 0),
    # computed at the anchors only and read through anchor_at
    anchors = np.flatnonzero(is_anchor)
    anchor_frames, anchor_joints = np.divmod(anchors, q.shape[1])
    on_other = np.zeros(is_anchor.size, dtype=bool)
    on_other[anchors] = np.cos(np.deg2rad(anchor_values[anchor_frames, anchor_joints, 1])) < 0.0
    anchor_other = on_other.take(anchor_at)
    last_anchor = anchor_values[anchor_at[-1] // q.shape[1], columns[0]]  # (J, 3)
    if carry is not None:
        anchor_other = np.where(local, anchor_other, np.cos(np.deg2rad(carry[3][..., 1])) < 0.0)
        last_anchor = np.where(local[-1][:, None], last_anchor, carry[3])
    principal, other, switch = _solutions(q, order, None if carry is None else carry[1], principal)
    if carry is None:
        switch[0] = False
    switches = np.cumsum(switch, axis=0)
    switches_since = switches - switches.take(anchor_at)
    if carry is not None:
        switches_since = np.where(local, switches_since, switches + carry[4][None])
    flipped = anchor_other ^ (switches_since % 2 == 1)
    candidate = np.where(flipped[..., None], other, principal) if flipped.any() else principal
    # Unwrap by whole turns within each run, starting from the anchor's angles.
    start = np.where(is_anchor[..., None], anchor_values, candidate)
    turns = _turns(start, start[0] if carry is None else carry[2])
    np.copyto(turns, 0.0, where=is_anchor[..., None])
    total = np.cumsum(turns, axis=0, out=turns)  # whole numbers: exact
    since = total - total.reshape(-1, 3).take(anchor_at, axis=0)
    if carry is not None:
        since = np.where(local[..., None], since, total + carry[5][None])
    # (an anchor's own turns since itself are 0: its start, the anchor's angles, as they are)
    angles = start - 360.0 * since
    last = (
        q[-1],
        principal[-1],
        start[-1],
        last_anchor,
        switches_since[-1],
        since[-1],
        reference[-1],
    )
    if backward:
        _continue_backward(q, order, reference, kept, angles, carry is None)
    return angles, last


def _continue_backward(q, order, reference, kept, angles, first_block) -> None:
    """Rewrite in ``angles`` ``(F, J, 3)`` (degrees), in place, the runs of changed samples
    that arrive at the kept sample after them on another Euler solution (a step that
    differs from the input's own there, whole turns aside, by more than
    :data:`~motionclean.core.eulerjoin.JUMP_MARGIN` on a channel) and start at the clip's
    first frame, or after a kept sample from which the rotation turns more into the run
    than it turns out of it into the kept sample after: continued backward from that kept
    sample instead, as every other run continues forward from the kept sample before it;
    a run from frame 0 only where frame 0 moved further than that last turn.
    (A run that arrives whole turns off is :func:`~motionclean.core.eulerjoin.rejoin`'s,
    which follows the input's own wraps.)

    Such a run starts at frame 0's angles nearest its original ones, which say nothing
    where frame 0 changed far, or at the kept sample's, far from it: a reference pose
    repaired to the motion's first frame was written on the other Euler solution, its
    channels stepping 180, 106 and 180 degrees into the next frame where the input turned
    0.06. The Euler solution switches where the rotation itself turns most. ``reference``
    and ``kept`` as in :func:`continuous_euler`; ``first_block``: whether frame 0 is the
    clip's; a run is looked at within this block of frames only."""
    end, joint = np.nonzero(kept[1:] & ~kept[:-1])  # the kept samples after runs, less 1
    end += 1
    off = angles[end, joint] - angles[end - 1, joint]
    off -= reference[end, joint] - reference[end - 1, joint]
    off -= 360.0 * np.round(off / 360.0)
    far = np.any(np.abs(off) > JUMP_MARGIN, axis=-1)
    if not far.any():
        return
    end, joint = end[far], joint[far]
    frame = np.arange(kept.shape[0])[:, None]
    start = np.maximum.accumulate(np.where(kept, frame, -1), axis=0)[end - 1, joint] + 1
    out_of = quat.angle_between(q[end - 1, joint], q[end, joint])  # into the kept sample
    later = start > 0
    into = quat.angle_between(q[start[later] - 1, joint[later]], q[start[later], joint[later]])
    # a run from the clip's first frame: where frame 0 moved further than the rotation turns
    # out of the run (a repaired reference pose), not where the kept sample after is far
    # (a rest pose after a noisy joint every frame of which changed)
    moved = quat.angle_between(quat.from_euler(reference[0, joint], order), q[0, joint])
    backward = np.where(later, False, first_block & (moved > out_of))
    backward[later] = into > out_of[later]
    start, end, joint = start[backward], end[backward], joint[backward]
    if not joint.size:
        return
    joints, column = np.unique(joint, return_inverse=True)
    low, high = int(start.min()), int(end.max())
    rows = slice(high, low - 1 if low else None, -1)  # frames high .. low, backward
    back = _continue_block(
        np.ascontiguousarray(q[rows][:, joints]),
        order,
        reference[rows][:, joints],
        kept[rows][:, joints],
        None,
        backward=False,
    )[0][::-1]
    bounds = np.zeros((high - low + 2, joints.size), dtype=np.intp)  # +1 at starts, -1 at ends
    np.add.at(bounds, (start - low, column), 1)
    np.add.at(bounds, (end - low, column), -1)
    runs = np.cumsum(bounds, axis=0)[:-1] > 0
    span = slice(low, high + 1)
    angles[span, joints] = np.where(runs[..., None], back, angles[span, joints])


def _continue_run(q, order, carry, principal=None):
    """:func:`_continue_block` of a block without anchors (no kept sample, no leap): every
    frame continues the run the carry comes from. The same operations on what the general
    case would select, so the same bits."""
    principal, other, switch = _solutions(q, order, carry[1], principal)
    switches_since = np.cumsum(switch, axis=0)
    switches_since += carry[4][None]
    anchor_other = np.cos(np.deg2rad(carry[3][..., 1])) < 0.0
    flipped = anchor_other ^ (switches_since % 2 == 1)
    start = np.where(flipped[..., None], other, principal) if flipped.any() else principal
    since = np.cumsum(_turns(start, carry[2]), axis=0)
    since += carry[5][None]
    last = (q[-1], principal[-1], start[-1], carry[3], switches_since[-1], since[-1].copy())
    since *= 360.0
    return np.subtract(start, since, out=since), last


def _turns(start: np.ndarray, before: np.ndarray) -> np.ndarray:
    """``round(step / 360)`` of each step of ``start`` ``(F, J, 3)`` from the frame before
    (``before`` ``(J, 3)`` before the first): the whole turns an unwrap takes off."""
    step = np.empty_like(start)
    np.subtract(start[0], before, out=step[0])
    np.subtract(start[1:], start[:-1], out=step[1:])
    step /= 360.0
    return np.round(step, out=step)


def _solutions(q, order, last, principal=None):
    """The two Euler solutions of ``q`` (principal, other) and the frames where the other is
    nearer the frame before's principal angles (``last``: those of the frame before the
    block; None: the block's first frame is compared with itself). ``principal``:
    ``quat.to_euler(q, order)`` when the caller has it.

    The two solutions are symmetric (P->O is as far as O->P, P->P as O->O, modulo whole
    turns), so whether a frame switches does not depend on the solution the frame before
    was written on: the solution in use is the anchor's, switched at every such frame."""
    if principal is None:
        principal = quat.to_euler(q, order)
    principal = _split_locked(principal, order, last)
    other = principal + [180.0, 0.0, 180.0]
    np.subtract(180.0, principal[..., 1], out=other[..., 1])
    switch = np.empty(principal.shape[:-1], dtype=bool)
    first = principal[:1] if last is None else last[None]
    switch[:1] = _turn_distance(other[:1], first) < _turn_distance(principal[:1], first)
    before = principal[:-1]
    np.less(
        _turn_distance(other[1:], before), _turn_distance(principal[1:], before), out=switch[1:]
    )
    return principal, other, switch


#: A frame whose middle angle is this close to +-90 degrees (degrees) is split as at
#: gimbal lock (:func:`_split_locked`): re-splitting its outer angles moves its rotation by
#: at most ``pi`` times this angle in radians, 1e-4 degrees, where the principal split
#: swings by tens of degrees between neighbouring frames.
LOCKED_MIDDLE_DEG = 1e-4 / np.pi


def _split_locked(principal, order, last):
    """``principal`` ``(F, J, 3)`` with each frame at or near gimbal lock split as the last
    frame before it that is not (``last``, the frame before the block, when none in it)
    (:func:`quat.keep_first_at_lock`): only the sum or difference of the outer angles is
    determined there, and the principal split is arbitrary (a slerp between frames on
    either side of a middle angle of 90 degrees wrote 83 and -87 degrees between 2 and -5).
    A copy where a frame is locked, else ``principal`` itself."""
    locked = np.abs(principal[..., 1]) >= 90.0 - LOCKED_MIDDLE_DEG
    if not locked.any():
        return principal
    frame = np.arange(principal.shape[0])[:, None]
    before = np.maximum.accumulate(np.where(locked, -1, frame), axis=0)  # last unlocked frame
    first = principal[np.maximum(before, 0), np.arange(principal.shape[1])[None, :], 0]
    known = before >= 0
    if last is not None:
        first = np.where(known, first, last[None, :, 0])
        known[:] = True
    pick = locked & known
    out = principal.copy()
    out[pick] = quat.keep_first_at_lock(principal[pick], order, first[pick])
    out[pick, 2] = (out[pick, 2] + 180.0) % 360.0 - 180.0
    return out


def _turn_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared distance between Euler triples ``(..., 3)`` (degrees), each angle's
    difference taken modulo whole turns (summed in the order ``np.sum`` takes)."""
    d = a - b
    turns = d / 360.0
    np.round(turns, out=turns)
    turns *= 360.0
    d -= turns
    d *= d
    total = d[..., 0] + d[..., 1]
    total += d[..., 2]
    return total
