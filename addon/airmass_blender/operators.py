"""The operators: airmass.generate_sky, airmass.sun_sync, airmass.bake_sky_animation,
airmass.create_volume, airmass.compare, and the small helpers the panel uses.

Every operator reports failures with self.report({'ERROR'}, message) (a RuntimeError when
called through bpy.ops from a script) and leaves nothing half-made: work is done first,
datablocks are built into temporaries and swapped in only when complete.
"""

import traceback

import bpy
from bpy.props import EnumProperty

from . import animation, compare, native, sun, volume, world
from .jobs import JobOperatorMixin, describe
from .properties import SettingsError, refresh_constituents


class AIRMASS_OT_generate_sky(JobOperatorMixin, bpy.types.Operator):
    """Render the sky texture through the Airmass library into a packed float image (also saved as EXR in the
    Output Folder when it resolves) and use it as the World background"""
    bl_idname = "airmass.generate_sky"
    bl_label = "Generate Sky"
    bl_options = {"REGISTER", "UNDO"}

    def make_plan(self, context):
        return world.SkyPlan(context)


class AIRMASS_OT_sun_sync(bpy.types.Operator):
    """Sync the sun direction with a Sun lamp; set the lamp's strength (W/m²) and colour from the
    sunlight transmitted to the observer"""
    bl_idname = "airmass.sun_sync"
    bl_label = "Sun Sync"
    bl_options = {"REGISTER", "UNDO"}

    direction: EnumProperty(
        name="Direction", default="TO_LAMP",
        items=[("TO_LAMP", "Settings → Lamp", "Point the Sun lamp (created if needed) at the settings' sun"),
               ("FROM_LAMP", "Lamp → Settings", "Read the sun direction from the Sun lamp")])

    def execute(self, context):
        scene = context.scene
        try:
            if self.direction == "TO_LAMP":
                obj = sun.settings_to_lamp(scene, create=True)
            else:
                obj = sun.lamp_to_settings(scene)
        except Exception as e:  # noqa: BLE001
            if not isinstance(e, (native.NativeError, SettingsError, ValueError)):
                traceback.print_exc()
            self.report({"ERROR"}, describe(e))
            return {"CANCELLED"}
        self.report({"INFO"}, "Sun lamp '%s': %.4g W/m², colour (%.3f, %.3f, %.3f)"
                    % (obj.name, obj.data.energy, *obj.data.color))
        return {"FINISHED"}


class AIRMASS_OT_bake_sky_animation(JobOperatorMixin, bpy.types.Operator):
    """Render a sky per frame of the scene (sun from place and time, or from the Sun lamp) as an EXR sequence,
    show it in the World and keyframe the Sun lamp, so the .blend renders the animation without the add-on"""
    bl_idname = "airmass.bake_sky_animation"
    bl_label = "Bake Sky Animation"
    bl_options = {"REGISTER", "UNDO"}

    def make_plan(self, context):
        return animation.BakePlan(context)


class AIRMASS_OT_create_volume(JobOperatorMixin, bpy.types.Operator):
    """Create the atmosphere as a Cycles volume: analytic (exact densities from Math nodes on a
    shell mesh) or VDB (voxels for the region the active camera needs)"""
    bl_idname = "airmass.create_volume"
    bl_label = "Create Atmosphere Volume"
    bl_options = {"REGISTER", "UNDO"}

    mode: EnumProperty(
        name="Mode", default="ANALYTIC",
        items=[("ANALYTIC", "Analytic", "Shell mesh whose material evaluates each density exactly (no voxels, no OSL)"),
               ("VDB", "VDB", "OpenVDB grids written by the library, imported as a Volume object")])

    def make_plan(self, context):
        if self.mode == "VDB":
            return volume.VdbPlan(context)
        return volume.AnalyticPlan(context)


class AIRMASS_OT_compare(JobOperatorMixin, bpy.types.Operator):
    """Render the active camera in Cycles and natively (airmass compare: sky texture, analytic and VDB
    volume paths) and show the error; the report goes to <Output Folder>/<scene>_compare"""
    bl_idname = "airmass.compare"
    bl_label = "Compare with Native"

    def make_plan(self, context):
        return compare.ComparePlan(context)

    def report_success(self, context, plan):
        # A path that failed (an export refused, say) is in the report; the others are valid.
        self.report({"WARNING"} if plan.partial else {"INFO"}, plan.summary)


class AIRMASS_OT_refresh_constituents(bpy.types.Operator):
    """Reload the constituent list from the preset or scene file"""
    bl_idname = "airmass.refresh_constituents"
    bl_label = "Refresh Constituents"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        error = refresh_constituents(context.scene.airmass)
        if error:
            self.report({"ERROR"}, error)
            return {"CANCELLED"}
        return {"FINISHED"}


class AIRMASS_OT_reload_library(bpy.types.Operator):
    """Try loading the Airmass native library again"""
    bl_idname = "airmass.reload_library"
    bl_label = "Reload Library"

    def execute(self, context):
        native.reset()
        error = native.load_error()
        if error:
            self.report({"ERROR"}, error)
            return {"CANCELLED"}
        self.report({"INFO"}, "Airmass library %s loaded" % native.version())
        return {"FINISHED"}


CLASSES = (AIRMASS_OT_generate_sky, AIRMASS_OT_sun_sync, AIRMASS_OT_bake_sky_animation, AIRMASS_OT_create_volume,
           AIRMASS_OT_compare, AIRMASS_OT_refresh_constituents, AIRMASS_OT_reload_library)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
