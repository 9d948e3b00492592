"""SMPL, SMPL-H and SMPL-X parameters (AMASS ``.npz`` and the same arrays in pickles).

A record is a flat set of named arrays, one row per frame:

- the joint rotations as axis-angle vectors (radians), either all in one ``poses`` (or
  ``pose``) array of ``3 J`` values per frame (``J`` = 22, 24, 52 or 55: see
  :data:`~motionclean.io.smpl_model.TREES`), or split into ``root_orient`` (or
  ``global_orient``, 3 values), ``pose_body`` (``body_pose``: 63 values, or 69 for SMPL),
  ``pose_hand`` (90; or ``left_hand_pose`` + ``right_hand_pose``), ``pose_jaw``
  (``jaw_pose``, 3) and ``pose_eye`` (6; or ``leye_pose`` + ``reye_pose``). Rows of
  ``(J, 3)`` vectors or ``(J, 3, 3)`` rotation matrices are read too. When both forms are
  present (AMASS SMPL-X), ``poses`` is read and every form is written back;
- ``trans`` (or ``transl``): the root translation (metres), optional; AIST++'s
  ``smpl_trans`` is in units of ``smpl_scaling`` metres, and read divided by it;
- ``mocap_framerate`` / ``mocap_frame_rate`` / ``fps``: frames per second (when absent,
  with a note: 60 for an AIST++ record, which has ``smpl_scaling``, else 30); ``betas``,
  ``gender`` and anything else are carried as read.

Each joint becomes a joint of the clip (the model's names and tree), its rotation the
quaternion of its axis-angle vector. Joint positions are not in the file: with a body
model (``J_regressor``, ``v_template``, ``shapedirs``) or a skeleton the clip gets the
model's rest offsets and its root translation is ``trans`` plus the pelvis's rest position
(where SMPL puts it); without either the offsets are zero and world-space figures
(contacts, footlock, the player) are skipped with a note. The rest pose stands along the
model's Y axis whatever way the clip's root turns it (AMASS is Z up): the up axis, body
height and feet are found from the motion (``core.kinematics``).

Writing back: every array keeps its key, dtype, shape and place; a sample whose rotation
(or translation) did not change keeps its values bit for bit, a changed one is written as
the axis-angle vector equivalent to the new rotation nearest to the value read.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core import checks, quat
from ..core.checks import MAX_MAGNITUDE, within_magnitude
from ..core.errors import MotionError
from ..core.motion import (
    MAX_FRAME_TIME,
    MIN_FRAME_TIME,
    POSITION_CHANNELS,
    UNCHANGED_TOLERANCE,
    Motion,
    joint_major_zeros,
    same_rotations,
)
from ..core.rates import same_rate
from . import npz, smpl_model
from .files import FileBytes, pieces, read_regular_file
from .smpl_model import SMPL, SMPL_BODY, SMPLH, SMPLX, TREES, Tree

#: Rotation channels each joint gets (its Euler order when written as BVH or CSV).
ROTATION = ("Zrotation", "Yrotation", "Xrotation")
#: Keys of the frame rate, in the order they are looked for.
RATE_KEYS = ("mocap_framerate", "mocap_frame_rate", "fps", "frame_rate", "framerate")
#: Frame rate taken when the record has none (video pose estimators run at 30 fps), and
#: the rates a record may state or be given (frames per second).
DEFAULT_RATE = 30.0
#: AIST++'s rate (its motions are 60 fps, which its files do not say).
AIST_RATE = 60.0
#: (The rates a clip may have in every format: 1/3600 to 1,000,000 fps.)
MIN_RATE, MAX_RATE = 1.0 / MAX_FRAME_TIME, 1.0 / MIN_FRAME_TIME
#: Keys of the whole pose, and of the root translation, in the order they are looked for
#: (WHAM's world-grounded ``pose_world`` / ``trans_world`` before its camera-frame ones).
POSE_KEYS = ("pose_world", "poses", "pose", "smpl_poses", "fullpose")
TRANS_KEYS = ("trans_world", "trans", "transl", "smpl_trans")
#: Keys of the split pose, by body part (a pair: one array per side).
ROOT_KEYS = ("root_orient", "global_orient")
BODY_KEYS = ("pose_body", "body_pose")
JAW_KEYS = ("pose_jaw", "jaw_pose")
EYE_KEYS = ("pose_eye",)
EYE_PAIR = ("leye_pose", "reye_pose")
HAND_KEYS = ("pose_hand",)
HAND_PAIR = ("left_hand_pose", "right_hand_pose")


@dataclass(frozen=True)
class PoseField:
    """An array holding joints ``first .. first + count - 1`` of the tree: as axis-angle
    rows (``(F, 3 count)`` or ``(F, count, 3)``) or rotation matrices (``(F, count, 3, 3)``,
    ``matrix``)."""

    key: str
    first: int
    count: int
    matrix: bool = False


@dataclass(frozen=True, eq=False)
class SmplParams:
    """A SMPL record as read, for the writer: the model tree, where the rotations and
    translation are, the arrays themselves, the root's rest position added to ``trans``,
    the container the record came from (for its writer) and the file's bytes (an untouched
    clip is written back as them)."""

    tree: Tree
    fields: tuple[PoseField, ...]
    trans_key: str | None
    record: dict[str, np.ndarray]
    root_offset: np.ndarray
    container: Any
    raw: bytes | FileBytes
    has_skeleton: bool
    notes: tuple[str, ...] = field(default=())
    rows: np.ndarray | None = None  # the clip frame of each row (None: row k is frame k)
    frame_time: float = 0.0  # as read
    trans_scale: float = 1.0  # metres per unit of the record's translation
    rig: bool = False  # joint offsets from a user's rig (--skeleton), in the rig's units

    @property
    def needs_skeleton(self) -> bool:
        """True when the clip has no joint positions (no body model, no skeleton)."""
        return not self.has_skeleton

    @property
    def length_unit(self) -> str | None:
        """Metres (``trans``, a body model's offsets), or None where a rig gave the offsets
        in its own units (``core.kinematics.length_unit``)."""
        return None if self.rig else "m"

    @property
    def no_world(self) -> str | None:
        """Why world-space figures are skipped (see ``core.kinematics.world_note``)."""
        if self.has_skeleton:
            return None
        return "SMPL parameters hold no joint positions; give --skeleton or --body-model"

    #: What a BVH writer says when the clip has no skeleton.
    no_skeleton_message = (
        "SMPL parameters hold no joint positions; to write BVH give a skeleton "
        "(--skeleton rig.bvh) or a body model (--body-model model.npz); in Python "
        "mc.load(CLIP, skeleton=RIG) or mc.load(CLIP, body_model=MODEL)"
    )


def _first(record: dict, keys: tuple[str, ...]) -> str | None:
    return next((key for key in keys if key in record), None)


def _frames_of(array: np.ndarray, key: str, per_frame: tuple[int, ...], path) -> int:
    if array.ndim < 1 or array.shape[1:] != per_frame:
        raise MotionError(
            f"{key}: shape {array.shape}, expected (frames, {', '.join(map(str, per_frame))})", path
        )
    return int(array.shape[0])


def _pose_field(record: dict, key: str, first: int, count: int | None, path) -> PoseField:
    """The field of ``key`` holding ``count`` joints (any count when None: from its shape)."""
    array = record[key]
    if not isinstance(array, np.ndarray) or array.dtype.kind not in "fiu":
        raise MotionError(f"{key}: not an array of numbers", path)
    shape = array.shape[1:]
    if len(shape) == 3 and shape[1:] == (3, 3):
        n, matrix = shape[0], True
    elif len(shape) == 2 and shape == (3, 3) and count in (1, None):
        n, matrix = 1, True
    elif len(shape) == 2 and shape[1] == 3:
        n, matrix = shape[0], False
    elif len(shape) == 1 and shape[0] % 3 == 0:
        n, matrix = shape[0] // 3, False
    else:
        raise MotionError(
            f"{key}: shape {array.shape} holds no axis-angle vectors or rotation matrices", path
        )
    if count is not None and n != count:
        raise MotionError(f"{key}: {n} joints per frame, expected {count}", path)
    return PoseField(key, first, n, matrix)


def find_layout(record: dict, path) -> tuple[Tree, tuple[PoseField, ...], str | None]:
    """The model tree, the arrays holding its rotations and the translation's key."""
    fields: list[PoseField] = []
    whole = _first(record, POSE_KEYS)
    root = _first(record, ROOT_KEYS)
    tree = None
    if whole is not None:
        full = _pose_field(record, whole, 0, None, path)
        tree = TREES.get(full.count)
        if tree is None:
            raise MotionError(
                f"{whole}: {full.count} joints per frame; SMPL has 24, SMPL-H 52, SMPL-X 55 "
                "(22 for the body alone)",
                path,
            )
        fields.append(full)
    if root is not None:
        body = _first(record, BODY_KEYS)
        if body is None:
            if whole is None:
                raise MotionError(f"{root} without a body pose (pose_body or body_pose)", path)
        else:
            split = _split_fields(record, root, body, path)
            split_tree = _split_tree(split)
            if tree is None:
                tree = split_tree
            elif split_tree.n_joints > tree.n_joints:
                raise MotionError(
                    f"{whole} holds {tree.n_joints} joints, the split arrays {split_tree.n_joints}",
                    path,
                )
            fields.extend(split)
    if tree is None:
        raise MotionError(
            "no SMPL pose: expected 'poses' (AMASS) or 'root_orient' + 'pose_body' "
            "(or 'global_orient' + 'body_pose')",
            path,
        )
    trans = _first(record, TRANS_KEYS)
    if whole == "pose_world":  # WHAM: the world pose goes with the world translation only
        trans = "trans_world" if "trans_world" in record else None
    return tree, tuple(fields), trans


def _split_fields(record: dict, root: str, body: str, path) -> list[PoseField]:
    fields = [_pose_field(record, root, 0, 1, path)]
    body_field = _pose_field(record, body, 1, None, path)
    if body_field.count not in (21, 23):
        raise MotionError(
            f"{body}: {body_field.count} joints per frame, expected 21 (SMPL-H/X) or 23 (SMPL)",
            path,
        )
    fields.append(body_field)
    jaw, eyes = _first(record, JAW_KEYS), _first(record, EYE_KEYS)
    pair = [key for key in EYE_PAIR if key in record]
    hands = _first(record, HAND_KEYS)
    hand_pair = [key for key in HAND_PAIR if key in record]
    face = jaw is not None
    if body_field.count == 23 and (face or hands or hand_pair):
        raise MotionError(
            f"{body} has SMPL's 23 joints, which have no hand, jaw or eye poses", path
        )
    at = 22
    if jaw is not None:
        fields.append(_pose_field(record, jaw, at, 1, path))
        if eyes is not None:
            fields.append(_pose_field(record, eyes, at + 1, 2, path))
        elif len(pair) == 2:
            fields += [
                _pose_field(record, pair[0], at + 1, 1, path),
                _pose_field(record, pair[1], at + 2, 1, path),
            ]
        else:
            raise MotionError(
                f"{jaw} without eye poses (pose_eye, or leye_pose and reye_pose)", path
            )
        at += 3
    if hands is not None:
        fields.append(_hand_field(record, hands, at, 30, path))
    elif len(hand_pair) == 2:
        fields += [
            _hand_field(record, hand_pair[0], at, 15, path),
            _hand_field(record, hand_pair[1], at + 15, 15, path),
        ]
    elif face:
        raise MotionError("jaw and eye poses without hand poses: not a SMPL-X layout", path)
    return fields


def _hand_field(record: dict, key: str, first: int, count: int, path) -> PoseField:
    array = record[key]
    if isinstance(array, np.ndarray) and array.ndim == 2 and array.shape[1] < 3 * count:
        raise MotionError(
            f"{key}: {array.shape[1]} values per frame, not {count} axis-angle vectors (hand "
            "poses in PCA components are not read; export the full axis-angle pose)",
            path,
        )
    return _pose_field(record, key, first, count, path)


def _split_tree(fields: list[PoseField]) -> Tree:
    last = max(f.first + f.count for f in fields)
    if last == 24:
        return SMPL
    if last == 22:
        return SMPL_BODY
    if last == 52:
        return SMPLH
    return SMPLX


#: AIST++'s key of the scale its ``smpl_trans`` is stored in (the body scaled to it).
SCALE_KEY = "smpl_scaling"


def translation_scale(record: dict, path) -> tuple[float, str | None]:
    """Metres per unit of the record's translation: ``1 / smpl_scaling`` where the record
    has it (AIST++: SMPL's ``transl`` is ``smpl_trans / smpl_scaling``), else 1; and a note
    of the division."""
    if SCALE_KEY not in record:
        return 1.0, None
    value = np.asarray(record[SCALE_KEY])
    scale = float(value.reshape(-1)[0]) if value.size == 1 and value.dtype.kind in "fiu" else 0.0
    if not (np.isfinite(scale) and scale > 0.0):
        raise MotionError(
            f"{SCALE_KEY}: expected one positive number, got {value.ravel()[:3]}", path
        )
    return 1.0 / scale, f"translation divided by {SCALE_KEY} {scale:.6g} (AIST++): metres"


def checked_rate(frame_rate) -> float | None:
    """A ``frame_rate`` argument (frames per second; None: not given) as a float from
    :data:`MIN_RATE` to :data:`MAX_RATE`: TypeError for anything but a number, ValueError
    out of that range (NaN too)."""
    if frame_rate is None:
        return None
    frame_rate = checks.number(frame_rate, "frame_rate")
    if not MIN_RATE <= frame_rate <= MAX_RATE:
        raise ValueError(f"frame_rate must be from {MIN_RATE:g} to {MAX_RATE:g}, got {frame_rate}")
    return frame_rate


def frame_time_of(record: dict, path, given: float | None = None) -> tuple[float, str | None]:
    """Seconds per frame from the record's frame rate, or the rate ``given`` (frames per
    second) where it states none, else :data:`AIST_RATE` for an AIST++ record (one with
    :data:`SCALE_KEY`) and :data:`DEFAULT_RATE` for any other; and a note of the rate taken
    when it was not the record's, or of ``given`` not taken."""
    key = _first(record, RATE_KEYS)
    given = checked_rate(given)  # (the library's callers)
    if key is None and given is not None:
        return 1.0 / given, f"no frame rate in the file; {given:g} fps as given"
    if key is None and SCALE_KEY in record:
        return 1.0 / AIST_RATE, (
            f"no frame rate in the file; {AIST_RATE:g} fps, AIST++'s rate (--input-fps gives "
            "another)"
        )
    if key is None:
        return 1.0 / DEFAULT_RATE, (
            f"no frame rate in the file; {DEFAULT_RATE:g} fps assumed (--input-fps gives it)"
        )
    rate = _number(record[key])
    if not (MIN_RATE <= rate <= MAX_RATE):
        raise MotionError(
            f"{key}: frame rate {_shown(record[key], rate)} is not a number of frames per "
            f"second from {MIN_RATE:g} to {MAX_RATE:g}",
            path,
        )
    if given is not None and given != rate:
        return 1.0 / rate, f"the file's {rate:g} fps taken, not {given:g} as given"
    others = [
        f"{other} {_number(record[other]):g}"
        if math.isfinite(_number(record[other]))
        else f"{other} (not a number of frames per second)"
        for other in RATE_KEYS
        if other != key
        and other in record
        and not same_rate(1.0 / rate, 1.0 / max(_number(record[other]), MIN_RATE))
    ]
    if others:
        return 1.0 / rate, f"{key} {rate:g} fps taken; the file also says {', '.join(others)}"
    return 1.0 / rate, None


def _shown(value, number: float) -> str:
    """A rate key's ``value`` for a message: its ``number`` (:func:`_number`) where it is
    one, else its first elements (40 characters at most)."""
    array = np.asarray(value)
    if array.size == 1:
        return f"{number:g}" if not math.isnan(number) else str(array.reshape(-1)[0])[:40]
    shown = str(array.ravel()[:3].tolist())
    return shown if len(shown) <= 40 else shown[:36] + " ..."


def _number(value) -> float:
    """A one-element array's real number (integers and floats, not booleans or complex
    numbers), nan where it holds none or one too large for a float."""
    array = np.asarray(value)
    if array.size != 1 or array.dtype.kind not in "iuf" and array.dtype != object:
        return float("nan")
    item = array.reshape(-1)[0]
    if isinstance(item, bool | np.bool_ | complex | np.complexfloating):
        return float("nan")
    try:
        return float(item)
    except (TypeError, ValueError, OverflowError):
        return float("nan")


#: A pose matrix whose ``R^T R`` differs from the identity by more than this (largest
#: entry), or whose determinant is negative, is no rotation (float32 files: about 1e-6).
ORTHONORMAL_TOLERANCE = 1e-3


def _rotations(record: dict, f: PoseField, path) -> np.ndarray:
    """``(F, count, 4)`` quaternions of a field; matrices that are no rotation (a scale, a
    shear, a mirror) refused, as writing a changed joint back would drop what they hold."""
    array = np.asarray(record[f.key], dtype=np.float64)
    if f.matrix:
        m = array.reshape(array.shape[0], f.count, 3, 3)
        gram = np.einsum("...ji,...jk->...ik", m, m) - np.eye(3)
        off = np.abs(gram).max(axis=(-2, -1))
        bad = (off > ORTHONORMAL_TOLERANCE) | (np.linalg.det(m) < 0.0)
        if bad.any():
            frame, joint = (int(i) for i in np.argwhere(bad)[0])
            raise MotionError(
                f"{f.key}: frame {frame}, matrix {joint} is no rotation (R^T R differs from "
                f"the identity by {off[frame, joint]:.3g}, determinant "
                f"{np.linalg.det(m[frame, joint]):.3g})",
                path,
            )
        return smpl_model.matrix_to_quaternion(m)
    return smpl_model.axis_angle_to_quaternion(array.reshape(array.shape[0], f.count, 3))


def _check_numbers(record: dict, keys, path) -> None:
    """Refuse arrays ``keys`` of anything but real numbers (integer or float), or with NaN,
    inf or a value beyond :data:`MAX_MAGNITUDE`."""
    for key in keys:
        array = record[key]
        if array.dtype.kind not in "fiu":
            raise MotionError(f"{key}: not an array of real numbers ({array.dtype})", path)
        if not within_magnitude(array):
            bad = ~(np.abs(array) <= MAX_MAGNITUDE)  # NaN too
            frame = int(np.argwhere(bad.reshape(array.shape[0], -1))[0][0])
            raise MotionError(
                f"{key}: a value that is not a finite number of at most {MAX_MAGNITUDE:g} in "
                f"size at frame {frame}",
                path,
            )


def smpl_motion(
    record: dict[str, np.ndarray],
    path,
    *,
    container: Any,
    raw: bytes,
    skeleton: Motion | None = None,
    body_model: tuple[dict[str, np.ndarray], str] | None = None,
    notes: tuple[str, ...] = (),
    rows: np.ndarray | None = None,
    frame_rate: float | None = None,
) -> Motion:
    """A clip of the SMPL record ``record`` (see the module); ``body_model``: a body model
    file's arrays and path (:func:`read_body_model`); ``rows``: the frame of each pose row
    (from ``frame_ids``, one per row); ``frame_rate``: the rate taken where the record states
    none (frames per second)."""
    tree, fields, trans_key = find_layout(record, path)
    frames = {_frames_of(record[f.key], f.key, record[f.key].shape[1:], path) for f in fields}
    if trans_key is not None:
        frames.add(_frames_of(record[trans_key], trans_key, (3,), path))
    if len(frames) != 1:
        raise MotionError(
            f"pose and translation arrays have different frame counts ({sorted(frames)})", path
        )
    n_rows = frames.pop()
    if n_rows == 0:
        raise MotionError(
            f"no frames: {fields[0].key!r} has 0 rows; a SMPL clip needs at least one frame", path
        )
    if rows is not None and rows.size != n_rows:
        raise MotionError(f"frame_ids has {rows.size} entries for {n_rows} frames of poses", path)
    if rows is not None and rows[-1] == n_rows - 1:  # every frame
        rows = None
    _check_numbers(record, [f.key for f in fields] + ([trans_key] if trans_key else []), path)
    frame_time, rate_note = frame_time_of(record, path, frame_rate)
    notes = notes + ((rate_note,) if rate_note else ())
    trans_scale, scale_note = translation_scale(record, path) if trans_key else (1.0, None)
    notes = notes + ((scale_note,) if scale_note else ())
    model = np.empty((n_rows, tree.n_joints, 4))
    whole = [f for f in fields if f.first == 0 and f.count == tree.n_joints]
    for f in whole or fields:  # the whole pose when there is one, else the split arrays
        model[:, f.first : f.first + f.count] = _rotations(record, f, path)
    has_skeleton = skeleton is not None or body_model is not None
    offsets = np.zeros((tree.n_joints, 3))
    if body_model is not None:
        arrays, model_path = body_model
        offsets = smpl_model.model_offsets(arrays, tree, _betas(record), model_path)
    elif skeleton is not None:
        offsets = smpl_model.skeleton_offsets(skeleton, tree, path)
    root_offset = offsets[0].copy()
    channels: list[tuple[str, ...]] = [ROTATION] * tree.n_joints
    trans = None
    if trans_key is not None:
        trans = np.asarray(record[trans_key], dtype=np.float64) * trans_scale + root_offset
        if not within_magnitude(trans):  # (a tiny smpl_scaling)
            raise MotionError(
                f"{trans_key}: beyond {MAX_MAGNITUDE:g} once divided by {SCALE_KEY} "
                f"{1.0 / trans_scale:.6g}",
                path,
            )
        channels[0] = POSITION_CHANNELS + ROTATION
    n_frames = n_rows if rows is None else int(rows[-1]) + 1
    missing = None
    rotations = model
    if rows is not None:  # frames the person was not seen in: missing, the nearest held
        missing = np.ones((n_frames, tree.n_joints), dtype=bool)
        missing[rows] = False
        source_row = np.maximum.accumulate(np.where(missing[:, 0], -1, np.arange(n_frames)))
        source_row = np.searchsorted(rows, np.maximum(source_row, 0))
        rotations = rotations[source_row]
        trans = None if trans is None else trans[source_row]
    rotations = quat.continuous(rotations)  # (a copy only when a sign flips)
    translations = joint_major_zeros(n_frames, tree.n_joints)
    if trans is not None:
        translations[:, 0] = trans
    source = SmplParams(
        tree,
        fields,
        trans_key,
        record,
        root_offset,
        container,
        raw,
        has_skeleton,
        notes,
        rows,
        frame_time,
        trans_scale,
        rig=body_model is None and skeleton is not None,
    )
    return Motion(
        names=list(tree.names),
        parents=np.array(tree.parents, dtype=np.intp),
        offsets=offsets,
        channels=channels,
        frame_time=frame_time,
        rotations=rotations,
        translations=translations,
        source_rotations=rotations.copy(),
        source=source,
        path=None if path is None else str(path),
        missing=missing,
    )


def _betas(record: dict) -> np.ndarray | None:
    betas = record.get("betas")
    if not isinstance(betas, np.ndarray) or betas.dtype.kind not in "fiu" or betas.size == 0:
        return None
    betas = np.asarray(betas, dtype=np.float64)
    return betas.reshape(-1, betas.shape[-1]).mean(axis=0)  # per-frame shapes: their mean


def _read_translation(src: SmplParams) -> np.ndarray:
    assert src.trans_key is not None
    trans = np.asarray(src.record[src.trans_key], dtype=np.float64)
    return trans * src.trans_scale + src.root_offset


def refuse_no_frames(motion: Motion) -> None:
    """SMPL output of a clip without frames is refused (its reader refuses such a file)."""
    if motion.n_frames == 0:
        raise MotionError(
            "SMPL parameters need at least one frame: this clip has none", motion.path
        )


def same_frames(motion: Motion) -> bool:
    """True when ``motion`` (read from a SMPL record) still has the record's frames."""
    src = motion.source
    assert isinstance(src, SmplParams)
    n_frames = len(src.record[src.fields[0].key]) if src.rows is None else int(src.rows[-1]) + 1
    return motion.n_frames == n_frames and motion.frame_time == src.frame_time


def changed_arrays(motion: Motion) -> dict[str, np.ndarray]:
    """The record's arrays that ``motion`` changed, new values in their dtype and shape
    (unchanged samples keep their values bit for bit); empty for an untouched clip. Only
    for a clip with the record's frames (:func:`same_frames`)."""
    src = motion.source
    assert isinstance(src, SmplParams)
    assert motion.source_rotations is not None
    at = slice(None) if src.rows is None else src.rows  # the frames the rows hold
    kept = same_rotations(motion.rotations[at], motion.source_rotations[at])
    model = motion.rotations[at]
    out: dict[str, np.ndarray] = {}
    for f in src.fields:
        joints = slice(f.first, f.first + f.count)
        if kept[:, joints].all():
            continue
        old = src.record[f.key]
        changed = ~kept[:, joints]
        shape = (len(old), f.count, 3, 3) if f.matrix else (len(old), f.count, 3)
        values = np.asarray(old, dtype=np.float64).reshape(shape).copy()
        if f.matrix:
            values[changed] = quat.as_matrix(model[:, joints][changed])
        else:
            values[changed] = smpl_model.quaternion_to_axis_angle(
                model[:, joints][changed], values[changed]
            )
        # (unchanged samples went to float64 and back: the same bits)
        out[f.key] = values.reshape(old.shape).astype(old.dtype)
    if src.trans_key is not None:
        old = src.record[src.trans_key]
        now = motion.translations[at, 0]
        moved = np.abs(now - _read_translation(src)).max(axis=-1) > UNCHANGED_TOLERANCE
        if moved.any():
            new = old.copy()
            new[moved] = ((now[moved] - src.root_offset) / src.trans_scale).astype(old.dtype)
            out[src.trans_key] = new
    return out


def resampled_record(motion: Motion) -> dict[str, np.ndarray]:
    """The record of a clip whose frames changed (resampled): its rotation and translation
    arrays anew in their keys, dtypes and forms, the frame rate updated, the arrays that are
    not per frame (``betas``, ``gender``, ...) carried; per-frame arrays motionclean does not
    read (``dmpls``, ``verts``, ``frame_ids``, ...) no longer fit the frames and are left
    out. In the record's key order."""
    src = motion.source
    assert isinstance(src, SmplParams)
    if motion.missing is not None:
        raise MotionError("a resampled SMPL clip has missing samples; fill them first", motion.path)
    rows = len(src.record[src.fields[0].key])
    model = motion.rotations
    vectors = 2.0 * quat.log_shortest(model)  # (F, J, 3)
    new: dict[str, np.ndarray] = {}
    for f in src.fields:
        old = src.record[f.key]
        joints = slice(f.first, f.first + f.count)
        values = quat.as_matrix(model[:, joints]) if f.matrix else vectors[:, joints]
        new[f.key] = values.reshape((motion.n_frames, *old.shape[1:])).astype(old.dtype)
    if src.trans_key is not None:
        old = src.record[src.trans_key]
        trans = (motion.translations[:, 0] - src.root_offset) / src.trans_scale
        new[src.trans_key] = trans.astype(old.dtype)
    # (every rate key the record has says the new rate: a resample had left fps=30 beside
    # mocap_framerate=120)
    for rate_key in [k for k in RATE_KEYS if k in src.record] or ["mocap_framerate"]:
        new[rate_key] = np.asarray(motion.frame_rate)
    out = {}
    for key, value in src.record.items():
        if key in new:
            out[key] = new.pop(key)
        elif not (value.ndim and value.shape[0] == rows):
            out[key] = value
    out.update(new)
    return out


def fresh_record(motion: Motion) -> dict[str, np.ndarray]:
    """A SMPL record (``poses`` in model order, ``trans``, ``mocap_framerate``) of a clip read
    from another format whose joints and tree are a SMPL model's (by name, in any order: a
    BVH lists them depth first; a clip without a tree, every joint a root as a channel CSV
    read without a skeleton has them, takes the model's by the names) and whose rest pose
    is the model's (zero rotations a T-pose);
    ``trans`` is the pelvis's position less its rest offset, as SMPL adds it back."""
    names = {name: j for j, name in enumerate(motion.names)}
    tree = next((t for t in TREES.values() if set(t.names) == names.keys()), None)
    if tree is None:
        raise MotionError(
            "SMPL output needs the joints of SMPL, SMPL-H or SMPL-X (pelvis, left_hip, ...); "
            f"this clip has {motion.n_joints} others",
            motion.path,
        )
    order = np.array([names[name] for name in tree.names], dtype=np.intp)
    parents = [tree.names.index(motion.names[p]) if p >= 0 else -1 for p in motion.parents[order]]
    treeless = not any(p >= 0 for p in parents)  # (a channel CSV read without a skeleton)
    if parents != list(tree.parents) and not treeless:
        raise MotionError(f"the joints are {tree.model}'s but not its tree", motion.path)
    if motion.missing is not None:
        raise MotionError("SMPL parameters have no missing samples; fill them first", motion.path)
    r = 2.0 * quat.log_shortest(motion.rotations[:, order])
    record = {
        "poses": r.reshape(motion.n_frames, -1),
        "mocap_framerate": np.array(motion.frame_rate),
    }
    root = int(order[0])
    if motion.layout.has_position[root]:
        record["trans"] = motion.translations[:, root] - motion.offsets[root]
    return record


def amass_record(motion: Motion) -> dict[str, np.ndarray]:
    """The AMASS record of a clip read from a pickle (WHAM, VIBE, 4D-Humans, AIST++ keys):
    ``poses`` (frames, 3 x joints; model order, axis-angle radians), ``trans``,
    ``mocap_framerate`` and the record's ``betas`` (per-frame shapes averaged: AMASS has
    one per sequence) and ``gender`` where it has them."""
    src = motion.source
    assert isinstance(src, SmplParams)
    if motion.missing is not None:
        frames = int(motion.missing.any(axis=1).sum())
        raise MotionError(
            f"an AMASS .npz has no missing frames, and {frames} of this clip are (the person "
            "not seen); clean it first (fill-gaps bridges them) or write .pkl",
            motion.path,
        )
    record = fresh_record(motion)
    record["trans"] = (  # (a record without one, 4D-Humans' tracks: the root stays put)
        motion.translations[:, 0] - src.root_offset
        if src.trans_key is not None
        else np.zeros((motion.n_frames, 3))
    )
    betas = _betas(src.record)
    if betas is not None:
        record["betas"] = betas
    gender = src.record.get("gender")
    if isinstance(gender, np.ndarray) and gender.dtype.kind in "US":
        record["gender"] = gender
    return record


# ----------------------------------------------------------------------------- .npz files


def parse_smpl_npz(
    data: bytes,
    path,
    skeleton: Motion | None = None,
    body_model=None,
    frame_rate: float | None = None,
) -> Motion:
    """A clip of an AMASS-style ``.npz`` (see the module); ``body_model`` is the arrays of
    a body model file (:func:`read_body_model`), ``frame_rate`` the rate taken where the
    file states none."""
    members = npz.read_npz(data, path)
    record = {m.key: m.array for m in members if m.array is not None}
    return smpl_motion(
        record,
        path,
        container=members,
        raw=data,
        skeleton=skeleton,
        body_model=body_model,
        frame_rate=frame_rate,
    )


#: The protocols whose pickles start with the PROTO opcode (0x80, then the protocol): the
#: official SMPL and MANO ``.pkl`` body models are protocol 2.
PICKLE_PROTOCOLS = range(2, 6)


def _pickled(data: bytes, path) -> bool:
    """Whether a body model file is a pickle, not a zip: by its first bytes (PROTO, one
    of :data:`PICKLE_PROTOCOLS`) or, not starting as a zip does, by its ``.pkl`` suffix."""
    if data[:2] == b"PK":
        return False
    proto = len(data) > 1 and data[0] == 0x80 and data[1] in PICKLE_PROTOCOLS
    return proto or Path(path).suffix.lower() in (".pkl", ".pickle")


def read_body_model(path) -> tuple[dict[str, np.ndarray], str]:
    """The arrays of a body model ``.npz`` (SMPL-X's ``SMPLX_NEUTRAL.npz`` and the like),
    read as safely as any clip, and its path. A pickled model (the official ``.pkl``, of
    chumpy objects) is refused saying how to get an ``.npz``."""
    data, _ = read_regular_file(Path(path))
    if _pickled(data, path):
        raise MotionError(
            "a pickled body model: only .npz body models are read (the SMPL-X and AMASS "
            "SMPL+H downloads have one; or save the .pkl's arrays with numpy.savez)",
            path,
        )
    return {m.key: m.array for m in npz.read_npz(data, path) if m.array is not None}, str(path)


def npz_pieces(motion: Motion) -> Iterable[bytes]:
    """``motion`` as an ``.npz``: its own archive with the changed arrays replaced (the
    input bytes when nothing changed), or a fresh AMASS archive (``poses``, ``trans``,
    ``mocap_framerate``) of a clip from a pickle or another format."""
    refuse_no_frames(motion)
    src = motion.source
    if isinstance(src, SmplParams) and not isinstance(src.container, list):  # a pickle's
        record = amass_record(motion)
    elif isinstance(src, SmplParams) and not same_frames(motion):
        record = resampled_record(motion)
    elif isinstance(src, SmplParams):
        changed = changed_arrays(motion)
        if isinstance(src.container, list):  # read from an .npz
            return pieces(src.raw) if not changed else [npz.write_npz(src.container, changed)]
        record = {key: value for key, value in src.record.items() if isinstance(value, np.ndarray)}
        record.update(changed)
    else:
        record = fresh_record(motion)
    out = io.BytesIO()
    np.savez(out, **record)  # type: ignore[arg-type]  # (the stubs take one keyword for all)
    return [out.getvalue()]
