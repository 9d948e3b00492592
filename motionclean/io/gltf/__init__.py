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
(:func:`.read._length_unit`; a file motionclean wrote from another format keeps that format's
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
source's folder, links resolved (:func:`.container._beside`). Sparse accessors and compressed
animation data are refused. A VRM animation (``.vrma``) is a GLB, written only into the
one it was read from (:func:`.write.vrma_pieces`).
"""

from __future__ import annotations

from .container import GLB_SUFFIXES
from .read import parse_gltf
from .write import fresh_gltf, gltf_pieces, vrma_pieces

__all__ = ["GLB_SUFFIXES", "fresh_gltf", "gltf_pieces", "parse_gltf", "vrma_pieces"]
