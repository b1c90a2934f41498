"""Add-on preferences: where the refrakt executable is (empty: the one bundled with the add-on,
else refrakt on PATH)."""

import bpy
from bpy.props import StringProperty

from . import binary


class RefraktPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary: StringProperty(
        name="refrakt Executable",
        description="Path to the refrakt executable; empty: the refrakt bundled with the add-on, else refrakt on PATH",
        default="",
        subtype="FILE_PATH",
    )
    farm: StringProperty(
        name="refrakt-farm Executable",
        description="Path to refrakt-farm (Render on Cluster); empty: find refrakt-farm on PATH",
        default="",
        subtype="FILE_PATH",
    )
    check_report: StringProperty(default="", options={"SKIP_SAVE"})
    # Where the checked refrakt came from: binary.PREFERENCES, BUNDLED or PATH ("" before a check).
    check_source: StringProperty(default="", options={"SKIP_SAVE"})

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "binary")
        layout.prop(self, "farm")
        row = layout.row()
        row.operator("refrakt.check_binary", icon="CHECKMARK")
        try:
            row.label(text=f"Using {binary.describe(*binary.locate(self.binary))}")
        except binary.BinaryError as e:
            layout.label(text=str(e), icon="ERROR")
        for line in self.check_report.splitlines():
            layout.label(text=line)


def get(context):
    return context.preferences.addons[__package__].preferences


def register():
    bpy.utils.register_class(RefraktPreferences)


def unregister():
    bpy.utils.unregister_class(RefraktPreferences)
