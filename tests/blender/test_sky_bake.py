"""Bake Sky Animation, end to end, in two Blender processes (issue 16 item 3):

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_sky_bake.py \\
        -- --zip build/addon/airmass_blender.zip --cli build/bin/airmass --lib build/lib/libairmass_c.so

Process 1 (with the add-on, installed from the zip as run_addon_tests.py does) bakes one hour
of a sunrise in Paris (48.859375° N, 2.34375° E — exact in float32 — 21 June 2026, 04:00 to
05:00 UTC, the Time keyframed, one frame per 10 minutes: frames 1–7) at 64 × 32 pixels and
saves the .blend. It also checks that a re-bake with nothing changed renders no frame, and that
Esc (the cancel the modal operator sends) and a failing step leave the previous files, manifest,
World and lamp exactly as they were, with no temporary file left.

Process 2 opens the saved .blend with --factory-startup (no add-on: a render farm's Blender)
and, at frames 1 and 7, renders the World through an equirectangular camera at the image's
own size (Cycles, 1 sample at pixel centres) and checks that the rendered rows equal those of
sky_0001.exr resp. sky_0007.exr (and not the other file's); and that the Sun lamp points where
`airmass sun` (the CLI, run here) puts the sun, with the energy, colour and angle the library's
sun light (native.sun_light through ctypes, outside the add-on) gives for that sun.
"""

import argparse
import datetime
import hashlib
import importlib.util
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import traceback

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
LATITUDE, LONGITUDE = 48.859375, 2.34375  # Paris, exactly representable in float32
DATE, HOURS = "2026-06-21", (4.0, 5.0)    # frame 1 at 04:00 UTC, frame 7 at 05:00 UTC
FRAMES = 7
WIDTH = 64


def _load(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


T = _load(os.path.join(HERE, "run_addon_tests.py"), "airmass_run_addon_tests")  # helpers, not its main()
check, close = T.check, T.close


def utc(frame):
    minutes = int(round(HOURS[0] * 60 + (frame - 1) * 10))
    return "%sT%02d:%02d:00Z" % (DATE, minutes // 60, minutes % 60)


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


# ---- process 1: bake ------------------------------------------------------------------------------

def lamp_keys(obj):
    """energy, colour, rotation of the lamp at every frame (evaluated)."""
    scene = bpy.context.scene
    out = []
    for f in range(1, FRAMES + 1):
        scene.frame_set(f)
        out.append((obj.data.energy, tuple(obj.data.color), obj.data.angle, tuple(obj.matrix_world.col[2])))
    scene.frame_set(1)
    return out


def state(scene, folder):
    """Everything a failed or cancelled bake must leave as it was."""
    from airmass_blender import sun
    files = T.files_in(folder)
    world = scene.world
    env = world.node_tree.nodes.get("Airmass Sky")
    obj = sun.find_lamp(scene)
    return {"files": [os.path.basename(f) for f in files], "hashes": {os.path.basename(f): sha(f) for f in files},
            "world": world.name, "image": env.image.name if env and env.image else None,
            "image_path": env.image.filepath if env and env.image else None,
            "frame_user": (env.image_user.frame_start, env.image_user.frame_offset, env.image_user.frame_duration),
            "lamp": obj.name, "keys": lamp_keys(obj), "data": T.data_snapshot(),
            "actions": sorted(a.name for a in bpy.data.actions)}


def fcurves(idblock):
    ad = idblock.animation_data
    if hasattr(ad.action, "fcurves"):  # before 5.0
        return ad.action.fcurves
    from bpy_extras import anim_utils  # 5.0: layered actions
    return anim_utils.action_get_channelbag_for_slot(ad.action, ad.action_slot).fcurves


def set_manifest_keys(path, frames, key):
    with open(path) as f:
        m = json.load(f)
    for fr in frames:
        m["frames"][str(fr)]["key"] = key
    with open(path, "w") as f:
        json.dump(m, f)


def bake_process(args, tmp):
    from airmass_blender import animation, native
    scene, _ = T.fresh_scene("bake")
    blend = os.path.join(tmp, "bake.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    s = scene.airmass
    s.output_folder = "//sky/"  # relative to the .blend: the farm gets the folder with it
    s.preset = "earth"
    s.basis = "RGB"
    s.sky_width = WIDTH
    s.latitude, s.longitude, s.date = LATITUDE, LONGITUDE, DATE
    s.minutes_per_frame = 0.0
    scene.frame_start, scene.frame_end = 1, FRAMES
    # Time keyframed: 04:00 at frame 1, 05:00 at frame 7, linear (10 min per frame).
    for frame, hours in ((1, HOURS[0]), (FRAMES, HOURS[1])):
        s.utc_hours = hours
        check(scene.keyframe_insert('airmass.utc_hours', frame=frame), "keyframe on utc_hours")
    for fc in fcurves(scene):
        for k in fc.keyframe_points:
            k.interpolation = "LINEAR"
    scene.frame_set(1)
    folder = os.path.join(tmp, "sky")

    t0 = time.time()
    check(bpy.ops.airmass.bake_sky_animation() == {"FINISHED"}, "bake did not finish")
    print("first bake: %.1f s" % (time.time() - t0))
    names = ["Scene_sky_%04d.exr" % f for f in range(1, FRAMES + 1)]
    manifest = os.path.join(folder, "Scene_sky_animation.json")
    check(T.files_in(folder) == sorted([os.path.join(folder, n) for n in names] + [manifest]),
          "files after the bake: %s" % T.files_in(folder))
    with open(manifest) as f:
        m = json.load(f)
    check(m["last_bake"] == {"rendered": list(range(1, FRAMES + 1)), "unchanged": 0}, str(m["last_bake"]))
    for f in range(1, FRAMES + 1):  # Time is a float32 property: hours to about 2 ms
        got = datetime.datetime.fromisoformat(m["frames"][str(f)]["utc"].replace("Z", "+00:00"))
        want = datetime.datetime.fromisoformat(utc(f).replace("Z", "+00:00"))
        check(abs((got - want).total_seconds()) <= 0.005, "frame %d utc %s, not %s" % (f, got, want))
    check([m["frames"][str(f)]["utc"] for f in (1, FRAMES)] == [utc(1).replace("Z", ".000Z"),
                                                               utc(FRAMES).replace("Z", ".000Z")], "ends' utc")
    env = scene.world.node_tree.nodes["Airmass Sky"]
    check(env.image.source == "SEQUENCE" and env.image.filepath == "//sky/Scene_sky_0001.exr",
          "sequence image %s %s" % (env.image.source, env.image.filepath))
    bpy.ops.wm.save_mainfile()
    saved = state(scene, folder)

    # Re-bake, nothing changed: no frame rendered, no file touched.
    stats = {n: os.stat(os.path.join(folder, n)) for n in names}
    check(bpy.ops.airmass.bake_sky_animation() == {"FINISHED"}, "re-bake did not finish")
    with open(manifest) as f:
        m = json.load(f)
    check(m["last_bake"] == {"rendered": [], "unchanged": FRAMES}, "re-bake: %s" % m["last_bake"])
    for n in names:
        st = os.stat(os.path.join(folder, n))
        check((st.st_ino, st.st_mtime_ns) == (stats[n].st_ino, stats[n].st_mtime_ns), "re-bake touched " + n)
    again = state(scene, folder)
    diff = {k: (saved[k], again[k]) for k in saved if saved[k] != again[k]}
    check(set(diff) <= {"hashes", "actions"}, "re-bake changed %s" % diff)  # new actions, the manifest's last_bake
    check({k for k in saved["hashes"] if saved["hashes"][k] != again["hashes"][k]} <= {os.path.basename(manifest)},
          "re-bake changed a frame file")
    bpy.ops.wm.save_mainfile()
    saved = again

    # Esc: frames 5–7 out of date; the cancel arrives while frame 6 renders. Nothing changes.
    with open(manifest, "rb") as f:
        manifest_bytes = f.read()
    set_manifest_keys(manifest, (5, 6, 7), "stale")
    before = state(scene, folder)
    plan = animation.BakePlan(bpy.context)
    check([f for f, _ in plan.todo] == [5, 6, 7], "to render: %s" % [f for f, _ in plan.todo])
    # True = cancel, as Esc does. The three frames share the bar in thirds; the cancel comes at
    # frame 6's first report past 1/3. (It was > 0.45, which needed a report in the middle of
    # frame 6's table precompute: with the tail-corrected stop the precompute reports fewer,
    # larger steps and the first one past 0.45 was frame 6's last, after its image was staged.)
    progress = native.Progress(lambda fraction: fraction > 0.34)
    try:
        plan.work(progress)
        raise AssertionError("the cancelled bake finished")
    except native.NativeError as e:
        check(e.cancelled, "not a cancel: %s" % e)
        check(len(plan.staged) == 1, "staged before the cancel: %s" % plan.staged)
        plan.abort()
    finally:
        progress.close()
    check(state(scene, folder) == before, "a cancelled bake changed the state")

    # A step failing after the files were renamed into place and the lamp keyframed: all rolled back.
    original = animation.BakePlan._wire_sequence

    def failing(self, scene_, undo):
        original(self, scene_, undo)
        raise RuntimeError("injected failure after wiring the World")
    animation.BakePlan._wire_sequence = failing
    try:
        bpy.ops.airmass.bake_sky_animation()
        raise AssertionError("the failing bake reported success")
    except RuntimeError as e:
        check("injected failure" in str(e), "error: %s" % e)
    finally:
        animation.BakePlan._wire_sequence = original
    check(state(scene, folder) == before, "a failed bake changed the state:\n%s\n%s"
          % (state(scene, folder), before))
    with open(manifest, "wb") as f:
        f.write(manifest_bytes)
    bake_from_lamp()
    return blend


def bake_from_lamp():
    """Sun From = Sun Lamp: the user's own lamp animation gives each frame's sun; it is kept, and
    the lamp's light is keyframed for those suns (a new scene; the saved .blend is not touched)."""
    from airmass_blender import native, sun
    scene, out = T.fresh_scene("lamp")
    s = scene.airmass
    s.preset, s.basis, s.sky_width, s.multiple_scattering = "earth", "RGB", 16, False
    scene.frame_start, scene.frame_end = 1, 2
    data = bpy.data.lights.new("User Sun", type="SUN")
    obj = bpy.data.objects.new("User Sun", data)
    scene.collection.objects.link(obj)
    s.sun_object = obj
    suns = {1: (10.0, 100.0), 2: (20.0, 250.0)}
    for frame, (e, r) in suns.items():
        obj.rotation_euler = sun.lamp_rotation(math.radians(e), math.radians(r))
        obj.keyframe_insert("rotation_euler", frame=frame)
    action = obj.animation_data.action
    s.bake_sun_source = "LAMP"
    check(bpy.ops.airmass.bake_sky_animation() == {"FINISHED"}, "bake from the lamp did not finish")
    check(obj.animation_data.action == action, "the lamp's own rotation animation was replaced")
    with open(os.path.join(out, "Scene_sky_animation.json")) as f:
        m = json.load(f)
    for frame, (e, r) in suns.items():
        entry = m["frames"][str(frame)]
        close(entry["blender_elevation_deg"], e, abs_=1e-4, rel=0.0, what="frame %d elevation" % frame)
        close(entry["blender_rotation_deg"], r, abs_=1e-4, rel=0.0, what="frame %d rotation" % frame)
        scene.frame_set(frame)
        spec = native.Spec(preset="earth")
        spec.basis, spec.sun_elevation_deg, spec.sun_rotation_deg = 1, e, r
        strength = max(native.sun_light(spec, chapman="airmass")["irradiance_rgb"])
        close(obj.data.energy, strength, rel=1e-4, what="frame %d energy from the lamp's sun" % frame)
    print("PASS bake from the Sun lamp's animation: its rotation kept, its light keyed per frame")


# ---- process 2: a Blender without the add-on renders the saved file ------------------------------

def cli_sun(cli, frame):
    out = subprocess.run([cli, "sun", "--latitude", repr(LATITUDE), "--longitude", repr(LONGITUDE),
                          "--time", utc(frame)], capture_output=True, text=True, check=True).stdout.split("\n")
    header, row = out[0].split(","), out[1].split(",")
    values = dict(zip(header, row))
    return float(values["blender_elevation_deg"]), float(values["blender_rotation_deg"])


def row_means(pixels):
    """[(r, g, b) mean per row] of a (height, width, 4) array."""
    return pixels[:, :, :3].mean(axis=1)


def render_world(scene, frame, path):
    import numpy as np
    scene.frame_set(frame)
    cam_data = bpy.data.cameras.new("equirect")
    cam_data.type = "PANO"
    if hasattr(cam_data, "panorama_type"):  # 4.0+
        cam_data.panorama_type = "EQUIRECTANGULAR"
    else:
        cam_data.cycles.panorama_type = "EQUIRECTANGULAR"
    cam = bpy.data.objects.new("equirect", cam_data)
    scene.collection.objects.link(cam)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)  # horizontal view, +Z up: image rows are elevations
    scene.camera = cam
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01  # one sample at the pixel centre
    T.render_tiny(scene, path, samples=1, width=WIDTH, height=WIDTH // 2)
    img = bpy.data.images.load(path, check_existing=False)
    try:
        return np.array(T._image_pixels(img), dtype=np.float64)
    finally:
        bpy.data.images.remove(img)


def exr_pixels(path):
    import numpy as np
    img = bpy.data.images.load(path, check_existing=False)
    try:
        return np.array(T._image_pixels(img), dtype=np.float64)
    finally:
        bpy.data.images.remove(img)


def render_process(args, tmp):
    import numpy as np
    check("airmass_blender" not in bpy.context.preferences.addons and not hasattr(bpy.types.Scene, "airmass"),
          "the add-on is enabled in the render process")
    os.environ["AIRMASS_C_LIBRARY"] = os.path.abspath(args.lib)
    native = _load(os.path.join(REPO, "addon", "airmass_blender", "native.py"), "airmass_native_plain")
    scene = bpy.context.scene
    check((scene.frame_start, scene.frame_end) == (1, FRAMES), "frame range %d-%d" % (scene.frame_start,
                                                                                       scene.frame_end))
    env = next(n for n in scene.world.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment")
    folder = os.path.join(tmp, "sky")
    lamp = next(o for o in scene.objects if o.type == "LIGHT" and o.data.type == "SUN")
    files = {f: exr_pixels(os.path.join(folder, "Scene_sky_%04d.exr" % f)) for f in (1, FRAMES)}
    for frame in (1, FRAMES):
        other = FRAMES if frame == 1 else 1
        shown = render_world(scene, frame, os.path.join(tmp, "render_%d.exr" % frame))
        want, wrong = row_means(files[frame]), row_means(files[other])
        got = row_means(shown)
        scale = want.max()
        err, err_other = np.abs(got - want).max() / scale, np.abs(got - wrong).max() / scale
        print("frame %d: rendered rows vs file %d: %.2e, vs file %d: %.2e" % (frame, frame, err, other, err_other))
        check(err < 2e-3, "frame %d: the World does not show file %04d (row error %.3g)" % (frame, frame, err))
        check(err_other > 50 * err and err_other > 0.02, "frame %d: files %d and %d are not told apart (%.3g)"
              % (frame, frame, other, err_other))
        # The lamp: direction = `airmass sun`, light = the library's sun light for that sun.
        scene.frame_set(frame)
        elevation, rotation = cli_sun(args.cli, frame)
        sun_dir = T.sky_texture_sun(math.radians(elevation), math.radians(rotation))
        lamp_dir = tuple(lamp.matrix_world.col[2][:3])
        angle = T.angle_deg(lamp_dir, sun_dir)
        print("frame %d (%s): sun elevation %.4f°, rotation %.4f°; lamp off by %.2e°"
              % (frame, utc(frame), elevation, rotation, angle))
        check(angle < 2e-4, "frame %d: lamp direction off by %g°" % (frame, angle))
        spec = native.Spec(preset="earth")
        spec.basis = 1
        spec.sun_elevation_deg, spec.sun_rotation_deg = elevation, rotation
        light = native.sun_light(spec, chapman="airmass")
        rgb = light["irradiance_rgb"]
        strength = max(rgb)
        check(strength > 0.0 and not light["below_horizon"], "frame %d: sun below the horizon" % frame)
        close(lamp.data.energy, strength, rel=1e-5, what="frame %d energy" % frame)
        for c in range(3):
            close(lamp.data.color[c], rgb[c] / strength, rel=1e-5, what="frame %d colour[%d]" % (frame, c))
        close(lamp.data.angle, math.radians(light["angular_diameter_deg"]), rel=1e-5, what="frame %d angle" % frame)
        print("frame %d: lamp %.6g W/m², colour (%.4f, %.4f, %.4f) as the library" % (frame, strength,
                                                                                    *lamp.data.color))


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="test_sky_bake.py")
    ap.add_argument("--zip")
    ap.add_argument("--cli", required=True)
    ap.add_argument("--lib", required=True)
    ap.add_argument("--render", metavar="TMP", help="(process 2) render the opened .blend; TMP holds its frames")
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    if args.render:
        try:
            render_process(args, args.render)
        except Exception:  # noqa: BLE001
            traceback.print_exc()
            print("FAIL test_sky_bake (render process)")
            raise SystemExit(1)
        print("PASS test_sky_bake (render process)")
        return
    tmp = tempfile.mkdtemp(prefix="airmass-sky-bake-")
    T.Ctx.tmp = tmp
    try:
        T.install_addon(os.path.abspath(args.zip))
        t0 = time.time()
        blend = bake_process(args, tmp)
        print("PASS test_sky_bake (bake process, %.1f s)" % (time.time() - t0))
        r = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", blend, "--python-exit-code", "1",
                            "--python", os.path.abspath(__file__), "--", "--cli", args.cli, "--lib", args.lib,
                            "--render", tmp], capture_output=True, text=True)
        print(r.stdout[-6000:])
        print(r.stderr[-3000:], file=sys.stderr)
        check(r.returncode == 0 and "PASS test_sky_bake (render process)" in r.stdout,
              "the render process failed (exit %d)" % r.returncode)
    except Exception:  # noqa: BLE001
        traceback.print_exc()
        print("FAIL test_sky_bake")
        raise SystemExit(1)
    finally:
        if args.keep:
            print("kept", tmp)
        else:
            import shutil
            shutil.rmtree(tmp, ignore_errors=True)
    print("all sky bake tests passed")


if __name__ == "__main__":
    main()
