"""Run by Blender's Python (bpy): import a clip (BVH or glTF) with Blender's own importer and
print, per frame and bone, the bone's world rotation (w, x, y, z) and head position as JSON.

usage: python pose_frames.py CLIP FPS FIRST LAST
"""

import json
import sys

import bpy

clip, fps, first, last = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
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
print("POSES" + json.dumps(frames))
