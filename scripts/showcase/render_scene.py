"""One gallery scene, one seed, rendered in headless Blender through the add-on's operators.

    blender -b --factory-startup --python-exit-code 1 --python scripts/showcase/render_scene.py -- \\
        --zip build/addon/airmass_blender.zip --scene NAME --seed K --out DIR \\
        [--width 960 --height 540 --samples N]

Writes DIR/NAME_seedK.exr (linear Rec.709, 32-bit float, Cycles CPU, no denoiser) and
DIR/NAME_seedK.json (render seconds, the settings, the operators' reports); with --mask also
DIR/NAME_sky.npy, the "sky" pixels the noise is measured over (see sky_mask()).

Everything the add-on contributes is made by its operators, as a user would click them:
bpy.ops.airmass.generate_sky (World sky texture), airmass.sun_sync (Sun lamp),
airmass.create_volume (the atmosphere, ANALYTIC or VDB). The terrain is the user's own
scene, built with plain Blender (a grid, a Displace modifier with a procedural texture).

Scenes (scripts/showcase.sh, docs/gallery.md):
  terrain_volume  mountains, golden hour (sun 5°), analytic volume, black World, Sun lamp
  sunset_shadow   sun 1° below the horizon, looking away from it: the Earth's shadow and
                  the Belt of Venus; analytic volume of the whole planet
  limb_vdb        the planet's limb from 400 km, VDB volume of the camera's view region
  terrain_sky     the terrain of terrain_volume lit by Generate Sky's texture + the synced
                  Sun lamp alone (no volume): what the volume adds
"""

import argparse
import atexit
import json
import math
import os
import shutil
import sys
import tempfile
import time

import bpy
import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree

ADDON = "airmass_blender"
R_EARTH = 6360.0  # km, the `earth` preset's radius (checked against the add-on's description below)

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--zip", required=True)
ap.add_argument("--scene", required=True)
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--out", required=True)
ap.add_argument("--width", type=int, default=960)
ap.add_argument("--height", type=int, default=540)
ap.add_argument("--samples", type=int, required=True)
ap.add_argument("--mask", action="store_true", help="also write the sky mask NAME_sky.npy")
args = ap.parse_args(argv)
OUT = os.path.abspath(args.out)
os.makedirs(OUT, exist_ok=True)
REPORTS = []


def install_addon(zip_path):
    tmp = tempfile.mkdtemp(prefix="airmass-showcase-")
    # The installed add-on and the Output Folder (the sky EXR, the VDB files): removed on exit.
    atexit.register(shutil.rmtree, tmp, True)
    fp = bpy.context.preferences.filepaths
    if hasattr(fp, "script_directories"):  # Blender 4.2+
        fp.script_directories.new().directory = tmp
    else:
        fp.script_directory = tmp
    r = bpy.ops.preferences.addon_install(filepath=os.path.abspath(zip_path), target="PREFS", overwrite=True)
    if r != {"FINISHED"}:
        raise SystemExit("showcase: addon_install returned %s" % r)
    bpy.utils.refresh_script_paths()
    bpy.ops.preferences.addon_enable(module=ADDON)
    return tmp


def op(call, what, **kw):
    """An add-on operator as a user runs it; its report line is kept for the JSON."""
    t0 = time.time()
    r = call(**kw)
    if r != {"FINISHED"}:
        raise SystemExit("showcase: %s returned %s" % (what, r))
    REPORTS.append({"operator": what, "args": {k: str(v) for k, v in kw.items()},
                    "seconds": round(time.time() - t0, 2)})


def fresh(tmp):
    bpy.ops.wm.read_homefile(use_empty=False)
    scene = bpy.context.scene
    for o in list(bpy.data.objects):
        if o.type in ("MESH", "LIGHT"):  # the default cube would sit inside the planet; Airmass makes the sun
            bpy.data.objects.remove(o)
    s = scene.airmass
    s.preset = "earth"
    s.output_folder = os.path.join(tmp, "airmass")
    return scene, s


def camera(scene, location, pitch_deg, heading_deg, lens):
    """Heading as the Sky Texture's rotation (0 → +Y, 90° → +X), pitch above the horizontal."""
    cam = scene.camera
    cam.location = location
    cam.rotation_mode = "XYZ"
    cam.rotation_euler = (math.radians(90.0 + pitch_deg), 0.0, math.radians(-heading_deg))
    cam.data.lens = lens
    cam.data.sensor_fit = "AUTO"
    cam.data.clip_start = 1e-3
    return cam


def black_world(scene):
    """With an Airmass volume the atmosphere's light comes from the volume (docs/addon.md)."""
    w = bpy.data.worlds.new("Space")
    w.use_nodes = True
    w.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = w


# ---- the user's terrain ----------------------------------------------------------------------

TERRAIN = {"size_x": 160.0, "size_y": 160.0, "y0": -20.0, "subdiv": 480, "height": 5.5,
           "noise_scale": 20.0, "octaves": 6.0, "intensity": 0.4}


def make_terrain(scene):
    """A 160 km × 160 km grid ahead of the camera (+Y), bent down with the planet's curvature,
    raised by a Displace modifier (Blender's ridged multifractal Musgrave texture), low near the camera and at the
    edges (a vertex group), rock-and-grass grey-green Principled BSDF."""
    t = TERRAIN
    n = t["subdiv"]
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=n, y_subdivisions=n, size=1.0,
                                    location=(0.0, t["y0"] + 0.5 * t["size_y"], 0.0))
    obj = bpy.context.active_object
    obj.name = "Terrain"
    obj.scale = (t["size_x"], t["size_y"], 1.0)
    bpy.ops.object.transform_apply(location=True, rotation=False, scale=True)
    me = obj.data
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    x, y = co[:, 0], co[:, 1]
    # The planet's curvature: the drop below the tangent plane at horizontal distance d.
    d2 = x * x + y * y
    co[:, 2] = -(d2 / (np.sqrt(R_EARTH * R_EARTH - d2) + R_EARTH))
    me.vertices.foreach_set("co", co.ravel())
    me.update()
    # Mountain weight: 0.1 in the valley in front of the camera, rising from 8 km to 1 at 35 km,
    # and falling to 0 within 10 km of the grid's edge (the terrain meets the ground sphere).
    ramp = 0.1 + 0.9 * np.clip((y - 8.0) / 27.0, 0.0, 1.0)
    edge = np.minimum.reduce([x + 0.5 * t["size_x"], 0.5 * t["size_x"] - x,
                              y - t["y0"], t["y0"] + t["size_y"] - y])
    w = ramp * np.clip(edge / 10.0, 0.0, 1.0)
    vg = obj.vertex_groups.new(name="mountains")
    q = np.round(w * 255.0).astype(int)  # weights in steps of 1/255: one vg.add call per step
    for level in np.unique(q[q > 0]):
        vg.add(np.nonzero(q == level)[0].tolist(), float(level) / 255.0, "REPLACE")
    tex = bpy.data.textures.new("Ridges", type="MUSGRAVE")
    tex.musgrave_type = "RIDGED_MULTIFRACTAL"  # sharp crests, eroded-looking valleys
    tex.noise_basis = "BLENDER_ORIGINAL"
    tex.noise_scale = t["noise_scale"]
    tex.octaves = t["octaves"]
    tex.offset, tex.gain = 1.0, 2.0
    tex.noise_intensity = t["intensity"]
    mod = obj.modifiers.new("Displace", "DISPLACE")
    mod.texture = tex
    mod.texture_coords = "GLOBAL"
    mod.direction = "Z"
    mod.mid_level = 0.0  # upward only: the terrain never dips below the planet's ground sphere
    mod.strength = t["height"]
    mod.vertex_group = "mountains"
    mat = bpy.data.materials.new("Terrain")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.11, 0.12, 0.08, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular"].default_value = 0.2
    me.materials.append(mat)
    bpy.ops.object.shade_smooth()
    return obj


# ---- the scenes ------------------------------------------------------------------------------

def terrain_common(scene, s):
    s.sun_elevation, s.sun_rotation = math.radians(5.0), math.radians(55.0)
    camera(scene, (0.0, 0.0, 1.5), pitch_deg=0.5, heading_deg=0.0, lens=35.0)
    make_terrain(scene)


def scene_terrain_volume(scene, s):
    terrain_common(scene, s)
    s.volume_region, s.view_distance, s.step_km = "VIEW", 300.0, 3.0
    s.volume_lighting = "SUN_EMISSION"
    op(bpy.ops.airmass.create_volume, "airmass.create_volume", mode="ANALYTIC")
    op(bpy.ops.airmass.sun_sync, "airmass.sun_sync", direction="TO_LAMP")
    black_world(scene)
    return {"volume_bounces": 0, "diffuse_bounces": 1}


def scene_terrain_sky(scene, s):
    terrain_common(scene, s)
    s.sun_disc = False  # the lamp is the sun
    s.sky_width = 2048
    op(bpy.ops.airmass.generate_sky, "airmass.generate_sky")
    op(bpy.ops.airmass.sun_sync, "airmass.sun_sync", direction="TO_LAMP")
    # The flat ground beyond the terrain: the planet as the sky texture's ground would be
    # seen without a volume is the texture's lower half (no ground object needed).
    return {"volume_bounces": 0, "diffuse_bounces": 1}


def scene_sunset_shadow(scene, s):
    s.sun_elevation, s.sun_rotation = math.radians(-1.0), math.radians(270.0)
    camera(scene, (0.0, 0.0, 0.002), pitch_deg=18.0, heading_deg=90.0, lens=24.0)
    s.volume_region, s.step_km = "PLANET", 4.0
    s.volume_lighting = "SUN_EMISSION"
    op(bpy.ops.airmass.create_volume, "airmass.create_volume", mode="ANALYTIC")
    op(bpy.ops.airmass.sun_sync, "airmass.sun_sync", direction="TO_LAMP")
    black_world(scene)
    return {"volume_bounces": 0, "diffuse_bounces": 0}


def scene_limb_vdb(scene, s):
    h = 400.0
    dip = math.degrees(math.acos(R_EARTH / (R_EARTH + h)))
    s.sun_elevation, s.sun_rotation = math.radians(12.0), math.radians(35.0)
    camera(scene, (0.0, 0.0, h), pitch_deg=-dip + 7.0, heading_deg=0.0, lens=22.0)
    s.volume_region, s.view_distance, s.step_km = "VIEW", 3300.0, 8.0
    s.volume_lighting = "SUN_EMISSION"
    op(bpy.ops.airmass.create_volume, "airmass.create_volume", mode="VDB")
    op(bpy.ops.airmass.sun_sync, "airmass.sun_sync", direction="TO_LAMP")
    black_world(scene)
    return {"volume_bounces": 0, "diffuse_bounces": 0}


SCENES = {"terrain_volume": scene_terrain_volume, "terrain_sky": scene_terrain_sky,
          "sunset_shadow": scene_sunset_shadow, "limb_vdb": scene_limb_vdb}


# ---- the sky mask ----------------------------------------------------------------------------

def pixel_rays(scene, cam, w, h):
    """World-space origin and unit directions through the pixel centres, rows from the top."""
    frame = [Vector(v) for v in cam.data.view_frame(scene=scene)]  # camera space: TR, BR, BL, TL
    tr, br, bl, tl = frame
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    U, V = np.meshgrid(u, v)
    tl, tr, bl = np.array(tl), np.array(tr), np.array(bl)
    p = tl[None, None, :] + U[..., None] * (tr - tl)[None, None, :] + V[..., None] * (bl - tl)[None, None, :]
    m = np.array(cam.matrix_world.to_3x3())
    d = p @ m.T
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.array(cam.matrix_world.translation), d


def sky_mask(scene, name):
    """Pixels whose camera ray hits no surface (neither the user's terrain nor the planet's
    ground, a sphere of radius R about (0, 0, −R)) and passes through the atmosphere (its
    closest approach to the planet's centre is below the top, R + 100 km): the sky the noise
    is measured over. Eroded by 2 pixels so that edges (anti-aliasing) do not count."""
    cam = scene.camera
    w, h = scene.render.resolution_x, scene.render.resolution_y
    o, d = pixel_rays(scene, cam, w, h)
    c = np.array([0.0, 0.0, -R_EARTH])
    oc = o - c
    b = d @ oc
    cc = oc @ oc
    disc_ground = b * b - (cc - R_EARTH * R_EARTH)
    hits_ground = (disc_ground > 0) & (-b - np.sqrt(np.maximum(disc_ground, 0)) > 0)
    top = R_EARTH + 100.0
    closest2 = cc - np.maximum(-b, 0.0) ** 2  # squared closest approach along the forward ray
    in_air = closest2 < top * top
    mask = ~hits_ground & in_air
    terrain = bpy.data.objects.get("Terrain")
    if terrain is not None:
        dg = bpy.context.evaluated_depsgraph_get()
        bvh = BVHTree.FromObject(terrain, dg)
        ov = Vector(o)
        flat = d.reshape(-1, 3)
        mflat = mask.reshape(-1)
        for i in np.nonzero(mflat)[0]:
            if bvh.ray_cast(ov, Vector(flat[i]))[0] is not None:
                mflat[i] = False
        mask = mflat.reshape(h, w)
    m = mask.copy()
    for _ in range(2):  # erosion by one pixel, 4-neighbourhood
        e = m.copy()
        e[1:, :] &= m[:-1, :]
        e[:-1, :] &= m[1:, :]
        e[:, 1:] &= m[:, :-1]
        e[:, :-1] &= m[:, 1:]
        m = e
    np.save(os.path.join(OUT, "%s_sky.npy" % name), m)
    return int(m.sum())


# ---- main ------------------------------------------------------------------------------------

def main():
    tmp = install_addon(args.zip)
    scene, s = fresh(tmp)
    t0 = time.time()
    extra = SCENES[args.scene](scene, s)
    build_seconds = time.time() - t0
    cy = scene.cycles
    scene.render.engine = "CYCLES"
    cy.device = "CPU"
    cy.samples = args.samples
    cy.seed = args.seed
    cy.use_denoising = False  # Debian's Blender has no OpenImageDenoise
    if hasattr(cy, "use_adaptive_sampling"):
        cy.use_adaptive_sampling = False  # the same samples everywhere: the noise is what the count gives
    cy.max_bounces = 4
    cy.diffuse_bounces = extra["diffuse_bounces"]
    cy.glossy_bounces = 0
    # transparent_max_bounces stays at Blender's default (8): entering and leaving the volume's
    # shell mesh are transparent bounces; at 0 the rays stop at the shell and the image is black.
    cy.volume_bounces = extra["volume_bounces"]
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = args.width, args.height, 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "ZIP"
    r.use_file_extension = False
    scene.view_settings.view_transform = "Standard"
    stem = os.path.join(OUT, "%s_seed%d" % (args.scene, args.seed))
    r.filepath = stem + ".exr.tmp"
    mask_pixels = sky_mask(scene, args.scene) if args.mask else None
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    os.replace(stem + ".exr.tmp", stem + ".exr")
    lamp = next((o for o in scene.objects if o.type == "LIGHT"), None)
    info = {
        "scene": args.scene, "seed": args.seed, "width": args.width, "height": args.height,
        "samples": args.samples, "render_seconds": round(seconds, 1), "build_seconds": round(build_seconds, 1),
        "threads": r.threads if r.threads_mode == "FIXED" else os.cpu_count(),
        "blender": bpy.app.version_string, "device": cy.device, "denoiser": "none",
        "max_bounces": cy.max_bounces, "diffuse_bounces": cy.diffuse_bounces, "volume_bounces": cy.volume_bounces,
        "volume_max_steps": cy.volume_max_steps, "filter": "%s %.2f px" % (cy.pixel_filter_type, cy.filter_width),
        "sun_elevation_deg": round(math.degrees(s.sun_elevation), 3),
        "sun_rotation_deg": round(math.degrees(s.sun_rotation), 3),
        "camera": {"location_km": list(scene.camera.location), "lens_mm": scene.camera.data.lens},
        "airmass": {"preset": s.preset, "volume_region": s.volume_region, "view_distance_km": s.view_distance,
                    "step_km": s.step_km, "volume_lighting": s.volume_lighting,
                    "volume_multiple": s.volume_multiple, "phase_mixing": s.phase_mixing, "sky_width": s.sky_width,
                    "sun_disc": s.sun_disc},
        "lamp": None if lamp is None else {"strength": lamp.data.energy, "colour": list(lamp.data.color),
                                           "angle_deg": math.degrees(lamp.data.angle)},
        "operators": REPORTS, "mask_pixels": mask_pixels,
    }
    with open(stem + ".json.tmp", "w", encoding="utf-8") as f:
        json.dump(info, f, indent=1)
    os.replace(stem + ".json.tmp", stem + ".json")
    print("showcase: %s seed %d: %d × %d, %d samples, %.1f s" % (args.scene, args.seed, args.width, args.height,
                                                                 args.samples, seconds))


main()
