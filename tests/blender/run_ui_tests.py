"""The add-on's interactive path, in a real (virtual) window:

    xvfb-run -a blender --factory-startup --enable-event-simulate \\
        --python tests/blender/run_ui_tests.py -- --zip build/addon/airmass_blender.zip

From the UI, Generate Sky and Create Volume run their native work on a thread while a
modal timer keeps Blender responsive; Esc cancels. This checks, with a window and an event
loop (which `-b` lacks): an invoked operator finishes and builds the World; Blender keeps
handling timers while the native work runs; Esc cancels it and nothing is left behind
(no file, no image). Exits with status 1 on failure (os._exit, from a timer).
"""

import argparse
import os
import shutil
import sys
import tempfile
import time

import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--zip", required=True)
args = ap.parse_args(argv)

tmp = tempfile.mkdtemp(prefix="airmass-ui-tests-")
out = os.path.join(tmp, "out")
os.makedirs(out)
bpy.context.preferences.filepaths.script_directory = os.path.join(tmp, "scripts")
os.makedirs(bpy.context.preferences.filepaths.script_directory)
bpy.context.preferences.view.show_splash = False
bpy.ops.preferences.addon_install(filepath=os.path.abspath(args.zip), target="PREFS", overwrite=True)
bpy.utils.refresh_script_paths()
bpy.ops.preferences.addon_enable(module="airmass_blender")

state = {"step": "settle", "t0": time.time(), "ticks": 0, "failures": [], "last_tick": 0.0, "steady": 0}


def fail(msg):
    state["failures"].append(msg)
    print("FAIL", msg)


def finish():
    shutil.rmtree(tmp, ignore_errors=True)
    if state["failures"]:
        print("UI tests failed:", "; ".join(state["failures"]))
        sys.stdout.flush()
        os._exit(1)
    print("all Blender UI tests passed")
    sys.stdout.flush()
    os._exit(0)


def invoke(op, **kw):
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, area=area, region=region):
        return op("INVOKE_DEFAULT", **kw)


def press_esc(next_step):
    window = bpy.context.window_manager.windows[0]
    window.event_simulate(type="ESC", value="PRESS")
    window.event_simulate(type="ESC", value="RELEASE")
    state["step"], state["t0"] = next_step, time.time()
    return 0.2


def worker_running():
    return any("airmass" in (t.name or "") for t in __import__("threading").enumerate())


def ticker():
    state["ticks"] += 1  # counts while native work runs: the event loop is alive
    now = time.time()
    # Under Xvfb the first seconds go to software-GL shader compilation and first draws;
    # the tests start once the event loop runs timers steadily.
    state["steady"] = state["steady"] + 1 if now - state["last_tick"] < 0.2 else 0
    state["last_tick"] = now
    return 0.02 if state["step"] != "done" else None


def step():
    scene = bpy.context.scene
    s = scene.airmass
    st = state["step"]
    if st == "settle":
        if state["steady"] >= 10:
            state["step"] = "start"
        elif time.time() - state["t0"] > 120:
            fail("Blender's event loop never settled")
            return finish()
        return 0.1
    if st == "start":
        s.output_folder = out
        # long enough (seconds) that a blocked UI could not tick 5 times by chance
        s.sky_width, s.view_samples, s.sky_grid = 1024, 16, 0
        state["ticks"] = 0
        result = invoke(bpy.ops.airmass.generate_sky)
        if result != {"RUNNING_MODAL"}:
            fail("generate_sky invoke returned %s" % result)
            return finish()
        state["step"], state["t0"] = "wait_sky", time.time()
        return 0.1
    if st == "wait_sky":
        world = scene.world
        env = world.node_tree.nodes.get("Airmass Sky") if world and world.node_tree else None
        if env is not None and env.image is not None:
            print("PASS invoked Generate Sky finished (%.2f s, %d timer ticks meanwhile)"
                  % (time.time() - state["t0"], state["ticks"]))
            if state["ticks"] < 5:
                fail("no timer ran while the sky was computed: the UI was blocked")
            # A long sky, cancelled with Esc.
            s.sky_width, s.view_samples, s.sky_grid = 4096, 32, 0
            state["files"] = sorted(os.listdir(out))
            state["images"] = len(bpy.data.images)
            os.remove(os.path.join(out, state["files"][0]))  # the next run must not rewrite it
            state["files"] = sorted(os.listdir(out))
            result = invoke(bpy.ops.airmass.generate_sky)
            if result != {"RUNNING_MODAL"}:
                fail("second invoke returned %s" % result)
                return finish()
            state["step"], state["t0"] = "esc", time.time()
            return 0.3
        if time.time() - state["t0"] > 120:
            fail("invoked Generate Sky did not finish in 120 s")
            return finish()
        return 0.1
    if st == "esc":
        return press_esc("wait_cancel")
    if st == "wait_cancel":
        leftovers = [f for f in os.listdir(out) if f not in state["files"]]
        if not worker_running():
            if leftovers:
                fail("files left after Esc: %s" % leftovers)
            if len(bpy.data.images) != state["images"]:
                fail("images changed after Esc")
            elapsed = time.time() - state["t0"]
            print("PASS Esc cancelled Generate Sky (%.2f s after Esc), nothing left behind" % elapsed)
            state["step"] = "bake"
            return 0.1
        if time.time() - state["t0"] > 60:
            fail("Esc did not stop the work within 60 s")
            return finish()
        return 0.1
    # Bake Sky Animation from the UI: frames rendered on the worker, encoded by the main thread's
    # drain (jobs.Plan.drain); then Esc during a re-bake leaves the frames and the World as they were.
    if st == "bake":
        scene.frame_start, scene.frame_end = 1, 4
        s.sky_width, s.view_samples, s.sky_grid = 64, 8, -1
        s.utc_hours, s.minutes_per_frame = 4.0, 10.0
        state["ticks"] = 0
        result = invoke(bpy.ops.airmass.bake_sky_animation)
        if result != {"RUNNING_MODAL"}:
            fail("bake_sky_animation invoke returned %s" % result)
            return finish()
        state["step"], state["t0"] = "wait_bake", time.time()
        return 0.1
    if st == "wait_bake":
        running = worker_running()
        env = scene.world.node_tree.nodes.get("Airmass Sky") if scene.world and scene.world.node_tree else None
        image = env.image if env is not None else None
        if not running and image is not None and image.name == "Airmass Sky Sequence":
            frames = sorted(f for f in os.listdir(out) if "_sky_0" in f)
            if frames != ["Scene_sky_%04d.exr" % f for f in range(1, 5)] or image.source != "SEQUENCE":
                fail("invoked bake: files %s, image source %s" % (frames, image.source))
            print("PASS invoked Bake Sky Animation finished (%.2f s, %d timer ticks meanwhile)"
                  % (time.time() - state["t0"], state["ticks"]))
            state["bake_files"] = {f: open(os.path.join(out, f), "rb").read() for f in os.listdir(out)}
            state["bake_image"] = (image.name, image.filepath)
            s.latitude += 1.0  # every frame out of date ...
            s.sky_width, s.sky_grid = 2048, 0  # ... and slow, so that Esc arrives while frame 1 renders
            result = invoke(bpy.ops.airmass.bake_sky_animation)
            if result != {"RUNNING_MODAL"}:
                fail("second bake invoke returned %s" % result)
                return finish()
            state["step"], state["t0"] = "bake_esc", time.time()
            return 0.5
        if time.time() - state["t0"] > 120:
            fail("invoked Bake Sky Animation did not finish in 120 s")
            return finish()
        return 0.1
    if st == "bake_esc":
        return press_esc("wait_bake_cancel")
    if st == "wait_bake_cancel":
        if not worker_running():
            now = {f: open(os.path.join(out, f), "rb").read() for f in os.listdir(out)}
            if now != state["bake_files"]:
                fail("Esc during a bake changed the files: %s" % sorted(set(now) ^ set(state["bake_files"])))
            env = scene.world.node_tree.nodes.get("Airmass Sky")
            if (env.image.name, env.image.filepath) != state["bake_image"]:
                fail("Esc during a bake changed the World's image")
            print("PASS Esc cancelled Bake Sky Animation (%.2f s after Esc), files and World unchanged"
                  % (time.time() - state["t0"]))
            state["step"] = "done"
            return finish()
        if time.time() - state["t0"] > 60:
            fail("Esc did not stop the bake within 60 s")
            return finish()
        return 0.1
    return None


bpy.app.timers.register(ticker, first_interval=0.5)
bpy.app.timers.register(step, first_interval=1.0)
