"""Tests of the Blender add-on, run inside headless Blender:

    blender -b --factory-startup --python-exit-code 1 \\
        --python tests/blender/run_addon_tests.py -- --zip build/addon/airmass_blender.zip [-k NAME] [--keep]

The zip is installed into a temporary scripts folder (Preferences → File Paths → Scripts,
installed with target PREFS), enabled, and every test runs on a fresh startup scene
(wm.read_homefile). Independent references: the sun direction from Blender's Sky Texture
formula, densities from the preset's profiles written out here, coefficients read back
from the .vdb with pyopenvdb, pixel directions from Cycles' equirectangular mapping.
Exit code 1 (through --python-exit-code) when any test fails.
"""

import argparse
import math
import resource
import os
import shutil
import sys
import tempfile
import threading
import time
import traceback

import bpy
from mathutils import Vector

ADDON = "airmass_blender"
TESTS = []


def test(fn):
    TESTS.append(fn)
    return fn


class Ctx:
    zip = None
    tmp = None
    native = None  # the add-on's native module once enabled


def check(cond, message):
    if not cond:
        raise AssertionError(message)


def close(a, b, rel=1e-6, abs_=0.0, what=""):
    if not (abs(a - b) <= max(abs_, rel * max(abs(a), abs(b)))):
        raise AssertionError("%s: %r vs %r (rel %.3g)" % (what, a, b, abs(a - b) / max(1e-300, abs(b))))


# ---- setup --------------------------------------------------------------------------------

def install_addon(zip_path):
    scripts = os.path.join(Ctx.tmp, "scripts")
    os.makedirs(scripts, exist_ok=True)
    fp = bpy.context.preferences.filepaths
    if hasattr(fp, "script_directories"):  # Blender 4.2+
        entry = fp.script_directories.new()
        entry.directory = scripts
    else:
        fp.script_directory = scripts
    result = bpy.ops.preferences.addon_install(filepath=zip_path, target="PREFS", overwrite=True)
    check(result == {"FINISHED"}, "addon_install returned %s" % result)
    check(os.path.isfile(os.path.join(scripts, "addons", ADDON, "__init__.py")), "package not installed")
    bpy.utils.refresh_script_paths()
    bpy.ops.preferences.addon_enable(module=ADDON)
    import importlib
    Ctx.native = importlib.import_module(ADDON + ".native")


def fresh_scene(name):
    """Factory startup scene (cube, camera, light), our settings with a per-test output folder."""
    bpy.ops.wm.read_homefile(use_empty=False)
    scene = bpy.context.scene
    check(hasattr(scene, "airmass"), "scene.airmass missing after read_homefile")
    out = os.path.join(Ctx.tmp, "out", name)
    os.makedirs(out, exist_ok=True)
    s = scene.airmass
    s.output_folder = out
    s.preset = "earth"
    s.sky_width = 256
    s.view_samples = 8
    for o in list(bpy.data.objects):
        if o.type == "MESH":  # the default cube would sit inside the planet's ground
            bpy.data.objects.remove(o)
    return scene, out


def data_snapshot():
    return {k: len(getattr(bpy.data, k)) for k in ("objects", "meshes", "materials", "images", "worlds",
                                                  "volumes", "lights", "collections", "node_groups")}


def files_in(folder):
    out = []
    for root, _dirs, files in os.walk(folder):
        out += [os.path.join(root, f) for f in files]
    return sorted(out)


def ground_camera(scene, pitch_deg=5.0, heading_deg=0.0, altitude_km=0.002):
    """The scene camera above the origin, looking toward heading (0 = +Y, 90 = +X, as the Sky
    Texture's rotation: Z rotation −heading turns +Y to (sin h, cos h)) and pitched up."""
    cam = scene.camera
    cam.location = (0.0, 0.0, altitude_km)
    cam.rotation_mode = "XYZ"
    cam.rotation_euler = (math.radians(90.0 + pitch_deg), 0.0, math.radians(-heading_deg))
    cam.data.lens = 18.0
    cam.data.clip_start = 1e-4
    return cam


def render_tiny(scene, path, samples=4, width=32, height=18):
    """Cycles CPU, denoising off (Debian's Blender has no OIDN); returns the pixels as floats."""
    r = scene.render
    r.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    if hasattr(scene.cycles, "use_adaptive_sampling"):
        scene.cycles.use_adaptive_sampling = False
    scene.cycles.max_bounces = 2
    scene.cycles.volume_bounces = 1
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.filepath = path
    r.use_file_extension = False
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    seconds = time.time() - t0
    img = bpy.data.images.load(path, check_existing=False)
    try:
        px = list(img.pixels)
    finally:
        bpy.data.images.remove(img)
    rgb = [px[i + c] for i in range(0, len(px), 4) for c in range(3)]
    check(all(math.isfinite(v) for v in rgb), "render has NaN/Inf")
    mean = sum(rgb) / len(rgb)
    check(mean > 0.0 and max(rgb) > 0.0, "render is black (mean %g)" % mean)
    return rgb, mean, seconds


# ---- independent references -----------------------------------------------------------------

def sky_texture_sun(elevation, rotation):
    """Blender's Sky Texture sun direction (renderer-facts: rotation 0 → +Y, 90° → +X)."""
    return (math.cos(elevation) * math.sin(rotation), math.cos(elevation) * math.cos(rotation), math.sin(elevation))


def equirect_direction(x, y, width, height):
    """Direction through pixel (x, y) (y = 0 TOP row), inverting Cycles'
    u = (atan2(d.y, d.x) − π)/(−2π), v = (acos(d.z) − π)/(−π)."""
    u = (x + 0.5) / width
    v = 1.0 - (y + 0.5) / height
    phi = math.pi - 2.0 * math.pi * u
    theta = math.pi - math.pi * v  # acos(d.z) = π − π v
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))


def angle_deg(a, b):
    d = sum(x * y for x, y in zip(a, b)) / math.sqrt(sum(x * x for x in a) * sum(y * y for y in b))
    return math.degrees(math.acos(max(-1.0, min(1.0, d))))


# Density profiles of the `earth` preset (examples/earth.toml), km.
EARTH_PROFILES = {
    "rayleigh": lambda h: math.exp(-h / 8.0),
    "mie": lambda h: math.exp(-h / 1.2),
    "ozone": lambda h: max(0.0, min((h - 10.0) / 15.0, (40.0 - h) / 15.0)),
}
EARTH_R_KM, EARTH_TOP_KM = 6360.0, 6420.0


def _bilinear_extend(image, uv):
    """Cycles' Linear + Extend lookup of an image: texel centres at (i + 0.5)/width, indices
    clamped to the edge; RGB."""
    import numpy as np
    w, h = image.size
    px = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, 4).astype(np.float64)
    x, y = uv[0] * w - 0.5, uv[1] * h - 0.5
    i0, j0 = math.floor(x), math.floor(y)
    fx, fy = x - i0, y - j0
    ci = lambda i: min(w - 1, max(0, i))  # noqa: E731
    cj = lambda j: min(h - 1, max(0, j))  # noqa: E731
    v = ((1 - fx) * (1 - fy) * px[cj(j0), ci(i0)] + fx * (1 - fy) * px[cj(j0), ci(i0 + 1)]
         + (1 - fx) * fy * px[cj(j0 + 1), ci(i0)] + fx * fy * px[cj(j0 + 1), ci(i0 + 1)])
    return (float(v[0]), float(v[1]), float(v[2]))


def evaluate_socket(socket, position, cache=None):
    """Evaluates a Math/VectorMath/Texture Coordinate node graph in double precision, with
    Texture Coordinate "Object" = `position` — an independent check of what Cycles computes."""
    cache = {} if cache is None else cache
    node = socket.node
    key = (node.name, socket.identifier)
    if key in cache:
        return cache[key]

    def inp(i):
        s = node.inputs[i]
        if s.is_linked:
            return evaluate_socket(s.links[0].from_socket, position, cache)
        v = s.default_value
        return tuple(v) if hasattr(v, "__len__") else float(v)

    t = node.bl_idname
    if t == "ShaderNodeTexCoord":
        check(socket.name == "Object", "unexpected coordinate output %s" % socket.name)
        val = tuple(position)
    elif t == "ShaderNodeNewGeometry":
        check(socket.name in ("Position", "Incoming"), "unexpected geometry output %s" % socket.name)
        val = tuple(position) if socket.name == "Position" else tuple(cache["incoming"])
    elif t == "ShaderNodeCombineXYZ":
        val = (inp(0), inp(1), inp(2))
    elif t == "ShaderNodeSeparateXYZ":
        val = inp(0)["XYZ".index(socket.name)]
    elif t == "ShaderNodeTexImage":
        check(socket.name == "Color" and node.interpolation == "Linear" and node.extension == "EXTEND",
              "unexpected image lookup %s %s %s" % (socket.name, node.interpolation, node.extension))
        val = _bilinear_extend(node.image, inp(0))
    elif t == "ShaderNodeTexWhiteNoise":
        # Cycles' hash of the position; here the caller's draw u in [0, 1), cache["white noise"].
        check(socket.name == "Value", "unexpected white noise output %s" % socket.name)
        val = cache["white noise"]
    elif t == "ShaderNodeRGB":
        val = tuple(socket.default_value)
    elif t == "ShaderNodeMixRGB":
        check(node.blend_type == "MIX" and not node.use_clamp, "unexpected mix %s" % node.blend_type)
        f, c1, c2 = inp(0), inp(1), inp(2)
        val = tuple(a + f * (b - a) for a, b in zip(c1, c2))
    elif t == "ShaderNodeMix":
        check(node.data_type == "RGBA" and node.blend_type == "MIX" and not node.clamp_factor
              and not node.clamp_result, "unexpected mix %s %s" % (node.data_type, node.blend_type))
        check(socket.identifier == "Result_Color", "unexpected mix output %s" % socket.identifier)
        ids = [i.identifier for i in node.inputs]
        f, c1, c2 = inp(ids.index("Factor_Float")), inp(ids.index("A_Color")), inp(ids.index("B_Color"))
        val = tuple(a + f * (b - a) for a, b in zip(c1, c2))
    elif t == "ShaderNodeVectorMath":
        a, b = inp(0), inp(1)
        check(node.operation == "DOT_PRODUCT", "unexpected vector op %s" % node.operation)
        val = sum(x * y for x, y in zip(a, b))
    elif t == "ShaderNodeMath":
        a, b, c = inp(0), inp(1), inp(2)
        op = node.operation
        val = {
            "ADD": lambda: a + b, "SUBTRACT": lambda: a - b, "MULTIPLY": lambda: a * b,
            "DIVIDE": lambda: a / b if b != 0 else 0.0, "MULTIPLY_ADD": lambda: a * b + c,
            "SQRT": lambda: math.sqrt(a) if a > 0 else 0.0, "EXPONENT": lambda: math.exp(a),
            "MINIMUM": lambda: min(a, b), "MAXIMUM": lambda: max(a, b),
            "LESS_THAN": lambda: 1.0 if a < b else 0.0, "GREATER_THAN": lambda: 1.0 if a > b else 0.0,
            "POWER": lambda: a ** b if a > 0 else 0.0,
            "ARCSINE": lambda: math.asin(a) if -1.0 <= a <= 1.0 else 0.0,
        }[op]()
        if node.use_clamp:
            val = min(1.0, max(0.0, val))
    else:
        raise AssertionError("node %s (%s) in a density expression" % (node.name, t))
    cache[key] = val
    return val


# ---- tests ----------------------------------------------------------------------------------

@test
def test_registered():
    scene, _ = fresh_scene("registered")
    n = Ctx.native
    check(n.load_error() is None, "library: %s" % n.load_error())
    check(n.version(), "no version")
    for op in ("generate_sky", "sun_sync", "create_volume", "compare"):
        check(hasattr(bpy.ops.airmass, op), "operator airmass.%s missing" % op)
    for panel in ("AIRMASS_PT_world", "AIRMASS_PT_view3d"):
        check(hasattr(bpy.types, panel), "panel %s missing" % panel)
    s = scene.airmass
    for prop in ("preset", "sun_elevation", "sun_rotation", "altitude", "planet_radius", "atmosphere_top",
                 "constituents", "basis", "chapman", "view_samples", "output_folder"):
        check(hasattr(s, prop), "scene.airmass.%s missing" % prop)
    check("earth" in n.preset_names(), "preset list")
    # The constituent list follows the preset.
    s.preset = "mars"
    s.preset = "earth"
    check([c.name for c in s.constituents] == ["rayleigh", "mie", "ozone"],
          "constituents %s" % [c.name for c in s.constituents])


@test
def test_generate_sky_world_and_orientation():
    scene, out = fresh_scene("sky")
    s = scene.airmass
    s.sun_elevation = math.radians(20.0)
    s.sun_rotation = math.radians(30.0)
    s.sun_disc = True
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "generate_sky failed")
    world = scene.world
    tree = world.node_tree
    env, bg = tree.nodes.get("Airmass Sky"), tree.nodes.get("Airmass Background")
    check(env is not None and bg is not None, "Airmass nodes missing")
    check(env.bl_idname == "ShaderNodeTexEnvironment" and env.projection == "EQUIRECTANGULAR", "env node")
    out_node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld" and n.is_active_output)
    check(out_node.inputs["Surface"].links[0].from_node == bg, "Background not wired to the World Output")
    check(bg.inputs["Color"].links[0].from_node == env, "Environment not wired to the Background")
    close(bg.inputs["Strength"].default_value, s.sky_strength, what="background strength")
    img = env.image
    check(img is not None and tuple(img.size) == (256, 128), "image size %s" % (tuple(img.size),))
    check(img.name == "Airmass Sky" and img.is_float and img.packed_file is not None, "image not a packed float")
    check(img.colorspace_settings.name == "Linear", "colour space %s (Blender 3.4's linear: 'Linear')"
          % img.colorspace_settings.name)
    n = Ctx.native
    check(img.get("airmass:version") == n.version(), "metadata airmass:version %r" % img.get("airmass:version"))
    check('"width":256' in str(img.get("airmass:settings", "")).replace(" ", ""), "metadata airmass:settings")
    exr = os.path.join(out, "%s_sky.exr" % bpy.path.clean_name(scene.name))
    check(os.path.isfile(exr) and os.path.normpath(bpy.path.abspath(img.filepath_raw)) == exr,
          "EXR %s missing or not the image's file (%s)" % (exr, img.filepath_raw))
    # The pixels are the library's sky, rows flipped (Blender's rows start at the bottom), exactly.
    import numpy as np
    props = __import__(ADDON + ".properties", fromlist=["x"])
    ref, _ = n.render_sky(props.make_spec(s), width=256, view_samples=s.view_samples, chapman=s.chapman,
                          sun_disc=True, grid=s.sky_grid, multiple_scattering=s.multiple_scattering)
    got = np.empty(256 * 128 * 4, dtype=np.float32)
    img.pixels.foreach_get(got)
    check(np.array_equal(got.reshape(128, 256, 4), ref[::-1]),
          "image pixels differ from the library's sky (max %g)" % np.abs(got.reshape(128, 256, 4) - ref[::-1]).max())
    check(not np.array_equal(ref, ref[::-1]), "the sky is symmetric top/bottom: the flip test means nothing")

    # Brightest pixel (the sun disc) is where the Sky Texture formula puts the sun, and where
    # the synced lamp points from.
    w, h = img.size
    px = got.tolist()  # bottom row first
    best, best_xy = -1.0, None
    for j in range(h):
        for i in range(w):
            k = 4 * (j * w + i)
            lum = 0.2126 * px[k] + 0.7152 * px[k + 1] + 0.0722 * px[k + 2]
            if lum > best:
                best, best_xy = lum, (i, h - 1 - j)
    check(all(math.isfinite(v) for v in px), "sky has NaN/Inf")
    d = equirect_direction(best_xy[0], best_xy[1], w, h)
    expected = sky_texture_sun(s.sun_elevation, s.sun_rotation)
    pixel_deg = 360.0 / w
    check(angle_deg(d, expected) < 1.5 * pixel_deg,
          "brightest pixel at %.2f° from the sun (pixel %.2f°)" % (angle_deg(d, expected), pixel_deg))
    check(bpy.ops.airmass.sun_sync(direction="TO_LAMP") == {"FINISHED"}, "sun_sync failed")
    lamp = s.sun_object
    toward_sun = lamp.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, 1))
    check(angle_deg(d, tuple(toward_sun)) < 1.5 * pixel_deg, "lamp does not point from the brightest pixel")

    # Re-running replaces: same nodes, one image, one world.
    before = data_snapshot()
    node_names = sorted(n.name for n in tree.nodes)
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "second generate_sky failed")
    check(sorted(n.name for n in scene.world.node_tree.nodes) == node_names, "nodes duplicated on re-run")
    check(data_snapshot() == before, "datablocks changed on re-run: %s vs %s" % (data_snapshot(), before))
    check(len([i for i in bpy.data.images if i.name.startswith("Airmass Sky")]) == 1, "images duplicated")
    check(len([f for f in files_in(out) if "airmass-tmp" in f]) == 0, "temporary files left")
    check([f for f in files_in(out) if f.endswith(".exr")] == [exr], "files %s" % files_in(out))
    # EEVEE's sun extraction (4.2+) is not in 3.4: nothing to switch off, nothing set.
    check(not hasattr(scene.world, "sun_threshold"), "3.4 has World.sun_threshold?")

    rgb, mean, sec = render_tiny(scene, os.path.join(out, "render_sky.exr"))
    print("    sky render: mean %.4g, %.2f s" % (mean, sec))


def _image_pixels(img):
    import numpy as np
    a = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
    img.pixels.foreach_get(a)
    return a.reshape(img.size[1], img.size[0], 4)


@test
def test_generate_sky_unsaved_factory_defaults():
    """A new, unsaved file with the factory defaults (Output Folder '//airmass/'): the first
    Generate Sky works, writes no file, and the image is packed — and survives save + reload
    with the same pixels. Once the .blend is saved, '//airmass/' resolves: the EXR written
    there holds exactly the packed pixels."""
    import numpy as np
    bpy.ops.wm.read_homefile(use_empty=False)
    scene = bpy.context.scene
    s = scene.airmass
    check(bpy.data.filepath == "" and s.output_folder == "//airmass/", "not a new file with factory defaults: %r %r"
          % (bpy.data.filepath, s.output_folder))
    check(s.sky_width == 1024, "factory sky width %d" % s.sky_width)
    cwd_before = sorted(os.listdir(os.getcwd()))
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "first Generate Sky in an unsaved file failed")
    img = scene.world.node_tree.nodes["Airmass Sky"].image
    check(img is not None and img.packed_file is not None and img.is_float, "image not packed")
    check(tuple(img.size) == (1024, 512) and img.filepath_raw == "", "image %s %r" % (tuple(img.size),
                                                                                     img.filepath_raw))
    check(sorted(os.listdir(os.getcwd())) == cwd_before, "files written next to the working folder")
    px = _image_pixels(img)
    check(np.isfinite(px).all() and px[..., :3].max() > 0.0 and (px[..., 3] == 1.0).all(), "sky pixels")
    meta = {k: img[k] for k in img.keys() if k.startswith("airmass:")}
    check("airmass:version" in meta and "airmass:scene" in meta, "metadata %s" % sorted(meta))
    # Save, reload: still packed, the same pixels, the same metadata.
    folder = os.path.join(Ctx.tmp, "unsaved")
    os.makedirs(folder, exist_ok=True)
    blend = os.path.join(folder, "sky.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    bpy.ops.wm.open_mainfile(filepath=blend)
    scene = bpy.context.scene
    img = scene.world.node_tree.nodes["Airmass Sky"].image
    check(img is not None and img.packed_file is not None, "image not packed after reload")
    check(np.array_equal(_image_pixels(img), px), "pixels changed by save + reload")
    check({k: img[k] for k in img.keys() if k.startswith("airmass:")} == meta, "metadata changed by reload")
    check(sorted(os.listdir(folder)) == ["sky.blend"], "files next to the .blend: %s" % os.listdir(folder))
    # Saved: '//airmass/' now resolves, and the EXR there is the packed image.
    s = scene.airmass
    s.sky_width = 128
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "Generate Sky in the saved file failed")
    img = scene.world.node_tree.nodes["Airmass Sky"].image
    exr = os.path.join(folder, "airmass", "%s_sky.exr" % bpy.path.clean_name(scene.name))
    check(os.path.isfile(exr), "EXR not written to %s" % exr)
    check(files_in(os.path.join(folder, "airmass")) == [exr], "files %s" % files_in(os.path.join(folder, "airmass")))
    check(img.packed_file is not None and tuple(img.size) == (128, 64), "new image not packed")
    import OpenImageIO as oiio  # Debian's Blender sees the system's Python modules
    buf = oiio.ImageBuf(exr)
    spec = buf.spec()
    check((spec.width, spec.height, spec.nchannels, str(spec.format)) == (128, 64, 4, "float"),
          "EXR %dx%d×%d %s" % (spec.width, spec.height, spec.nchannels, spec.format))
    on_disk = np.asarray(buf.get_pixels(oiio.FLOAT)).reshape(64, 128, 4)  # top row first
    check(np.array_equal(on_disk[::-1], _image_pixels(img)), "the saved EXR differs from the packed pixels")
    check(len([i for i in bpy.data.images if i.name.startswith("Airmass Sky")]) == 1,
          "images duplicated: %s" % [i.name for i in bpy.data.images])


@test
def test_sun_sync_both_ways():
    scene, _ = fresh_scene("sun")
    s = scene.airmass
    lights_before = len(bpy.data.lights)
    s.sun_elevation, s.sun_rotation = math.radians(60.0), math.radians(90.0)
    check(bpy.ops.airmass.sun_sync(direction="TO_LAMP") == {"FINISHED"}, "sun_sync failed")
    lamp = s.sun_object
    check(lamp is not None and lamp.data.type == "SUN", "no Sun lamp")
    from mathutils import Vector
    z = lamp.matrix_world.to_3x3() @ Vector((0, 0, 1))
    check(angle_deg(tuple(z), sky_texture_sun(s.sun_elevation, s.sun_rotation)) < 1e-4, "lamp direction")
    check(angle_deg(tuple(z), (0.5, 0.0, math.sqrt(3) / 2)) < 1e-4, "rotation 90° must point the sun toward +X")
    # Strength × colour = the library's transmitted irradiance.
    n = Ctx.native
    from importlib import import_module
    props = import_module(ADDON + ".properties")
    light = n.sun_light(props.make_spec(s), chapman=s.chapman)
    for c in range(3):
        close(lamp.data.energy * lamp.data.color[c], light["irradiance_rgb"][c], rel=1e-5, what="lamp rgb %d" % c)
    check(max(lamp.data.color) == 1.0 or abs(max(lamp.data.color) - 1.0) < 1e-6, "colour not normalised")
    noon_ratio = lamp.data.color[2] / lamp.data.color[0]
    noon_strength = lamp.data.energy
    # Re-run: no second lamp.
    check(bpy.ops.airmass.sun_sync(direction="TO_LAMP") == {"FINISHED"}, "second sun_sync failed")
    check(len(bpy.data.lights) == lights_before + 1, "lamp duplicated")
    # Lamp → settings.
    lamp.rotation_euler = (math.radians(90.0 - 3.0), 0.0, math.radians(180.0 - 250.0))
    bpy.context.view_layer.update()
    check(bpy.ops.airmass.sun_sync(direction="FROM_LAMP") == {"FINISHED"}, "FROM_LAMP failed")
    close(math.degrees(s.sun_elevation), 3.0, abs_=1e-4, what="elevation from lamp")
    close(math.degrees(s.sun_rotation) % 360.0, 250.0, abs_=1e-4, what="rotation from lamp")
    # Low sun: dimmer and redder.
    check(lamp.data.energy < noon_strength, "low sun not dimmer")
    check(lamp.data.color[2] / lamp.data.color[0] < noon_ratio, "low sun not redder")
    # Below the horizon: no direct light.
    s.sun_elevation = math.radians(-10.0)
    check(bpy.ops.airmass.sun_sync(direction="TO_LAMP") == {"FINISHED"}, "sun_sync below horizon")
    check(lamp.data.energy == 0.0, "sun below the horizon still lights (%g)" % lamp.data.energy)
    # Live sync (the update callback's hook that sun.py registers): changing the angles moves
    # the lamp without an operator; with live sync off it stays.
    s.sun_live_sync = True
    s.sun_elevation, s.sun_rotation = math.radians(35.0), math.radians(120.0)
    bpy.context.view_layer.update()
    z = lamp.matrix_world.to_3x3() @ Vector((0, 0, 1))
    check(angle_deg(tuple(z), sky_texture_sun(s.sun_elevation, s.sun_rotation)) < 1e-4, "live sync did not move the lamp")
    check(lamp.data.energy > 0.0, "live sync did not relight the lamp")
    s.sun_live_sync = False
    s.sun_elevation = math.radians(10.0)
    bpy.context.view_layer.update()
    z = lamp.matrix_world.to_3x3() @ Vector((0, 0, 1))
    check(angle_deg(tuple(z), sky_texture_sun(math.radians(35.0), math.radians(120.0))) < 1e-4,
          "the lamp moved with live sync off")


def check_closed_shell(obj, center, r_ground, r_top, theta):
    """The domain mesh is closed (every edge shared by two faces), oriented outward (its
    signed volume, by the divergence theorem over fan-triangulated faces, is the volume of
    the spherical shell sector between its inner and outer radii), and contains the whole
    atmosphere: every face of the outer boundary lies outside the top sphere, every vertex
    of the inner boundary inside the ground."""
    from mathutils import Vector
    mesh = obj.data
    counts = {}
    for p in mesh.polygons:
        for key in p.edge_keys:
            counts[key] = counts.get(key, 0) + 1
    bad = [k for k, c in counts.items() if c != 2]
    check(not bad, "%d non-manifold edges (e.g. %s)" % (len(bad), bad[:3]))
    c = Vector(center)
    co = [obj.matrix_world @ v.co for v in mesh.vertices]
    dist = [(v - c).length for v in co]
    r_out, r_in = max(dist), min(dist)
    check(r_in <= r_ground, "inner boundary %.6g above the ground %.6g" % (r_in, r_ground))
    outer_faces = [p for p in mesh.polygons if min(dist[i] for i in p.vertices) > 0.5 * (r_ground + r_top)]
    lowest = min(((sum((co[i] for i in p.vertices), Vector()) / len(p.vertices)) - c).length for p in outer_faces)
    check(lowest >= r_top, "an outer face dips below the atmosphere top (%.9g < %.9g)" % (lowest, r_top))
    o = co[0]
    vol = 0.0
    for p in mesh.polygons:
        idx = list(p.vertices)
        a = co[idx[0]] - o
        for i in range(1, len(idx) - 1):
            vol += a.dot((co[idx[i]] - o).cross(co[idx[i + 1]] - o)) / 6.0
    expected = 2.0 * math.pi / 3.0 * (r_out ** 3 - r_in ** 3) * (1.0 - math.cos(theta))
    # Faceting: the polyhedron lies within ~(π/256)² of its sphere, amplified ×36 by the
    # thin shell: 1 % is loose for that and tight for a wrong or inside-out face set.
    close(vol, expected, rel=1e-2, what="shell volume")


def _atmosphere_objects(scene):
    return [o for o in scene.objects if o.get("airmass_role") == "atmosphere"]


def _scatter_nodes(mat):
    return {n.name: n for n in mat.node_tree.nodes if n.bl_idname in ("ShaderNodeVolumeScatter",
                                                                      "ShaderNodeVolumeAbsorption")}


def _scattering_rgb(mat, name):
    """σs of a constituent: its own Volume Scatter, or its share of the dithered one."""
    nodes = mat.node_tree.nodes
    if nodes.get("%s scatter" % name) is not None:
        return _coefficient_rgb(nodes["%s scatter" % name])
    weight, colour = nodes["%s scatter weight" % name], nodes["%s scatter colour" % name]
    m = weight.inputs[1].default_value
    return [colour.outputs[0].default_value[i] * m for i in range(3)]


def _density_source(mat, name):
    """The socket of a constituent's relative density ρ (before its coefficient)."""
    nodes = mat.node_tree.nodes
    weight = nodes.get("%s scatter weight" % name)
    if weight is not None:
        return weight.inputs[0].links[0].from_socket
    node = nodes.get("%s scatter" % name) or nodes.get("%s absorption" % name)
    return node.inputs["Density"].links[0].from_node.inputs[0].links[0].from_socket  # ρ × D


def henyey_greenstein(g, cos_theta):
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * cos_theta) ** 1.5)


def check_dithered_mixture(mat, constituents, points):
    """The dithered Volume Scatter, averaged over the White Noise draw u, equals the sum of
    the constituents' own closures: per channel E_u[colour·density·HG(g(u))] = Σ σs_j ρ_j HG(g_j)."""
    node = mat.node_tree.nodes["scatter (dithered)"]
    sockets = {k: node.inputs[k].links[0].from_socket for k in ("Color", "Density", "Anisotropy")}
    n = 4000
    for p in points:
        for mu in (-0.6, 0.2, 0.97):
            mean = [0.0, 0.0, 0.0]
            for k in range(n):
                cache = {"white noise": (k + 0.5) / n}
                col = evaluate_socket(sockets["Color"], p, cache)
                dens = evaluate_socket(sockets["Density"], p, cache)
                ph = henyey_greenstein(evaluate_socket(sockets["Anisotropy"], p, cache), mu)
                for c in range(3):
                    mean[c] += col[c] * dens * ph / n
            want = [0.0, 0.0, 0.0]
            for c in constituents:
                if max(c["scattering_rgb"]) <= 0:
                    continue
                rho = evaluate_socket(_density_source(mat, c["name"]), p, {})
                ph = henyey_greenstein(hg_g(c), mu)
                for i in range(3):
                    want[i] += c["scattering_rgb"][i] * rho * ph
            for i in range(3):
                # the draw's grid puts each share's edge within 1/n: relative error ≤ 2/n
                close(mean[i], want[i], rel=2e-3, abs_=1e-15, what="dithered mixture ch%d at %s, μ=%g" % (i, p, mu))


def hg_g(c):
    phase, g = c.get("phase", "isotropic"), float(c.get("g", 0.0))
    if phase == "henyey_greenstein":
        return g
    if phase == "cornette_shanks":
        return 3.0 * g * (4.0 + g * g) / (5.0 * (2.0 + g * g))
    return 0.0


def _coefficient_rgb(node):
    col = node.inputs["Color"].default_value
    dens = node.inputs["Density"]
    # Density = ρ × D: the constant D is the second input of the MULTIPLY feeding it.
    if dens.is_linked:
        mul = dens.links[0].from_node
        D = mul.inputs[1].default_value
    else:
        D = dens.default_value
    if node.bl_idname == "ShaderNodeVolumeScatter":
        return [col[i] * D for i in range(3)]
    return [(1.0 - col[i]) * D for i in range(3)]


@test
def test_analytic_volume():
    scene, out = fresh_scene("analytic")
    s = scene.airmass
    s.sun_elevation = math.radians(25.0)
    cam = ground_camera(scene, pitch_deg=4.0)
    check(bpy.ops.airmass.sun_sync() == {"FINISHED"}, "sun_sync before the volume")
    scene.cycles.transparent_max_bounces = 0  # Cycles then stops every path at the shell: dark
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume ANALYTIC failed")
    check(scene.cycles.transparent_max_bounces == 8, "transparent bounces %d for the shell (want 8)"
          % scene.cycles.transparent_max_bounces)
    # With a volume in the scene Cycles attenuates the lamp itself: it now carries the
    # top-of-atmosphere irradiance, not the transmitted one.
    props = __import__(ADDON + ".properties", fromlist=["x"])
    light = Ctx.native.sun_light(props.make_spec(s), chapman=s.chapman)
    lamp = s.sun_object
    for c in range(3):
        close(lamp.data.energy * lamp.data.color[c], light["irradiance_top_rgb"][c], rel=1e-5,
              what="lamp carries top-of-atmosphere rgb %d" % c)
    objs = _atmosphere_objects(scene)
    check(len(objs) == 1 and objs[0].type == "MESH", "one shell mesh expected, got %s" % objs)
    obj = objs[0]
    mat = obj.active_material
    check(mat is not None and mat.node_tree.nodes.get("Material Output").inputs["Volume"].is_linked, "no volume")
    # Coefficients equal the library's analytic description (RGB per km at density 1).
    desc = Ctx.native.analytic_density(__import__(ADDON + ".properties", fromlist=["x"]).make_spec(s), unit="km")
    nodes = _scatter_nodes(mat)
    for c in desc["constituents"]:
        if max(c["scattering_rgb"]) > 0:
            got = _scattering_rgb(mat, c["name"])
            for i in range(3):
                close(got[i], c["scattering_rgb"][i], rel=1e-6, what="%s σs[%d]" % (c["name"], i))
        if max(c["absorption_rgb"]) > 0:
            got = _coefficient_rgb(nodes["%s absorption" % c["name"]])
            for i in range(3):
                close(got[i], c["absorption_rgb"][i], rel=1e-5, abs_=1e-12, what="%s σa[%d]" % (c["name"], i))
    # Blender 3.4: the Rayleigh (g = 0) and Cornette–Shanks aerosol phases share one dithered
    # Volume Scatter (Phase Mixing, the default); its mean over the draw is the two closures'
    # sum, with Cornette–Shanks as Henyey–Greenstein of the same mean cosine.
    check(s.phase_mixing == "DITHER" and "scatter (dithered)" in mat.node_tree.nodes, "dithered scatter missing")
    check(not any(n.bl_idname == "ShaderNodeVolumeScatter" and n.name != "scatter (dithered)"
                  for n in mat.node_tree.nodes), "a second Volume Scatter next to the dithered one")
    close(hg_g({"phase": "cornette_shanks", "g": 0.8}), 3 * 0.8 * (4 + 0.64) / (5 * (2 + 0.64)), rel=1e-12,
          what="Cornette–Shanks mean cosine")
    R = EARTH_R_KM
    check_dithered_mixture(mat, desc["constituents"],
                           [tuple(d[i] * (R + h) - (R if i == 2 else 0.0) for i in range(3))
                            for h, d in ((0.3, (0.0, 0.0, 1.0)), (2.0, (0.6, 0.0, 0.8)), (14.0, (0.0, -1.0, 0.0)))])
    # Densities: evaluate the node graph at points of known altitude (independent profiles).
    for name, rho in EARTH_PROFILES.items():
        src = _density_source(mat, name)
        for h in (0.0005, 0.3, 1.0, 5.0, 12.0, 25.0, 33.3, 59.9):
            for direction in ((0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.0, -1.0, 0.0)):
                # The point at altitude h in `direction` from the planet centre (0, 0, −R).
                p = tuple(direction[i] * (R + h) - (R if i == 2 else 0.0) for i in range(3))
                got = evaluate_socket(src, p)
                # Node constants are float32 (relative 6e-8); 1e-6 leaves room for the
                # exponent's amplification (|h/H| ≤ 50) and nothing for a wrong formula.
                close(got, rho(h), rel=1e-6, abs_=1e-9, what="%s density at h=%g km" % (name, h))
        for h in (60.5, -0.2):  # above the top and below the ground: 0
            p = (0.0, 0.0, h)
            check(evaluate_socket(src, p) == 0.0, "%s not 0 at h=%g" % (name, h))
    # Separate closures on request: one Volume Scatter per constituent with its own g.
    s.phase_mixing = "SEPARATE"
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume SEPARATE failed")
    mat = _atmosphere_objects(scene)[0].active_material
    nodes = _scatter_nodes(mat)
    check("scatter (dithered)" not in nodes, "dithered scatter with SEPARATE")
    close(nodes["mie scatter"].inputs["Anisotropy"].default_value, hg_g({"phase": "cornette_shanks", "g": 0.8}),
          rel=1e-6, what="Mie g")
    close(nodes["rayleigh scatter"].inputs["Anisotropy"].default_value, 0.0, abs_=1e-12, what="Rayleigh g")
    for c in desc["constituents"]:
        if max(c["scattering_rgb"]) > 0:
            got = _scattering_rgb(mat, c["name"])
            for i in range(3):
                close(got[i], c["scattering_rgb"][i], rel=1e-6, what="%s σs[%d] (separate)" % (c["name"], i))
    s.phase_mixing = "DITHER"
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume DITHER failed")
    obj = _atmosphere_objects(scene)[0]
    # The domain: a closed shell cap around the camera, from the ground to the top.
    theta = min(math.pi, 1.05 * s.view_distance / R + 1e-3)
    check_closed_shell(obj, (0.0, 0.0, -R), R, EARTH_TOP_KM, theta)
    # Planet-scale scene settings.
    check(abs(scene.unit_settings.scale_length - 1000.0) < 1e-9, "km units not set")
    check(cam.data.clip_end >= EARTH_TOP_KM + EARTH_R_KM, "camera clip end %g" % cam.data.clip_end)
    grounds = [o for o in scene.objects if o.get("airmass_role") == "ground"]
    check(len(grounds) == 1, "ground sphere")

    before = data_snapshot()
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "second create_volume failed")
    check(data_snapshot() == before, "re-run changed datablock counts: %s vs %s" % (data_snapshot(), before))
    check(len(_atmosphere_objects(scene)) == 1, "atmosphere duplicated")

    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "sky for the volume scene")
    rgb, mean, sec = render_tiny(scene, os.path.join(out, "render_analytic.exr"))
    print("    analytic render: mean %.4g, %.2f s" % (mean, sec))

    # The whole planet: a closed shell from just inside the ground to just outside the top.
    s.volume_region = "PLANET"
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume PLANET failed")
    objs = _atmosphere_objects(scene)
    check(len(objs) == 1, "atmosphere duplicated after a region change")
    check_closed_shell(objs[0], (0.0, 0.0, -R), R, EARTH_TOP_KM, math.pi)


def _sun_column_reference(p, s_dir, profile, R, top, pieces=4000):
    """∫ρ ds from p (scene frame, km; planet centre (0, 0, −R)) toward s_dir to the top, by
    composite 8-point Gauss–Legendre on uniform pieces (independent of the library's table)."""
    import numpy as np
    v = np.array([p[0], p[1], p[2] + R])
    r = float(np.linalg.norm(v))
    r_mu = float(np.dot(v, s_dir))
    t_top = -r_mu + math.sqrt(r_mu * r_mu + top * top - r * r)
    x, w = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0.0, t_top, pieces + 1)
    mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * (edges[1:] - edges[:-1])
    t = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    h = np.sqrt(r * r + t * t + 2.0 * r_mu * t) - R
    rho = np.array([profile(hh) if hh <= top - R else 0.0 for hh in h])
    return float(np.sum(rho.reshape(pieces, 8) * w[None, :] * half[:, None]))


@test
def test_analytic_sun():
    """Lighting: Analytic Sun — the scatterers only absorb and one Emission carries the
    single-scattered sunlight. Its colour, evaluated from the node graph at points and ray
    directions, equals σs ρ P E_top exp(−Σ σt m) written out here: the preset's profiles, the
    phase formulas, the masses toward the sun by quadrature (only the coefficients and the sun's
    irradiance come from the library). The table's bilinear lookup is the error budget."""
    import numpy as np
    scene, out = fresh_scene("analytic_sun")
    s = scene.airmass
    s.sun_elevation, s.sun_rotation = math.radians(8.0), math.radians(30.0)
    ground_camera(scene, pitch_deg=4.0)
    s.volume_lighting = "SUN_EMISSION"
    check(s.volume_multiple, "Multiple Scattering is the Analytic Sun's default")
    s.volume_multiple = False  # single scattering first; the multiple-scattering term is checked below
    check(bpy.ops.airmass.sun_sync() == {"FINISHED"}, "sun_sync")
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume ANALYTIC (Analytic Sun)")
    mat = _atmosphere_objects(scene)[0].active_material
    nodes = mat.node_tree.nodes
    check(not any(n.bl_idname == "ShaderNodeVolumeScatter" for n in nodes), "a Volume Scatter with Analytic Sun")
    check(nodes.get("sun emission") is not None, "no sun emission")
    props = __import__(ADDON + ".properties", fromlist=["x"])
    spec = props.make_spec(s)
    desc = Ctx.native.analytic_density(spec, unit="km")
    light = Ctx.native.sun_light(spec, chapman=s.chapman)
    for c in desc["constituents"]:
        if max(c["scattering_rgb"]) > 0:
            got = _coefficient_rgb(nodes["%s extinction" % c["name"]])
            for i in range(3):
                close(got[i], c["scattering_rgb"][i], rel=1e-5,
                      what="%s extinction σs[%d]" % (c["name"], i))
    s_dir = np.array(light["direction"])
    E = light["irradiance_top_rgb"]
    R, top = EARTH_R_KM, EARTH_TOP_KM
    alpha = 0.5 * math.radians(light["angular_diameter_deg"])

    def phase(kind, g, c):
        if kind == "rayleigh":
            return 3.0 / (16.0 * math.pi) * (1.0 + c * c)
        if kind == "cornette_shanks":
            return 3.0 / (8.0 * math.pi) * (1 - g * g) * (1 + c * c) / ((2 + g * g) * (1 + g * g - 2 * g * c) ** 1.5)
        check(kind == "isotropic", "phase %s" % kind)
        return 1.0 / (4.0 * math.pi)

    colour = nodes["sun emission"].inputs["Color"].links[0].from_socket
    worst = 0.0
    up = np.array([0.0, 0.0, 1.0])
    horizontal = np.cross(up, s_dir)
    horizontal /= np.linalg.norm(horizontal)
    cases = []
    for h in (0.05, 1.0, 6.0, 22.0, 45.0):
        for direction in (up, np.array([0.6, 0.0, 0.8]), np.array([0.0, -0.8, 0.6]), horizontal):
            for incoming in (-s_dir, np.array([0.0, 0.0, -1.0]), np.array([0.48, 0.6, -0.64])):
                cases.append((h, direction / np.linalg.norm(direction), incoming / np.linalg.norm(incoming)))
    for h, direction, incoming in cases:
        p = direction * (R + h) - np.array([0.0, 0.0, R])
        v = p + np.array([0.0, 0.0, R])
        r, r_mu = float(np.linalg.norm(v)), float(np.dot(v, s_dir))
        elevation_over_horizon = (r_mu + math.sqrt(r * r - R * R)) / R
        if abs(elevation_over_horizon) < 3 * alpha:
            continue  # the penumbra: its own check below
        cos_theta = -float(np.dot(s_dir, incoming))
        expected = [0.0, 0.0, 0.0]
        if elevation_over_horizon > 0:
            m = {c["name"]: _sun_column_reference(p, s_dir, EARTH_PROFILES[c["name"]], R, top)
                 for c in desc["constituents"]}
            for ch in range(3):
                tau = sum((c["scattering_rgb"][ch] + c["absorption_rgb"][ch]) * m[c["name"]]
                          for c in desc["constituents"])
                src = sum(c["scattering_rgb"][ch] * EARTH_PROFILES[c["name"]](h) * phase(c["phase"], c["g"], cos_theta)
                          for c in desc["constituents"])
                expected[ch] = E[ch] * math.exp(-tau) * src
        got = evaluate_socket(colour, tuple(p), {"incoming": tuple(incoming)})
        for ch in range(3):
            err = abs(got[ch] - expected[ch]) / max(expected[ch], 1e-30)
            if expected[ch] == 0.0:
                check(got[ch] == 0.0, "in the planet's shadow at h=%g: %r" % (h, got))
                continue
            worst = max(worst, err)
            # The table's bilinear lookup (256 × 64 texels over Bruneton's mapping): measured
            # worst 9e-4 here; 5e-3 bounds it and no wrong formula, unit or texel offset fits.
            check(err < 5e-3, "sun emission at h=%g km, dir %s, incoming %s, ch %d: %.6g vs %.6g (rel %.3g)"
                  % (h, direction.round(3), incoming.round(3), ch, got[ch], expected[ch], err))
    print("    analytic sun emission vs written-out single scattering: worst relative %.3g over %d cases"
          % (worst, len(cases)))
    # The penumbra: the fraction of the sun's disc above the planet's horizon — a disc of angular
    # radius α cut by a line at the sun's elevation e over that horizon: 0 at e ≤ −α, 1/2 at 0,
    # ½ + (x sqrt(1 − x²) + asin x)/π = 0.8045 at x = e/α = ½, 1 at e ≥ α.
    w = np.cross(s_dir, up)
    w /= np.linalg.norm(w)
    h = 30.0
    r = R + h
    rho = math.sqrt(r * r - R * R)
    for e, fraction in ((-1.2 * alpha, 0.0), (0.0, 0.5), (0.5 * alpha, 0.5 + (0.5 * math.sqrt(0.75) + math.asin(0.5))
                                                                     / math.pi), (1.2 * alpha, 1.0)):
        mu = (e * R - rho) / r
        n = mu * s_dir + math.sqrt(1.0 - mu * mu) * w
        p = n * r - np.array([0.0, 0.0, R])
        got = evaluate_socket(colour, tuple(p), {"incoming": tuple(-s_dir)})
        if fraction == 0.0:
            check(got == (0.0, 0.0, 0.0), "sun emission below the sun disc's horizon: %r" % (got,))
            continue
        m = {c["name"]: _sun_column_reference(p, s_dir, EARTH_PROFILES[c["name"]], R, top)
             for c in desc["constituents"]}
        for ch in range(3):
            tau = sum((c["scattering_rgb"][ch] + c["absorption_rgb"][ch]) * m[c["name"]] for c in desc["constituents"])
            src = sum(c["scattering_rgb"][ch] * EARTH_PROFILES[c["name"]](h) * phase(c["phase"], c["g"], 1.0)
                      for c in desc["constituents"])
            expected = fraction * E[ch] * math.exp(-tau) * src
            # Grazing rays: the column is the table's edge (x_mu = 1) or next to it.
            close(got[ch], expected, rel=2e-2, what="penumbra e=%.3g mrad ch %d" % (1e3 * e, ch))
    # Sun Sync moves the material's sun with the lamp.
    s.sun_elevation = math.radians(20.0)
    check(bpy.ops.airmass.sun_sync() == {"FINISHED"}, "sun_sync after the volume")
    light2 = Ctx.native.sun_light(props.make_spec(s), chapman=s.chapman)
    got_dir = [nodes["sun direction"].inputs[i].default_value for i in range(3)]
    for i in range(3):
        close(got_dir[i], light2["direction"][i], rel=1e-6, abs_=1e-7, what="sun direction %d after Sun Sync" % i)
    # … and the emission is the new sun's (its direction, r μ's constant, its irradiance).
    s2 = np.array(light2["direction"])
    p = np.array([0.0, 0.0, 6.0])
    m = {c["name"]: _sun_column_reference(p, s2, EARTH_PROFILES[c["name"]], R, top) for c in desc["constituents"]}
    got = evaluate_socket(colour, tuple(p), {"incoming": (0.0, 0.0, -1.0)})
    for ch in range(3):
        tau = sum((c["scattering_rgb"][ch] + c["absorption_rgb"][ch]) * m[c["name"]] for c in desc["constituents"])
        src = sum(c["scattering_rgb"][ch] * EARTH_PROFILES[c["name"]](6.0) * phase(c["phase"], c["g"], float(s2[2]))
                  for c in desc["constituents"])
        close(got[ch], light2["irradiance_top_rgb"][ch] * math.exp(-tau) * src, rel=5e-3,
              what="sun emission after Sun Sync, ch %d" % ch)
    # Multiple Scattering (the default): the emission gains E_top ⊙ Ψ(μs, x_r) ⊙ Σ σs ρ, unshadowed,
    # Ψ the library's table (native.sun_ms_table) looked up here with the mapping written out.
    points = []
    for h, direction in ((0.3, up), (12.0, np.array([0.0, -0.8, 0.6])), (30.0, np.array([0.3, 0.2, 0.93])),
                         (30.0, -s2)):
        direction = direction / np.linalg.norm(direction)
        p = direction * (R + h) - np.array([0.0, 0.0, R])
        points.append((h, p, evaluate_socket(colour, tuple(p), {"incoming": (0.0, 0.0, -1.0)})))  # single only
    s.volume_multiple = True
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume with multiple scattering")
    nodes = _atmosphere_objects(scene)[0].active_material.node_tree.nodes
    check(nodes.get("sun multiple scattering") is not None, "no multiple-scattering lookup")
    colour2 = nodes["sun emission"].inputs["Color"].links[0].from_socket
    psi, mu_lo = Ctx.native.sun_ms_table(props.make_spec(s), mu_size=64, r_size=32, unit="km")
    for h, p, single in points:
        v = p + np.array([0.0, 0.0, R])
        r = float(np.linalg.norm(v))
        mu_s = float(np.dot(v, s2)) / r
        x = min(63.0, max(0.0, (mu_s - mu_lo) / (1.0 - mu_lo) * 63.0))  # Extend: clamped to the edge texels
        y = min(31.0, max(0.0, math.sqrt(r * r - R * R) / math.sqrt(top * top - R * R) * 31.0))
        i0, j0 = min(int(x), 62), min(int(y), 30)
        fx, fy = x - i0, y - j0
        look = ((1 - fx) * (1 - fy) * psi[j0, i0] + fx * (1 - fy) * psi[j0, i0 + 1] + (1 - fx) * fy * psi[j0 + 1, i0]
                + fx * fy * psi[j0 + 1, i0 + 1])
        got = evaluate_socket(colour2, tuple(p), {"incoming": (0.0, 0.0, -1.0)})
        for ch in range(3):
            ms = light2["irradiance_top_rgb"][ch] * float(look[ch]) * sum(
                c["scattering_rgb"][ch] * EARTH_PROFILES[c["name"]](h) for c in desc["constituents"])
            close(got[ch], single[ch] + ms, rel=1e-4, what="single + multiple at h=%g ch %d" % (h, ch))
            if h < 20.0 and mu_s > 0.0:  # by day low down the term is not negligible (or the check proves nothing)
                check(ms > 1e-2 * single[ch], "the multiple-scattering term is negligible: %g vs %g" % (ms, single[ch]))
    # Re-running replaces the tables' images too.
    before = data_snapshot()
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "second create_volume")
    check(data_snapshot() == before, "re-run changed datablock counts: %s vs %s" % (data_snapshot(), before))
    rgb, mean, sec = render_tiny(scene, os.path.join(out, "render_sun.exr"))
    check(mean > 0.0, "Analytic Sun render is black")
    print("    analytic sun render: mean %.4g, %.2f s" % (mean, sec))
    # The VDB volume takes the same lighting: its grids as the density, the same emission.
    s.volume_region, s.view_distance, s.voxel_size = "VIEW", 40.0, 1.0
    check(bpy.ops.airmass.create_volume(mode="VDB") == {"FINISHED"}, "create_volume VDB (Analytic Sun)")
    vmat = _atmosphere_objects(scene)[0].active_material
    check(vmat.node_tree.nodes.get("sun emission") is not None
          and not any(n.bl_idname == "ShaderNodeVolumeScatter" for n in vmat.node_tree.nodes),
          "VDB material without the Analytic Sun")
    images = [i for i in bpy.data.images if i.get("airmass_role") == "sun columns"]
    check(len(images) == 1 and images[0].packed_file is not None and images[0].users >= 1,
          "sun columns images: %s" % [(i.name, i.users) for i in images])
    rgb, mean, sec = render_tiny(scene, os.path.join(out, "render_sun_vdb.exr"))
    check(mean > 0.0, "Analytic Sun VDB render is black")


FIVE_CONSTITUENTS_TOML = '''preset = "earth"
[[constituent]]
name = "haze"
profile = { type = "exponential", scale_height_km = 2.0 }
extinction = { law = "angstrom", beta = 1e-3, alpha = 1.0 }
single_scattering_albedo = 0.95
phase = { type = "isotropic" }
[[constituent]]
name = "dust"
profile = { type = "exponential", scale_height_km = 3.0 }
extinction = { law = "angstrom", beta = 5e-4, alpha = 0.5 }
single_scattering_albedo = 0.8
phase = { type = "isotropic" }
'''


@test
def test_analytic_sun_table_names():
    """More than three constituents: the Analytic Sun's tables take one image per three
    constituents, each under its own name ("Airmass Sun Columns", "Airmass Sun Columns 2", …), and
    a rebuild replaces them under the same names (no ".001" names, nothing piles up)."""
    scene, out = fresh_scene("analytic_sun_names")
    s = scene.airmass
    toml = os.path.join(out, "five.toml")
    with open(toml, "w", encoding="utf-8") as f:
        f.write(FIVE_CONSTITUENTS_TOML)
    s.source, s.scene_file = "FILE", toml
    check([c.name for c in s.constituents] == ["rayleigh", "mie", "ozone", "haze", "dust"],
          "constituents %s" % [c.name for c in s.constituents])
    s.volume_lighting = "SUN_EMISSION"
    s.volume_multiple = True
    expected = {"Airmass Sun Columns": "rayleigh,mie,ozone", "Airmass Sun Columns 2": "haze,dust",
                "Airmass Sun Multiple Scattering": None}

    def tables():
        return {i.name: i.get("airmass_constituents") for i in bpy.data.images
                if i.get("airmass_role") in ("sun columns", "sun multiple scattering")}

    snapshot = None
    for run in range(3):
        check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume run %d" % run)
        check(tables() == expected, "run %d: table images %s" % (run, tables()))
        used = {n.image.name for n in _atmosphere_objects(scene)[0].active_material.node_tree.nodes
                if n.bl_idname == "ShaderNodeTexImage" and n.image is not None}
        check(used == set(expected), "run %d: the material reads %s" % (run, sorted(used)))
        if snapshot is not None:
            check(data_snapshot() == snapshot, "run %d changed datablock counts: %s vs %s"
                  % (run, data_snapshot(), snapshot))
        snapshot = data_snapshot()
    # Single scattering: the multiple-scattering image goes, the columns keep their names.
    s.volume_multiple = False
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume single scattering")
    del expected["Airmass Sun Multiple Scattering"]
    check(tables() == expected, "single scattering: table images %s" % tables())


@test
def test_analytic_sun_render_vs_native():
    """What Cycles renders from the Analytic Sun material equals the library's own render of the
    same physics — `airmass render --rgb-model renderer` (Blender's RGB coefficients and the sun
    lamp's RGB irradiance; the scene's phase functions, not Henyey–Greenstein), Box pixel filter,
    the same camera: Cycles' emission units, the Incoming direction's sign, the extinction and the
    table all at once. Sky pixels only (the cameras look up). Single scattering against the
    native single scattering; with Multiple Scattering against `--multiple --ms-mode isotropic_lut`
    (the same Hillaire Ψ, the library's own table and quadrature). Day: sun 8°, 30° from the sun's
    azimuth (the Mie lobe in view); sunset: sun −1°, looking away from it (the Earth's shadow: the
    planet's shadow and the penumbra; multiple scattering lights the shadow)."""
    for name, elevation, rotation, heading, pitch, multiple, bounds in (
            # Measured: mean 0.10 %, p95 0.29 %, max 0.74 % (16 spp, whole-planet step 1.28 km).
            ("day", 8.0, 30.0, 60.0, 22.0, False, (0.005, 0.015)),
            # Measured: mean 0.35 %, p95 1.7 %; max 25 % in the rows just above the horizon, where the
            # sun grazes the ground (the penumbra here, a hard shadow in the native render).
            ("sunset", -1.0, 270.0, 90.0, 12.0, False, (0.01, 0.03)),
            # Measured: mean 0.10 %, p95 0.28 %.
            ("day_ms", 8.0, 30.0, 60.0, 22.0, True, (0.01, 0.03)),
            # Measured: mean 0.75 %, p95 2.5 %, max 4.8 % (the bound is 1.3× the p95: the native
            # image's Ψ comes from its own 24 × 12 node table, the material's from a 64 × 32 resample).
            ("sunset_ms", -1.0, 270.0, 90.0, 12.0, True, (0.01, 0.03))):
        _analytic_sun_vs_native(name, elevation, rotation, heading, pitch, bounds, multiple)


def _analytic_sun_vs_native(name, elevation, rotation, heading, pitch, bounds, multiple):
    import subprocess
    import numpy as np
    scene, out = fresh_scene("analytic_sun_render_" + name)
    s = scene.airmass
    s.sun_elevation, s.sun_rotation = math.radians(elevation), math.radians(rotation)
    cam = ground_camera(scene, pitch_deg=pitch, heading_deg=heading, altitude_km=0.002)
    hfov = 60.0
    cam.data.sensor_fit = "AUTO"
    cam.data.lens = 0.5 * cam.data.sensor_width / math.tan(math.radians(0.5 * hfov))
    s.volume_lighting = "SUN_EMISSION"
    s.volume_multiple = multiple
    s.volume_region, s.step_km = "PLANET", 0.25
    check(bpy.ops.airmass.sun_sync() == {"FINISHED"}, "sun_sync")
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume")
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    w, h = 48, 27
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 1.0
    scene.cycles.seed = 3
    rgb, mean, sec = render_tiny(scene, os.path.join(out, "cycles.exr"), samples=16, width=w, height=h)
    cyc = np.array(rgb).reshape(h, w, 3)[::-1]  # Blender's pixels: bottom row first
    m = cam.matrix_world.to_3x3()
    d = m @ Vector((0.0, 0.0, -1.0))
    u = m @ Vector((0.0, 1.0, 0.0))
    native_exr = os.path.join(out, "native.exr")
    compare = _compare_module()
    check(compare.availability() is None, "the bundled CLI: %s" % compare.availability())  # also sets its x bit
    cmd = [compare.cli_path(), "render", "--preset", "earth", "--sun-elevation", repr(elevation),
           "--sun-rotation", repr(rotation), "--rgb-model", "renderer", "--pixel-filter", "box",
           "--width", str(w), "--height", str(h), "--camera-position-km", "0,0,0.002",
           "--camera-direction", "%.9f,%.9f,%.9f" % tuple(d), "--camera-up", "%.9f,%.9f,%.9f" % tuple(u),
           "--fov", repr(hfov), "--samples", "64", "--quiet", "-o", native_exr]
    if multiple:
        cmd += ["--multiple", "--ms-mode", "isotropic_lut", "--no-cache"]
    subprocess.run(cmd, check=True, timeout=300)
    img = bpy.data.images.load(native_exr, check_existing=False)
    try:
        px = np.array(img.pixels[:], dtype=np.float64).reshape(h, w, 4)[::-1, :, :3]
    finally:
        bpy.data.images.remove(img)
    # Sky pixels: the whole pixel above the horizon (its centre ray's elevation > 1.5 pixel
    # heights; the ground is lit differently: the native render has no skylight on it).
    frame = [Vector(v) for v in cam.data.view_frame(scene=scene)]  # TR, BR, BL, TL at depth −z
    tl, tr, bl = frame[3], frame[0], frame[2]
    rows = []
    for j in range(h):
        ray = m @ (tl + (tr - tl) * 0.5 + (bl - tl) * ((j + 0.5) / h))
        rows.append(math.degrees(math.asin(ray.normalized().z)))
    pixel_deg = abs(rows[0] - rows[-1]) / (h - 1)
    sky = np.array(rows) > 1.5 * pixel_deg
    check(sky.sum() >= h // 2, "too few sky rows: %s" % sky.sum())
    cyc, px = cyc[sky], px[sky]
    rel = np.abs(cyc - px) / np.maximum(px, 1e-3 * px.mean())
    print("    analytic sun vs native, %s (renderer RGB, scene phases): mean %.3g %%, p95 %.3g %%, max %.3g %%; "
          "Cycles %.2f s, image mean %.4g vs %.4g" % (name, 100 * rel.mean(), 100 * np.percentile(rel, 95),
                                                      100 * rel.max(), sec, cyc.mean(), px.mean()))
    # The bounds leave room for the step's jitter noise; a wrong phase (HG instead of Rayleigh),
    # Incoming's sign (the Mie lobe on the wrong side) or the emission's units are each tens of
    # per cent.
    check(rel.mean() < bounds[0] and np.percentile(rel, 95) < bounds[1],
          "analytic sun vs native, %s: mean %.3g, p95 %.3g" % (name, rel.mean(), np.percentile(rel, 95)))


@test
def test_vdb_voxel_values():
    """The panel's Voxel Values reach the grids the add-on writes: each grid's airmass:voxel_values
    says what it holds, and at 4-km voxels the aerosol's means carry a different column than its
    point values (the chords of its 1.2-km exponential; docs/vdb.md, Voxel values). Automatic keeps
    point values for a camera on the ground (it looks along the layer)."""
    import numpy as np
    pyopenvdb = __import__(ADDON + ".vdb_host", fromlist=["x"]).openvdb_module()
    kinds, mie = {}, {}
    for choice in ("AUTO", "AVERAGE", "POINT"):
        scene, out = fresh_scene("vdb_values_" + choice.lower())
        s = scene.airmass
        s.volume_region, s.view_distance, s.voxel_size, s.voxel_values = "VIEW", 20.0, 4.0, choice
        ground_camera(scene, pitch_deg=4.0)
        check(bpy.ops.airmass.create_volume(mode="VDB") == {"FINISHED"}, "create_volume VDB (%s) failed" % choice)
        kinds[choice], mie[choice] = set(), 0.0
        for path in (f for f in files_in(out) if f.endswith(".vdb")):
            for g in pyopenvdb.readAllGridMetadata(path):
                kinds[choice].add((g.name, g.metadata["airmass:voxel_values"]))
            for grid in pyopenvdb.readAll(path)[0]:
                if grid.name != "mie":
                    continue
                lo, hi = grid.evalActiveVoxelBoundingBox()
                block = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), dtype=np.float32)
                grid.copyToArray(block, ijk=lo)
                mie[choice] += float(block.sum(dtype=np.float64))
    names = {n for n, _ in kinds["POINT"]}
    check("mie" in names and "rayleigh" in names, "grids %s" % names)
    for choice, want in (("AUTO", "point"), ("AVERAGE", "average"), ("POINT", "point")):
        check(kinds[choice] == {(n, want) for n in names}, "%s: grids hold %s" % (choice, sorted(kinds[choice])))
    check(mie["AUTO"] == mie["POINT"], "auto from the ground: point values (%r vs %r)" % (mie["AUTO"], mie["POINT"]))
    rel = abs(mie["AVERAGE"] - mie["POINT"]) / mie["POINT"]
    check(rel > 0.01, "the aerosol's means and point values at 4-km voxels differ by only %.3g" % rel)
    print("    voxel values: the aerosol's sum over its voxels, means vs points %+.1f %%"
          % (100 * (mie["AVERAGE"] / mie["POINT"] - 1)))


@test
def test_vdb_volume():
    scene, out = fresh_scene("vdb")
    s = scene.airmass
    s.volume_region = "VIEW"
    s.view_distance = 40.0
    s.voxel_size = 1.0
    ground_camera(scene, pitch_deg=4.0)
    scene.cycles.transparent_max_bounces = 0  # a user's setting that renders volumes dark
    check(bpy.ops.airmass.create_volume(mode="VDB") == {"FINISHED"}, "create_volume VDB failed")
    objs = _atmosphere_objects(scene)
    check(len(objs) >= 1 and all(o.type == "VOLUME" for o in objs), "volume objects: %s" % objs)
    # Every tile's box is a boundary Cycles counts as a transparent bounce: raised to 2 per tile + 4.
    check(scene.cycles.transparent_max_bounces == 2 * len(objs) + 4,
          "transparent bounces %d for %d tiles" % (scene.cycles.transparent_max_bounces, len(objs)))
    # The add-on wrote the files itself, with this Blender's OpenVDB module (the library has none).
    vdb_host = __import__(ADDON + ".vdb_host", fromlist=["x"])
    pyopenvdb = vdb_host.openvdb_module()
    check(pyopenvdb is not None and pyopenvdb.__name__ == ("openvdb" if bpy.app.version >= (4, 4, 0)
                                                           else "pyopenvdb"), "OpenVDB module %s" % pyopenvdb)
    check(Ctx.native.has_vdb(), "airmass_has_vdb: the library reports no volume functions")
    check(not any("airmass-tmp" in f for f in files_in(out)), "temporaries left: %s" % files_in(out))
    check(sorted(bpy.path.abspath(o.data.filepath) for o in objs) == [f for f in files_in(out) if f.endswith(".vdb")],
          "files %s vs volumes" % files_in(out))
    plan = __import__(ADDON + ".volume", fromlist=["x"]).VdbPlan(bpy.context)
    for obj in objs:
        vol = obj.data
        check(vol.render.clipping == 0.0, "clipping %g" % vol.render.clipping)
        check(vol.render.precision == "FULL", "precision %s" % vol.render.precision)
        check(vol.grids.load(), "grids: %s" % vol.grids.error_message)
        names = {g.name for g in vol.grids}
        check({"rayleigh", "mie"} <= names <= {"rayleigh", "mie", "ozone"}, "grid names %s" % names)
        path = bpy.path.abspath(vol.filepath)
        meta = {g.name: dict(g.metadata) for g in pyopenvdb.readAllGridMetadata(path)}
        voxel = meta["rayleigh"]["airmass:voxel_size"]
        close(voxel, 1.0, rel=1e-9, what="voxel size")
        for k in range(3):
            close(obj.location[k], -0.5 * voxel, rel=1e-9, what="half-voxel shift")
        nodes = _scatter_nodes(obj.active_material)
        for name in names:
            m = meta[name]
            if max(m["airmass:scattering_rgb"]) > 0:
                got = _scattering_rgb(obj.active_material, name)
                for i in range(3):
                    close(got[i], m["airmass:scattering_rgb"][i], rel=1e-6, what="%s σs[%d]" % (name, i))
            if max(m["airmass:absorption_rgb"]) > 0:
                got = _coefficient_rgb(nodes["%s absorption" % name])
                for i in range(3):
                    close(got[i], m["airmass:absorption_rgb"][i], rel=1e-5, abs_=1e-12, what="%s σa" % name)
            attr = [n for n in obj.active_material.node_tree.nodes
                    if n.bl_idname == "ShaderNodeAttribute" and n.attribute_name == name]
            check(len(attr) == 1, "attribute node for %s" % name)
        # Every grid in the file holds the library's values over its box, active exactly where
        # they are nonzero (copyFromArray with tolerance 0), and nothing outside the box.
        for grid in pyopenvdb.readAll(path)[0]:
            lo, hi = grid.evalActiveVoxelBoundingBox()
            want = Ctx.native.vdb_grid_values(plan.spec, grid.name, lo, hi, **plan.options())
            import numpy as np
            got = np.zeros(want.shape, dtype=np.float32)
            grid.copyToArray(got, ijk=lo)
            check(np.array_equal(got, want), "%s: values differ from the library's (max |d| %g)"
                  % (grid.name, float(np.abs(got - want).max())))
            check(grid.activeVoxelCount() == int((want != 0).sum()) > 0, "%s: %d active vs %d nonzero"
                  % (grid.name, grid.activeVoxelCount(), int((want != 0).sum())))
    before = data_snapshot()
    files_before = files_in(out)
    check(bpy.ops.airmass.create_volume(mode="VDB") == {"FINISHED"}, "second create_volume VDB failed")
    check(data_snapshot() == before, "re-run changed datablock counts")
    check(files_in(out) == files_before, "re-run changed the files: %s" % files_in(out))
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "sky for the VDB scene")
    rgb, mean, sec = render_tiny(scene, os.path.join(out, "render_vdb.exr"))
    print("    VDB render: mean %.4g, %.2f s" % (mean, sec))
    # Enough bounces: the same seed with 1024 (Cycles' most) renders the same pixels.
    raised = scene.cycles.transparent_max_bounces
    scene.cycles.transparent_max_bounces = 1024
    rgb_max, _mean, _sec = render_tiny(scene, os.path.join(out, "render_vdb_1024.exr"))
    worst = max(abs(a - b) for a, b in zip(rgb, rgb_max)) / max(rgb_max)
    check(worst < 1e-4, "VDB render with %d transparent bounces differs from 1024 by %.3g of the maximum"
          % (raised, worst))



def _vdb_view_scene(name):
    scene, out = fresh_scene(name)
    s = scene.airmass
    s.volume_region = "VIEW"
    s.view_distance = 40.0
    s.voxel_size = 1.0
    ground_camera(scene, pitch_deg=4.0)
    return scene, out


@test
def test_vdb_cancel_leaves_nothing():
    """Esc (the job's cancel) during the plan, during the blocks, and while the file is being
    written: no file, no temporary, no datablock."""
    scene, out = _vdb_view_scene("vdb_cancel")
    n = Ctx.native
    volume = __import__(ADDON + ".volume", fromlist=["x"])
    vdb_host = __import__(ADDON + ".vdb_host", fromlist=["x"])
    before = data_snapshot()
    real_module = vdb_host.openvdb_module
    for when in ("plan", "blocks", "write"):
        plan = volume.VdbPlan(bpy.context)
        seen = []
        if when == "plan":
            prog = n.Progress(lambda f: seen.append(f) or True)  # the first report cancels
        elif when == "blocks":
            prog = n.Progress(lambda f: seen.append(f) or f > vdb_host.PLAN_SHARE)
        else:
            prog = n.Progress(lambda f: seen.append(f) and False)
            wrote = []

            class CancelAfterWrite:  # the module, whose write is followed by the user's Esc
                def __init__(self, m):
                    self.m = m

                def __getattr__(self, k):
                    return getattr(self.m, k)

                def write(self, path, grids, metadata=None):
                    self.m.write(path, grids, metadata=metadata)
                    wrote.append(path)
                    check(os.path.isfile(path), "the temporary %s was not written" % path)
                    prog.cancel()

            module = real_module()
            vdb_host.openvdb_module = lambda: CancelAfterWrite(module)
        try:
            plan.work(prog)
            raise AssertionError("not cancelled (%s)" % when)
        except n.NativeError as e:
            check(e.cancelled, "%s: status %s: %s" % (when, e.status, e))
            plan.abort()
        finally:
            vdb_host.openvdb_module = real_module
            prog.close()
        check(seen, "%s: no progress reported" % when)
        if when == "blocks":
            check(any(f > vdb_host.PLAN_SHARE for f in seen), "blocks never started: %s" % seen)
        if when == "write":
            check(wrote and all(".airmass-tmp-" in os.path.basename(w) for w in wrote), "wrote %s" % wrote)
        check(files_in(out) == [], "files after a cancel during the %s: %s" % (when, files_in(out)))
        check(data_snapshot() == before, "datablocks after a cancel during the %s" % when)
    # The operator still works afterwards.
    check(bpy.ops.airmass.create_volume(mode="VDB") == {"FINISHED"}, "create_volume VDB after cancels")


@test
def test_vdb_without_openvdb_module():
    """A Blender without an OpenVDB Python module: VDB mode says so and offers the analytic
    volume (which works); nothing is written or created."""
    scene, out = _vdb_view_scene("vdb_nomodule")
    vdb_host = __import__(ADDON + ".vdb_host", fromlist=["x"])
    saved = {k: sys.modules.get(k) for k in vdb_host.MODULE_NAMES}
    try:
        for k in vdb_host.MODULE_NAMES:
            sys.modules[k] = None  # `import openvdb` / `import pyopenvdb` now raise ImportError
        check(vdb_host.openvdb_module() is None, "the module is still found")
        msg = _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "no OpenVDB Python module", out)
        check("use the Analytic volume" in msg, "the message offers no way out: %r" % msg)
        check(vdb_host.unavailable_reason() and "Analytic" in vdb_host.unavailable_reason(), "unavailable_reason")
        check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "the analytic volume without OpenVDB")
        check(files_in(out) == [], "files written without OpenVDB: %s" % files_in(out))
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    check(vdb_host.openvdb_module() is not None, "the module is not found again")

def _expect_error(op_call, needle, out):
    """The operator must fail with a report containing `needle`, change no datablock and
    write no file."""
    before, files_before = data_snapshot(), files_in(out) if os.path.isdir(out) else []
    try:
        op_call()
    except RuntimeError as e:
        msg = str(e)
        check(needle.lower() in msg.lower(), "error %r lacks %r" % (msg, needle))
    else:
        raise AssertionError("no error (expected %r)" % needle)
    check(data_snapshot() == before, "datablocks changed after a failure: %s vs %s" % (data_snapshot(), before))
    after = files_in(out) if os.path.isdir(out) else []
    check(after == files_before, "files changed after a failure: %s" % sorted(set(after) - set(files_before)))
    return msg


@test
def test_bad_input():
    scene, out = fresh_scene("bad")
    s = scene.airmass
    ops = [lambda: bpy.ops.airmass.generate_sky(), lambda: bpy.ops.airmass.create_volume(mode="ANALYTIC"),
           lambda: bpy.ops.airmass.create_volume(mode="VDB"), lambda: bpy.ops.airmass.sun_sync()]
    s.override_planet = True
    s.planet_radius = -1.0
    for op in ops:
        _expect_error(op, "planet.radius_km", out)
    s.planet_radius, s.atmosphere_top = 6360.0, 6300.0
    for op in ops:
        _expect_error(op, "planet.atmosphere_top_km", out)
    s.override_planet = False
    mie = next(c for c in s.constituents if c.name == "mie")
    mie.scale_height = 0.0
    for op in ops[:3]:
        _expect_error(op, "scale_height_km", out)
    mie.scale_height = mie.preset_scale_height
    s.output_folder = ""
    _expect_error(lambda: bpy.ops.airmass.generate_sky(), "Output Folder is not set", out)
    _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "Output Folder is not set", out)
    s.output_folder = "//relative/"
    # The sky needs no file (it is packed into the .blend): it works and writes nothing; the
    # VDB needs its files and says why it cannot have them.
    _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "not saved", out)
    files_before = files_in(Ctx.tmp)
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "generate_sky with //relative/ in an unsaved file")
    img = scene.world.node_tree.nodes["Airmass Sky"].image
    check(img.packed_file is not None and img.filepath_raw == "", "sky not packed / has a file %r" % img.filepath_raw)
    check(files_in(Ctx.tmp) == files_before, "files written: %s" % sorted(set(files_in(Ctx.tmp)) - set(files_before)))
    # Not writable even for root: below a regular file, and inside /proc.
    blocker = os.path.join(out, "a_file")
    with open(blocker, "w") as f:
        f.write("x")
    s.output_folder = os.path.join(blocker, "sub")
    _expect_error(lambda: bpy.ops.airmass.generate_sky(), "cannot be created", out)
    s.output_folder = "/proc/airmass-test-output"
    _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "cannot be created", out)
    s.output_folder = out
    # A scene file that does not exist / is not valid TOML.
    s.source = "FILE"
    s.scene_file = os.path.join(out, "missing.toml")
    _expect_error(lambda: bpy.ops.airmass.generate_sky(), "does not exist", out)
    bad = os.path.join(out, "bad.toml")
    with open(bad, "w") as f:
        f.write('preset = "earth"\n[planet]\nradius_km = -5\n')
    s.scene_file = bad
    _expect_error(lambda: bpy.ops.airmass.generate_sky(), "radius_km", out)
    s.source = "PRESET"
    # Sky settings: a VDB of the view region needs a camera.
    bpy.data.objects.remove(scene.camera)
    s.volume_region = "VIEW"
    _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "camera", out)
    # Too fine voxels for the memory limit: refused before anything is written.
    s.volume_region = "PLANET"
    s.voxel_size = 0.5
    s.max_dense_mb = 64
    _expect_error(lambda: bpy.ops.airmass.create_volume(mode="VDB"), "", out)
    # Blender keeps running and the next good call works.
    s.volume_region, s.voxel_size = "VIEW", 0.0
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "a good call after failures")


@test
def test_library_fails_to_load():
    scene, out = fresh_scene("noload")
    n = Ctx.native
    garbage = os.path.join(Ctx.tmp, "libairmass_c_garbage.so")
    with open(garbage, "wb") as f:
        f.write(b"this is not an ELF file")
    old = os.environ.get(n.LIBRARY_ENV)
    try:
        for path, needle in ((garbage, "failed to load"), (os.path.join(Ctx.tmp, "nothing.so"), "not found")):
            os.environ[n.LIBRARY_ENV] = path
            n.reset()
            check(n.load_error() and needle in n.load_error(), "load_error %r" % n.load_error())
            check("OpenImageIO" not in n.load_error(), "stale dependency hint: %r" % n.load_error())
            for op in (lambda: bpy.ops.airmass.generate_sky(), lambda: bpy.ops.airmass.sun_sync(),
                       lambda: bpy.ops.airmass.create_volume(mode="ANALYTIC"),
                       lambda: bpy.ops.airmass.create_volume(mode="VDB")):
                _expect_error(op, needle, out)
            # The panel's draw code copes (it shows the error): exercise its helper.
            ui = __import__(ADDON + ".ui", fromlist=["x"])
            check(ui._wrap(n.load_error(), 60), "wrap")
    finally:
        if old is None:
            os.environ.pop(n.LIBRARY_ENV, None)
        else:
            os.environ[n.LIBRARY_ENV] = old
        n.reset()
    check(n.load_error() is None, "library does not load again: %s" % n.load_error())
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "generate_sky after the library is back")


@test
def test_cancel_and_progress():
    scene, out = fresh_scene("cancel")
    n = Ctx.native
    props = __import__(ADDON + ".properties", fromlist=["x"])
    spec = props.make_spec(scene.airmass)
    # The callback cancels at its first call.
    seen = []
    prog = n.Progress(lambda f: seen.append(threading.get_ident()) or True)
    try:
        n.render_sky(spec, width=2048, view_samples=64, grid=0, progress=prog)
        raise AssertionError("not cancelled")
    except n.NativeError as e:
        check(e.cancelled, "status %s: %s" % (e.status, e))
    finally:
        prog.close()
    check(seen and all(t == threading.get_ident() for t in seen), "progress not on the calling thread")
    # The token, from another thread.
    prog = n.Progress(None)
    threading.Timer(0.05, prog.cancel).start()
    t0 = time.time()
    try:
        n.render_sky(spec, width=4096, view_samples=64, grid=0, progress=prog)
        raise AssertionError("not cancelled by the token")
    except n.NativeError as e:
        check(e.cancelled, "status %s: %s" % (e.status, e))
    finally:
        prog.close()
    check(time.time() - t0 < 30.0, "the token took %.1f s to stop the sky" % (time.time() - t0))
    # Progress reaches 1 on success.
    fractions = []
    prog = n.Progress(lambda f: fractions.append(f) and False)
    px, _ = n.render_sky(spec, width=64, progress=prog)
    prog.close()
    check(fractions and fractions[-1] == 1.0 and fractions == sorted(fractions), "fractions %s" % fractions)
    check(px.shape == (32, 64, 4) and px[..., :3].max() > 0.0, "sky after progress")
    # The operator's plan, cancelled: the previous image, World and file stay as they were.
    check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "generate_sky before the cancel")
    world = __import__(ADDON + ".world", fromlist=["x"])
    env = scene.world.node_tree.nodes["Airmass Sky"]
    old_image, old_pixels = env.image, _image_pixels(env.image)
    before, files_before = data_snapshot(), files_in(out)
    scene.airmass.sky_width, scene.airmass.view_samples, scene.airmass.sky_grid = 4096, 64, 0
    plan = world.SkyPlan(bpy.context)
    prog = n.Progress(lambda f: True)
    try:
        plan.finish(bpy.context, plan.work(prog))
        raise AssertionError("the plan was not cancelled")
    except n.NativeError as e:
        check(e.cancelled, "status %s: %s" % (e.status, e))
        plan.abort()
    finally:
        prog.close()
    check(data_snapshot() == before, "datablocks changed by a cancelled sky: %s vs %s" % (data_snapshot(), before))
    check(env.image == old_image and (_image_pixels(env.image) == old_pixels).all(), "the previous image changed")
    check(files_in(out) == files_before, "files changed by a cancelled sky: %s" % files_in(out))


@test
def test_extremes():
    """Sun exactly at the zenith and the nadir (±π/2 stored as float32 reads ±90.0000025°),
    rotation beyond 360°, an observer in space: every operator works, images are finite."""
    scene, out = fresh_scene("extremes")
    s = scene.airmass
    s.sky_width = 64
    cases = [(math.pi / 2, 0.0, 0.0), (-math.pi / 2, 0.0, 0.0), (0.0, 4 * math.pi + 0.3, 0.0),
             (math.radians(30.0), 1.0, 1000.0), (math.radians(-0.3), 2.0, 10.0)]
    for elevation, rotation, altitude in cases:
        s.sun_elevation, s.sun_rotation, s.altitude = elevation, rotation, altitude
        check(bpy.ops.airmass.generate_sky() == {"FINISHED"}, "sky at %s" % ((elevation, rotation, altitude),))
        img = scene.world.node_tree.nodes["Airmass Sky"].image
        px = img.pixels[:]
        check(all(math.isfinite(v) and v >= 0.0 for v in px), "sky not finite/non-negative at %s"
              % ((elevation, rotation, altitude),))
        check(bpy.ops.airmass.sun_sync() == {"FINISHED"}, "sun_sync at %s" % ((elevation, rotation, altitude),))
        lamp = s.sun_object
        check(math.isfinite(lamp.data.energy) and lamp.data.energy >= 0.0, "lamp strength")
        if elevation < -0.01:
            check(lamp.data.energy == 0.0, "sun below the horizon lights the scene")


def _compare_module():
    return __import__(ADDON + ".compare", fromlist=["x"])


def _compare_setup(name, paths):
    """A fresh scene whose camera stands 2 m above the ground looking 5° up, compared at
    16 × 9 pixels (the render resolution's 16:9), few samples."""
    scene, out = fresh_scene(name)
    ground_camera(scene, pitch_deg=5.0, heading_deg=30.0)
    s = scene.airmass
    s.sun_elevation, s.sun_rotation = math.radians(20.0), math.radians(200.0)
    s.compare_width, s.compare_samples, s.compare_seeds = 16, 4, 2
    s.compare_paths = set(paths)
    s.view_distance = 30.0
    return scene, out


def _temporaries(out):
    return [f for f in os.listdir(out) if ".tmp-" in f or ".old-" in f]


def _check_compare_result(scene, out, paths):
    """The report and summary exist, every asked path has finite errors, the job's camera is
    the scene camera (1 Blender unit = 1 km), and the images are loaded."""
    import json
    folder = os.path.join(out, "%s_compare" % bpy.path.clean_name(scene.name))
    for f in ("report.md", "summary.json", "job.json", "scene.toml"):
        check(os.path.isfile(os.path.join(folder, f)), "%s missing" % f)
    with open(os.path.join(folder, "summary.json")) as f:
        summary = json.load(f)
    check(sorted(summary["paths"]) == sorted(paths), "summary paths %s" % sorted(summary["paths"]))
    stats = {}
    for p in paths:
        e = summary["paths"][p]
        check("error" not in e, "%s: %s" % (p, e.get("error")))
        for k in ("mean_rel_err", "p95_rel_err", "max_rel_err", "noise_rel"):
            check(isinstance(e[k], float) and math.isfinite(e[k]) and e[k] >= 0.0, "%s %s = %r" % (p, k, e[k]))
        stats[p] = e
    with open(os.path.join(folder, "job.json")) as f:
        job = json.load(f)
    cam = scene.camera
    jc = job["camera"]
    check((jc["width"], jc["height"]) == (16, 9), "job camera size %s" % ((jc["width"], jc["height"]),))
    close(jc["lens_mm"], cam.data.lens, rel=1e-6, what="lens (AUTO fit, 36 mm along the width)")
    for k in range(3):
        close(jc["location"][k], cam.matrix_world.translation[k], rel=1e-9, abs_=1e-12, what="camera location km")
        close(jc["axis_z"][k], cam.matrix_world.col[2][k], abs_=1e-6, what="camera axis z")
        close(jc["axis_y"][k], cam.matrix_world.col[1][k], abs_=1e-6, what="camera axis y")
    images = {}
    for p in paths:
        for suffix in ("", " error"):
            name = "Airmass Compare %s%s" % (p, suffix)
            img = bpy.data.images.get(name)
            check(img is not None, "image %s not loaded" % name)
            check(img.size[0] > 0 and img.size[1] > 0, "image %s is empty" % name)
            check(os.path.normpath(bpy.path.abspath(img.filepath)).startswith(folder + os.sep),
                  "image %s from %s" % (name, img.filepath))
            images[name] = img
    check(not _temporaries(out), "temporary folders left: %s" % _temporaries(out))
    return folder, stats, images


def _no_system_python():
    """PATH with stand-in `python3` and `python` first, which fail and leave a mark: Compare
    with Native must not need them (this Blender renders and runs the report). Returns the
    mark's path and a function restoring PATH."""
    bin_dir = os.path.join(Ctx.tmp, "no-python-bin")
    mark = os.path.join(Ctx.tmp, "system-python-was-run")
    os.makedirs(bin_dir, exist_ok=True)
    for name in ("python3", "python"):
        f = os.path.join(bin_dir, name)
        with open(f, "w") as fh:
            fh.write("#!/bin/sh\necho \"$0 $*\" >> '%s'\nexit 1\n" % mark)
        os.chmod(f, 0o755)
    old = os.environ.get("PATH", "")
    os.environ["PATH"] = bin_dir + os.pathsep + old

    def restore():
        os.environ["PATH"] = old
    return mark, restore


@test
def test_compare_sky_texture():
    scene, out = _compare_setup("compare", {"SKY_TEXTURE"})
    cmp = _compare_module()
    check(cmp.available(), "Compare with Native unavailable: %s" % cmp.availability())
    plan = cmp.ComparePlan(bpy.context)
    plan.work_dir = "/nonexistent"
    argv = plan.command("scene.toml")
    check(argv[argv.index("--blender") + 1] == bpy.app.binary_path and "--python" not in argv,
          "the CLI must get this Blender for renders and report, and no --python: %s" % argv)
    mark, restore_path = _no_system_python()
    t0 = time.time()
    try:
        check(bpy.ops.airmass.compare() == {"FINISHED"}, "compare failed")
    finally:
        restore_path()
    t1 = time.time()
    check(not os.path.exists(mark), "Compare with Native ran the system Python: %s"
          % (open(mark).read() if os.path.exists(mark) else ""))
    folder, stats, images = _check_compare_result(scene, out, ["sky_texture"])
    with open(os.path.join(folder, "report.md"), encoding="utf-8") as f:
        made_by = [ln for ln in f if ln.startswith("Made by report.py")]
    check(len(made_by) == 1 and "'s image API (bpy)" in made_by[0],
          "the report did not run in this Blender: %s" % made_by)
    e = stats["sky_texture"]
    # The accuracy itself is tests/python/test_compare.py's to assert (at a size and sample
    # count where it means something); here: the add-on drives the same comparison.
    check(scene.airmass.compare_report == os.path.join(folder, "report.md"), "compare_report")
    print("    sky texture: mean %.3g%%, p95 %.3g%%, %.1f s" % (100 * e["mean_rel_err"], 100 * e["p95_rel_err"],
                                                                 t1 - t0))
    # Re-running replaces the folder and reloads the same images.
    marker = os.path.join(folder, "marker")
    open(marker, "w").close()
    before, names = data_snapshot(), sorted(i.name for i in bpy.data.images)
    check(bpy.ops.airmass.compare() == {"FINISHED"}, "second compare failed")
    check(not os.path.exists(marker), "the previous result folder was not replaced")
    check(data_snapshot() == before, "re-run changed datablock counts: %s vs %s" % (data_snapshot(), before))
    check(sorted(i.name for i in bpy.data.images) == names, "images duplicated/renamed: %s"
          % sorted(i.name for i in bpy.data.images))
    _check_compare_result(scene, out, ["sky_texture"])

    # Cancel while Blender renders (as Esc does, through the token): the CLI stops its
    # Blender, the temporary folder goes, the previous result stays.
    n = Ctx.native
    prog = n.Progress(None)
    plan = cmp.ComparePlan(bpy.context, samples=256, paths=["analytic_volume"])

    def cancel_when_blender_runs():
        for _ in range(1200):
            # The log is written in the CLI's staging folder beside the add-on's temporary folder.
            tmp = [f for f in _temporaries(out) if ".tmp-" in f]
            if any(os.path.exists(os.path.join(out, t, "blender_analytic_volume.log")) for t in tmp):
                break
            time.sleep(0.05)
        prog.cancel()

    watcher = threading.Thread(target=cancel_when_blender_runs)
    watcher.start()
    try:
        plan.work(prog)
        raise AssertionError("not cancelled")
    except n.NativeError as e:
        check(e.cancelled, "status %s: %s" % (e.status, e))
        plan.abort()
    finally:
        watcher.join()
        prog.close()
    check(not _temporaries(out), "temporary folders after cancel: %s" % _temporaries(out))
    check(os.path.isfile(os.path.join(folder, "summary.json")), "the previous result was damaged by the cancel")
    time.sleep(0.5)
    stray = []
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                with open("/proc/%s/cmdline" % pid, "rb") as f:
                    if out.encode() in f.read():
                        stray.append(pid)
            except OSError:
                pass
    check(not stray, "processes left after cancel: %s" % stray)


@test
def test_compare_analytic_volume():
    scene, out = _compare_setup("compare_volume", {"ANALYTIC_VOLUME", "ANALYTIC_VOLUME_MS"})
    t0 = time.time()
    result = _compare_module().run(bpy.context)
    t1 = time.time()
    folder, stats, _ = _check_compare_result(scene, out, ["analytic_volume", "analytic_volume_ms"])
    for p in ("analytic_volume", "analytic_volume_ms"):
        check("%s mean" % p in result["summary"], "summary %r" % result["summary"])
        e = stats[p]
        print("    %s: mean %.3g%%, p95 %.3g%%, noise %.3g%%" % (
            p, 100 * e["mean_rel_err"], 100 * e["p95_rel_err"], 100 * e["noise_rel"]))
    print("    both paths: %.1f s" % (t1 - t0))
    # Multiple scattering alone needs no Split/RGB volume mode.
    scene.airmass.compare_paths = {"ANALYTIC_VOLUME_MS"}
    scene.airmass.compare_volume_modes = set()
    plan = _compare_module().ComparePlan(bpy.context)
    check(plan.paths == ["analytic_volume_ms"], "paths %r" % plan.paths)


@test
def test_compare_bad_input():
    scene, out = _compare_setup("compare_bad", {"SKY_TEXTURE"})
    s = scene.airmass
    op = lambda: bpy.ops.airmass.compare()  # noqa: E731
    blocker = os.path.join(out, "a_file")
    with open(blocker, "w") as f:
        f.write("x")
    s.output_folder = os.path.join(blocker, "sub")
    _expect_error(op, "cannot be created", out)
    s.output_folder = out
    s.compare_paths = set()
    _expect_error(op, "no path chosen", out)
    s.compare_paths = {"SKY_TEXTURE"}
    scene.camera.data.type = "ORTHO"
    _expect_error(op, "perspective camera", out)
    scene.camera.data.type = "PERSP"
    scene.camera.data.shift_x = 0.1
    _expect_error(op, "lens shift", out)
    scene.camera.data.shift_x = 0.0
    s.override_planet = True
    s.planet_radius, s.atmosphere_top = 6360.0, 6300.0
    _expect_error(op, "planet.atmosphere_top_km", out)
    s.override_planet = False
    # The CLI refuses the only path (a VDB of 1000 km of view within 1 MiB): an error naming
    # it, and the temporary folder is gone.
    s.compare_paths = {"VDB_VOLUME"}
    s.view_distance, s.max_dense_mb = 1000.0, 1.0
    _expect_error(op, "every path failed", out)
    s.compare_paths = {"SKY_TEXTURE"}
    # No CLI: unavailable, said so.
    cmp = _compare_module()
    old = os.environ.get(cmp.CLI_ENV)
    os.environ[cmp.CLI_ENV] = os.path.join(Ctx.tmp, "no-such-airmass")
    try:
        check(not cmp.available(), "a missing CLI is available")
        _expect_error(op, "not available", out)
    finally:
        if old is None:
            os.environ.pop(cmp.CLI_ENV, None)
        else:
            os.environ[cmp.CLI_ENV] = old
    bpy.data.objects.remove(scene.camera)
    _expect_error(op, "active camera", out)


@test
def test_c_abi_messages():
    n = Ctx.native
    spec = n.Spec(preset="no-such-preset")
    try:
        n.validate_scene(spec)
        raise AssertionError("unknown preset accepted")
    except n.NativeError as e:
        check(e.status == n.SCENE_ERROR and "no-such-preset" in str(e) and "earth" in str(e), str(e))
    spec = n.Spec(preset="earth")
    spec.constituents = [("dust", True, 2.0, None)]
    try:
        n.validate_scene(spec)
        raise AssertionError("unknown constituent accepted")
    except n.NativeError as e:
        check("dust" in str(e) and "rayleigh" in str(e), str(e))
    spec.constituents = [("ozone", True, None, 5000.0)]
    try:
        n.validate_scene(spec)
        raise AssertionError("scale height of a tent accepted")
    except n.NativeError as e:
        check("exponential" in str(e), str(e))
    spec = n.Spec(preset="earth")
    spec.sun_elevation_deg = 95.0
    try:
        n.validate_scene(spec)
        raise AssertionError("elevation 95 accepted")
    except n.NativeError as e:
        check("sun.elevation_deg" in str(e) and "[-90, 90]" in str(e), str(e))
    spec = n.Spec(preset="earth")
    spec.constituents = [("mie", False, None, None)]
    check([c["name"] for c in n.validate_scene(spec)["constituents"]] == ["rayleigh", "ozone"], "disable mie")


def cpu_seconds():
    """This process and its finished children (the comparison's CLI, its Blender and report)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime + c.ru_utime + c.ru_stime


# ---- main -----------------------------------------------------------------------------------

def run_tests(tests, argv, prog):
    """Installs the zip given by --zip into a temporary folder and runs `tests` (those whose
    name contains -k); raises SystemExit naming the failures. Shared with test_operator_faults.py."""
    ap = argparse.ArgumentParser(prog=prog)
    ap.add_argument("--zip", required=True)
    ap.add_argument("-k", dest="select", default="")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args(argv)
    Ctx.zip = os.path.abspath(args.zip)
    check(os.path.isfile(Ctx.zip), "add-on zip %s does not exist (build the airmass_addon_zip target)" % Ctx.zip)
    Ctx.tmp = tempfile.mkdtemp(prefix="airmass-blender-tests-")
    failures = []
    try:
        install_addon(Ctx.zip)
        for fn in tests:
            if args.select and args.select not in fn.__name__:
                continue
            t0, c0 = time.time(), cpu_seconds()
            try:
                fn()
                status = "PASS"
            except Exception:  # noqa: BLE001
                failures.append(fn.__name__)
                status = "FAIL"
                traceback.print_exc()
            print("%s %s (%.1f s wall, %.1f s CPU)" % (status, fn.__name__, time.time() - t0, cpu_seconds() - c0))
    finally:
        if not args.keep:
            shutil.rmtree(Ctx.tmp, ignore_errors=True)
        else:
            print("kept", Ctx.tmp)
    print("%d failed: %s" % (len(failures), ", ".join(failures)) if failures else "all Blender add-on tests passed")
    if failures:
        raise SystemExit("Blender add-on tests failed: " + ", ".join(failures))


def main():
    run_tests(TESTS, sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [], "run_addon_tests.py")


if __name__ == "__main__":  # imported by test_sky_bake.py and test_operator_faults.py for helpers
    main()
