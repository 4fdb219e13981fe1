"""Live Sky Preview (addon/airmass_blender/live.py; issue 14 goal 3), in Debian's Blender 3.4:

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_live_preview.py \\
        -- --zip build/addon/airmass_blender.zip

Background Blender runs no timers, so the test drives live.tick() itself, with a clock of its own
for the 0.3 s rest (`now`) and real waits for the worker thread. It checks that
  * the sun moved three times while a render runs is rendered once more, at the LAST position only
    (throttled: the middle position is never rendered), at the preview quality;
  * the World's image follows the last direction: its brightest pixel (the sun disc, box-filtered
    into the pixel it covers) is within 1.5 pixels of where Blender's equirectangular mapping puts
    that sun, for each of several positions;
  * after the rest the image is the full-quality one, equal value for value to native.render_sky of
    the same settings (the one-shot C ABI call) — and the preview differs from it (a real preview);
  * a move during the full-quality render cancels it and the new sun is shown;
  * the session is kept while only the sun moves and made anew when the atmosphere changes.
"""

import importlib.util
import math
import os
import sys
import time

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))


def _load(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


T = _load(os.path.join(HERE, "run_addon_tests.py"), "airmass_run_addon_tests")  # helpers, not its main()
check = T.check


class Clock:
    now = 1000.0


def drive(live, scene, until_idle=True, step=0.0):
    """Ticks until no render runs; the test's clock advances `step` per tick (default: not at all, so
    the sun never rests while a render runs, however long it takes on a loaded machine)."""
    for _ in range(100000):
        Clock.now += step
        live.tick(scene, now=Clock.now)
        if not live.busy() or not until_idle:
            return
        time.sleep(0.005)
    raise AssertionError("the live preview never finished a render")


def settle(live, scene):
    """Lets the sun rest past the 0.3 s, then ticks until the full-quality image is shown."""
    Clock.now += 0.5
    live.tick(scene, now=Clock.now)
    drive(live, scene)
    drive(live, scene)


def image_pixels(name):
    import numpy as np
    image = bpy.data.images[name]
    w, h = image.size
    flat = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(h, w, 4)  # row 0 = the bottom row (Blender)


def expected_sun_pixel(elevation, rotation, w, h):
    """(column, row from the bottom) of the sun in Blender's equirectangular image (docs/sky.md)."""
    ce = math.cos(elevation)
    d = (ce * math.sin(rotation), ce * math.cos(rotation), math.sin(elevation))
    u = (math.atan2(d[1], d[0]) - math.pi) / (-2 * math.pi)
    v = (math.acos(d[2]) - math.pi) / (-math.pi)
    return u * w, v * h


def brightest(pixels):
    import numpy as np
    lum = 0.2126 * pixels[..., 0] + 0.7152 * pixels[..., 1] + 0.0722 * pixels[..., 2]
    row, col = np.unravel_index(int(np.argmax(lum)), lum.shape)
    return col + 0.5, row + 0.5


def test_live_preview():
    import numpy as np
    from airmass_blender import live, native, world
    from airmass_blender.properties import make_spec
    scene, _out = T.fresh_scene("live")
    s = scene.airmass
    s.preset = "blender-nishita"   # 21 wavelengths: quick tables
    s.sky_width = 256
    s.view_samples = 16
    s.sun_disc = True
    live.reset()
    s.live_preview = True
    w, h = 256, 128
    suns = [(math.radians(12.0), math.radians(30.0)), (math.radians(25.0), math.radians(120.0)),
            (math.radians(41.0), math.radians(250.0))]

    # Three moves while the first render (the session's tables, then the sky) runs.
    s.sun_elevation, s.sun_rotation = suns[0]
    Clock.now += 0.01
    live.tick(scene, now=Clock.now)
    check(live.busy(), "a move starts a render")
    s.sun_elevation, s.sun_rotation = suns[1]
    drive(live, scene, until_idle=False)
    s.sun_elevation, s.sun_rotation = suns[2]
    drive(live, scene, until_idle=False)
    drive(live, scene)   # the first render ends, the latest sun starts
    drive(live, scene)
    rendered = [(q, (round(e, 4), round(r, 4))) for q, (e, r, _a) in live._state["renders"]]
    want = [("preview", (round(suns[0][0], 4), round(suns[0][1], 4))),
            ("preview", (round(suns[2][0], 4), round(suns[2][1], 4)))]
    check(rendered == want, "throttled to the latest sun: rendered %s, expected %s" % (rendered, want))
    session = live._state["session"][1]

    # The image follows the sun, position after position.
    for e, r in suns[::-1] + [(math.radians(5.0), math.radians(90.0))]:
        s.sun_elevation, s.sun_rotation = e, r
        drive(live, scene)
        drive(live, scene)
        check(live._state["shown"][1] == "preview", "a preview is shown while the sun moves")
        px = image_pixels(world.IMAGE_NAME)
        got = brightest(px)
        want_px = expected_sun_pixel(e, r, w, h)
        dx = abs(math.remainder(got[0] - want_px[0], w))
        dy = abs(got[1] - want_px[1])
        check(math.hypot(dx, dy) <= 1.5, "sun at %.0f/%.0f deg: brightest pixel %s, expected %s"
              % (math.degrees(e), math.degrees(r), got, want_px))
    check(live._state["session"][1] is session, "the session is kept while only the sun moves")
    preview = image_pixels(world.IMAGE_NAME).copy()

    # The rest: the full-quality image, equal to the one-shot library call of the same settings.
    settle(live, scene)
    check(live._state["shown"][1] == "full", "full quality after the sun rests, got %s" % (live._state["shown"],))
    image = bpy.data.images[world.IMAGE_NAME]
    check(image.get("airmass:live") == "full" and image.packed_file is not None, "the full image is packed")
    full = image_pixels(world.IMAGE_NAME)
    ref, _meta = native.render_sky(make_spec(s), **world.sky_options(s))
    ref = ref[::-1]
    diff = float(np.max(np.abs(full - ref)))
    check(diff == 0.0, "the full-quality image equals native.render_sky value for value (max |diff| %g)" % diff)
    rel = float(np.max(np.abs(preview - ref)[..., :3] / np.maximum(ref[..., :3], 1e-6)))
    check(rel > 0.0, "the preview is a cheaper image, not the full one (max rel diff %g)" % rel)

    # A move during a full-quality render cancels it; the new sun is shown.
    s.preset = "earth"  # a new atmosphere: a new session (48 wavelengths: a render long enough to interrupt)
    Clock.now += 0.5
    live.tick(scene, now=Clock.now)
    check(live.busy() and live._state["job"].quality == "full", "a full-quality render runs after the change")
    s.sun_elevation, s.sun_rotation = math.radians(33.0), math.radians(200.0)
    drive(live, scene)
    drive(live, scene)
    check(live._state["shown"][0][:2] == (s.sun_elevation, s.sun_rotation),
          "after a move during the full render the new sun is shown: %s" % (live._state["shown"],))
    check(live._state["session"][1] is not session, "a new atmosphere makes a new session")
    s.live_preview = False
    check(not live.busy(), "turning the preview off stops it")


def test_live_image_fault():
    """The live image is made by compat.new_float_image (the one float-image builder): when a new
    size's image cannot be made, nothing half-made is left and the World keeps the previous image
    under its name (before, the previous one was renamed "Airmass Sky (old)" and an untagged new
    one stayed)."""
    from airmass_blender import compat, live, world
    scene, _out = T.fresh_scene("live_fault")
    s = scene.airmass
    s.preset = "blender-nishita"
    s.sky_width = 64
    s.view_samples = 4
    live.reset()
    s.live_preview = True
    Clock.now += 0.01
    live.tick(scene, now=Clock.now)
    drive(live, scene)
    drive(live, scene)
    shown = bpy.data.images.get(world.IMAGE_NAME)
    check(shown is not None and tuple(shown.size) == (64, 32), "the first preview image: %s" % shown)
    check(shown.colorspace_settings.name == compat.float_image_colorspace() and shown.is_float,
          "the live image is a float image in %s: %s, float %s"
          % (compat.float_image_colorspace(), shown.colorspace_settings.name, shown.is_float))
    names = sorted(i.name for i in bpy.data.images)

    def broken(image):
        raise RuntimeError("no colour space (test)")
    original = compat.set_float_image_colorspace
    compat.set_float_image_colorspace = broken
    try:
        s.sky_width = 128  # a new size: a new image, made when the moved sun's preview is applied
        s.sun_elevation += math.radians(3.0)
        renders = len(live._state["renders"])
        failed = None
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and len(live._state["renders"]) == renders:
            try:
                live.tick(scene, now=Clock.now)
            except RuntimeError as e:
                failed = e
                break
            time.sleep(0.005)
        check(failed is not None and "no colour space" in str(failed), "the image's fault surfaces: %r" % failed)
    finally:
        compat.set_float_image_colorspace = original
    check(sorted(i.name for i in bpy.data.images) == names,
          "images after the failed new image: %s, before %s" % (sorted(i.name for i in bpy.data.images), names))
    env = scene.world.node_tree.nodes.get(world.ENV_NODE)
    check(env.image == bpy.data.images.get(world.IMAGE_NAME) and tuple(env.image.size) == (64, 32),
          "the World keeps the previous image: %s" % env.image)
    s.live_preview = False


TESTS = [test_live_preview, test_live_image_fault]


def main():
    T.run_tests(TESTS, sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [], "test_live_preview.py")


if __name__ == "__main__":
    main()
