"""The images in docs/addon.md, made with the add-on itself in headless Blender:

    blender -b --factory-startup --python addon/tools/make_doc_images.py -- \\
        --zip build/addon/airmass_blender.zip --out docs/images [--quick]

Writes addon_sky.png (the sky texture Generate Sky writes, sun at 8°), addon_ground.png
(a Cycles render lit by that sky and the synced Sun lamp), addon_orbit.png (the analytic
atmosphere volume from 400 km, black World, Sun lamp) and addon_vdb.png (the VDB volume of
the camera's view region at sunset). Colour management: Filmic, exposures chosen per image
and printed. About 5–10 minutes on 2 cores (--quick: tiny images, for checking the script;
AIRMASS_DOC_IMAGE=sky|orbit|vdb makes one group only).
"""

import argparse
import math
import os
import sys
import tempfile
import time

import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--zip", required=True)
ap.add_argument("--out", required=True)
ap.add_argument("--quick", action="store_true")
args = ap.parse_args(argv)
OUT = os.path.abspath(args.out)
os.makedirs(OUT, exist_ok=True)
SCALE = 0.25 if args.quick else 1.0
ONLY = os.environ.get("AIRMASS_DOC_IMAGE", "")  # e.g. "orbit": make only that image

tmp = tempfile.mkdtemp(prefix="airmass-doc-images-")
bpy.context.preferences.filepaths.script_directory = tmp
bpy.ops.preferences.addon_install(filepath=os.path.abspath(args.zip), target="PREFS", overwrite=True)
bpy.utils.refresh_script_paths()
bpy.ops.preferences.addon_enable(module="airmass_blender")


def fresh(name):
    bpy.ops.wm.read_homefile(use_empty=False)
    scene = bpy.context.scene
    for o in list(bpy.data.objects):
        if o.type == "MESH" or (o.type == "LIGHT" and o.get("airmass_role") != "sun"):
            bpy.data.objects.remove(o)
    s = scene.airmass
    s.preset = "earth"
    s.output_folder = os.path.join(tmp, name)
    return scene, s


def setup_render(scene, width, height, samples, exposure):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = max(1, int(samples * (0.25 if args.quick else 1.0)))
    scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    scene.render.resolution_x = int(width * SCALE)
    scene.render.resolution_y = int(height * SCALE)
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.exposure = exposure
    scene.render.image_settings.file_format = "PNG"


def render(scene, name):
    scene.render.filepath = os.path.join(OUT, name)
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    print("wrote %s (%.1f s)" % (scene.render.filepath, time.time() - t0))


def camera(scene, location, pitch_deg, heading_deg, lens=18.0):
    cam = scene.camera
    cam.location = location
    cam.rotation_mode = "XYZ"
    cam.rotation_euler = (math.radians(90.0 + pitch_deg), 0.0, math.radians(-heading_deg))
    cam.data.lens = lens
    cam.data.clip_start = 1e-4
    return cam


def black_world(scene):
    w = bpy.data.worlds.new("Space")
    w.use_nodes = True
    w.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = w


def make_sky_images():
    # 1. The sky texture itself.
    scene, s = fresh("sky")
    s.sun_elevation, s.sun_rotation = math.radians(8.0), math.radians(90.0)
    s.sky_width = int(1024 * SCALE)
    bpy.ops.airmass.generate_sky()
    img = scene.world.node_tree.nodes["Airmass Sky"].image
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.exposure = -3.0
    img.save_render(os.path.join(OUT, "addon_sky.png"), scene=scene)
    print("wrote addon_sky.png")

    # 2. A ground-level render lit by the sky and the synced lamp (sun disc off: the lamp is the sun).
    s.sun_disc = False
    bpy.ops.airmass.generate_sky()
    bpy.ops.airmass.sun_sync()
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.0, 0.0, 0.0))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.001, location=(-0.0012, 0.008, 0.001))
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_cube_add(size=0.0015, location=(0.0016, 0.009, 0.00075))
    camera(scene, (0.0, 0.0, 0.0016), pitch_deg=-3.0, heading_deg=0.0, lens=30.0)
    setup_render(scene, 640, 360, 64, exposure=-4.0)
    render(scene, "addon_ground.png")


def make_orbit_image():
    # 3. The analytic volume from orbit (whole planet), black World, top-of-atmosphere sun.
    scene, s = fresh("orbit")
    s.volume_region = "PLANET"
    s.sun_elevation, s.sun_rotation = math.radians(6.0), math.radians(40.0)
    h = 400.0
    dip = math.degrees(math.acos(6360.0 / (6360.0 + h)))
    camera(scene, (0.0, 0.0, h), pitch_deg=-dip + 6.0, heading_deg=0.0, lens=24.0)
    bpy.ops.airmass.create_volume(mode="ANALYTIC")
    black_world(scene)
    bpy.ops.airmass.sun_sync()
    setup_render(scene, 320, 180, 16, exposure=-5.0)
    scene.cycles.volume_bounces = 0
    render(scene, "addon_orbit.png")


def make_vdb_image():
    # 4. The VDB volume of the camera's view region, low sun.
    scene, s = fresh("vdb")
    s.volume_region = "VIEW"
    s.view_distance = 150.0
    s.sun_elevation, s.sun_rotation = math.radians(4.0), math.radians(20.0)
    camera(scene, (0.0, 0.0, 0.5), pitch_deg=3.0, heading_deg=20.0, lens=20.0)
    bpy.ops.airmass.create_volume(mode="VDB")
    black_world(scene)
    bpy.ops.airmass.sun_sync()
    setup_render(scene, 320, 180, 16, exposure=-4.5)
    scene.cycles.volume_bounces = 0
    render(scene, "addon_vdb.png")


for name, fn in (("sky", make_sky_images), ("orbit", make_orbit_image), ("vdb", make_vdb_image)):
    if not ONLY or ONLY == name:
        fn()
