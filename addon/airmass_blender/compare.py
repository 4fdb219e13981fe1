"""Compare with Native: render the active camera in Cycles and natively, and show the error.

The add-on calls the same code as `airmass compare` (docs/compare.md): the zip bundles the
CLI (bin/airmass) and its scripts (compare_scripts/blender_render.py, report.py), and this
module

  1. writes the scene the panel describes — the library's own validated scene (preset or
     file + every override, as JSON from the C ABI) written back as TOML, with the active
     camera converted to the CLI's [camera] — and checks that the library reads that TOML
     back as the same scene;
  2. runs `airmass compare SCENE -o TMP --blender <this Blender> --scripts <zip>/compare_scripts
     --addon <folder holding airmass_blender> ...` as a subprocess into a fresh temporary
     folder beside the result, reading its progress events (--progress-json, JSON lines) and
     the Blender logs (where the events say they are: the CLI writes into a staging folder
     beside TMP and swaps it in whole at the end, carrying scene.toml and the events file). This
     Blender (bpy.app.binary_path) does everything the CLI does not do natively: the renders
     and the report (report.py in this Blender's own Python, numpy and bpy's image API), so no
     system Python is needed; the add-on never passes --python;
  3. cancels by SIGTERM: the CLI's interrupt guard turns it into a cancel flag, it kills its
     Blender process group and exits; the temporary folder is then removed, so nothing is
     left (the CLI itself does not clean up after a cancel);
  4. on success swaps the folder in as <output>/<scene>_compare/ (the previous result is
     replaced), loads each path's side-by-side and error PNGs as Blender images (reused by
     name on a re-run, never duplicated) and returns a summary of summary.json's per-path
     mean and 95th-percentile relative errors.

Camera. The CLI's camera is Blender's with sensor fit AUTO: `fov_deg` is the field of view
along the larger image side with pixels square. Any Blender perspective camera without lens
shift and with square pixels maps onto it exactly: the view frame (which includes the
camera's own sensor fit) gives the half extent along the larger side, fov = 2 atan(half/depth).
Positions: 1 Blender unit = 1 km (or 1 m, the panel's Length Unit), the frame of the
volumes and of docs/scene.md (origin on the ground below the observer, Z up, planet centre
at (0, 0, −R)); the CLI wants metres.

Paths. The one table of comparison paths is compare/plan.json (the zip's
compare_scripts/plan.json, the file the bundled CLI is built from): the Paths checkboxes are
its Blender paths (properties.py). `path_list()` is the bundled CLI's
`airmass compare --list-paths --json` (read once per CLI file when availability is checked:
it also shows the CLI runs); the add-on offers its Blender paths (`blender_paths()`; the
checkboxes are tested to be exactly these) and weights its progress by each path's `step_cost`. Without a working CLI,
Compare with Native is not available and says why (NotAvailable).

`run(context, ...)` does all of it synchronously (for scripts); the operator
`airmass.compare` runs the same ComparePlan through jobs.JobOperatorMixin (worker thread,
progress bar, Esc). Errors are raised as exceptions whose message names the problem.
"""

import json
import math
import os
import queue
import shutil
import signal
import subprocess
import tempfile
import threading

import bpy
from mathutils import Vector

from . import native
from .jobs import JobError, Plan
from .properties import KM, SettingsError, ensure_folder, make_spec, resolve_output_folder

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
CLI_ENV = "AIRMASS_CLI"  # overrides the bundled CLI (like AIRMASS_C_LIBRARY for the library)
IMAGE_ROLE = "airmass_role"
IMAGE_PREFIX = "Airmass Compare "
CANCEL_GRACE_S = 20.0  # the CLI needs ≤ 3 s to stop its Blender; then it is killed


class CompareError(JobError):
    """The comparison ran and failed; the message says why (the CLI's own words)."""


class NotAvailable(SettingsError):  # noqa: N818 — the name the operator has always caught
    """The bundled CLI or scripts are missing or do not run."""


# ---- what the zip bundles ------------------------------------------------------------------

def cli_path():
    return os.environ.get(CLI_ENV) or os.path.join(PACKAGE_DIR, "bin", "airmass")


def scripts_dir():
    return os.path.join(PACKAGE_DIR, "compare_scripts")


def addon_parent():
    """The folder holding the airmass_blender package (the CLI's --addon)."""
    return os.path.dirname(PACKAGE_DIR)


_availability = {}


def availability():
    """None when Compare with Native can run, else why not (cached per CLI file and mtime).
    Needs the bundled CLI and scripts, and this Blender's executable (renders and report)."""
    if not bpy.app.binary_path or not os.path.isfile(bpy.app.binary_path):
        return "this Blender's executable is unknown (bpy.app.binary_path is '%s')" % bpy.app.binary_path
    exe = cli_path()
    try:
        key = (exe, os.stat(exe).st_mtime_ns)
    except OSError:
        return "the Airmass CLI is not at '%s' (the add-on zip bundles it as bin/airmass; reinstall the add-on " \
               "or set %s)" % (exe, CLI_ENV)
    if key in _availability:
        return _availability[key]
    reason = None
    if not os.access(exe, os.X_OK):
        # zipfile.extractall (Blender's add-on installer) drops the executable bit.
        try:
            os.chmod(exe, os.stat(exe).st_mode | 0o755)
        except OSError as e:
            reason = "the Airmass CLI '%s' is not executable and cannot be made so: %s" % (exe, e)
    for script in ("blender_render.py", "report.py", "job_schema.py"):
        if reason is None and not os.path.isfile(os.path.join(scripts_dir(), script)):
            reason = "the comparison script %s is missing from '%s' (reinstall the add-on)" % (script, scripts_dir())
    if reason is None:
        reason = _read_path_list(exe, key)
    _availability[key] = reason
    return reason


def available():
    return availability() is None


# ---- the comparison paths: the CLI's one list ------------------------------------------------------

_path_lists = {}  # (CLI file, mtime) -> `airmass compare --list-paths --json`'s "paths"


def _read_path_list(exe, key):
    """Runs `airmass compare --list-paths --json` (which also shows that the CLI runs); None, or
    why it cannot be used."""
    try:
        r = subprocess.run([exe, "compare", "--list-paths", "--json"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, timeout=30, check=False)
    except (OSError, subprocess.SubprocessError) as e:
        return "the Airmass CLI '%s' does not run: %s" % (exe, e)
    if r.returncode != 0:
        return "the Airmass CLI '%s' does not run (exit status %d): %s" % (
            exe, r.returncode, r.stderr.decode("utf-8", "replace").strip()[-400:])
    try:
        paths = json.loads(r.stdout.decode("utf-8", "replace"))["paths"]
        if not paths or not all(isinstance(p.get("name"), str) and p.get("renderer") for p in paths):
            raise ValueError("no paths")
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        return "the Airmass CLI '%s' printed no list of comparison paths (compare --list-paths --json: %s); " \
               "reinstall the add-on" % (exe, e)
    _path_lists[key] = paths
    return None


def path_list():
    """The comparison paths of the bundled CLI, in its order — `airmass compare --list-paths
    --json`: name, renderer, what it renders, native reference, modes, render count, step cost.
    Raises NotAvailable (the reason) when the CLI is missing or does not run."""
    reason = availability()
    if reason:
        raise NotAvailable("Compare with Native is not available: " + reason)
    exe = cli_path()
    return _path_lists[(exe, os.stat(exe).st_mtime_ns)]


def blender_paths():
    """The paths the add-on renders (in this Blender): the CLI's paths whose renderer is Blender."""
    return [p["name"] for p in path_list() if p["renderer"] == "blender"]


# ---- the scene as TOML -----------------------------------------------------------------------

def _toml_value(v, where):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise SettingsError("%s = %r is not finite" % (where, v))
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x, where) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join("%s = %s" % _toml_pair(k, x, where + "." + k) for k, x in v.items()) + " }"
    raise SettingsError("%s: cannot write %r as TOML" % (where, v))


def _toml_pair(key, value, where):
    """The JSON form is SI (`radius_m`, `scale_height_m`); scene files write lengths in km."""
    if key.endswith("_m") and not key.endswith("_per_m"):
        scale = (lambda x: x / KM)
        value = [scale(float(x)) for x in value] if isinstance(value, list) else scale(float(value))
        key = key[:-2] + "_km"
    return key, _toml_value(value, where)


def scene_toml(scene_json, camera):
    """A self-contained scene file (docs/scene.md) for the validated scene and `camera`."""
    lines = ["# Written by the Airmass Blender add-on (Compare with Native)",
             "name = %s" % _toml_value(str(scene_json.get("name") or "scene"), "name")]
    for table in ("planet", "sun", "observer", "spectrum"):
        body = dict(scene_json.get(table) or {})
        if table == "spectrum" and body.get("basis") != "spectral":
            body.pop("wavelengths_nm", None)  # implied by the basis; not allowed with it
        lines.append("")
        lines.append("[%s]" % table)
        for k, v in body.items():
            lines.append("%s = %s" % _toml_pair(k, v, "%s.%s" % (table, k)))
    lines += ["", "[camera]"]
    for k in ("position_km", "direction", "up", "fov_deg", "width", "height", "max_distance_km"):
        lines.append("%s = %s" % (k, _toml_value(camera[k], "camera." + k)))
    for i, c in enumerate(scene_json.get("constituents") or []):
        lines += ["", "[[constituent]]"]
        for k, v in c.items():
            lines.append("%s = %s" % _toml_pair(k, v, "constituent[%d].%s" % (i, k)))
    return "\n".join(lines) + "\n"


def _same(a, b, path=""):
    """Where two JSON values differ beyond rounding (km ↔ m conversions), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in set(a) | set(b):
            if k not in a or k not in b:
                return "%s.%s" % (path, k)
            d = _same(a[k], b[k], "%s.%s" % (path, k))
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return path
        for i, (x, y) in enumerate(zip(a, b)):
            d = _same(x, y, "%s[%d]" % (path, i))
            if d:
                return d
        return None
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return None if abs(a - b) <= 1e-12 * max(abs(a), abs(b)) else path
    return None if a == b else path


def checked_scene_toml(spec, camera):
    """scene_toml of the settings' scene, read back by the library: the CLI gets exactly the
    scene the add-on's other operators use (or this raises)."""
    original = native.validate_scene(spec)
    text = scene_toml(original, camera)
    back = native.validate_scene(native.Spec(toml=text, source_name="compare-scene.toml"))
    for j in (original, back):
        j.pop("camera", None)
    where = _same(original, back)
    if where:
        raise RuntimeError("internal error: the scene written for the comparison differs from the add-on's at %s"
                           % where)
    return text


# ---- the camera ------------------------------------------------------------------------------

def camera_for_cli(scene, cam, unit_m, width, max_distance_km):
    """The CLI's [camera] for a Blender camera object (see the module docstring)."""
    if cam is None or cam.type != "CAMERA":
        raise SettingsError("Compare with Native needs an active camera in the scene")
    data = cam.data
    if data.type != "PERSP":
        raise SettingsError("Compare with Native needs a perspective camera ('%s' is %s)"
                            % (cam.name, data.type.lower()))
    if abs(data.shift_x) > 1e-9 or abs(data.shift_y) > 1e-9:
        raise SettingsError("Compare with Native: camera '%s' has a lens shift (%g, %g); the native camera has "
                            "none: set Shift X and Y to 0" % (cam.name, data.shift_x, data.shift_y))
    r = scene.render
    if abs(r.pixel_aspect_x - r.pixel_aspect_y) > 1e-9:
        raise SettingsError("Compare with Native needs square pixels (Pixel Aspect %g:%g)"
                            % (r.pixel_aspect_x, r.pixel_aspect_y))
    res_x = max(1, r.resolution_x)
    res_y = max(1, r.resolution_y)
    height = max(1, int(round(width * res_y / res_x)))
    m = cam.matrix_world
    rot = m.to_3x3().normalized()
    direction = (rot @ Vector((0.0, 0.0, -1.0))).normalized()
    up = (rot @ Vector((0.0, 1.0, 0.0))).normalized()
    frame = data.view_frame(scene=scene)  # corners at depth −z; the camera's sensor fit included
    depth = abs(frame[0].z)
    half = max(max(abs(v.x) for v in frame), max(abs(v.y) for v in frame))
    fov_deg = math.degrees(2.0 * math.atan(half / depth))
    return {"position_km": [float(x) * unit_m / 1000.0 for x in m.translation], "direction": [float(x) for x in direction],
            "up": [float(x) for x in up], "fov_deg": fov_deg, "width": int(width), "height": int(height),
            "max_distance_km": float(max_distance_km)}


# ---- progress from the CLI's events -------------------------------------------------------------

PROGRESS_FILE = "progress.jsonl"  # the CLI's --progress-json, in the work folder


class _Progress:
    """Turns the CLI's progress events (--progress-json: JSON lines, docs/compare.md) into a
    fraction and a status. The CLI announces every step with its index and the total, and each
    Blender path with the number of Cycles renders it makes; within a Blender step the renders
    done are the lines blender_render.py logs per written image."""

    def _weight(self, step, path):
        """Relative cost of a step: a renderer step's is the path list's step_cost (a Blender
        volume path is the slow part); the inputs and the report 2, a native render 1."""
        info = self.paths.get(path)
        if info is not None and step == "%s %s" % (info["renderer"], path):
            return float(info.get("step_cost", 1.0))
        return {"sky_texture_input": 2.0, "report": 2.0}.get(step, 1.0)

    def __init__(self, work_dir, paths=()):
        self.work_dir = work_dir
        self.paths = {p["name"]: p for p in paths}  # path_list()
        self.file = os.path.join(work_dir, PROGRESS_FILE)
        self.offset = 0
        self.pending = ""
        self.steps = {}  # index -> weight of the steps seen (the others count 1 until announced)
        self.total_steps = None
        self.done = 0.0  # the weight of the finished steps
        self.current = None  # (step, path, index, weight, renders, of)
        self.status = "native renders"
        self.finished = False
        self.errors = []

    def poll(self):
        """Reads the events written since the last call."""
        try:
            with open(self.file, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except OSError:
            return
        self.offset += len(data)
        text = self.pending + data.decode("utf-8", "replace")
        lines = text.split("\n")
        self.pending = lines.pop()  # an incomplete last line waits for the next poll
        for ln in lines:
            if ln.strip():
                try:
                    self.event(json.loads(ln))
                except ValueError:
                    pass

    def event(self, e):
        kind = e.get("event")
        step, path = e.get("step"), e.get("path")
        if e.get("total") is not None:
            self.total_steps = int(e["total"])
        if kind == "render_start":
            w = self._weight(step, path)
            self.steps[e["index"]] = w
            # "log": where the step's log is written while it runs (the CLI's staging folder
            # beside its -o folder, published whole at the end).
            self.current = {"step": step, "path": path, "weight": w, "renders": e.get("renders"), "fraction": 0.0,
                            "log": e.get("log") or os.path.join(self.work_dir, "blender_%s.log" % path)}
            self.status = ("Blender: %s" % path) if step.startswith("blender ") else step.replace("_", " ")
        elif kind == "progress" and self.current is not None and e.get("of"):
            self.current["fraction"] = min(1.0, float(e["done"]) / float(e["of"]))
        elif kind == "render_done":
            self.done += self.steps.get(e.get("index"), 1.0)
            self.current = None
        elif kind == "error":
            self.errors.append(e.get("message"))
        elif kind == "done":
            self.finished = True
            self.current = None

    def _total(self):
        n = self.total_steps or 1
        seen = sum(self.steps.values())
        return seen + (n - len(self.steps)) * 4.0  # steps not announced yet: a guess of their weight

    def fraction(self):
        self.poll()
        if self.finished:
            return 1.0
        done = self.done
        c = self.current
        if c is not None:
            if c["step"].startswith("blender ") and c["renders"]:
                try:
                    with open(c["log"], errors="replace") as f:
                        k = sum(1 for ln in f if ln.startswith("[airmass-compare] blender_") and ln.rstrip().endswith(" s"))
                except OSError:
                    k = 0
                n = int(c["renders"])
                c["fraction"] = min(0.95, k / n)
                self.status = "Blender: %s, render %d of %d" % (c["path"], min(k + 1, n), n)
            done += c["weight"] * c["fraction"]
        return max(0.0, min(1.0, done / self._total()))


# ---- the plan --------------------------------------------------------------------------------------

def _remove_tree(path):
    if path and os.path.isdir(path):
        shutil.rmtree(path, ignore_errors=True)


def _pct(x):
    return "%.3g%%" % (100.0 * x)


class ComparePlan(Plan):
    label = "Compare with Native"

    def __init__(self, context, *, camera=None, width=None, samples=None, seeds=None, paths=None,
                 volume_modes=None, output_folder=None):
        scene = context.scene
        s = scene.airmass
        self.path_list = path_list()  # raises NotAvailable (the reason) without a working CLI
        names = [p["name"] for p in self.path_list if p["renderer"] == "blender"]
        self.settings = s
        self.width = int(width if width is not None else s.compare_width)
        self.samples = int(samples if samples is not None else s.compare_samples)
        self.seeds = int(seeds if seeds is not None else s.compare_seeds)
        self.paths = list(paths) if paths is not None else [p for p in names if p.upper() in s.compare_paths]
        self.volume_modes = list(volume_modes) if volume_modes is not None else \
            [m.lower() for m in ("SPLIT", "RGB", "RGB_DITHER") if m in s.compare_volume_modes]
        if not self.paths:
            raise SettingsError("Compare with Native: no path chosen (tick Sky Texture, Analytic Volume or VDB Volume)")
        bad = [p for p in self.paths if p not in names]
        if bad:
            raise SettingsError("Compare with Native: unknown path %s (allowed: %s)" % (bad[0], ", ".join(names)))
        split = [p["name"] for p in self.path_list if p.get("volume_modes")]  # rendered per Split / RGB mode
        if any(p in split for p in self.paths) and not self.volume_modes:
            raise SettingsError("Compare with Native: choose a volume render mode (Split and/or RGB)")
        for name, value, lo, hi in (("Width", self.width, 4, 16384), ("Samples", self.samples, 1, 1 << 20),
                                    ("Seeds", self.seeds, 2, 1000)):
            if not lo <= value <= hi:
                raise SettingsError("Compare with Native: %s = %d must be in [%d, %d]" % (name, value, lo, hi))
        from .volume import units
        _, unit_m = units(s)
        cam_obj = camera if camera is not None else scene.camera
        self.camera = camera_for_cli(scene, cam_obj, unit_m, self.width, s.view_distance)
        self.scene_text = checked_scene_toml(make_spec(s), self.camera)
        if output_folder is not None:
            self.folder = ensure_folder(os.path.normpath(bpy.path.abspath(output_folder)))
        else:
            self.folder = resolve_output_folder(s)
        self.name = "%s_compare" % bpy.path.clean_name(scene.name)
        self.final_dir = os.path.join(self.folder, self.name)
        if os.path.exists(self.final_dir) and not os.path.isdir(self.final_dir):
            raise SettingsError("'%s' exists and is not a folder" % self.final_dir)
        self.blender = bpy.app.binary_path
        if not self.blender or not os.path.isfile(self.blender):
            raise SettingsError("Compare with Native: this Blender's executable is unknown (bpy.app.binary_path)")
        self.voxel_size = s.voxel_size if s.voxel_size > 0 else None
        self.voxel_values = s.voxel_values.lower()  # AUTO/AVERAGE/POINT -> the CLI's names
        self.step_km = s.step_km
        self.max_dense_mb = s.max_dense_mb
        self.work_dir = None
        self.summary = None
        self.result = None
        self.status = ""
        self.partial = False

    def command(self, scene_file):
        # --blender: this Blender renders, and runs the report in its own Python (no --python).
        cmd = [cli_path(), "compare", scene_file, "-o", self.work_dir, "--blender", self.blender,
               "--scripts", scripts_dir(), "--addon", addon_parent(),
               "--width", str(self.camera["width"]), "--height", str(self.camera["height"]),
               "--samples", str(self.samples), "--sky-samples", str(self.samples), "--seeds", str(self.seeds),
               "--paths", ",".join(self.paths), "--volume-modes", ",".join(self.volume_modes or ["split"]),
               "--step", repr(float(self.step_km)), "--max-dense-mb", repr(float(self.max_dense_mb)),
               "--voxel-values", self.voxel_values,
               "--progress-json", os.path.join(self.work_dir, PROGRESS_FILE)]
        if self.voxel_size is not None:
            cmd += ["--voxel-size", repr(float(self.voxel_size))]
        return cmd

    # -- worker thread: no bpy ------------------------------------------------------------------
    def work(self, progress):
        self.work_dir = tempfile.mkdtemp(prefix=".%s.tmp-" % self.name, dir=self.folder)
        scene_file = os.path.join(self.work_dir, "scene.toml")
        with open(scene_file, "w", encoding="utf-8") as f:
            f.write(self.scene_text)
        tracker = _Progress(self.work_dir, self.path_list)
        lines = queue.Queue()
        output = []
        proc = subprocess.Popen(self.command(scene_file), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, start_new_session=True, cwd=self.work_dir)

        def read():
            for raw in proc.stdout:
                lines.put(raw.decode("utf-8", "replace"))
            lines.put(None)

        reader = threading.Thread(target=read, name="airmass-compare-output", daemon=True)
        reader.start()
        cancelled = False
        try:
            eof = False
            while not eof:
                try:
                    text = lines.get(timeout=0.2)
                    if text is None:
                        eof = True
                    else:
                        output.append(text)
                except queue.Empty:
                    pass
                fraction = tracker.fraction()
                self.status = tracker.status
                progress.fraction = fraction
                wants_stop = progress.cancel_requested
                if progress.callback is not None:
                    try:
                        wants_stop = bool(progress.callback(fraction)) or wants_stop
                    except Exception:  # noqa: BLE001 — a failing callback stops the work
                        wants_stop = True
                if wants_stop and not cancelled:
                    cancelled = True
                    self._stop(proc)
            rc = proc.wait()
        finally:
            if proc.poll() is None:
                self._stop(proc)
            reader.join(timeout=5)
        if cancelled:
            raise native.NativeError(native.CANCELLED, "Compare with Native cancelled")
        if rc != 0:
            raise CompareError("airmass compare failed (exit status %d): %s" % (rc, _last_error(output)))
        return self._read_summary(output)

    @staticmethod
    def _stop(proc):
        """SIGTERM: the CLI's interrupt guard cancels, kills its Blender and exits; SIGKILL if it
        does not within CANCEL_GRACE_S."""
        try:
            proc.send_signal(signal.SIGTERM)
            proc.wait(timeout=CANCEL_GRACE_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        except OSError:
            pass

    def _read_summary(self, output):
        path = os.path.join(self.work_dir, "summary.json")
        try:
            with open(path) as f:
                summary = json.load(f)
        except (OSError, ValueError) as e:
            raise CompareError("airmass compare wrote no readable summary.json (%s): %s" % (e, _last_error(output)))
        entries = summary.get("paths", {})
        ok = {p: e for p, e in entries.items() if "error" not in e}
        failed = {p: str(e["error"]).splitlines()[0] for p, e in entries.items() if "error" in e}
        if not ok:
            raise CompareError("Compare with Native: every path failed: " +
                               "; ".join("%s: %s" % kv for kv in failed.items()))
        for p, e in ok.items():
            for k in ("mean_rel_err", "p95_rel_err"):
                if not isinstance(e.get(k), (int, float)) or not math.isfinite(e[k]):
                    raise CompareError("Compare with Native: %s %s is %r in summary.json" % (p, k, e.get(k)))
        return summary, ok, failed

    # -- main thread ------------------------------------------------------------------------------
    def finish(self, context, result):
        summary, ok, failed = result
        self._swap_in()
        images = self._load_images(ok)
        s = self.settings
        report = os.path.join(self.final_dir, "report.md")
        parts = ["%s mean %s p95 %s" % (p, _pct(e["mean_rel_err"]), _pct(e["p95_rel_err"])) for p, e in ok.items()]
        parts += ["%s FAILED: %s" % kv for kv in failed.items()]
        self.partial = bool(failed)
        self.summary = "Compare with Native (%dx%d): %s; report %s" % (
            self.camera["width"], self.camera["height"], "; ".join(parts), report)
        s.compare_report = report
        s.compare_summary = "; ".join(parts)
        self.result = {"summary": self.summary, "report": report, "folder": self.final_dir,
                       "summary_json": os.path.join(self.final_dir, "summary.json"), "paths": summary.get("paths", {}),
                       "images": images}

    def _swap_in(self):
        """The new folder replaces <output>/<scene>_compare (the old one is moved aside first and
        removed once the new one is in place)."""
        old = None
        if os.path.isdir(self.final_dir):
            old = tempfile.mkdtemp(prefix=".%s.old-" % self.name, dir=self.folder)
            os.rmdir(old)
            os.rename(self.final_dir, old)
        try:
            os.rename(self.work_dir, self.final_dir)
        except OSError:
            if old is not None:
                os.rename(old, self.final_dir)
            raise
        self.work_dir = None
        _remove_tree(old)

    def _load_images(self, ok):
        """{name: image}: each path's side-by-side and error PNGs; an image of the same name is
        reloaded from the new file instead of duplicated; stale ones (paths not run now) go."""
        wanted = {}
        for p in ok:
            for kind, suffix in (("side_by_side", ""), ("error", " error")):
                f = os.path.join(self.final_dir, "png", "%s_%s.png" % (p, kind))
                if os.path.isfile(f):
                    wanted[IMAGE_PREFIX + p + suffix] = f
        images = {}
        for name, f in wanted.items():
            img = bpy.data.images.get(name)
            if img is not None and img.get(IMAGE_ROLE) == "compare":
                img.filepath = f
                img.reload()
            else:
                img = bpy.data.images.load(f, check_existing=False)
                img.name = name
                img[IMAGE_ROLE] = "compare"
            images[name] = img
        for img in list(bpy.data.images):
            if img.get(IMAGE_ROLE) == "compare" and img.name not in wanted and img.users == 0:
                bpy.data.images.remove(img)
        return images

    def abort(self):
        if self.work_dir:
            # The CLI's staging folder beside the work folder, left if it had to be killed.
            stage = ".%s.airmass-stage-" % os.path.basename(self.work_dir)
            for n in os.listdir(self.folder):
                if n.startswith(stage):
                    _remove_tree(os.path.join(self.folder, n))
        _remove_tree(self.work_dir)
        self.work_dir = None


def _last_error(output):
    """The CLI's error line ("airmass: ..."), else the last lines it printed."""
    text = [ln.rstrip() for ln in output if ln.strip()]
    errors = [ln for ln in text if ln.startswith("airmass: ")]
    if errors:
        i = text.index(errors[-1])
        return "\n".join(text[i:i + 12])[len("airmass: "):]
    return "\n".join(text[-6:]) or "no output"


def run(context, *, camera=None, width=None, samples=None, seeds=None, paths=None, volume_modes=None,
        output_folder=None, progress=None):
    """Synchronous Compare with Native (for scripts). `progress(fraction)` returning True
    cancels. Returns a dict: summary (str), report, folder, summary_json, paths, images."""
    plan = ComparePlan(context, camera=camera, width=width, samples=samples, seeds=seeds, paths=paths,
                       volume_modes=volume_modes, output_folder=output_folder)
    prog = native.Progress(progress)
    try:
        result = plan.work(prog)
        plan.finish(context, result)
    except BaseException:
        plan.abort()
        raise
    finally:
        prog.close()
    return plan.result
