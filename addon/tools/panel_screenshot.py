"""Screenshot of the add-on's World panel, for docs/addon.md. Needs a display; headless:

    xvfb-run -a -s "-screen 0 1400x1700x24" blender --factory-startup \\
        --python addon/tools/panel_screenshot.py -- --zip build/addon/airmass_blender.zip \\
        --out docs/images/addon_panel.png

Installs the zip into a temporary scripts folder, opens every Airmass sub-panel, maximises
the Properties editor on the World tab, saves a screenshot of it and quits.
"""

import argparse
import os
import sys
import tempfile

import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--zip", required=True)
ap.add_argument("--out", required=True)
args = ap.parse_args(argv)
OUT = os.path.abspath(args.out)

tmp = tempfile.mkdtemp(prefix="airmass-screenshot-")
bpy.context.preferences.filepaths.script_directory = tmp
bpy.context.preferences.view.show_splash = False
bpy.ops.preferences.addon_install(filepath=os.path.abspath(args.zip), target="PREFS", overwrite=True)
bpy.utils.refresh_script_paths()
bpy.ops.preferences.addon_enable(module="airmass_blender")

# Show the sub-panels open (they are closed by default).
import airmass_blender.ui as ui  # noqa: E402

for cls in ui.CLASSES:
    if "DEFAULT_CLOSED" in getattr(cls, "bl_options", set()):
        bpy.utils.unregister_class(cls)
        cls.bl_options = set()
        bpy.utils.register_class(cls)

scene = bpy.context.scene
scene.airmass.preset = "earth"
scene.airmass.output_folder = "/tmp/airmass/"


def properties_area():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "PROPERTIES":
                return window, area
    return None, None


state = {"step": 0}


def step():
    window, area = properties_area()
    if area is None:
        print("no Properties editor")
        bpy.ops.wm.quit_blender()
        return None
    s = state["step"]
    state["step"] += 1
    if s == 0:
        area.spaces.active.context = "WORLD"
        with bpy.context.temp_override(window=window, area=area):
            bpy.ops.screen.screen_full_area()
        return 0.5
    if s == 1:
        window.cursor_warp(5, 5)  # no tooltip in the picture
        return 1.0  # let it draw
    if s == 2:
        window, area = properties_area()
        with bpy.context.temp_override(window=window, area=area):
            bpy.ops.screen.screenshot_area(filepath=OUT)
        print("wrote", OUT)
        bpy.ops.wm.quit_blender()
        return None
    return None


bpy.app.timers.register(step, first_interval=1.0)
