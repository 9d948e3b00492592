"""Run by Blender's Python (bpy): import clips (BVH or glTF) with Blender's own importer, each
into an empty scene, and print, per clip, frame and bone, the bone's world rotation (w, x,
y, z) and head position as one JSON list (one process for all: bpy starts once).

usage: python pose_frames.py FPS CLIP FIRST LAST [CLIP FIRST LAST ...]
"""

import json
import sys

import bpy


def poses(clip: str, fps: int, first: int, last: int) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = fps, 1.0
    if clip.endswith(".bvh"):
        bpy.ops.import_anim.bvh(filepath=clip, frame_start=1, use_fps_scale=False)
    else:
        bpy.ops.import_scene.gltf(filepath=clip)
    armature = next(o for o in scene.objects if o.type == "ARMATURE")
    frames = {}
    for frame in range(first, last + 1):
        scene.frame_set(frame)
        bones = {}
        for bone in armature.pose.bones:
            world = armature.matrix_world @ bone.matrix
            q = world.to_quaternion()
            bones[bone.name] = [list(q), list(world.translation)]
        frames[frame] = bones
    return frames


fps, rest = int(sys.argv[1]), sys.argv[2:]
clips = [(rest[i], int(rest[i + 1]), int(rest[i + 2])) for i in range(0, len(rest), 3)]
print("POSES" + json.dumps([poses(clip, fps, first, last) for clip, first, last in clips]))
