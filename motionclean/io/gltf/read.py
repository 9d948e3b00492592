"""Reading a glTF file into a :class:`~motionclean.core.motion.Motion` (the package's
docstring: which joints, which channels, which unit)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...core import quat
from ...core.kinematics import axis_name
from ...core.motion import (
    POSITION_CHANNELS,
    Motion,
    joint_major_zeros,
)
from ...core.words import plural
from .container import (
    GLB_MAGIC,
    GLB_SUFFIXES,
    Buffers,
    fail,
    image_notes,
    index_of,
    items_of,
    parse_json,
    read_accessor,
    read_chunks,
)
from .sampling import (
    Keys,
    as_wxyz,
    channel_sampler,
    key_grid,
    key_step,
    on_grid,
    read_keys,
    sample_keys,
)
from .skeleton import (
    carried_note,
    humanoid_joints,
    joint_order,
    node_parents,
    node_rest,
    node_scale,
    vrm_nodes,
)

#: Rotation channels a joint gets (its Euler order when written as BVH or CSV).
ROTATION = ("Zrotation", "Xrotation", "Yrotation")


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
    """A glTF file as read, for the writer (the package's docstring)."""

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
        fail(f"no animation {wanted[:40]!r}: the file has {held}", path)
    return a, (
        f"animation {names[a][:40]!r} of {len(animations)} is read" if len(names) > 1 else None
    )


#: Key times within this fraction of a key step of each other are the same frames: float32
#: times of one grid (a channel keyed off the exact grid by more than :data:`.sampling.ON_GRID`, as
#: BrainStem's by 0.16 %, is written back on it and still plays with the others).
SAME_TIMES = 0.01


def _read_animations(
    document: dict,
    buffers: Buffers,
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


def _one_time_base(document: dict, buffers: Buffers, read: tuple[int, ...], path) -> bool:
    """Whether the channels of animations ``read`` key one time base: those of the channel
    with the most keys, each channel's keys among them (within :data:`SAME_TIMES` of a key
    step) from its first to its last (Blender keys a still channel at both ends only)."""
    animations = document["animations"]
    size = len(items_of(document, "accessors", path))
    inputs: set[int] = set()
    for a in read:
        for channel in animations[a]["channels"]:
            s, sampler = channel_sampler(animations[a], channel, a, path)
            what = f"animations[{a}].samplers[{s}].input"
            inputs.add(index_of(sampler.get("input"), size, what, path))
    times = [read_accessor(document, buffers, index, path)[:, 0] for index in sorted(inputs)]
    base = max(times, key=len)
    tolerance = SAME_TIMES * key_step(base) if base.size >= 2 else 0.0
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
        fail("skins[0].joints is not a list of nodes", path)
    return {index_of(j, size, "skins[0].joints", path) for j in listed}


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
            fail(f"animations[{a}].channels is not a list of objects", path)
        for c, channel in enumerate(channels):
            target = channel.get("target")
            if not isinstance(target, dict):
                fail(f"animations[{a}].channels[{c}] has no target", path)
            if "node" not in target:
                continue
            n = index_of(target["node"], size, f"animations[{a}].channels[{c}].target.node", path)
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
    """A clip of a ``.gltf`` or ``.glb`` file's bytes (the package's docstring): the animation named
    ``animation`` (or of that index, as digits; default the first, or all of them where
    each keys other joints on one time base)."""
    glb = data[:4] == GLB_MAGIC or str(path).lower().endswith(GLB_SUFFIXES)
    document, binary = read_chunks(data, path) if glb else (parse_json(data, path), None)
    buffers = Buffers(document, binary, path)
    nodes = items_of(document, "nodes", path)
    parent = node_parents(nodes, path)
    animations = items_of(document, "animations", path)
    bones, carried = vrm_nodes(document, len(nodes), path)
    skins = items_of(document, "skins", path)
    skeleton = humanoid_joints(bones, parent) if bones else _skin_joints(skins, len(nodes), path)
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
    notes.extend(carried_note(carried, {n for n, _ in aimed.moves}))
    notes.extend(image_notes(document, path))
    if not joints:
        fail("no skin and no animated node: no skeleton to read", path)
    order, parents = joint_order(joints, nodes, parent)
    up, note = _scene_up(order[0], nodes, parent, path)
    notes.extend([note] if note else [])
    rest = [node_rest(nodes[n], n, path) for n in order]
    keys: dict[tuple[int, str], Keys] = {}
    for (n, kind), (a, c) in aimed.moves.items():
        if n in joints:
            keys[(n, kind)] = read_keys(
                document, buffers, a, c, 4 if kind == "rotation" else 3, path
            )
    if keys:
        start, frame_time, n_frames = key_grid(list(keys.values()), len(order), path)
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
            exact = exact and on_grid(found.times, grid, frame_time)
            values = found.values if exact else sample_keys(found, grid, kind == "rotation")
            a, c = aimed.moves[(n, kind)]
            tracks.append(Track(c, exact, found.input, a))
            if kind == "rotation":
                q = as_wxyz(values)
                norm = np.linalg.norm(q, axis=-1)
                if not np.all(norm > 1e-6):
                    fail(f"node {n} ({_name(nodes[n], n)}): a rotation key of zero length", path)
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
    scales = [node_scale(nodes[n], n, path) for n in armature] + [
        _key_values(read_keys(document, buffers, a, c, 3, path))
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
        _, rotation = node_rest(node, n, path)
        turn = quat.multiply(rotation, turn)
        factors = node_scale(node, n, path)
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


#: The ``asset.generator`` of the glTF files :func:`.write.fresh_gltf` writes.
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
            fail(
                f"animations[{a}].channels[{c}].target.path is {str(kind)[:40]!r}, not one of "
                f"{', '.join(TARGET_PATHS)}",
                path,
            )
        _, earlier = aimed.seen[(n, kind)]  # (in the same animation: merged ones are apart)
        fail(
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
    for a file :func:`.write.fresh_gltf` wrote, which keeps the lengths of the clip it was made
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


def _key_values(keys: Keys) -> np.ndarray:
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
                sites[j] = node_rest(node, c, path)[0]
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
