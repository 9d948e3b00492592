"""motionclean for Blender: a panel in the Graph Editor and Dope Sheet sidebars that cleans
the selected armatures' actions with motionclean's pipelines.

The extension bundles the motionclean package as its own module (``.motionclean``, put there
by ``make blender``); Blender's Python has numpy, the only other thing it needs.
"""

from __future__ import annotations

import bpy

from . import operators, panels, properties

CLASSES = (
    properties.MOTIONCLEAN_PG_result,
    properties.MOTIONCLEAN_PG_settings,
    operators.MOTIONCLEAN_OT_clean,
    operators.MOTIONCLEAN_OT_open_report,
    panels.MOTIONCLEAN_PT_graph,
    panels.MOTIONCLEAN_PT_dopesheet,
)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.motionclean = bpy.props.PointerProperty(type=properties.MOTIONCLEAN_PG_settings)


def unregister() -> None:
    del bpy.types.Scene.motionclean
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
