"""The panel's settings and the figures of the last run, stored with the scene."""

from __future__ import annotations

from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    StringProperty,
)
from bpy.types import PropertyGroup


class MOTIONCLEAN_PG_result(PropertyGroup):
    """One cleaned action: where it went and the report's figures."""

    objects: StringProperty(name="Objects", description="The armatures that play the action")
    source: StringProperty(name="Action", description="The action that was cleaned")
    result: StringProperty(name="Result", description="The cleaned action")
    frames: StringProperty(name="Frames", description="The frames cleaned")
    noise_removed: FloatProperty(
        name="Noise Removed",
        description="Fraction of the RMS angular acceleration removed, over all bones",
        subtype="FACTOR",
    )
    deviation_max: FloatProperty(
        name="Largest Change", description="Largest rotation change of any bone, degrees"
    )
    keys: StringProperty(
        name="Keys", description="How many keys got new values and how many were added"
    )
    lines: StringProperty(name="Figures", description="The report's repairs and feet, one per line")
    report: StringProperty(name="Report", description="The HTML report", subtype="FILE_PATH")


class MOTIONCLEAN_PG_settings(PropertyGroup):
    """What the Clean Actions operator runs, on which frames, and where the result goes."""

    pipeline: EnumProperty(
        name="Pipeline",
        description="The steps to run, as on the command line",
        items=(
            ("DEFAULT", "Default", "What `motionclean clean` runs without -p or -f"),
            ("FILE", "TOML File", "A pipeline file, as `motionclean clean -p FILE`"),
            ("STEPS", "Steps", "Steps typed in, as `motionclean clean -f STEP -f STEP`"),
        ),
        default="DEFAULT",
    )
    pipeline_file: StringProperty(
        name="Pipeline File", description="A pipeline TOML file", subtype="FILE_PATH"
    )
    steps: StringProperty(
        name="Steps",
        description="Steps as after `motionclean clean` (-f is optional): "
        "-f lee-shin:k=2,iterations=5 -f bilateral:sigma_t=1,sigma_g=0.1. A step's "
        "frames=[A,B] counts the action's frames from its first key (0), not Blender's "
        "frame numbers",
    )
    frames: EnumProperty(
        name="Frames",
        description="The frames of each action to clean (within its keys)",
        items=(
            ("SCENE", "Scene Range", "The scene's start to end frame"),
            ("PREVIEW", "Preview Range", "The scene's preview range (must be on)"),
            ("ACTION", "Whole Action", "From the action's first key to its last"),
        ),
        default="SCENE",
    )
    in_place: BoolProperty(
        name="In Place",
        description='Change the actions themselves; off: a cleaned copy ("Walk.clean") is '
        "made beside each and assigned, the original kept",
        default=False,
    )
    results: CollectionProperty(type=MOTIONCLEAN_PG_result)
