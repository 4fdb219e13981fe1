"""Panels: World properties → Airmass (everything), 3D View sidebar → Airmass (the essentials)."""

import bpy

from . import compare, native, vdb_host


def _library_status(layout):
    error = native.load_error()
    if error:
        box = layout.box()
        box.alert = True
        col = box.column(align=True)
        col.label(text="Airmass library not loaded", icon="ERROR")
        for line in _wrap(error, 60):
            col.label(text=line)
        box.operator("airmass.reload_library", icon="FILE_REFRESH")
    return error is None


def _wrap(text, width):
    words, lines, line = text.split(), [], ""
    for w in words:
        if len(line) + len(w) + 1 > width and line:
            lines.append(line)
            line = w
        else:
            line = (line + " " + w).strip()
    if line:
        lines.append(line)
    return lines


def _source(layout, s):
    layout.prop(s, "source", expand=True)
    if s.source == "PRESET":
        layout.prop(s, "preset")
    else:
        layout.prop(s, "scene_file")


def _sun(layout, s):
    col = layout.column(align=True)
    col.prop(s, "sun_elevation")
    col.prop(s, "sun_rotation")
    layout.prop(s, "altitude")


class AirmassWorldPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "world"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and hasattr(context.scene, "airmass")


class AIRMASS_PT_world(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Airmass Atmosphere"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.airmass
        ok = _library_status(layout)
        _source(layout, s)
        _sun(layout, s)
        layout.prop(s, "output_folder")
        col = layout.column(align=True)
        col.enabled = ok
        col.scale_y = 1.3
        col.operator("airmass.generate_sky", icon="WORLD")
        col.prop(s, "live_preview")
        if s.live_status:
            col.label(text=s.live_status, icon="ERROR")
        row = col.row(align=True)
        row.operator("airmass.sun_sync", text="Sun → Lamp", icon="LIGHT_SUN").direction = "TO_LAMP"
        row.operator("airmass.sun_sync", text="Lamp → Sun", icon="IMPORT").direction = "FROM_LAMP"
        row = layout.row()
        row.prop(s, "sun_object")
        row = layout.row()
        row.prop(s, "sun_live_sync")


class AIRMASS_PT_world_planet(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Planet"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.airmass, "override_planet", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        s = context.scene.airmass
        col = layout.column()
        col.enabled = s.override_planet
        col.prop(s, "planet_radius")
        col.prop(s, "atmosphere_top")
        col.prop(s, "ground_albedo")


class AIRMASS_PT_world_constituents(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Constituents"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        s = context.scene.airmass
        if not s.constituents:
            layout.label(text="Constituents of the scene appear here", icon="INFO")
        for c in s.constituents:
            box = layout.box()
            row = box.row()
            row.prop(c, "enabled", text=c.name)
            row.label(text=c.profile_kind.replace("_", " "))
            col = box.column()
            col.use_property_split = True
            col.enabled = c.enabled
            col.prop(c, "density_scale")
            if c.profile_kind == "exponential":
                col.prop(c, "scale_height")
        layout.operator("airmass.refresh_constituents", icon="FILE_REFRESH")


class AIRMASS_PT_world_quality(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Accuracy and Speed"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.airmass
        layout.prop(s, "basis")
        layout.prop(s, "chapman")
        layout.prop(s, "sky_width")
        layout.prop(s, "view_samples")
        layout.prop(s, "sky_grid")
        layout.prop(s, "multiple_scattering")
        layout.prop(s, "sun_disc")
        layout.prop(s, "sky_strength")


class AIRMASS_PT_world_animation(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Sky Animation"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = True  # the place and time are animatable
        s = context.scene.airmass
        layout.prop(s, "bake_sun_source")
        if s.bake_sun_source == "PLACE_TIME":
            col = layout.column(align=True)
            col.prop(s, "latitude")
            col.prop(s, "longitude")
            col = layout.column(align=True)
            col.prop(s, "date")
            col.prop(s, "utc_hours")
            col.prop(s, "minutes_per_frame")
        layout.label(text="Frames %d–%d, %d px wide, into the Output Folder"
                     % (context.scene.frame_start, context.scene.frame_end, s.sky_width))
        row = layout.row()
        row.scale_y = 1.3
        row.enabled = native.load_error() is None
        row.operator("airmass.bake_sky_animation", icon="RENDER_ANIMATION")


class AIRMASS_PT_world_volume(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Atmosphere Volume"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.airmass
        layout.prop(s, "length_unit")
        layout.prop(s, "step_km")
        layout.prop(s, "volume_lighting")
        row = layout.row()
        row.enabled = s.volume_lighting == "SUN_EMISSION"
        row.prop(s, "volume_multiple")
        row = layout.row()
        row.enabled = s.volume_lighting == "SCATTER"
        row.prop(s, "phase_mixing")
        layout.prop(s, "add_ground")
        layout.prop(s, "set_units")
        col = layout.column(heading="VDB")
        col.prop(s, "volume_region")
        col.prop(s, "voxel_size")
        col.prop(s, "voxel_values")
        sub = col.column()
        sub.enabled = s.volume_region == "VIEW"
        sub.prop(s, "view_distance")
        col.prop(s, "max_dense_mb")
        row = layout.row(align=True)
        row.scale_y = 1.3
        row.operator("airmass.create_volume", text="Analytic Volume", icon="MESH_UVSPHERE").mode = "ANALYTIC"
        vdb = row.row(align=True)
        reason = vdb_host.unavailable_reason()
        vdb.enabled = reason is None  # this Blender has no OpenVDB Python module: the analytic volume only
        vdb.operator("airmass.create_volume", text="VDB Volume", icon="VOLUME_DATA").mode = "VDB"
        if reason:
            for line in _wrap(reason, 48):
                layout.label(text=line, icon="INFO")
        needed = max((o.get("airmass_transparent_bounces", 0) for o in context.scene.objects
                      if o.get("airmass_role") == "atmosphere"), default=0)
        cycles = getattr(context.scene, "cycles", None)
        if cycles is not None and cycles.transparent_max_bounces < needed:
            # Lowered after the volume was made: Cycles stops paths at its boundaries (dark volume).
            layout.label(text="Light Paths > Transparent below %d: the volume renders dark" % needed,
                         icon="ERROR")


class AIRMASS_PT_world_compare(AirmassWorldPanel, bpy.types.Panel):
    bl_label = "Compare with Native"
    bl_parent_id = "AIRMASS_PT_world"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.airmass
        reason = compare.availability()
        if reason:
            box = layout.box()
            box.alert = True
            for line in _wrap(reason, 60):
                box.label(text=line)
        layout.prop(s, "compare_width")
        layout.prop(s, "compare_samples")
        layout.prop(s, "compare_seeds")
        col = layout.column(heading="Paths", align=True)
        col.prop(s, "compare_paths")
        layout.prop(s, "compare_volume_modes")
        row = layout.row()
        row.scale_y = 1.3
        row.enabled = reason is None
        row.operator("airmass.compare", icon="IMAGE_REFERENCE")
        if s.compare_summary:
            box = layout.box()
            col = box.column(align=True)
            for part in s.compare_summary.split("; "):
                col.label(text=part)
            col.prop(s, "compare_report", text="")


class AIRMASS_PT_view3d(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Airmass"
    bl_label = "Airmass"

    @classmethod
    def poll(cls, context):
        return context.scene is not None and hasattr(context.scene, "airmass")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        s = context.scene.airmass
        ok = _library_status(layout)
        if s.source == "PRESET":
            layout.prop(s, "preset")
        else:
            layout.prop(s, "scene_file")
        _sun(layout, s)
        col = layout.column(align=True)
        col.enabled = ok
        col.operator("airmass.generate_sky", icon="WORLD")
        col.operator("airmass.sun_sync", text="Sun → Lamp", icon="LIGHT_SUN").direction = "TO_LAMP"
        row = col.row(align=True)
        row.operator("airmass.create_volume", text="Analytic", icon="MESH_UVSPHERE").mode = "ANALYTIC"
        row.operator("airmass.create_volume", text="VDB", icon="VOLUME_DATA").mode = "VDB"
        sub = col.row(align=True)
        sub.enabled = compare.available()
        sub.operator("airmass.compare", icon="IMAGE_REFERENCE")


CLASSES = (AIRMASS_PT_world, AIRMASS_PT_world_planet, AIRMASS_PT_world_constituents, AIRMASS_PT_world_quality,
           AIRMASS_PT_world_animation, AIRMASS_PT_world_volume, AIRMASS_PT_world_compare, AIRMASS_PT_view3d)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)


def unregister():
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
