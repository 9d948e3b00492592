"""SMPL parameters in pickles (``.pkl``): WHAM, VIBE and the like, read without running code.

The file is read by :func:`~motionclean.io.safepickle.loads` (numpy arrays and plain
containers only; joblib's format and compression included). The SMPL record is the
top-level dict when it holds a pose (see :mod:`motionclean.io.smpl` for its keys), else
the entry of a dict of people (``{track_id: record}``, as WHAM's ``wham_output.pkl`` and
VIBE's output) with the most frames; a note names the one read. WHAM's records hold both
camera-frame (``pose``, ``trans``) and world-grounded (``pose_world``, ``trans_world``)
motion: the world one is read.

A record with ``frame_ids`` (the video frames a person was seen in) is laid on the frames
from its first to its last: frames in between that it skips are missing samples
(``Motion.missing``), which ``fill-gaps`` bridges; the writer writes the rows of the
frames in ``frame_ids`` only.

Written back (``.pkl``): the same containers with the changed arrays replaced (dtype and
shape kept), pickled with protocol 4 (readable by ``pickle.load`` and ``joblib.load``;
defaultdicts come back as dicts); an untouched clip is written as the input bytes.
"""

from __future__ import annotations

import pickle
from typing import Any

import numpy as np

from ..core.errors import MotionError
from ..core.motion import Motion
from . import safepickle, smpl
from .files import pieces


def _is_record(value: Any) -> bool:
    return isinstance(value, dict) and any(key in value for key in smpl.POSE_KEYS + smpl.ROOT_KEYS)


def _arrays(record: dict) -> dict[str, np.ndarray]:
    """The record's named arrays (numbers given as Python scalars become 0-d arrays)."""
    out = {}
    for key, value in record.items():
        if not isinstance(key, str):
            continue
        if isinstance(value, np.ndarray):
            out[key] = value
        elif (
            isinstance(value, (int, float))
            and not isinstance(value, bool)
            or isinstance(value, str)
        ):
            out[key] = np.asarray(value)
    return out


def _locate(tree: Any, path) -> tuple[tuple, dict, str | None]:
    """The route to the SMPL record, the record and a note naming the person read."""
    if _is_record(tree):
        return (), tree, None
    if isinstance(tree, dict):
        people = [(key, value) for key, value in tree.items() if _is_record(value)]
        if people:

            def frames(item) -> int:
                arrays = _arrays(item[1])
                key = next((k for k in smpl.POSE_KEYS + smpl.ROOT_KEYS if k in arrays), None)
                return int(arrays[key].shape[0]) if key and arrays[key].ndim else 0

            key, record = max(people, key=frames)
            note = (
                None
                if len(people) == 1
                else (f"{len(people)} people in the file: {str(key)[:40]!r} read (the most frames)")
            )
            return (key,), record, note
    raise MotionError(
        "no SMPL record in the pickle: expected a dict with 'poses'/'pose' or "
        "'global_orient' + 'body_pose' (or a dict of such records, one per person)",
        path,
    )


def _frame_rows(arrays: dict, path) -> np.ndarray | None:
    """The frame of each row (from ``frame_ids``), None when the rows are every frame."""
    ids = arrays.get("frame_ids")
    if ids is None or ids.dtype.kind not in "iu" or ids.ndim != 1:
        return None
    if ids.size and np.any(np.diff(ids) <= 0):
        raise MotionError("frame_ids do not increase", path)
    rows = (ids - ids[0]).astype(np.intp) if ids.size else ids.astype(np.intp)
    if rows.size and rows[-1] >= 100 * rows.size + 1000:
        raise MotionError(f"frame_ids span {rows[-1] + 1} frames for {rows.size} rows", path)
    return None if rows.size == 0 or rows[-1] == rows.size - 1 else rows


def parse_pickle(data: bytes, path, skeleton: Motion | None = None, body_model=None) -> Motion:
    """A clip of a pickle's SMPL record (see the module)."""
    tree = safepickle.loads(data, path)
    route, record, note = _locate(tree, path)
    arrays = _arrays(record)
    model, model_path = body_model if body_model is not None else (None, None)
    return smpl.smpl_motion(
        arrays,
        path,
        container=(tree, route),
        raw=data,
        skeleton=skeleton,
        body_model=model,
        body_model_path=model_path,
        notes=(note,) if note else (),
        rows=_frame_rows(arrays, path),
    )


def pickle_pieces(motion: Motion):
    """``motion`` as a pickle (see the module)."""
    src = motion.source
    if isinstance(src, smpl.SmplParams) and isinstance(src.container, tuple):
        changed = smpl.changed_arrays(motion)
        if not changed:
            return pieces(src.raw)
        tree, route = src.container
        out = _replaced(tree, route, changed)
    elif isinstance(src, smpl.SmplParams):  # read from an .npz
        out = {key: value for key, value in src.record.items()}
        out.update(smpl.changed_arrays(motion))
    else:
        out = smpl.fresh_record(motion)
    return [pickle.dumps(out, protocol=4)]


def _replaced(tree: Any, route: tuple, changed: dict[str, np.ndarray]) -> Any:
    """A copy of ``tree`` with the record at ``route`` holding the ``changed`` arrays (the
    containers on the way copied, everything else shared)."""
    if not route:
        record = dict(tree)
        record.update(changed)
        return record
    copy = dict(tree)
    copy[route[0]] = _replaced(tree[route[0]], route[1:], changed)
    return copy
