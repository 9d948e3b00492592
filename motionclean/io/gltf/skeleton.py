"""The skeleton of a glTF file: its node tree, the nodes' rest transforms, and a VRM
animation's humanoid bone map."""

from __future__ import annotations

import numpy as np

from ...core.checks import MAX_MAGNITUDE
from ..smpl_model import matrix_to_quaternion
from .container import IN_RANGE, VRM_ANIMATION, fail, index_of


def node_parents(nodes: list, path) -> np.ndarray:
    """Each node's parent (-1 for a root); a node with two parents or a cycle is refused."""
    parent = np.full(len(nodes), -1, dtype=np.intp)
    for n, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list):
            fail(f"nodes[{n}].children is not a list", path)
        for child in children:
            c = index_of(child, len(nodes), f"nodes[{n}].children", path)
            if c == n:
                fail(f"node {n} lists itself as a child", path)
            if parent[c] >= 0:
                fail(f"node {c} has two parents", path)
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
        fail("the node tree has a cycle", path)
    return parent


def joint_order(joints: set[int], nodes: list, parent: np.ndarray) -> tuple[list[int], list[int]]:
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


def _matrix(node: dict, n: int, path) -> np.ndarray:
    """A node's ``matrix`` as a ``(4, 4)`` array (glTF stores it column-major)."""
    if not _numbers(node["matrix"], 16):
        fail(f"nodes[{n}].matrix is not 16 numbers{IN_RANGE}", path)
    return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T


def _matrix_scale(m: np.ndarray) -> np.ndarray:
    """The scale factors ``(3,)`` of a 4x4 node matrix: the norms of its columns."""
    return np.linalg.norm(m[:3, :3], axis=0)


def node_scale(node: dict, n: int, path) -> np.ndarray:
    """A node's scale factors ``(3,)`` (from its matrix's columns, or its ``scale``)."""
    if "matrix" in node:
        return _matrix_scale(_matrix(node, n, path))
    factors = node.get("scale", [1.0, 1.0, 1.0])
    if not _numbers(factors, 3):
        fail(f"nodes[{n}].scale is not 3 numbers{IN_RANGE}", path)
    return np.asarray(factors, dtype=np.float64)


def node_rest(node: dict, n: int, path) -> tuple[np.ndarray, np.ndarray]:
    """A node's rest translation ``(3,)`` and rotation ``(4,)`` (w, x, y, z)."""
    if "matrix" in node:
        m = _matrix(node, n, path)
        scale = _matrix_scale(m)
        if np.any(scale <= 0.0):
            fail(f"nodes[{n}].matrix has a zero scale", path)
        return m[:3, 3].copy(), matrix_to_quaternion(m[:3, :3] / scale)
    t = node.get("translation", [0.0, 0.0, 0.0])
    r = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    if not _numbers(t, 3) or not _numbers(r, 4):
        fail(f"nodes[{n}]: translation or rotation is not 3 or 4 numbers{IN_RANGE}", path)
    q = np.array([r[3], r[0], r[1], r[2]], dtype=np.float64)
    norm = np.linalg.norm(q)
    if not norm > 1e-6:
        fail(f"nodes[{n}].rotation is not a rotation (norm {norm:.3g})", path)
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


def vrm_nodes(document: dict, size: int, path) -> tuple[set[int], dict[int, str]]:
    """A VRM animation's humanoid bone nodes, and its expression and look-at nodes with
    what each one is (``expression 'happy'``, ``lookAt``); both empty for a glTF without
    the :data:`.container.VRM_ANIMATION` extension."""
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
        fail(f"{where}.{key} is not an object", path)
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
        fail(f"{where} is not an object", path)
    return index_of(spec.get("node"), size, f"{where}.node", path)


def humanoid_joints(bones: set[int], parent: np.ndarray) -> set[int]:
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


def carried_note(carried: dict[int, str], animated: set[int]) -> list[str]:
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
