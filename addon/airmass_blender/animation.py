"""Bake Sky Animation: a sky per frame of the scene, written as an EXR sequence, shown by the
World's Environment Texture, with the Sun lamp keyframed to match — so the saved .blend
renders the animation with plain Blender (no add-on: a render farm needs nothing).

Each frame's sun comes from
  * Place and Time: latitude, longitude (animatable), Date and Time (UTC h, animatable) plus
    Minutes per Frame after the first frame, through the library's solar position (NREL SPA,
    exactly `airmass sun`'s numbers; Blender angles for a scene whose +Y is north), or
  * Sun Lamp: the lamp's own (animated) direction at that frame.
Per frame the library renders the sky (without its sun disc: the lamp carries the direct sun)
and the lamp light (sun.lamp_light: the same strength and colour as Sun Sync / `airmass sun`
plus native.sun_light). The frames go to <Output Folder>/<scene>_sky_<frame, 4 digits>.exr
through Blender's image API (world.build_sky_image, as Generate Sky); the World's Environment
Texture (world.wire_world) shows that image sequence, file N at frame N; the lamp gets one
keyframe per frame on energy, colour and angle, and — Place and Time — on its rotation.

Re-bake: <scene>_sky_animation.json beside the frames keeps, per frame, a key (SHA-256 of the
library version, the scene sent to the library with that frame's sun angles, and the sky
settings and image size); a frame whose key is unchanged and whose file exists is not rendered
again.

All or nothing: frames are rendered into temporary files; only when every frame is there are
they renamed into place (the files they replace kept aside), the World (a staged copy) and the
lamp's new actions swapped in, and the manifest written. Any failure or Esc restores the
previous World, lamp, files and manifest and removes the temporaries.
"""

import copy
import datetime
import hashlib
import json
import math
import os
import queue
import tempfile
import threading

import bpy

from . import compat, native, sun, world
from .jobs import JobError, Plan
from .properties import SettingsError, _Guard, make_spec, resolve_output_folder

IMAGE_NAME = "Airmass Sky Sequence"
MANIFEST_FORMAT = "airmass-sky-animation"
MAX_FRAMES = 100000


def frame_path(folder, scene_name, frame):
    return os.path.join(folder, "%s_sky_%04d.exr" % (bpy.path.clean_name(scene_name), frame))


def manifest_path(folder, scene_name):
    return os.path.join(folder, "%s_sky_animation.json" % bpy.path.clean_name(scene_name))


def utc_string(date_text, hours):
    """ISO 8601 UTC of `hours` after 00:00 UTC of the day `date_text` (YYYY-MM-DD), to the ms."""
    try:
        day = datetime.date.fromisoformat(date_text.strip())
    except ValueError:
        raise SettingsError("Date '%s' is not a date YYYY-MM-DD" % date_text)
    start = datetime.datetime(day.year, day.month, day.day, tzinfo=datetime.timezone.utc)
    try:
        t = start + datetime.timedelta(milliseconds=round(hours * 3600000.0))
    except OverflowError:
        raise SettingsError("Date '%s' + Time %g h is outside the years 1–9999" % (date_text, hours))
    return t.strftime("%Y-%m-%dT%H:%M:%S") + ".%03dZ" % (t.microsecond // 1000)


def frame_suns(scene):
    """[(frame, utc or None, Sky Texture elevation°, rotation°)] over the scene's frame range,
    reading the animated settings (or the lamp) at each frame."""
    s = scene.airmass
    lamp = None
    if s.bake_sun_source == "LAMP":
        lamp = sun.find_lamp(scene)
        if lamp is None:
            raise SettingsError("Sun From is Sun Lamp, but the scene has no Sun lamp: choose one in Sun Lamp, "
                                "or take the sun from Place and Time")
    suns = []
    current = (scene.frame_current, scene.frame_subframe)
    try:
        with _Guard():  # live sync must not react to the frames stepped through here
            for frame in range(scene.frame_start, scene.frame_end + 1):
                scene.frame_set(frame)
                if lamp is not None:
                    elevation, rotation = sun.lamp_angles(lamp)
                    suns.append((frame, None, math.degrees(elevation), math.degrees(rotation)))
                    continue
                hours = s.utc_hours + s.minutes_per_frame * (frame - scene.frame_start) / 60.0
                utc = utc_string(s.date, hours)
                try:
                    p = native.solar_position(s.latitude, s.longitude, utc)
                except native.NativeError as e:
                    raise SettingsError("frame %d: %s" % (frame, e))
                suns.append((frame, utc, p["blender_elevation_deg"], p["blender_rotation_deg"]))
    finally:
        with _Guard():
            scene.frame_set(current[0], subframe=current[1])
    return suns


def _read_manifest(path):
    try:
        with open(path, "r", encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT or not isinstance(data.get("frames"), dict):
        return {}
    return data["frames"]


def _remove_quietly(path):
    try:
        os.remove(path)
    except OSError:
        pass


class BakePlan(Plan):
    label = "Bake Sky Animation"

    def __init__(self, context):
        scene = context.scene
        s = scene.airmass
        count = scene.frame_end - scene.frame_start + 1
        if scene.frame_start < 0:
            raise SettingsError("Frame Start = %d: must be ≥ 0 (the files are numbered by frame)" % scene.frame_start)
        if not 1 <= count <= MAX_FRAMES:
            raise SettingsError("Frame range %d–%d: must hold 1 to %d frames" % (scene.frame_start, scene.frame_end,
                                                                                 MAX_FRAMES))
        base = make_spec(s)
        native.validate_scene(base)  # fail before any work, with the field's name
        self.folder = resolve_output_folder(s)  # an image sequence needs files
        self.scene_name = scene.name
        self.source = s.bake_sun_source
        self.options = world.sky_options(s, sun_disc=False)  # the lamp carries the direct sun
        self.width, self.height = self.options["width"], self.options["height"]
        self.strength = s.sky_strength
        self.matrix = compat.rec709_to_working_matrix()
        self.working_space = compat.working_space()
        library = native.version()
        sky = dict(self.options, pixels=self.working_space, matrix=[list(r) for r in self.matrix])
        old = _read_manifest(manifest_path(self.folder, self.scene_name))
        self.manifest = {k: v for k, v in old.items()
                         if isinstance(v, dict) and os.path.isfile(os.path.join(self.folder, str(v.get("file"))))}
        self.frames = []  # (frame, utc, elevation°, rotation°, (strength, colour, angle), key)
        self.todo = []    # (frame, spec) to render
        for frame, utc, elevation, rotation in frame_suns(scene):
            spec = copy.copy(base)
            spec.sun_elevation_deg, spec.sun_rotation_deg = elevation, rotation
            strength, colour, angle, _ = sun.lamp_light(scene, spec=spec)
            key = hashlib.sha256(json.dumps({"library": library, "spec": vars(spec), "sky": sky},
                                            sort_keys=True, default=str).encode()).hexdigest()
            self.frames.append((frame, utc, elevation, rotation, (strength, colour, angle), key))
            entry = self.manifest.get(str(frame))
            if not (entry and entry.get("key") == key
                    and entry.get("file") == os.path.basename(self.path(frame))):
                self.todo.append((frame, spec))
        self.staged = {}            # frame → temporary file holding its EXR
        self._queue = queue.Queue(maxsize=2)  # frames rendered on a worker, encoded on the main thread
        self.summary = None

    def path(self, frame):
        return frame_path(self.folder, self.scene_name, frame)

    # -- worker ---------------------------------------------------------------------------------
    def work(self, progress):
        n = len(self.todo)
        on_main = threading.current_thread() is threading.main_thread()
        for i, (frame, spec) in enumerate(self.todo):
            self.status = "frame %d (%d of %d to render)" % (frame, i + 1, n)
            pixels, metadata = native.render_sky(spec, progress=progress, progress_range=(i / n, (i + 1) / n),
                                                 **self.options)
            compat.convert_pixels(pixels, self.matrix)
            item = (frame, pixels[::-1].ravel(), metadata)  # Blender's rows start at the bottom
            if on_main:
                self._encode(*item)
                continue
            while True:  # a worker hands the pixels to the main thread (bpy), which drains the queue
                try:
                    self._queue.put(item, timeout=0.1)
                    break
                except queue.Full:
                    if progress.cancel_requested:
                        raise native.NativeError(native.CANCELLED, "%s: cancelled" % self.label)
        return None

    # -- main thread ----------------------------------------------------------------------------
    def _encode(self, frame, flat, metadata):
        """The frame's EXR, encoded by Blender (a packed float image), into a temporary file."""
        image = world.build_sky_image("Airmass Sky Frame (staging)", self.width, self.height, flat, metadata,
                                      self.working_space)
        try:
            data = bytes(image.packed_file.data)
        finally:
            bpy.data.images.remove(image)
        self.staged[frame] = world.stage_file(self.path(frame), data)

    def drain(self, context):
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                return
            self._encode(*item)

    def abort(self):
        while True:
            try:
                self._queue.get_nowait()
            except queue.Empty:
                break
        for tmp in self.staged.values():
            _remove_quietly(tmp)
        self.staged.clear()

    def finish(self, context, result):
        scene = context.scene
        self.drain(context)
        missing = [f for f, _ in self.todo if f not in self.staged]
        if missing:
            raise JobError("%s: frames %s were not rendered" % (self.label, missing[:5]))
        undo = []  # callables restoring the previous state, run in reverse on failure
        backups = []
        try:
            self._commit_files(undo, backups)
            old_actions = self._keyframe_lamp(scene, undo)
            wired = self._wire_sequence(scene, undo)
            self._write_manifest()  # last: nothing after it can fail
        except Exception:
            for step in reversed(undo):
                try:
                    step()
                except Exception:  # noqa: BLE001 — restore as much as possible
                    pass
            raise
        finally:
            for tmp in self.staged.values():
                _remove_quietly(tmp)
            self.staged.clear()
        for b in backups:
            _remove_quietly(b)
        self._retire(*wired, old_actions)
        first, last = self.frames[0][0], self.frames[-1][0]
        self.summary = ("Baked frames %d–%d: %d rendered, %d unchanged, into %s"
                        % (first, last, len(self.todo), len(self.frames) - len(self.todo), self.folder))
        if any(slot.material is not None and slot.material.get("airmass_lighting") == "SUN_EMISSION"
               for o in scene.objects if o.get("airmass_role") == "atmosphere" for slot in o.material_slots):
            # Not keyed (yet): the Analytic Sun volume's sun is a constant of its material.
            self.summary += ("; note: the atmosphere volume's Analytic Sun keeps one sun (not animated): use "
                             "Lighting 'Volume Scatter' for an animated volume")

    def _commit_files(self, undo, backups):
        """Renames the staged frames into place; the files they replace are kept aside until the
        whole bake succeeded."""
        for frame in sorted(self.staged):
            final = self.path(frame)
            backup = None
            if os.path.exists(final):
                fd, backup = tempfile.mkstemp(prefix=".%s.airmass-old-" % os.path.basename(final), dir=self.folder)
                os.close(fd)
                os.replace(final, backup)
                backups.append(backup)
            # Registered before the rename, so a failing rename still gets its old file back.
            undo.append((lambda f=final, b=backup: os.replace(b, f) if b else _remove_quietly(f)))
            os.replace(self.staged[frame], final)
            del self.staged[frame]

    def _keyframe_lamp(self, scene, undo):
        """One keyframe per frame: energy, colour, angle and (Place and Time) rotation. The lamp's
        previous actions and values come back on failure; a lamp made here is removed."""
        obj = sun.find_lamp(scene)
        if obj is None:
            obj = sun.new_lamp(scene)

            def remove_lamp(o=obj):
                data = o.data
                bpy.data.objects.remove(o)
                if data.users == 0:
                    bpy.data.lights.remove(data)
            undo.append(remove_lamp)
        light = obj.data
        saved = (obj.rotation_mode, tuple(obj.rotation_euler), light.energy, tuple(light.color), light.angle,
                 compat.action_state(obj), compat.action_state(light))

        def restore():
            made = [a for a in (compat.action_state(obj)[0], compat.action_state(light)[0])
                    if a is not None and a not in (saved[5][0], saved[6][0])]
            compat.restore_action_state(obj, saved[5])
            compat.restore_action_state(light, saved[6])
            obj.rotation_mode, obj.rotation_euler = saved[0], saved[1]
            light.energy, light.color, light.angle = saved[2], saved[3], saved[4]
            for a in made:
                bpy.data.actions.remove(a)
        undo.append(restore)
        keyframe_rotation = self.source == "PLACE_TIME"
        with _Guard():
            if keyframe_rotation:
                compat.restore_action_state(obj, (None, None))
                obj.rotation_mode = "XYZ"
            compat.restore_action_state(light, (None, None))
            previous = None
            for frame, _utc, elevation, rotation, (strength, colour, angle), _key in self.frames:
                if keyframe_rotation:
                    euler = sun.lamp_rotation(math.radians(elevation), math.radians(rotation))
                    if previous is not None:
                        euler.make_compatible(previous)  # no 360° jumps between keys
                    previous = euler
                    obj.rotation_euler = euler
                    _insert(obj, "rotation_euler", frame)
                sun.apply_light(obj, strength, colour, angle)
                for prop in ("energy", "color", "angle"):
                    _insert(light, prop, frame)
        for idblock in (obj, light):
            action = compat.action_state(idblock)[0]
            if action is not None:
                action[sun.ROLE] = "sky-bake"  # a later bake may remove it once unused
        return [a for a in (saved[5][0], saved[6][0]) if a is not None]

    def _wire_sequence(self, scene, undo):
        """A staged copy of the World shows the image sequence; swapped in at the end."""
        first = self.path(self.frames[0][0])
        image = bpy.data.images.get(IMAGE_NAME)
        if image is not None and image.source == "SEQUENCE":  # a previous bake's: pointed at the new files
            before = (image.filepath_raw, image.colorspace_settings.name)

            def restore_image(im=image, b=before):
                im.filepath_raw, im.colorspace_settings.name = b
                im.reload()
            undo.append(restore_image)
            image.filepath_raw = first
            image.reload()
        else:
            image = bpy.data.images.load(first, check_existing=False)
            undo.append(lambda: bpy.data.images.remove(image))
            image.source = "SEQUENCE"
        compat.set_float_image_colorspace(image)
        if bpy.data.filepath and _relative_output(scene):
            try:
                image.filepath = bpy.path.relpath(first)
            except ValueError:  # another drive (Windows): keep the absolute path
                pass
        old_world = scene.world
        staged_world = old_world.copy() if old_world is not None else None
        scene.world = staged_world
        undo.append(lambda: _swap_back_world(scene, old_world))
        new_world = world.wire_world(scene, image, self.strength)  # creates a World when there was none
        env = new_world.node_tree.nodes[world.ENV_NODE]
        user = env.image_user
        user.frame_start = scene.frame_start           # the scene frame that shows the first file …
        user.frame_offset = scene.frame_start - 1      # … which is numbered by its frame: file N at frame N
        user.frame_duration = len(self.frames)
        user.use_cyclic = False
        user.use_auto_refresh = True
        compat.set_world_sun_extraction(new_world, False)  # the lamp gives the sun
        return old_world, new_world, image

    @staticmethod
    def _retire(old_world, new_world, image, old_actions):
        """After the commit: the previous World goes when nothing else uses it (the new one takes
        its name), and so do a previous sequence image and a previous bake's lamp actions left
        without users."""
        for action in old_actions:
            if action.users == 0 and action.get(sun.ROLE) == "sky-bake":
                bpy.data.actions.remove(action)
        if old_world is not None and old_world.users == 0:
            name = old_world.name
            tree = old_world.node_tree
            old_images = [n.image for n in tree.nodes if getattr(n, "image", None) is not None] if tree else []
            bpy.data.worlds.remove(old_world)
            new_world.name = name
            for im in old_images:
                if im.users == 0 and im != image and im.name.startswith(IMAGE_NAME):
                    bpy.data.images.remove(im)
        if image.name != IMAGE_NAME:
            image.name = IMAGE_NAME

    def _write_manifest(self):
        frames = dict(self.manifest)
        for frame, utc, elevation, rotation, (strength, colour, angle), key in self.frames:
            frames[str(frame)] = {"file": os.path.basename(self.path(frame)), "key": key, "utc": utc,
                                  "blender_elevation_deg": elevation, "blender_rotation_deg": rotation,
                                  "sun_strength": strength, "sun_color": list(colour),
                                  "sun_angle_deg": math.degrees(angle)}
        data = {"format": MANIFEST_FORMAT, "format_version": 1, "library": native.version(), "scene": self.scene_name,
                "sun_from": self.source, "frame_start": self.frames[0][0], "frame_end": self.frames[-1][0],
                "width": self.width, "height": self.height,
                "last_bake": {"rendered": [f for f, _ in self.todo],
                              "unchanged": len(self.frames) - len(self.todo)},
                "frames": {k: frames[k] for k in sorted(frames, key=int)}}
        path = manifest_path(self.folder, self.scene_name)
        tmp = world.stage_file(path, (json.dumps(data, indent=1) + "\n").encode("utf-8"))
        backup = None
        if os.path.exists(path):
            fd, backup = tempfile.mkstemp(prefix=".%s.airmass-old-" % os.path.basename(path), dir=self.folder)
            os.close(fd)
            os.replace(path, backup)
        os.replace(tmp, path)
        if backup:
            _remove_quietly(backup)


def _relative_output(scene):
    """Whether the Output Folder is relative to the .blend (then the sequence's path is too)."""
    return scene.airmass.output_folder.strip().startswith("//")


def _insert(idblock, prop, frame):
    if not idblock.keyframe_insert(prop, frame=frame):
        raise JobError("Blender did not insert a keyframe for %s.%s at frame %d" % (idblock.name, prop, frame))


def _swap_back_world(scene, old_world):
    staged = scene.world
    scene.world = old_world
    if staged is not None and staged != old_world and staged.users == 0:
        bpy.data.worlds.remove(staged)
