"""Live Sky Preview: the World's sky follows the sun while it is dragged (issue 14 goal 3).

With scene.airmass.live_preview on, a timer (bpy.app.timers, every TICK seconds) watches the sun
(the settings' Sun Elevation / Sun Rotation, which Live Sync keeps equal to the Airmass Sun
lamp's direction, and the observer's Altitude). On a change it renders the sky for the LATEST
sun only — throttled: while one render runs, newer positions just replace the pending one — at
the preview quality (PREVIEW below: the sky grid, view samples and multiple-scattering view of
bench/bench_sky_session.cpp, its error against the full quality measured there and in
docs/sky.md). When the sun has not moved for SETTLE seconds, it renders the full-quality image
(the panel's Sky Width, View Samples, Sky Grid: the pixels Generate Sky makes) and packs it. A
move during that render cancels it (the library's cancel token) and previews again.

The atmosphere is made once per atmosphere (native.SkySession: the compiled atmosphere and its
multiple-scattering tables, about a second): every render reuses it; a change of any setting the
atmosphere depends on (source, preset, planet, constituents, basis, Chapman method, Multiple
Scattering) makes a new session on the next render. Renders run on a worker thread (the library
releases the GIL); the pixels go into the image on the main thread, through Blender's image API
(image.pixels.foreach_set), never through a file.

The module's state is per Blender session (one live preview: the active scene's). Tests drive
tick() directly (background Blender runs no timers).
"""

import threading
import time

import bpy

from . import compat, native
from .properties import make_spec

TICK = 0.05     # s between looks at the sun
SETTLE = 0.3    # s without a move before the full-quality image
# The preview quality: sky grid 32, 16 view samples, multiple-scattering view 16 — at 1024 × 512
# for `earth` 31–47 ms of CPU per sun (17–25 ms wall on 2 threads) against 47–70 ms (25–37 ms)
# for the full quality, p95 0.33 % / max 2.9 % from it (bench/bench_sky_session.cpp, docs/sky.md).
PREVIEW = {"grid": 32, "view_samples": 16, "multiple_grid": 16}

_state = {
    "session": None,      # (key, native.SkySession)
    "job": None,          # the running _Job, or None
    "shown": None,        # (sun, quality) of the image in the World
    "last_move": 0.0,     # time.monotonic() of the last change of the sun
    "seen": None,         # the sun at the last tick
    "renders": [],        # (quality, sun) of every image applied, for tests and the status line
}


def _sun_of(s):
    return (float(s.sun_elevation), float(s.sun_rotation), float(s.altitude))


def atmosphere_key(s):
    """What the session depends on: the scene without its sun and observer, the basis, the Chapman
    method and multiple scattering (a change makes a new session)."""
    spec = make_spec(s)
    spec.sun_elevation_deg = spec.sun_rotation_deg = spec.altitude_m = None
    return (repr(sorted(vars(spec).items())), s.chapman, bool(s.multiple_scattering))


def full_options(s):
    from .world import sky_options
    options = sky_options(s)
    return options


def preview_options(s):
    options = full_options(s)
    options.update(PREVIEW)
    return options


class _Job:
    """One render on a worker thread: the session (made first when the atmosphere changed), then
    the sky for `sun` at `options`."""

    def __init__(self, key, spec, sun, options, quality):
        self.key, self.spec, self.sun, self.options, self.quality = key, spec, sun, options, quality
        self.progress = native.Progress()
        self.pixels = None
        self.metadata = None
        self.error = None
        self.session = None
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self, session):
        self.session = session
        self.thread.start()
        return self

    def _run(self):
        try:
            if self.session is None or self.session[0] != self.key:
                create = {k: v for k, v in self.options.items() if k in ("chapman", "multiple_scattering")}
                self.session = (self.key, native.SkySession(self.spec, progress=self.progress, **create))
            # The sun and observer exactly as Generate Sky passes them (make_spec: degrees, metres).
            spec = self.spec
            self.pixels, self.metadata = self.session[1].render(
                spec.sun_elevation_deg, spec.sun_rotation_deg, spec.altitude_m, progress=self.progress,
                metadata=self.quality == "full", **self.options)
        except Exception as e:  # noqa: BLE001 — reported on the main thread
            self.error = e

    def cancel(self):
        self.progress.cancel()

    @property
    def done(self):
        return not self.thread.is_alive()


def _image(scene, width, height):
    """The World's sky image of this size: the Generate Sky image when it has the size, else a new
    float image (compat.new_float_image; filled and packed by _apply, no read-back) wired into the
    World (world.wire_world). When the new image cannot be made the previous one stays as it was."""
    from .world import IMAGE_NAME, wire_world
    image = bpy.data.images.get(IMAGE_NAME)
    if image is None or tuple(image.size) != (width, height):
        new = compat.new_float_image(IMAGE_NAME + " (new)", width, height)
        if image is not None:
            image.name = IMAGE_NAME + " (old)"
        new.name = IMAGE_NAME
        wire_world(scene, new, scene.airmass.sky_strength)
        if image is not None and image.users == 0:
            bpy.data.images.remove(image)
        image = new
    return image


def _apply(scene, job):
    """The job's pixels into the World's image (main thread)."""
    from .world import PIXELS_KEY
    pixels = job.pixels
    compat.convert_pixels(pixels, compat.rec709_to_working_matrix())
    height, width = pixels.shape[0], pixels.shape[1]
    image = _image(scene, width, height)
    image.pixels.foreach_set(pixels[::-1].ravel())  # Blender's rows start at the bottom
    image[PIXELS_KEY] = "linear Rec.709 -> %s" % compat.working_space()
    image["airmass:live"] = job.quality
    if job.quality == "full":
        for key, value in job.metadata.items():
            image[key] = value
        image.pack()
    image.update()
    _state["shown"] = (job.sun, job.quality)
    _state["renders"].append((job.quality, job.sun))


def tick(scene=None, now=None):
    """One look at the sun: apply a finished render, start the next one. Returns the seconds to the
    next tick (None: stop the timer)."""
    scene = scene if scene is not None else bpy.context.scene
    s = getattr(scene, "airmass", None)
    if s is None or not s.live_preview:
        _halt()
        return None
    now = time.monotonic() if now is None else now
    sun = _sun_of(s)
    if sun != _state["seen"]:
        _state["seen"] = sun
        _state["last_move"] = now
    job = _state["job"]
    if job is not None:
        if not job.done:
            # A full-quality render is cancelled by any move; a preview runs to its end (it is short)
            # and the latest sun is rendered next.
            if job.quality == "full" and sun != job.sun:
                job.cancel()
            return TICK
        _state["job"] = None
        _state["session"] = job.session
        if job.error is None and job.pixels is not None:
            _apply(scene, job)
        elif job.error is not None and not getattr(job.error, "cancelled", False):
            # Said in the panel; not retried until the sun or the atmosphere changes.
            s.live_status = "Live preview: %s" % job.error
            _state["shown"] = (job.sun, "full")
            return TICK
        if job.error is None:
            s.live_status = ""
    shown = _state["shown"]
    try:
        key = atmosphere_key(s)
    except Exception as e:  # noqa: BLE001 — a bad setting: say so and stop
        s.live_status = "Live preview: %s" % e
        return TICK
    session = _state["session"]
    if session is not None and session[0] != key:
        shown = None  # the atmosphere changed: render again
    settled = now - _state["last_move"] >= SETTLE
    quality = "full" if settled else "preview"
    if shown is not None and shown[0] == sun and (shown[1] == "full" or quality == "preview"):
        return TICK
    options = full_options(s) if quality == "full" else preview_options(s)
    _state["job"] = _Job(key, make_spec(s), sun, options, quality).start(session)
    return TICK


def busy():
    return _state["job"] is not None


def _halt():
    job = _state["job"]
    if job is not None:
        job.cancel()
        job.thread.join()
        _state["job"] = None


def stop():
    _halt()
    if bpy.app.timers.is_registered(_timer):
        bpy.app.timers.unregister(_timer)


def reset():
    """Forget everything (tests; a new file)."""
    stop()
    _state.update(session=None, shown=None, seen=None, last_move=0.0, renders=[])


def _timer():
    try:
        return tick()
    except Exception:  # noqa: BLE001 — a timer that raises is removed by Blender; stop cleanly
        _halt()
        return None


def live_preview_changed(self, context):
    if self.live_preview:
        _state["shown"] = None
        if not bpy.app.timers.is_registered(_timer):
            bpy.app.timers.register(_timer, first_interval=0.0)
    else:
        stop()


@bpy.app.handlers.persistent
def _load_pre(_dummy=None):
    reset()


@bpy.app.handlers.persistent
def _load_post(_dummy=None):
    """A file saved with Live Preview on resumes it."""
    scene = bpy.context.scene
    s = getattr(scene, "airmass", None) if scene is not None else None
    if s is not None and s.live_preview and not bpy.app.background and not bpy.app.timers.is_registered(_timer):
        bpy.app.timers.register(_timer, first_interval=0.0)


def register():
    if _load_pre not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_load_pre)
    if _load_post not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_load_post)


def unregister():
    for handlers, fn in ((bpy.app.handlers.load_pre, _load_pre), (bpy.app.handlers.load_post, _load_post)):
        if fn in handlers:
            handlers.remove(fn)
    reset()
