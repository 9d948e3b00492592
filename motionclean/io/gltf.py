"""glTF 2.0 (``.gltf``, ``.glb``): a skin's joints and their animation, read with json
and numpy.

The clip's joints are the first skin's joints (or, in a file without skins, the nodes the
animation moves), in depth-first order of the node tree; a joint's parent is its nearest
ancestor among them. Its rest offset is the node's translation; its local rotation is the
node's ``rotation`` (glTF's ``(x, y, z, w)`` becomes our ``(w, x, y, z)``), animated by
the first animation's ``rotation`` channel (or the one asked for; where several animations
each key other joints on one time base, as COLLADA2GLTF writes an animation per joint, all
of them: viewers play them together), and a joint whose ``translation`` channel
varies gets position channels (glTF replaces the node's translation, as BVH position
channels replace an OFFSET). Scale is not read (and never changed): lengths are metres,
glTF's unit, where no node of the armature is scaled, else the skeleton's own units
(:func:`_length_unit`; a file motionclean wrote from another format keeps that format's
lengths, a BVH's centimetres, and says no unit). A VRM animation (the
``VRMC_vrm_animation`` extension) is read by its humanoid bone map: the joints are the
bones' nodes (and any node between two of them), hips at the root; its expression nodes
(whose translation's x is a weight) and its look-at node are not joints, their channels
kept as they are, and a note names them.

Keyframes become frames on a uniform grid: the frame time is the smallest key step of the
channels (a uniform channel's span over its steps, else its median step; snapped to a
whole frame rate within 0.01 %, the error of exporters' float32 times, while the keys stay
on its grid; else made exact: a whole or NTSC rate's within the float32 rounding of the
times, or the shortest decimal within it), from the earliest key to the latest. A channel
keyed on every frame of the grid is read as it is; any other is sampled: ``STEP`` holds
the previous key, ``LINEAR`` interpolates (slerp for rotations, as glTF specifies),
``CUBICSPLINE`` evaluates its Hermite spline (rotations renormalised), each holding its
first and last key outside its range.

Writing back keeps the file: with nothing changed its bytes exactly, where they find the
files they refer to by relative URIs (none, or written into the folder they were read
from); otherwise every object of the JSON and every byte of the buffers stays, the
channels of joints that changed point to new samplers of the animation they are in
(``LINEAR`` on the grid; a channel read as it was keeps its time accessor and the values
of its unchanged frames), whose data is appended to the GLB binary chunk, or for
``.gltf`` to a new buffer embedded as a data URI; a changed ``.gltf``, or an unchanged
one written to another folder, is written self-contained (its ``.bin`` files' bytes
embedded as data URIs; the files themselves are never touched). Into another folder
images named by relative URIs are carried too: as data URIs in a ``.gltf``, in a GLB as
bufferViews of its binary chunk (its first buffer made the chunk when it had none); a URL
or an absolute path stays as it is, and so does an image not beside the source or of no
known type, which a note says when it is read. Relative URIs name files inside the
source's folder, links resolved (:func:`_beside`). Sparse accessors and compressed
animation data are refused. A VRM animation (``.vrma``) is a GLB, written only into the
one it was read from (:func:`vrma_pieces`).
"""

from __future__ import annotations

import base64
import binascii
import copy
import json
import math
import os
import stat
import struct
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import unquote, urlsplit

import numpy as np

from ..core import quat
from ..core.checks import MAX_MAGNITUDE, within_magnitude
from ..core.errors import MotionError
from ..core.kinematics import axis_name, rest_positions, turn_up_onto, up_direction
from ..core.motion import (
    MAX_FRAME_TIME,
    MIN_FRAME_TIME,
    POSITION_CHANNELS,
    RATES_ACCEPTED,
    UNCHANGED_TOLERANCE,
    Motion,
    joint_major_zeros,
    same_rotations,
)
from ..core.words import plural
from .files import pieces, read_regular_file
from .smpl_model import matrix_to_quaternion

GLB_MAGIC = b"glTF"
#: Suffixes of binary glTF files (a VRM animation, ``.vrma``, is one).
GLB_SUFFIXES = (".glb", ".vrma")
#: The extension that makes a GLB a VRM animation: it maps nodes to humanoid bones.
VRM_ANIMATION = "VRMC_vrm_animation"
JSON_CHUNK = 0x4E4F534A
BIN_CHUNK = 0x004E4942
#: Rotation channels a joint gets (its Euler order when written as BVH or CSV).
ROTATION = ("Zrotation", "Xrotation", "Yrotation")
#: Component types: numpy dtype and the divisor of normalized integers (glTF 2.0 3.11).
COMPONENTS = {
    5120: (np.int8, 127.0),
    5121: (np.uint8, 255.0),
    5122: (np.int16, 32767.0),
    5123: (np.uint16, 65535.0),
    5125: (np.uint32, None),
    5126: (np.float32, None),
}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
#: Largest grid, in joint samples (frames x joints) per keyframe of the whole animation:
#: more means keys too far apart for the frame time found (memory must follow the file, not
#: its times). A baked export holds about one key per joint sample, a hand-keyed one with a
#: key every half second on every joint at 60 fps 30; one sampler's keys moved 5,000 s away
#: had made 600,024 frames of 23 joints from 652 keys (3.3 GB read from 42 KB).
MAX_SAMPLES_PER_KEY = 250
#: A channel whose keys lie within this fraction of a frame of the grid (plus two float32
#: rounding steps of the time itself: key times are float32) is read as it is.
ON_GRID = 1e-3
FLOAT32_TIME = 2.0**-22
#: A frame rate within this fraction of a whole number is that number: exporters' float32
#: key times are off by up to about 1e-5 (Blender's 120 fps export reads as 119.9995).
SNAP = 1e-4


def _fail(message: str, path) -> NoReturn:
    raise MotionError(message, path)


@dataclass(frozen=True, eq=False)
class Track:
    """A joint's animated property: the channel (index in its animation, or -1 for none),
    whether its keys are the grid's frames (read as they are), its input accessor, and
    the animation the channel is in (an index; -1 for none)."""

    channel: int = -1
    exact: bool = False
    times: int = -1
    animation: int = -1


@dataclass(frozen=True, eq=False)
class GltfSource:
    """A glTF file as read, for the writer (see the module)."""

    raw: bytes
    document: dict
    binary: bytes | None  # the GLB binary chunk
    glb: bool
    nodes: tuple[int, ...]  # the joints' node indices
    animation: int  # the first animation read, where new channels go; -1: none
    rotation: tuple[Track, ...]
    translation: tuple[Track, ...]
    start: float
    frame_time: float
    n_frames: int
    buffers: Any  # the buffers' bytes, read when first asked for
    translations: np.ndarray  # (F, J, 3) as read
    notes: tuple[str, ...] = field(default=())
    #: The unit of its lengths where it holds (:func:`_length_unit`), else None: the
    #: skeleton's own (``core.kinematics.length_unit``).
    length_unit: str | None = None
    #: ``(J, 4)`` the joints' rest rotations (w, x, y, z): the nodes' own ``rotation``, part
    #: of the rest pose (``core.kinematics.rest_pose``), which offsets alone fold.
    rest_rotations: np.ndarray | None = None

    @property
    def start_time(self) -> float:
        """Seconds at the first frame, the earliest key (:func:`.text.start_time`)."""
        return self.start

    #: Significant digits the file's numbers hold: float32 accessors, and JSON numbers
    #: exporters print from float32 values (a new BVH's OFFSETs keep as many).
    float_digits = 7


# ----------------------------------------------------------------------------- the container


def _chunks(data: bytes, path) -> tuple[dict, bytes | None]:
    """The JSON and binary chunks of a GLB."""
    if len(data) < 20:
        _fail("a GLB shorter than its header", path)
    magic, version, length = struct.unpack_from("<4sII", data)
    if magic != GLB_MAGIC:
        _fail("not a GLB file (no 'glTF' magic)", path)
    if version != 2:
        _fail(f"glTF version {version}; only glTF 2.0 is read", path)
    if length != len(data):
        _fail(f"the header says {length} bytes, the file has {len(data)}", path)
    at, chunks = 12, []
    while at < len(data):
        if at + 8 > len(data):
            _fail("a chunk header runs past the end of the file", path)
        size, kind = struct.unpack_from("<II", data, at)
        if at + 8 + size > len(data):
            _fail("a chunk runs past the end of the file", path)
        chunks.append((kind, data[at + 8 : at + 8 + size]))
        at += 8 + size
    if not chunks or chunks[0][0] != JSON_CHUNK:
        _fail("the first chunk of a GLB must be JSON", path)
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == BIN_CHUNK else None
    return _json(chunks[0][1], path), binary


def _json(text: bytes, path) -> dict:
    try:
        document = json.loads(text.decode("utf-8").removeprefix("\ufeff"))
    except UnicodeDecodeError:
        _fail("the glTF JSON is not UTF-8 text", path)
    except RecursionError:
        _fail("the glTF JSON is nested too deeply", path)
    except ValueError as error:
        _fail(f"the glTF JSON does not parse: {str(error)[:100]}", path)
    if not isinstance(document, dict):
        _fail("the glTF JSON is not an object", path)
    version = (
        document.get("asset", {}).get("version")
        if isinstance(document.get("asset"), dict)
        else None
    )
    if not isinstance(version, str) or not version.startswith("2."):
        _fail(f"asset.version is {version!r}; only glTF 2.0 is read", path)
    return document


def _items(document: dict, key: str, path) -> list:
    value = document.get(key, [])
    if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
        _fail(f"{key!r} is not a list of objects", path)
    return value


def _json_text(value) -> str:
    """``value`` as its JSON writes it, cut to 20 characters (``"24"``: the string)."""
    text = json.dumps(value)[:20]
    return f"the string {text}" if isinstance(value, str) else text


def _index(value, size: int, what: str, path) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < size:
        _fail(f"{what}: {_json_text(value)} is not an index below {size}", path)
    return value


def _count(value, what: str, path) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        _fail(f"{what}: {_json_text(value)} is not a count", path)
    return value


class _Buffers:
    """The bytes of each buffer, read when first asked for (GLB chunk, data URI or a file
    beside the glTF)."""

    def __init__(self, document: dict, binary: bytes | None, path):
        self.specs = _items(document, "buffers", path)
        self.binary = binary
        self.path = path
        self.loaded: dict[int, bytes] = {}

    def __getitem__(self, index: int) -> bytes:
        if index not in self.loaded:
            self.loaded[index] = self._load(index)
        return self.loaded[index]

    def _load(self, index: int) -> bytes:
        spec = self.specs[index]
        length = _count(spec.get("byteLength"), f"buffers[{index}].byteLength", self.path)
        uri = spec.get("uri")
        if uri is None:
            if index != 0 or self.binary is None:
                _fail(f"buffers[{index}] has no uri and no GLB binary chunk", self.path)
            data = self.binary
        elif not isinstance(uri, str):
            _fail(f"buffers[{index}].uri is not text", self.path)
        elif uri.startswith("data:"):
            head, comma, payload = uri.partition(",")
            if not comma or not head.endswith(";base64"):
                _fail(f"buffers[{index}]: a data URI that is not base64", self.path)
            try:
                data = base64.b64decode(payload, validate=True)
            except (binascii.Error, ValueError):
                _fail(f"buffers[{index}]: its base64 data does not decode", self.path)
        else:
            data = self._file(index, uri)
        if len(data) < length:
            _fail(f"buffers[{index}] holds {len(data)} bytes, byteLength says {length}", self.path)
        return data

    def _file(self, index: int, uri: str) -> bytes:
        what = f"buffers[{index}]"
        return _read_file(self.path, what, _beside(self.path, what, uri), "a buffer")


def _beside(path, what: str, uri: str) -> Path:
    """The file a relative ``uri`` (of ``what``: ``images[0]``) names in the folder of the
    glTF at ``path``, its symbolic links resolved; its query and fragment (``?v=2``) are no
    part of the name. Refused (one-line MotionError) when it names no file, is a URL or an
    absolute path, climbs out by ``..``, holds a NUL byte, or leads out of the folder
    through a link: ``skin.png -> /etc/passwd`` would put that file into the output."""
    said = f"{what}: uri {uri[:60]!r}"
    parts = _split(uri)
    if parts is None:
        _fail(f"{said} is not a valid URI", path)
    name = unquote(parts.path)
    if not name or name.endswith("/"):
        _fail(f"{said} names no file", path)
    if not _relative_file(uri):
        _fail(f"{said} is a URL or an absolute path, not a file beside the glTF", path)
    if ".." in Path(name).parts:
        _fail(f"{said} climbs out of the glTF's folder ('..')", path)
    if "\0" in name:
        _fail(f"{said} holds a NUL byte", path)
    folder = Path(os.path.realpath(Path(path).parent))
    where = Path(os.path.realpath(folder / name))
    if not where.is_relative_to(folder):
        _fail(f"{said} links outside the glTF's folder", path)
    return where


def _split(uri: str):
    """``urlsplit(uri)``, or None where ``uri`` is no valid URI (``//[skin.png``)."""
    try:
        return urlsplit(uri)
    except ValueError:
        return None


def _read_file(path, what: str, where: Path, kind: str) -> bytes:
    """The bytes of ``where``, a file of ``what`` beside the glTF at ``path``
    (:func:`_beside`); errors name both (``kind`` of file: "is a directory, not an image")."""
    try:
        data, _ = read_regular_file(where, kind)
    except MotionError as error:
        _fail(f"{what}: {error.message} ({where})", path)
    return data


def _accessor(document: dict, buffers: _Buffers, index: object, path) -> np.ndarray:
    """``(count, width)`` float64 values of accessor ``index`` (normalized integers
    divided out)."""
    accessors = _items(document, "accessors", path)
    index = _index(index, len(accessors), "accessor", path)
    spec = accessors[index]
    where = f"accessors[{index}]"
    if "sparse" in spec:
        _fail(f"{where}: sparse accessors are not read", path)
    kind = spec.get("componentType")
    if kind not in COMPONENTS:
        _fail(f"{where}: componentType {str(kind)[:12]} is not a glTF component type", path)
    dtype, divisor = COMPONENTS[kind]
    width = WIDTHS.get(spec.get("type"))
    if width is None:
        _fail(f"{where}: type {str(spec.get('type'))[:12]!r} is not read", path)
    count = _count(spec.get("count"), f"{where}.count", path)
    views = _items(document, "bufferViews", path)
    if "bufferView" not in spec:
        return (
            np.zeros((count, width)) if count <= 1 << 16 else _fail(f"{where}: no bufferView", path)
        )
    view = views[_index(spec["bufferView"], len(views), f"{where}.bufferView", path)]
    if view.get("extensions"):
        _fail(f"{where}: compressed data ({str(view['extensions'])[:60]}) is not read", path)
    buffer_index = _index(
        view.get("buffer"), len(buffers.specs), f"{where}: bufferView.buffer", path
    )
    item = np.dtype(dtype).itemsize
    stride = view.get("byteStride", width * item) or width * item
    view_offset = _count(view.get("byteOffset", 0), f"{where}: bufferView.byteOffset", path)
    view_length = _count(view.get("byteLength"), f"{where}: bufferView.byteLength", path)
    offset = _count(spec.get("byteOffset", 0), f"{where}.byteOffset", path)
    stride = _count(stride, f"{where}: byteStride", path)
    needed = offset + (stride * (count - 1) + width * item if count else 0)
    if stride < width * item or needed > view_length:
        _fail(f"{where}: {count} elements do not fit in their bufferView", path)
    data = buffers[buffer_index]
    if view_offset + view_length > len(data):
        _fail(f"{where}: its bufferView runs past the end of buffer {buffer_index}", path)
    raw = np.frombuffer(data, dtype=np.uint8, count=needed, offset=view_offset)
    start = raw[offset:]
    values = np.lib.stride_tricks.as_strided(
        start[: max(needed - offset, 0)].view(np.uint8),
        shape=(count, width * item),
        strides=(stride, 1),
    )
    out = np.ascontiguousarray(values).view(np.dtype(dtype).newbyteorder("<")).reshape(count, width)
    out = out.astype(np.float64)
    if divisor is not None and spec.get("normalized"):
        out = np.maximum(out / divisor, -1.0)
    return out


# ----------------------------------------------------------------------------- the skeleton


def _tree(nodes: list, path) -> np.ndarray:
    """Each node's parent (-1 for a root); a node with two parents or a cycle is refused."""
    parent = np.full(len(nodes), -1, dtype=np.intp)
    for n, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            _fail(f"nodes[{n}].children is not a list", path)
        for child in children:
            c = _index(child, len(nodes), f"nodes[{n}].children", path)
            if c == n:
                _fail(f"node {n} lists itself as a child", path)
            if parent[c] >= 0:
                _fail(f"node {c} has two parents", path)
            parent[c] = n
    # Every node has one parent at most, so a node that no walk down from the roots
    # reaches is on a cycle.
    reached = np.zeros(len(nodes), dtype=bool)
    stack = np.flatnonzero(parent < 0).tolist()
    while stack:
        n = stack.pop()
        reached[n] = True
        stack.extend(nodes[n].get("children", []))
    if not reached.all():
        _fail("the node tree has a cycle", path)
    return parent


def _order(joints: set[int], nodes: list, parent: np.ndarray) -> tuple[list[int], list[int]]:
    """``joints`` in depth-first order of the node tree (children in the order their parent
    lists them) and each one's nearest joint ancestor (an index into that list, -1 for
    none)."""
    order: list[int] = []
    above: list[int] = []
    stack = [(int(n), -1) for n in reversed(np.flatnonzero(parent < 0))]
    while stack:
        n, joint_above = stack.pop()
        if n in joints:
            order.append(n)
            above.append(joint_above)
            joint_above = len(order) - 1
        stack.extend((int(c), joint_above) for c in reversed(nodes[n].get("children", [])))
    return order, above


#: What a node's or key's numbers must be besides finite (larger is no capture).
_IN_RANGE = f" of at most {MAX_MAGNITUDE:g} in size"


def _matrix(node: dict, n: int, path) -> np.ndarray:
    """A node's ``matrix`` as a ``(4, 4)`` array (glTF stores it column-major)."""
    if not _numbers(node["matrix"], 16):
        _fail(f"nodes[{n}].matrix is not 16 numbers{_IN_RANGE}", path)
    return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T


def _matrix_scale(m: np.ndarray) -> np.ndarray:
    """The scale factors ``(3,)`` of a 4x4 node matrix: the norms of its columns."""
    return np.linalg.norm(m[:3, :3], axis=0)


def _scale(node: dict, n: int, path) -> np.ndarray:
    """A node's scale factors ``(3,)`` (from its matrix's columns, or its ``scale``)."""
    if "matrix" in node:
        return _matrix_scale(_matrix(node, n, path))
    factors = node.get("scale", [1.0, 1.0, 1.0])
    if not _numbers(factors, 3):
        _fail(f"nodes[{n}].scale is not 3 numbers{_IN_RANGE}", path)
    return np.asarray(factors, dtype=np.float64)


def _rest(node: dict, n: int, path) -> tuple[np.ndarray, np.ndarray]:
    """A node's rest translation ``(3,)`` and rotation ``(4,)`` (w, x, y, z)."""
    if "matrix" in node:
        m = _matrix(node, n, path)
        scale = _matrix_scale(m)
        if np.any(scale <= 0.0):
            _fail(f"nodes[{n}].matrix has a zero scale", path)
        return m[:3, 3].copy(), matrix_to_quaternion(m[:3, :3] / scale)
    t = node.get("translation", [0.0, 0.0, 0.0])
    r = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    if not _numbers(t, 3) or not _numbers(r, 4):
        _fail(f"nodes[{n}]: translation or rotation is not 3 or 4 numbers{_IN_RANGE}", path)
    q = np.array([r[3], r[0], r[1], r[2]], dtype=np.float64)
    norm = np.linalg.norm(q)
    if not norm > 1e-6:
        _fail(f"nodes[{n}].rotation is not a rotation (norm {norm:.3g})", path)
    return np.array(t, dtype=np.float64), q / norm


def _numbers(value, n: int) -> bool:
    """Whether ``value`` is a list of ``n`` numbers, none beyond :data:`MAX_MAGNITUDE`."""
    return (
        isinstance(value, list)
        and len(value) == n
        and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and abs(v) <= MAX_MAGNITUDE
            for v in value
        )
    )


# ----------------------------------------------------------------------------- VRM animation


def _vrm_nodes(document: dict, size: int, path) -> tuple[set[int], dict[int, str]]:
    """A VRM animation's humanoid bone nodes, and its expression and look-at nodes with
    what each one is (``expression 'happy'``, ``lookAt``); both empty for a glTF without
    the :data:`VRM_ANIMATION` extension."""
    extensions = document.get("extensions")
    vrm = extensions.get(VRM_ANIMATION) if isinstance(extensions, dict) else None
    if not isinstance(vrm, dict):
        return set(), {}
    where = f"extensions.{VRM_ANIMATION}"
    humanoid = _object(vrm, "humanoid", where, path)
    bones = _mapped(humanoid, "humanBones", f"{where}.humanoid", size, path)
    expressions = _object(vrm, "expressions", where, path)
    carried = {
        n: f"expression {name[:40]!r}"
        for kind in ("preset", "custom")
        for name, n in _mapped(expressions, kind, f"{where}.expressions", size, path).items()
    }
    if "lookAt" in vrm:
        carried[_node_of(vrm["lookAt"], f"{where}.lookAt", size, path)] = "lookAt"
    return set(bones.values()), carried


def _object(parent: dict, key: str, where: str, path) -> dict:
    """``parent[key]``, an object (empty where it is absent)."""
    value = parent.get(key, {})
    if not isinstance(value, dict):
        _fail(f"{where}.{key} is not an object", path)
    return value


def _mapped(parent: dict, key: str, where: str, size: int, path) -> dict[str, int]:
    """The node of each name in the object ``parent[key]`` (``{"hips": {"node": 0}}``)."""
    named = _object(parent, key, where, path)
    return {
        name: _node_of(spec, f"{where}.{key}.{name}", size, path) for name, spec in named.items()
    }


def _node_of(spec, where: str, size: int, path) -> int:
    """The node index of ``{"node": i}``."""
    if not isinstance(spec, dict):
        _fail(f"{where} is not an object", path)
    return _index(spec.get("node"), size, f"{where}.node", path)


def _humanoid(bones: set[int], parent: np.ndarray) -> set[int]:
    """The humanoid bones' nodes and every node between two of them (whose rest transform
    is part of the skeleton's)."""
    joints = set(bones)
    for n in bones:
        between = []
        above = int(parent[n])
        while above >= 0 and above not in bones:
            between.append(above)
            above = int(parent[above])
        if above >= 0:
            joints.update(between)
    return joints


def _carried_note(carried: dict[int, str], animated: set[int]) -> list[str]:
    """The note naming the VRM expression and look-at nodes the animation moves: carried
    as they are, never joints (an expression's weight is no position to clean)."""
    moved = [what for n, what in carried.items() if n in animated]
    if not moved:
        return []
    more = " ..." if len(moved) > 4 else ""
    return [
        f"{len(moved)} VRM animation node{'s' if len(moved) > 1 else ''}, not joints, "
        f"kept as they are when written back to glTF: {', '.join(moved[:4])}{more}"
    ]


# ----------------------------------------------------------------------------- sampling


@dataclass(frozen=True)
class _Keys:
    times: np.ndarray  # (K,)
    values: np.ndarray  # (K, n), or (K, 3, n) for CUBICSPLINE (in-tangent, value, out-tangent)
    interpolation: str
    input: int


def _sampler(animation: dict, channel: dict, a: int, path) -> tuple[int, dict]:
    """The index and object of the sampler of ``channel`` in animation ``a``."""
    samplers = animation.get("samplers", [])
    s = _index(channel.get("sampler"), len(samplers), f"animations[{a}] channel sampler", path)
    sampler = samplers[s]
    if not isinstance(sampler, dict):
        _fail(f"animations[{a}].samplers[{s}] is not an object", path)
    return s, sampler


def _keys(document: dict, buffers: _Buffers, a: int, c: int, width: int, path) -> _Keys:
    """The keys of channel ``c`` of animation ``a`` (values ``width`` numbers each)."""
    animation = document["animations"][a]
    s, sampler = _sampler(animation, animation["channels"][c], a, path)
    interpolation = sampler.get("interpolation", "LINEAR")
    if interpolation not in ("LINEAR", "STEP", "CUBICSPLINE"):
        _fail(
            f"animations[{a}].samplers[{s}]: interpolation {str(interpolation)[:20]!r} is unknown",
            path,
        )
    times = _accessor(document, buffers, sampler.get("input"), path)
    values = _accessor(document, buffers, sampler.get("output"), path)
    if times.shape[1] != 1 or values.shape[1] != width:
        _fail(
            f"animations[{a}].samplers[{s}]: input must be scalars and output {width} values each",
            path,
        )
    times = times[:, 0]
    per_key = 3 if interpolation == "CUBICSPLINE" else 1
    if values.shape[0] != per_key * times.size or times.size == 0:
        _fail(
            f"animations[{a}].samplers[{s}]: {values.shape[0]} outputs for {times.size} keys "
            f"({interpolation}: expected {per_key * times.size})",
            path,
        )
    if not (np.isfinite(times).all() and within_magnitude(values)):
        _fail(
            f"animations[{a}].samplers[{s}]: a key time or value is not a finite number{_IN_RANGE}",
            path,
        )
    if np.any(np.diff(times) <= 0.0):
        _fail(f"animations[{a}].samplers[{s}]: key times do not increase", path)
    if per_key == 3:
        values = values.reshape(times.size, 3, width)
    return _Keys(times, values, interpolation, sampler["input"])


def _grid(keys: list[_Keys], n_joints: int, path) -> tuple[float, float, int]:
    """Start time, frame time and frame count of the grid all channels of a skeleton of
    ``n_joints`` are sampled on (refused past :data:`MAX_SAMPLES_PER_KEY`)."""
    timed = [k.times for k in keys if k.times.size >= 2]
    start = min(float(k.times[0]) for k in keys)
    end = max(float(k.times[-1]) for k in keys)
    if not timed:
        return start, 1.0 / 30.0, 1
    dt = _frame_time(min(timed, key=_step), start)
    if not MIN_FRAME_TIME <= dt <= MAX_FRAME_TIME:  # as every reader refuses such a rate
        _fail(
            f"keys {dt:.6g} s apart: no usable frame rate ({RATES_ACCEPTED})",
            path,
        )
    frames = int(round((end - start) / dt)) + 1
    total_keys = sum(k.times.size for k in keys)
    if frames * n_joints > MAX_SAMPLES_PER_KEY * total_keys:
        _fail(
            f"keys {end - start:.6g} s apart at {dt:.6g} s per frame: {frames} frames of "
            f"{n_joints} joints for {total_keys} keys (at most {MAX_SAMPLES_PER_KEY} joint "
            "samples per key); refused",
            path,
        )
    return start, dt, frames


def _frame_time(times: np.ndarray, start: float) -> float:
    """The frame time of the finest channel's key ``times`` (the grid starting at
    ``start``): a whole rate's within :data:`SNAP` while the keys stay on its grid, else
    the step the float32 times measure, made exact (:func:`_exact`)."""
    dt = _step(times)
    rate = round(1.0 / dt)
    if rate > 0 and abs(1.0 / dt - rate) <= SNAP / dt:
        whole = 1.0 / rate
        grid = start + whole * np.round((times - start) / whole)
        if _on_grid(times, grid, whole):
            return whole
    return _exact(dt, FLOAT32_TIME * float(np.abs(times).max()) / (times.size - 1))


def _exact(dt: float, error: float) -> float:
    """The frame time that key times measure as ``dt``, give or take their float32 rounding
    ``error``: a whole or NTSC rate's (n * 1000/1001: 30000/1001 is 29.97 fps) exactly where
    one lies within it, else the shortest decimal that does (``0.0083333``, not
    ``0.00833330026837097``)."""
    whole, ntsc = round(1.0 / dt), round(1001.0 / (1000.0 * dt))
    for exact in (1.0 / max(whole, 1), 1001.0 / (1000 * max(ntsc, 1))):
        if abs(exact - dt) <= error:
            return exact
    decimals = (float(f"{dt:.{digits}g}") for digits in range(1, 18))
    return next(value for value in decimals if abs(value - dt) <= error)


def _on_grid(times: np.ndarray, grid: np.ndarray, frame_time: float) -> bool:
    """True when float32 key ``times`` are the ``grid`` times (see :data:`ON_GRID`)."""
    allowed = ON_GRID * frame_time + FLOAT32_TIME * np.abs(grid)
    return bool(np.all(np.abs(times - grid) <= allowed))


def _step(times: np.ndarray) -> float:
    """A channel's key step: its span over its steps when they are uniform (within 10 %),
    accurate however long the clip (float32 times); else the median step."""
    steps = np.diff(times)
    mean = float(times[-1] - times[0]) / steps.size
    return mean if np.all(np.abs(steps - mean) <= 0.1 * mean) else float(np.median(steps))


def _sample(keys: _Keys, times: np.ndarray, rotation: bool) -> np.ndarray:
    """Values of a channel at ``times`` (see the module)."""
    t = keys.times
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, max(t.size - 2, 0))
    if t.size == 1:
        value = keys.values[:, 1] if keys.interpolation == "CUBICSPLINE" else keys.values
        return np.repeat(value, times.size, axis=0)
    span = t[k + 1] - t[k]
    u = np.clip((times - t[k]) / span, 0.0, 1.0)[:, None]
    if keys.interpolation == "STEP":
        return keys.values[np.where(times >= t[k + 1], k + 1, k)]
    if keys.interpolation == "LINEAR":
        a, b = keys.values[k], keys.values[k + 1]
        if rotation:
            return quat.slerp(a, b, u[:, 0])
        return a + (b - a) * u
    v, tangent_in, tangent_out = keys.values[:, 1], keys.values[:, 0], keys.values[:, 2]
    u2, u3 = u * u, u * u * u
    d = span[:, None]
    out = (
        (2 * u3 - 3 * u2 + 1) * v[k]
        + (u3 - 2 * u2 + u) * d * tangent_out[k]
        + (-2 * u3 + 3 * u2) * v[k + 1]
        + (u3 - u2) * d * tangent_in[k + 1]
    )
    return quat.normalize(out) if rotation else out


def _as_wxyz(values: np.ndarray) -> np.ndarray:
    """glTF ``(x, y, z, w)`` along the last axis as ``(w, x, y, z)``."""
    return values[..., [3, 0, 1, 2]]


# ----------------------------------------------------------------------------- reading


def _animation_names(animations: list[dict]) -> list[str]:
    """Each animation's name, or its index where it has none."""
    return [str(a.get("name") or i) for i, a in enumerate(animations)]


def _listed(animations: list[dict]) -> str:
    """The animations by name (``number 3 (unnamed)`` for one without), the first 40."""
    names = _animation_names(animations)
    return ", ".join(
        repr(n[:40]) if animations[i].get("name") else f"number {i} (unnamed)"
        for i, n in enumerate(names[:40])
    ) + (", ..." if len(names) > 40 else "")


def _chosen_animation(animations: list[dict], wanted: str | None, path) -> tuple[int, str | None]:
    """The index of the animation to read (``wanted``: its name, or its index as digits;
    None: the first; -1 when the file has none) and the note that says which of several."""
    names = _animation_names(animations)
    listed = _listed(animations)
    if wanted is None:
        if len(animations) > 1:
            return 0, (
                f"{len(animations)} animations: the first ({names[0][:40]!r}) is read "
                f"(--animation NAME reads another: {listed})"
            )
        return (0 if animations else -1), None
    if wanted in names:
        a = names.index(wanted)
    elif wanted.isdigit() and int(wanted) < len(animations):
        a = int(wanted)
    else:
        held = f"{plural(len(animations), 'animation')}: {listed}" if animations else "none"
        _fail(f"no animation {wanted[:40]!r}: the file has {held}", path)
    return a, (
        f"animation {names[a][:40]!r} of {len(animations)} is read" if len(names) > 1 else None
    )


#: Key times within this fraction of a key step of each other are the same frames: float32
#: times of one grid (a channel keyed off the exact grid by more than :data:`ON_GRID`, as
#: BrainStem's by 0.16 %, is written back on it and still plays with the others).
SAME_TIMES = 0.01


def _read_animations(
    document: dict,
    buffers: _Buffers,
    wanted: str | None,
    skeleton: set[int] | None,
    path,
) -> tuple[tuple[int, ...], str | None]:
    """The animations to read (indices, none for a file without) and the note that says
    which: the one ``wanted`` names, else the first; or, where each of several keys other
    joints of ``skeleton`` (the first skin's or the VRM humanoid's; None without) on one
    time base (COLLADA2GLTF writes an animation per joint), all of them as one motion, as
    viewers play them. A note says when such animations key different times."""
    animations = document.get("animations", [])
    a, note = _chosen_animation(animations, wanted, path)
    keyed = [_nodes_keyed(animation) for animation in animations]
    if wanted is not None or len(animations) < 2 or not _apart(keyed, skeleton):
        return ((a,) if a >= 0 else ()), note
    every = tuple(range(len(animations)))
    if _one_time_base(document, buffers, every, path):
        return every, (
            f"{len(animations)} animations, each keying other joints over the same key times, "
            f"are read as one motion, as viewers play them (--animation NAME reads one "
            f"alone: {_listed(animations)})"
        )
    first = _animation_names(animations)[0][:40]
    return (a,), (
        f"{len(animations)} animations each key other joints, on different key times: the "
        f"first ({first!r}) is read, its {plural(len(keyed[0] or ()), 'joint')} moving and "
        f"the others at rest (--animation NAME reads another: {_listed(animations)})"
    )


def _nodes_keyed(animation: dict) -> set[int] | None:
    """The nodes ``animation``'s channels target, or None where a channel is no object
    with a target node (the animation's reading says what is wrong, if it is read)."""
    channels = animation.get("channels")
    if not isinstance(channels, list):
        return None
    targets = [c.get("target") if isinstance(c, dict) else None for c in channels]
    nodes = [t.get("node") if isinstance(t, dict) else None for t in targets]
    ints = [n for n in nodes if isinstance(n, int)]
    return set(ints) if len(ints) == len(nodes) else None


def _apart(keyed: list[set[int] | None], skeleton: set[int] | None) -> bool:
    """Whether every animation's nodes (``keyed``) are joints of ``skeleton`` and none is
    another's."""
    sets = [nodes for nodes in keyed if nodes]
    if skeleton is None or len(sets) < len(keyed) or not all(n <= skeleton for n in sets):
        return False
    return sum(len(nodes) for nodes in sets) == len(set().union(*sets))


def _one_time_base(document: dict, buffers: _Buffers, read: tuple[int, ...], path) -> bool:
    """Whether the channels of animations ``read`` key one time base: those of the channel
    with the most keys, each channel's keys among them (within :data:`SAME_TIMES` of a key
    step) from its first to its last (Blender keys a still channel at both ends only)."""
    animations = document["animations"]
    size = len(_items(document, "accessors", path))
    inputs: set[int] = set()
    for a in read:
        for channel in animations[a]["channels"]:
            s, sampler = _sampler(animations[a], channel, a, path)
            what = f"animations[{a}].samplers[{s}].input"
            inputs.add(_index(sampler.get("input"), size, what, path))
    times = [_accessor(document, buffers, index, path)[:, 0] for index in sorted(inputs)]
    base = max(times, key=len)
    tolerance = SAME_TIMES * _step(base) if base.size >= 2 else 0.0
    return all(_among(t, base, tolerance) for t in times)


def _among(times: np.ndarray, base: np.ndarray, tolerance: float) -> bool:
    """Whether key ``times`` (seconds) start and end at ``base``'s first and last, and each
    is one of the increasing ``base`` times, within ``tolerance``."""
    if times.size == 0:
        return False
    after = np.clip(np.searchsorted(base, times), 0, base.size - 1)
    before = np.maximum(after - 1, 0)
    off = np.minimum(np.abs(times - base[before]), np.abs(times - base[after]))
    ends = np.abs(times[[0, -1]] - base[[0, -1]])
    return bool(np.all(off <= tolerance) and np.all(ends <= tolerance))


def _skin_joints(skins: list, size: int, path) -> set[int] | None:
    """The nodes of the first skin's joints (None for a file without skins)."""
    if not skins:
        return None
    listed = skins[0].get("joints")
    if not isinstance(listed, list) or not listed:
        _fail("skins[0].joints is not a list of nodes", path)
    return {_index(j, size, "skins[0].joints", path) for j in listed}


@dataclass
class _Targets:
    """What the channels of the animations read animate, each channel as (animation,
    channel): rotations and translations by (node, path), scales by node; the first
    channel of each (node, path), and the channels whose path is unknown or taken by an
    earlier one as (animation, channel, node, path)."""

    moves: dict[tuple[int, str], tuple[int, int]] = field(default_factory=dict)
    scales: dict[int, tuple[int, int]] = field(default_factory=dict)
    seen: dict[tuple[int, str], tuple[int, int]] = field(default_factory=dict)
    wrong: list[tuple[int, int, int, Any]] = field(default_factory=list)


def _targets(animations: list[dict], read: tuple[int, ...], size: int, path) -> _Targets:
    """The targets of the channels of animations ``read`` (of ``size`` nodes)."""
    found = _Targets()
    for a in read:
        channels = animations[a].get("channels", [])
        if not isinstance(channels, list) or not all(isinstance(c, dict) for c in channels):
            _fail(f"animations[{a}].channels is not a list of objects", path)
        for c, channel in enumerate(channels):
            target = channel.get("target")
            if not isinstance(target, dict):
                _fail(f"animations[{a}].channels[{c}] has no target", path)
            if "node" not in target:
                continue
            n = _index(target["node"], size, f"animations[{a}].channels[{c}].target.node", path)
            kind = target.get("path")
            if kind not in TARGET_PATHS or (n, kind) in found.seen:
                found.wrong.append((a, c, n, kind))  # (judged once the joints are known)
            found.seen.setdefault((n, kind) if isinstance(kind, str) else (n, ""), (a, c))
            if kind in ("rotation", "translation"):
                found.moves[(n, kind)] = (a, c)
            elif kind == "scale":
                found.scales[n] = (a, c)
    return found


def parse_gltf(data: bytes, path, animation: str | None = None) -> Motion:
    """A clip of a ``.gltf`` or ``.glb`` file's bytes (see the module): the animation named
    ``animation`` (or of that index, as digits; default the first, or all of them where
    each keys other joints on one time base)."""
    glb = data[:4] == GLB_MAGIC or str(path).lower().endswith(GLB_SUFFIXES)
    document, binary = _chunks(data, path) if glb else (_json(data, path), None)
    buffers = _Buffers(document, binary, path)
    nodes = _items(document, "nodes", path)
    parent = _tree(nodes, path)
    animations = _items(document, "animations", path)
    bones, carried = _vrm_nodes(document, len(nodes), path)
    skins = _items(document, "skins", path)
    skeleton = _humanoid(bones, parent) if bones else _skin_joints(skins, len(nodes), path)
    read, note = _read_animations(document, buffers, animation, skeleton, path)
    notes: list[str] = [note] if note else []
    aimed = _targets(animations, read, len(nodes), path)
    if skeleton is None:
        joints = {n for n, _ in aimed.moves}
    else:
        joints = set(skeleton)
        if not bones and len(skins) > 1:
            notes.append(f"{len(skins)} skins: the joints of the first are read")
    joints -= carried.keys()
    _refuse_wrong_channels(aimed, joints, path)
    notes.extend(_carried_note(carried, {n for n, _ in aimed.moves}))
    notes.extend(_image_notes(document, path))
    if not joints:
        _fail("no skin and no animated node: no skeleton to read", path)
    order, parents = _order(joints, nodes, parent)
    up, note = _scene_up(order[0], nodes, parent, path)
    notes.extend([note] if note else [])
    rest = [_rest(nodes[n], n, path) for n in order]
    keys: dict[tuple[int, str], _Keys] = {}
    for (n, kind), (a, c) in aimed.moves.items():
        if n in joints:
            keys[(n, kind)] = _keys(document, buffers, a, c, 4 if kind == "rotation" else 3, path)
    if keys:
        start, frame_time, n_frames = _grid(list(keys.values()), len(order), path)
    else:
        start, frame_time, n_frames = 0.0, 1.0 / 30.0, 1
        notes.append("no animation: the rest pose as one frame at 30 fps")
    grid = start + frame_time * np.arange(n_frames)
    n_joints = len(order)
    rotations = np.empty((n_frames, n_joints, 4))
    translations = joint_major_zeros(n_frames, n_joints)
    offsets = np.array([t for t, _ in rest]).reshape(n_joints, 3)
    size = float(np.abs(offsets).max(initial=0.0))  # (the rig's scale: its longest offset)
    rotation_tracks: list[Track] = []
    translation_tracks: list[Track] = []
    channels_out: list[tuple[str, ...]] = []
    for j, n in enumerate(order):
        tracks = []
        for kind in ("rotation", "translation"):
            found = keys.get((n, kind))
            if found is None:
                tracks.append(Track())
                continue
            exact = found.interpolation != "CUBICSPLINE" and found.times.size == n_frames
            exact = exact and _on_grid(found.times, grid, frame_time)
            values = found.values if exact else _sample(found, grid, kind == "rotation")
            a, c = aimed.moves[(n, kind)]
            tracks.append(Track(c, exact, found.input, a))
            if kind == "rotation":
                q = _as_wxyz(values)
                norm = np.linalg.norm(q, axis=-1)
                if not np.all(norm > 1e-6):
                    _fail(f"node {n} ({_name(nodes[n], n)}): a rotation key of zero length", path)
                rotations[:, j] = q / norm[:, None]
            else:
                translations[:, j] = values
        rotation_tracks.append(tracks[0])
        translation_tracks.append(tracks[1])
        if tracks[0].channel < 0:
            rotations[:, j] = rest[j][1]
        # a root keyed in place keeps its position channels (a SMPL clip's fixed trans is
        # its placement); another joint's still track is its offset
        moving = tracks[1].channel >= 0 and (parents[j] < 0 or _moves(translations[:, j], size))
        if tracks[1].channel >= 0 and not moving:
            offsets[j] = translations[0, j]
            translations[:, j] = 0.0
        channels_out.append(POSITION_CHANNELS + ROTATION if moving else ROTATION)
    rotations = quat.continuous(rotations)
    armature = _armature(order, parent)
    scales = [_scale(nodes[n], n, path) for n in armature] + [
        _key_values(_keys(document, buffers, a, c, 3, path))
        for n, (a, c) in aimed.scales.items()
        if n in armature
    ]
    source = GltfSource(
        data,
        document,
        binary,
        glb,
        tuple(order),
        read[0] if read else -1,
        tuple(rotation_tracks),
        tuple(translation_tracks),
        start,
        frame_time,
        n_frames,
        buffers,
        np.array(translations),
        tuple(notes),
        _length_unit(document, scales),
        np.array([q for _, q in rest]).reshape(n_joints, 4),
    )
    return Motion(
        names=_unique([_name(nodes[n], n) for n in order]),
        parents=np.array(parents, dtype=np.intp),
        offsets=offsets,
        channels=channels_out,
        frame_time=frame_time,
        rotations=rotations,
        translations=translations,
        source_rotations=rotations.copy(),
        source=source,
        path=None if path is None else str(path),
        end_sites=_end_sites(order, nodes, joints, set(carried), path),
        up=up,
    )


def _scene_up(root: int, nodes: list, parent: np.ndarray, path) -> tuple[str | None, str | None]:
    """The up axis of the skeleton's own coordinates, from the nodes above its first root
    joint (the scene's up is +Y in glTF, 3.4): ``"y"`` where they do not turn it, the axis
    they turn +Y onto (``"z"``, ``"-y"`` ...), None where that is no axis; and a note where
    they turn or scale the skeleton (as an exporter's armature node does: FBX2glTF's
    scale 100 and quarter turn), whose transform positions and heights leave out."""
    turn = quat.identity()
    scale = 1.0
    hanger = None  # the lowest node that turns or scales
    n = int(parent[root])
    while n >= 0:
        node = nodes[n]
        _, rotation = _rest(node, n, path)
        turn = quat.multiply(rotation, turn)
        factors = _scale(node, n, path)
        scale *= float(np.prod(np.abs(factors))) ** (1.0 / 3.0)
        if hanger is None and not (
            np.allclose(rotation, quat.identity()) and np.allclose(factors, 1.0)
        ):
            hanger = _name(node, n)
        n = int(parent[n])
    local_up = quat.rotate(quat.conjugate(turn), np.array([0.0, 1.0, 0.0]))
    axis = int(np.argmax(np.abs(local_up)))
    up = axis_name(axis, local_up[axis]) if abs(local_up[axis]) >= 0.9 else None
    if hanger is None or (up == "y" and math.isclose(scale, 1.0, rel_tol=1e-6)):
        return up, None
    return up, (
        f"the skeleton hangs under node {hanger[:40]!r} (scale {scale:.4g}, its up the "
        f"skeleton's {up or 'no axis'}): positions and heights are in the skeleton's own "
        "units and axes"
    )


#: The ``asset.generator`` of the glTF files :func:`fresh_gltf` writes.
GENERATOR = "motionclean"


def _refuse_wrong_channels(aimed: _Targets, joints: set[int], path) -> None:
    """Refuse the first channel on a joint's node whose target path is not glTF's (a
    misspelt one had been dropped, the joint read at rest) or that animates what an
    earlier channel does (glTF 2.0 5.11; the last had silently won); such channels on other
    nodes (a mesh's, a camera's) are none of the clip's."""
    for a, c, n, kind in aimed.wrong:
        if n not in joints:
            continue
        if kind not in TARGET_PATHS:
            _fail(
                f"animations[{a}].channels[{c}].target.path is {str(kind)[:40]!r}, not one of "
                f"{', '.join(TARGET_PATHS)}",
                path,
            )
        _, earlier = aimed.seen[(n, kind)]  # (in the same animation: merged ones are apart)
        _fail(
            f"animations[{a}].channels[{earlier}] and [{c}] both animate node {n}'s "
            f"{kind} (glTF allows one channel per node and path)",
            path,
        )


#: The properties a glTF animation channel may target (glTF 2.0 5.12.2; "pointer" of
#: KHR_animation_pointer).
TARGET_PATHS = ("translation", "rotation", "scale", "weights", "pointer")
#: Scale factors within this of 1 leave lengths metres (0.1 %: a Blender export's bones
#: keyed at 0.99994-1.00006, its float32 rounding; a scaled armature's are 0.01, 0.0254 ...).
UNSCALED = 1e-3


def _length_unit(document: dict, scales: list[np.ndarray]) -> str | None:
    """``"m"``, glTF's unit of length (glTF 2.0 3.4), where the armature's ``scales`` (its
    nodes' scale factors and the values keyed for them) are all 1: the lengths read are
    then the scene's; else None (the skeleton's own units, as scale is not read). None too
    for a file :func:`fresh_gltf` wrote, which keeps the lengths of the clip it was made
    from (a BVH's centimetres)."""
    asset = document.get("asset")
    if isinstance(asset, dict) and asset.get("generator") == GENERATOR:
        return None
    return (
        "m"
        if all(np.allclose(factors, 1.0, rtol=0.0, atol=UNSCALED) for factors in scales)
        else None
    )


#: A translation track whose keys spread by no more than this share of the rig's size
#: (its longest offset) is still: float32 rounding (Blender 5.0.1 keys every bone's
#: translation at both ends, up to 4.3e-6 apart on a rig whose longest offset is 7.6).
STILL_SPREAD = 64 * float(np.finfo(np.float32).eps)


def _moves(track: np.ndarray, size: float) -> bool:
    """Whether a translation ``track`` ``(F, 3)`` moves beyond float32 rounding of the
    rig's ``size`` or its own values."""
    scale = max(size, float(np.abs(track).max()), float(np.finfo(np.float32).tiny))
    return float(np.ptp(track, axis=0).max()) > STILL_SPREAD * scale


def _armature(order: list[int], parent: np.ndarray) -> set[int]:
    """The joints' nodes ``order`` and every node above them."""
    armature: set[int] = set()
    for n in order:
        while n >= 0 and n not in armature:
            armature.add(n)
            n = int(parent[n])
    return armature


def _key_values(keys: _Keys) -> np.ndarray:
    """The values keyed (a cubic spline's without its tangents)."""
    return keys.values[:, 1] if keys.values.ndim == 3 else keys.values


def _end_sites(
    order: list[int], nodes: list, joints: set[int], carried: set[int], path
) -> dict[int, np.ndarray]:
    """Per joint (index into ``order``) with no joint among its children, the translation of
    its first child that is a bare leaf node (no children, mesh or camera, and not a
    ``carried`` node, a VRM expression or look-at target): a bone's tip."""
    sites = {}
    for j, n in enumerate(order):
        children = nodes[n].get("children", [])
        if any(c in joints for c in children):
            continue
        for c in children:
            if c in carried:
                continue
            node = nodes[c]
            if not (node.get("children") or "mesh" in node or "camera" in node or "matrix" in node):
                sites[j] = _rest(node, c, path)[0]
                break
    return sites


def _name(node: dict, n: int) -> str:
    name = node.get("name")
    return name if isinstance(name, str) and name.strip() else f"node{n}"


def _unique(names: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for name in names:
        seen[name] = seen.get(name, 0) + 1
        out.append(name if seen[name] == 1 else f"{name}.{seen[name] - 1}")
    return out


# ----------------------------------------------------------------------------- writing


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
    from, whose :data:`VRM_ANIMATION` extension maps its nodes to humanoid bones (a new
    GLB, or another file's, has no such map: no VRM tool would load it)."""
    src = _own_document(motion)
    extensions = src.document.get("extensions") if src is not None else None
    if not (isinstance(extensions, dict) and VRM_ANIMATION in extensions):
        _fail(
            f"a .vrma is a VRM animation ({VRM_ANIMATION}: nodes mapped to humanoid bones); "
            "this clip is not read from one: write .glb",
            motion.path,
        )
    return gltf_pieces(motion, target, glb=True)


def gltf_pieces(motion: Motion, target: Path, glb: bool) -> Iterable[bytes]:
    """``motion`` written into the glTF it was read from (see the module), as a GLB or a
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
                old = _as_wxyz(
                    _accessor(src.document, src.buffers, _output(src, track), motion.path)
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
        document.setdefault("buffers", []).append({"byteLength": len(new), "uri": _data_uri(new)})
    for index in _file_buffers(src.document):  # embedded: the file can go to any folder
        document["buffers"][index]["uri"] = _data_uri(src.buffers[index])
    images = {} if beside else _carried_images(src)
    if not glb:  # one self-contained file: the binary chunk embedded too
        if glb_binary or (src.glb and binary is not None and _first_buffer_is_binary(document)):
            assert binary is not None
            document["buffers"][0]["uri"] = _data_uri(binary)
        for index, (data, media) in images.items():
            document["images"][index]["uri"] = _data_uri(data, media)
        return [json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")]
    binary = binary if src.glb else None
    if images:
        binary = _chunk_images(document, _binary_chunk(document, src, binary, new), images)
    text = json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    return [_glb(text, binary)]


def _file_buffers(document: dict) -> list[int]:
    """The indices of the buffers whose URI names a file (relative to the glTF's folder)."""
    buffers = document.get("buffers", [])
    return [
        index
        for index, buffer in enumerate(buffers)
        if isinstance(buffer.get("uri"), str) and not buffer["uri"].startswith("data:")
    ]


def _relative_file(uri: object) -> bool:
    """Whether ``uri`` names a file by a path relative to the glTF's folder (not a data URI,
    a URL with a scheme or host, or an absolute path: those read the same from anywhere)."""
    if not isinstance(uri, str):
        return False
    parts = _split(uri)
    if parts is None:  # no valid URI: no file (a buffer's is refused when it is read)
        return False
    return not (parts.scheme or parts.netloc or os.path.isabs(unquote(parts.path)))


def _images(document: dict, path) -> list:
    """The ``images`` of ``document`` (``null`` read as none, as its absence)."""
    return [] if document.get("images") is None else _items(document, "images", path)


def _names_files(src: GltfSource) -> bool:
    """Whether ``src`` names files beside it: buffers or images by a relative URI."""
    images = _images(src.document, src.buffers.path)
    return bool(_file_buffers(src.document)) or any(
        _relative_file(image.get("uri")) for image in images
    )


def _beside_source(src: GltfSource, target: Path) -> bool:
    """Whether ``target`` (by its name and, through a symbolic link, where it lands) is in
    the folder ``src`` was read from, where the relative URIs it names find their files."""
    folder = os.path.realpath(Path(src.buffers.path).parent)
    return os.path.realpath(target.parent) == folder == os.path.dirname(os.path.realpath(target))


#: Media types of images by file suffix, for an image whose ``mimeType`` is not given: PNG
#: and JPEG (glTF 2.0 core), KTX2 (``KHR_texture_basisu``), WebP (``EXT_texture_webp``).
IMAGE_TYPES = {
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".ktx2": "image/ktx2",
    ".webp": "image/webp",
}


def _image_files(document: dict, path) -> tuple[dict[int, tuple[Path, str]], list[str]]:
    """The images of the glTF at ``path`` (its ``document``) named by a relative URI that a
    glTF written to another folder carries, by image index: the file (:func:`_beside`,
    whose refusals are raised) and its media type (``mimeType``, else by suffix); and a
    note for each other such image, which keeps its URI there: no file beside the glTF
    (uncopied textures), not a file, or neither a mimeType nor a known suffix (``.tga``)."""
    found, kept = {}, []
    for index, image in enumerate(_images(document, path)):
        uri = image.get("uri")
        if not _relative_file(uri):
            continue
        where = _beside(path, f"images[{index}]", uri)
        suffix = Path(unquote(uri.partition("?")[0].partition("#")[0])).suffix.lower()
        media = image.get("mimeType") or IMAGE_TYPES.get(suffix)
        why = _not_a_file(where)
        if why is None and isinstance(media, str):
            found[index] = where, media
            continue
        why = why or "no mimeType, and no image type by its suffix"
        kept.append(
            f"images[{index}] {uri[:60]!r}: {why}; a glTF written to another folder "
            "keeps this uri, not the image"
        )
    return found, kept


def _not_a_file(where: Path) -> str | None:
    """Why ``where`` is not a regular file to read ("no such file beside the glTF"), or
    None when it is one."""
    try:
        regular = stat.S_ISREG(os.stat(where).st_mode)
    except FileNotFoundError:
        return "no such file beside the glTF"
    except OSError as error:  # (a name too long, a loop of links)
        return f"cannot be read ({error.strerror or error})"
    return None if regular else "not a file (a folder, pipe or device)"


def _image_notes(document: dict, path) -> list[str]:
    """What :func:`_image_files` notes, said when the glTF is read; or that a glTF written
    from it into another folder is refused, and why (an image leading out of its folder)."""
    try:
        return _image_files(document, path)[1]
    except MotionError as error:
        return [f"{error.message}; writing it as glTF to another folder is refused"]


def _carried_images(src: GltfSource) -> dict[int, tuple[bytes, str]]:
    """The bytes and media type of each image of ``src`` a glTF in another folder carries
    (:func:`_image_files`), by image index."""
    path = src.buffers.path
    found, _ = _image_files(src.document, path)
    return {
        index: (_read_file(path, f"images[{index}]", where, "an image"), media)
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


def _data_uri(data: bytes, media: str = "application/octet-stream") -> str:
    return f"data:{media};base64," + base64.b64encode(data).decode("ascii")


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


def _glb(text: bytes, binary: bytes | None) -> bytes:
    text += b" " * (-len(text) % 4)
    chunks = [struct.pack("<II", len(text), JSON_CHUNK), text]
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        chunks += [struct.pack("<II", len(binary), BIN_CHUNK), binary]
    body = b"".join(chunks)
    return struct.pack("<4sII", GLB_MAGIC, 2, 12 + len(body)) + body


# ----------------------------------------------------------------------------- a new file


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
        _fail(f"glTF needs joint positions: {note}", motion.path)
    if getattr(motion.source, "needs_skeleton", False):
        _fail(
            "glTF needs joint positions: this clip has no skeleton (a channel CSV read "
            "without one; give --skeleton TEMPLATE.bvh)",
            motion.path,
        )
    if motion.n_frames == 0:
        _fail("glTF needs at least one frame: this clip has none", motion.path)
    if motion.missing is not None:
        frames = np.flatnonzero(motion.missing.any(axis=1))
        _fail(
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
        document["buffers"][0]["uri"] = _data_uri(data)
        return json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    text = json.dumps(document, ensure_ascii=False, separators=(",", ":")).encode("utf-8")
    return _glb(text, data)
