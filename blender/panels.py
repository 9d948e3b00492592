"""The motionclean panel, in the Graph Editor's and the Dope Sheet's sidebars."""

from __future__ import annotations

from typing import Any

from bpy.types import Panel

from .motionclean.core.words import whole_percent


class _MotioncleanPanel:
    bl_region_type = "UI"
    bl_category = "motionclean"
    bl_label = "motionclean"

    def draw(self, context: Any) -> None:
        layout = self.layout
        settings = context.scene.motionclean
        column = layout.column()
        column.prop(settings, "pipeline")
        if settings.pipeline == "FILE":
            column.prop(settings, "pipeline_file", text="")
        elif settings.pipeline == "STEPS":
            column.prop(settings, "steps", text="")
        column.prop(settings, "frames")
        column.prop(settings, "in_place")
        column.operator("motionclean.clean", icon="IPO_EASE_IN_OUT")
        for result in settings.results:
            box = layout.box()
            lines = box.column(align=True)
            lines.label(text=f"{result.objects}: {result.source} -> {result.result}")
            lines.label(text=f"Frames {result.frames}")
            lines.label(
                text=f"Noise removed {whole_percent(result.noise_removed)}, "
                f"largest change {result.deviation_max:.2f} deg"
            )
            lines.label(text=result.keys)
            for line in result.lines.splitlines():
                lines.label(text=line)
            box.operator("motionclean.open_report", icon="URL").path = result.report
            box.label(text=f"Report: {result.report}")  # (where the page is)


class MOTIONCLEAN_PT_graph(_MotioncleanPanel, Panel):
    bl_idname = "MOTIONCLEAN_PT_graph"
    bl_space_type = "GRAPH_EDITOR"


class MOTIONCLEAN_PT_dopesheet(_MotioncleanPanel, Panel):
    bl_idname = "MOTIONCLEAN_PT_dopesheet"
    bl_space_type = "DOPESHEET_EDITOR"
