"""SMPL parameters in pickles (``.pkl``): WHAM, VIBE and the like, read without running code.

The file is read by :func:`~motionclean.io.safepickle.loads` (numpy arrays and plain
containers only; joblib's format and compression included). The SMPL record is the
top-level dict when it holds a pose (see :mod:`motionclean.io.smpl` for its keys), else
the entry of a dict of people (``{track_id: record}``, as WHAM's ``wham_output.pkl`` and
VIBE's output) with the most frames; a note names the one read. WHAM's records hold both
camera-frame (``pose``, ``trans``) and world-grounded (``pose_world``, ``trans_world``)
motion: the world one is read and written, the camera frame's arrays (and ``verts``) stay
as read, and a note says so.

A record with ``frame_ids`` (the video frames a person was seen in) is laid on the frames
from its first to its last: frames in between that it skips are missing samples
(``Motion.missing``), which ``fill-gaps`` bridges; the writer writes the rows of the
frames in ``frame_ids`` only.

4D-Humans' tracker (PHALP) writes one entry per video frame instead, each with a list of
detections: ``tid`` (track ids) and ``smpl`` (per detection ``global_orient`` ``(1, 3, 3)``,
``body_pose`` ``(23, 3, 3)`` rotation matrices, ``betas``), and ``time`` (the frame number).
The track seen on the most frames is read (a note says which) as a SMPL record over the
frames from its first to its last, the frames it was not seen in missing; written back,
each of its detections gets its changed matrices, everything else shared as read.

Written back (``.pkl``): the same containers with the changed arrays replaced (dtype and
shape kept), pickled with protocol 4 (readable by ``pickle.load`` and ``joblib.load``;
defaultdicts come back as dicts); an untouched clip is written as the input bytes.
"""

from __future__ import annotations

import pickle
from dataclasses import dataclass
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
            # (a rate given as True or 60j is kept to be refused, not taken for none)
            or key in smpl.RATE_KEYS
            and isinstance(value, (bool, complex))
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
    """The frame of each row (from ``frame_ids``, first frame 0), None without them."""
    ids = arrays.get("frame_ids")
    if ids is None or ids.dtype.kind not in "iu" or ids.ndim != 1:
        return None
    if ids.size and np.any(np.diff(ids) <= 0):
        raise MotionError("frame_ids do not increase", path)
    rows = (ids - ids[0]).astype(np.intp) if ids.size else ids.astype(np.intp)
    if rows.size and rows[-1] >= 100 * rows.size + 1000:
        raise MotionError(f"frame_ids span {rows[-1] + 1} frames for {rows.size} rows", path)
    return rows


@dataclass(frozen=True, eq=False)
class Tracks:
    """A per-frame tracker output as read (4D-Humans/PHALP): the whole tree and, per row of
    the record, the frame's key and the detection's index in its lists."""

    tree: dict
    places: tuple[tuple[Any, int], ...]


def _is_tracks(tree: Any) -> bool:
    return (
        isinstance(tree, dict)
        and bool(tree)
        and all(isinstance(v, dict) and "smpl" in v and "tid" in v for v in tree.values())
    )


def _tracks_record(tree: dict, path) -> tuple[dict, Tracks, str]:
    """The SMPL record of the track seen on the most frames of a per-frame tracker output."""
    seen: dict[Any, list[tuple[float, Any, int, dict]]] = {}
    for order, (key, frame) in enumerate(tree.items()):
        detections, ids = frame["smpl"], frame["tid"]
        if not isinstance(detections, list) or not isinstance(ids, list | tuple | np.ndarray):
            raise MotionError(f"frame {str(key)[:40]!r}: 'smpl' and 'tid' are not lists", path)
        time = frame.get("time", order)
        if not isinstance(time, int | float | np.integer | np.floating):
            raise MotionError(f"frame {str(key)[:40]!r}: 'time' is not a frame number", path)
        for index, (tid, params) in enumerate(zip(ids, detections, strict=False)):
            if isinstance(params, dict) and {"global_orient", "body_pose"} <= params.keys():
                seen.setdefault(_hashable(tid), []).append((float(time), key, index, params))
    if not seen:
        raise MotionError("no SMPL detection in any frame of the tracker output", path)
    tid, rows = max(seen.items(), key=lambda item: len(item[1]))
    rows.sort(key=lambda row: row[0])
    record: dict[str, np.ndarray] = {}
    for name in ("global_orient", "body_pose", "betas"):
        parts = [row[3].get(name) for row in rows]
        stacked = [part for part in parts if isinstance(part, np.ndarray)]
        if len(stacked) == len(parts):
            if len({part.shape for part in stacked}) != 1:
                raise MotionError(f"track {tid!r}: {name} changes shape between frames", path)
            record[name] = np.stack(stacked)
    times = np.array([row[0] for row in rows])
    if np.any(times != np.round(times)):
        raise MotionError(f"track {tid!r}: frame times are not whole frame numbers", path)
    record["frame_ids"] = times.astype(np.int64)
    note = f"{len(seen)} tracks in the file: track {tid!r} read (seen on {len(rows)} frames)"
    unseen = int(times[-1] - times[0]) + 1 - len(rows)
    if unseen > 0:  # missing in the clip; a .pkl written back has no entry to fill for them
        note += (
            f"; not seen on {unseen} frames between: missing, and a .pkl written back keeps "
            "an entry for each frame seen only (write .npz to keep them filled)"
        )
    return record, Tracks(tree, tuple((row[1], row[2]) for row in rows)), note


def _hashable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist() if value.ndim == 0 else tuple(value.ravel().tolist())
    return value.item() if isinstance(value, np.generic) else value


def parse_pickle(
    data: bytes,
    path,
    skeleton: Motion | None = None,
    body_model=None,
    frame_rate: float | None = None,
) -> Motion:
    """A clip of a pickle's SMPL record (see the module); ``frame_rate``: the rate (frames
    per second) taken when the record states none."""
    tree: Any = safepickle.loads(data, path)
    container: Any
    note: str | None
    if _is_tracks(tree):
        record, container, note = _tracks_record(tree, path)
    else:
        route, record, note = _locate(tree, path)
        container = (tree, route)
    arrays = _arrays(record)
    notes = [note] if note else []
    if "pose_world" in arrays and "pose" in arrays:  # WHAM: what a render over the video uses
        world = ", ".join(key for key in ("pose_world", "trans_world") if key in arrays)
        left = ", ".join(key for key in ("pose", "trans", "verts") if key in arrays)
        notes.append(
            f"the world motion ({world}) is read and written; the camera frame's {left} "
            "stay as read (a render over the video from them shows the input)"
        )
    return smpl.smpl_motion(
        arrays,
        path,
        container=container,
        raw=data,
        skeleton=skeleton,
        body_model=body_model,
        notes=tuple(notes),
        rows=_frame_rows(arrays, path),
        frame_rate=frame_rate,
    )


def pickle_pieces(motion: Motion):
    """``motion`` as a pickle (see the module)."""
    smpl.refuse_no_frames(motion)
    src = motion.source
    if isinstance(src, smpl.SmplParams) and not smpl.same_frames(motion):
        if isinstance(src.container, Tracks):
            raise MotionError(
                "a tracker output keeps its video frames: write a resampled clip as .npz",
                motion.path,
            )
        record = smpl.resampled_record(motion)
        if isinstance(src.container, tuple):
            tree, route = src.container
            out = _replaced(tree, route, record, whole=True)
        else:
            out = record
    elif isinstance(src, smpl.SmplParams) and isinstance(src.container, tuple | Tracks):
        changed = smpl.changed_arrays(motion)
        if not changed:
            return pieces(src.raw)
        if isinstance(src.container, Tracks):
            out = _into_tracks(src.container, changed)
        else:
            tree, route = src.container
            out = _replaced(tree, route, changed)
    elif isinstance(src, smpl.SmplParams):  # read from an .npz
        out = {key: value for key, value in src.record.items()}
        out.update(smpl.changed_arrays(motion))
    else:
        out = smpl.fresh_record(motion)
    return [pickle.dumps(out, protocol=4)]


def _replaced(tree: Any, route: tuple, changed: dict[str, np.ndarray], whole=False) -> Any:
    """A copy of ``tree`` with the record at ``route`` holding the ``changed`` arrays (the
    containers on the way copied, everything else shared); with ``whole``, ``changed`` is
    the record's every array (the record's other values, not arrays, kept)."""
    if not route:
        if whole:
            kept = {key: value for key, value in tree.items() if not isinstance(value, np.ndarray)}
            return {**kept, **changed}
        record = dict(tree)
        record.update(changed)
        return record
    copy = dict(tree)
    copy[route[0]] = _replaced(tree[route[0]], route[1:], changed, whole)
    return copy


def _into_tracks(tracks: Tracks, changed: dict[str, np.ndarray]) -> dict:
    """A copy of a tracker output whose read detections hold the ``changed`` arrays (row by
    row; the frames, lists and dicts on the way copied, everything else shared)."""
    out = dict(tracks.tree)
    for row, (key, index) in enumerate(tracks.places):
        if out[key] is tracks.tree[key]:
            out[key] = dict(out[key])
            out[key]["smpl"] = list(out[key]["smpl"])
        params = dict(out[key]["smpl"][index])
        for name, values in changed.items():
            params[name] = values[row]
        out[key]["smpl"][index] = params
    return out
