"""Writing a glTF file back (the package's docstring: what is kept and what is new), and a
new one for a clip read from another format."""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ...core import quat
from ...core.kinematics import rest_positions, turn_up_onto, up_direction
from ...core.motion import (
    UNCHANGED_TOLERANCE,
    Motion,
    same_rotations,
)
from ..files import pieces
from .container import (
    VRM_ANIMATION,
    data_uri,
    fail,
    file_buffers,
    glb_bytes,
    image_files,
    images_of,
    read_accessor,
    read_referenced,
    relative_file,
)
from .read import GENERATOR, GltfSource, Track
from .sampling import as_wxyz


class _Appender:
    """New binary data for a buffer, with bufferViews and accessors added to ``document``."""

    def __init__(self, document: dict, buffer: int, base: int):
        self.document, self.buffer, self.base = document, buffer, base
        self.parts: list[bytes] = []
        self.size = 0

    def view(self, data: bytes) -> int:
        """A new bufferView of ``data`` (at a multiple of 4 bytes), by index."""
        pad = -(self.base + self.size) % 4
        self.parts.append(b"\0" * pad)
        self.size += pad
        views = self.document.setdefault("bufferViews", [])
        views.append(
            {"buffer": self.buffer, "byteOffset": self.base + self.size, "byteLength": len(data)}
        )
        self.parts.append(data)
        self.size += len(data)
        return len(views) - 1

    def accessor(self, values: np.ndarray, kind: str, bounds: bool = False) -> int:
        data = np.ascontiguousarray(values, dtype="<f4").tobytes()
        spec: dict[str, Any] = {
            "bufferView": self.view(data),
            "componentType": 5126,
            "count": len(values),
            "type": kind,
        }
        if bounds:
            flat = np.asarray(values, dtype=np.float32).reshape(len(values), -1)
            spec["min"] = [float(v) for v in flat.min(axis=0)]
            spec["max"] = [float(v) for v in flat.max(axis=0)]
        accessors = self.document.setdefault("accessors", [])
        accessors.append(spec)
        return len(accessors) - 1

    def data(self) -> bytes:
        return b"".join(self.parts)


def _own_document(motion: Motion) -> GltfSource | None:
    """The glTF ``motion`` is written into: the one it was read from, while it has that
    file's joints; None for a new one."""
    src = motion.source
    return src if isinstance(src, GltfSource) and motion.n_joints == len(src.nodes) else None


def vrma_pieces(motion: Motion, target: Path) -> Iterable[bytes]:
    """``motion`` as a VRM animation (``.vrma``): only into the VRM animation it was read
    from, whose :data:`.container.VRM_ANIMATION` extension maps its nodes to humanoid bones (a new
    GLB, or another file's, has no such map: no VRM tool would load it)."""
    src = _own_document(motion)
    extensions = src.document.get("extensions") if src is not None else None
    if not (isinstance(extensions, dict) and VRM_ANIMATION in extensions):
        fail(
            f"a .vrma is a VRM animation ({VRM_ANIMATION}: nodes mapped to humanoid bones); "
            "this clip is not read from one: write .glb",
            motion.path,
        )
    return gltf_pieces(motion, target, glb=True)


def gltf_pieces(motion: Motion, target: Path, glb: bool) -> Iterable[bytes]:
    """``motion`` written into the glTF it was read from (the package's docstring), as a GLB or a
    ``.gltf`` (whose binary chunk, if it came from a GLB, becomes a data URI) to be saved at
    ``target``: the input's bytes when nothing changed and they find the files they name
    from there, else buffer files are embedded as data URIs, and image files too when
    ``target`` is in another folder."""
    src = _own_document(motion)
    if src is None:
        return [fresh_gltf(motion, glb)]
    same_frames = motion.n_frames == src.n_frames and motion.frame_time == src.frame_time
    read = motion.source_rotations  # None once the frames changed (resampled, stitched)
    if same_frames and read is not None and read.shape == motion.rotations.shape:
        kept = same_rotations(motion.rotations, read)
    else:
        kept = np.zeros((motion.n_frames, motion.n_joints), dtype=bool)
    positions = motion.layout.position_columns[:, 0] >= 0
    if same_frames:
        moved = np.abs(motion.translations - src.translations).max(axis=-1) > UNCHANGED_TOLERANCE
        moved &= positions[None, :]
    else:  # new frames: every joint's track keyed on them (old keys would set the clip's span)
        keyed = np.array([track.channel >= 0 for track in src.translation])
        moved = np.repeat((positions | keyed)[None, :], motion.n_frames, axis=0)
    beside = _beside_source(src, target)
    if kept.all() and not moved.any() and glb == src.glb and (beside or not _names_files(src)):
        return pieces(src.raw)
    document = copy.deepcopy(src.document)
    glb_binary = src.glb and src.binary is not None and _first_buffer_is_binary(document)
    if glb_binary:
        assert src.binary is not None
        appender = _Appender(document, 0, len(src.binary))
    else:
        appender = _Appender(document, len(document.get("buffers", [])), 0)
    animation = _animation(document, src)
    grid = src.start + motion.frame_time * np.arange(motion.n_frames) if not same_frames else None
    shared_times: dict[str, int] = {}

    def times_for(track: Track) -> int:
        if same_frames and track.exact:
            return track.times
        if "grid" not in shared_times:
            t = grid if grid is not None else src.start + src.frame_time * np.arange(src.n_frames)
            shared_times["grid"] = appender.accessor(t[:, None], "SCALAR", bounds=True)
        return shared_times["grid"]

    for j, node in enumerate(src.nodes):
        rotation_changed = not kept[:, j].all()
        if rotation_changed:
            track = src.rotation[j]
            q = motion.rotations[:, j].copy()
            if same_frames and track.exact:  # unchanged frames keep the values read
                old = as_wxyz(
                    read_accessor(src.document, src.buffers, _output(src, track), motion.path)
                )
                q[kept[:, j]] = old[kept[:, j]]
            xyzw = q[:, [1, 2, 3, 0]]
            _point(
                _holder(document, track, animation),
                track,
                node,
                "rotation",
                times_for(track),
                appender.accessor(xyzw, "VEC4"),
            )
        if moved[:, j].any():
            track = src.translation[j]
            held = np.broadcast_to(motion.offsets[j], (motion.n_frames, 3))  # a still track
            _point(
                _holder(document, track, animation),
                track,
                node,
                "translation",
                times_for(track),
                appender.accessor(motion.translations[:, j] if positions[j] else held, "VEC3"),
            )
    new = appender.data()
    binary = src.binary
    if glb_binary:
        assert binary is not None
        binary += new
        document["buffers"][0]["byteLength"] = len(binary)
    elif new:
        document.setdefault("buffers", []).append({"byteLength": len(new), "uri": data_uri(new)})
    for index in file_buffers(src.document):  # embedded: the file can go to any folder
        document["buffers"][index]["uri"] = data_uri(src.buffers[index])
    images = {} if beside else _carried_images(src)
    if not glb:  # one self-contained file: the binary chunk embedded too
        if glb_binary or (src.glb and binary is not None and _first_buffer_is_binary(document)):
            assert binary is not None
            document["buffers"][0]["uri"] = data_uri(binary)
        for index, (data, media) in images.items():
            document["images"][index]["uri"] = data_uri(data, media)
        return [json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")]
    binary = binary if src.glb else None
    if images:
        binary = _chunk_images(document, _binary_chunk(document, src, binary, new), images)
    text = json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    return [glb_bytes(text, binary)]


def _names_files(src: GltfSource) -> bool:
    """Whether ``src`` names files beside it: buffers or images by a relative URI."""
    images = images_of(src.document, src.buffers.path)
    return bool(file_buffers(src.document)) or any(
        relative_file(image.get("uri")) for image in images
    )


def _beside_source(src: GltfSource, target: Path) -> bool:
    """Whether ``target`` (by its name and, through a symbolic link, where it lands) is in
    the folder ``src`` was read from, where the relative URIs it names find their files."""
    folder = os.path.realpath(Path(src.buffers.path).parent)
    return os.path.realpath(target.parent) == folder == os.path.dirname(os.path.realpath(target))


def _carried_images(src: GltfSource) -> dict[int, tuple[bytes, str]]:
    """The bytes and media type of each image of ``src`` a glTF in another folder carries
    (:func:`.container.image_files`), by image index."""
    path = src.buffers.path
    found, _ = image_files(src.document, path)
    return {
        index: (read_referenced(path, f"images[{index}]", where, "an image"), media)
        for index, (where, media) in found.items()
    }


def _binary_chunk(document: dict, src: GltfSource, binary: bytes | None, new: bytes) -> bytes:
    """The GLB binary chunk ``document`` (bound for a GLB) refers to as its first buffer,
    made so when it has none: that buffer's bytes (``src``'s, or ``new``, the buffer
    appended for a file that had none), or an empty buffer."""
    buffers = document.setdefault("buffers", [])
    if not buffers:
        buffers.append({"byteLength": 0})
        return b""
    if "uri" not in buffers[0]:  # (a .gltf's such buffer: the reader's error)
        return binary if binary is not None else src.buffers[0]
    del buffers[0]["uri"]
    return src.buffers[0] if src.document.get("buffers") else new


def _chunk_images(document: dict, binary: bytes, images: dict[int, tuple[bytes, str]]) -> bytes:
    """``binary`` (``document``'s first buffer, the GLB binary chunk) with ``images``
    appended, each image pointed to its new bufferView (as a GLB holds its images)."""
    appender = _Appender(document, 0, len(binary))
    for index, (data, media) in images.items():
        image = document["images"][index]
        del image["uri"]
        image["bufferView"] = appender.view(data)
        image["mimeType"] = media
    binary += appender.data()
    document["buffers"][0]["byteLength"] = len(binary)
    return binary


def _first_buffer_is_binary(document: dict) -> bool:
    buffers = document.get("buffers", [])
    return bool(buffers) and "uri" not in buffers[0]


def _output(src: GltfSource, track: Track) -> int:
    animation = src.document["animations"][track.animation]
    sampler = animation["samplers"][animation["channels"][track.channel]["sampler"]]
    return sampler["output"]


def _animation(document: dict, src: GltfSource) -> dict:
    """The animation of ``document`` new channels go into: the first read, else a new one."""
    if src.animation >= 0:
        return document["animations"][src.animation]
    document.setdefault("animations", []).append({"channels": [], "samplers": []})
    return document["animations"][-1]


def _holder(document: dict, track: Track, new: dict) -> dict:
    """The animation of ``document`` holding ``track``'s channel, or ``new`` (where new
    channels go) for a track without one."""
    return document["animations"][track.animation] if track.channel >= 0 else new


def _point(animation: dict, track: Track, node: int, kind: str, times: int, output: int) -> None:
    """Make the channel of ``track`` (or a new one for ``node``) use a new LINEAR sampler."""
    samplers = animation.setdefault("samplers", [])
    samplers.append({"input": times, "interpolation": "LINEAR", "output": output})
    if track.channel >= 0:
        animation["channels"][track.channel]["sampler"] = len(samplers) - 1
    else:
        animation.setdefault("channels", []).append(
            {"sampler": len(samplers) - 1, "target": {"node": node, "path": kind}}
        )


#: The node a fresh glTF hangs a skeleton under when its up axis is not +Y (glTF's up).
UP_NODE = "motionclean_up"


def fresh_gltf(motion: Motion, glb: bool) -> bytes:
    """A glTF of a clip read from another format: a node per joint (its offset as rest
    translation, no rest rotation) and per end site (``<joint>_end``, a child node outside
    the skin), a skin of the joints (inverse bind matrices of the rest pose, so importers
    make an armature), one animation
    on the clip's frames (LINEAR rotations, and translations where a joint has position
    channels), data in the GLB binary chunk or a data URI. A skeleton whose up axis (given
    or found, :func:`~motionclean.core.kinematics.up_direction`) is not +Y keeps its own
    coordinates under a node (:data:`UP_NODE`) that turns its up onto +Y, glTF's: viewers
    stand it upright and the reader finds its up from that node."""
    note = getattr(motion.source, "no_world", None)
    if note is not None:
        fail(f"glTF needs joint positions: {note}", motion.path)
    if getattr(motion.source, "needs_skeleton", False):
        fail(
            "glTF needs joint positions: this clip has no skeleton (a channel CSV read "
            "without one; give --skeleton TEMPLATE.bvh)",
            motion.path,
        )
    if motion.n_frames == 0:
        fail("glTF needs at least one frame: this clip has none", motion.path)
    if motion.missing is not None:
        frames = np.flatnonzero(motion.missing.any(axis=1))
        fail(
            f"glTF has no missing samples: {frames.size} frames have some (first {frames[0]}); "
            "fill them first (-f fill-gaps)",
            motion.path,
        )
    n = motion.n_joints
    tips = sorted(motion.end_sites)
    nodes: list[dict[str, Any]] = [
        {"name": name, "translation": [float(v) for v in motion.offsets[j]]}
        for j, name in enumerate(motion.names)
    ]
    for k, j in enumerate(tips):
        nodes.append(
            {
                "name": f"{motion.names[j]}_end",
                "translation": [float(v) for v in motion.end_sites[j]],
            }
        )
        nodes[j].setdefault("children", []).append(n + k)
    for j, parent in enumerate(motion.parents.tolist()):
        if parent >= 0:
            nodes[parent].setdefault("children", []).append(j)
    roots = [j for j in range(n) if motion.parents[j] < 0]
    turn = turn_up_onto(*up_direction(motion), 1)
    if turn is not None:  # the skeleton's own coordinates kept, hung under a turn to +Y up
        nodes.append(
            {"name": UP_NODE, "rotation": [float(v) for v in turn[[1, 2, 3, 0]]], "children": roots}
        )
    document: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": GENERATOR},
        "scene": 0,
        "scenes": [{"nodes": roots if turn is None else [len(nodes) - 1]}],
        "nodes": nodes,
        "animations": [{"channels": [], "samplers": []}],
    }
    appender = _Appender(document, 0, 0)
    rest = rest_positions(motion)  # joints, then end sites: their rest world translations
    inverse_bind = np.zeros((n, 4, 4))  # each the inverse of (turn, rest translation)
    inverse_bind[:] = np.eye(4)
    if turn is not None:  # column-major: the rotation's transpose holds the matrix itself
        inverse_bind[:, :3, :3] = quat.as_matrix(turn)
    inverse_bind[:, 3, :3] = -rest[:n]  # column-major: the translation is the last column
    skin_matrices = appender.accessor(inverse_bind.reshape(n, 16), "MAT4")
    document["skins"] = [{"joints": list(range(n)), "inverseBindMatrices": skin_matrices}]
    times = appender.accessor(
        (np.arange(motion.n_frames) * motion.frame_time)[:, None], "SCALAR", bounds=True
    )
    animation = document["animations"][0]
    positions = motion.layout.position_columns >= 0
    for j in range(n):
        rotation = appender.accessor(motion.rotations[:, j][:, [1, 2, 3, 0]], "VEC4")
        _point(animation, Track(), j, "rotation", times, rotation)
        if positions[j].any():
            local = np.where(positions[j], motion.translations[:, j], motion.offsets[j])
            _point(animation, Track(), j, "translation", times, appender.accessor(local, "VEC3"))
    data = appender.data()
    document["buffers"] = [{"byteLength": len(data)}]
    if not glb:
        document["buffers"][0]["uri"] = data_uri(data)
        return json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    text = json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    return glb_bytes(text, data)
