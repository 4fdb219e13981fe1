"""Blender-side script: render Blender's own Nishita Sky Texture through an equirectangular
camera, one ray per pixel centre, to a 32-bit linear EXR.

    blender -b --factory-startup --python-exit-code 1 --python scripts/blender_nishita_pano.py \
        -- OUT.exr WIDTH HEIGHT SUN_ELEVATION_DEG SUN_ROTATION_DEG

The camera is level and looks along +X, so the panorama uses the World's equirectangular
convention (the layout of `airmass sky`). Sky altitude 1 m, no sun disc, Cycles on the CPU,
1 sample, denoising off. Used by tests/python/test_sky_exr.py and bench/nishita_error.py.
"""
import math
import sys

import bpy

out, w, h, elev, rot = sys.argv[sys.argv.index("--") + 1:]
scene = bpy.context.scene
for o in list(bpy.data.objects):
    if o.type != "CAMERA":
        bpy.data.objects.remove(o)
cam = scene.camera
cam.location = (0, 0, 0)
# Level, looking along +X: the panorama then uses the World's equirectangular convention.
cam.rotation_euler = (math.pi / 2, 0, -math.pi / 2)
cam.data.type = "PANO"
cam.data.cycles.panorama_type = "EQUIRECTANGULAR"
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 1
scene.cycles.use_denoising = False
scene.cycles.filter_width = 0.01  # one ray through each pixel centre
scene.render.resolution_x, scene.render.resolution_y = int(w), int(h)
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Standard"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.filepath = out
world = bpy.data.worlds.new("nishita")
scene.world = world
world.use_nodes = True
tex = world.node_tree.nodes.new("ShaderNodeTexSky")
tex.sky_type = "NISHITA"
tex.sun_elevation = math.radians(float(elev))
tex.sun_rotation = math.radians(float(rot))
tex.altitude = 1.0
tex.sun_disc = False
world.node_tree.links.new(tex.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
bpy.ops.render.render(write_still=True)
