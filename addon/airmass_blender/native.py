"""ctypes binding of libairmass_c (plugin/capi/include/airmass/airmass_c.h).

Pure Python, no bpy: usable from Blender (any bundled Python 3.10–3.13) and from
plain Python tests. The library is looked up next to this file (the add-on zip bundles
it: libairmass_c.so on Linux, airmass_c.dll on Windows) unless the environment variable
AIRMASS_C_LIBRARY names another file. The library has no shared dependencies beyond the
C/C++ runtime (C ABI 7: it writes no files, the host stores what it returns; every struct's
struct_size is set here from ctypes.sizeof of its mirror, and the library refuses another size).

Every wrapper raises NativeError (with the library's status and message) on failure, so
callers report one exception type. The library never aborts; a wrapper never leaves a
library-allocated string unfreed.
"""

import ctypes
import json
import os
import sys
import threading

ABI_VERSION = 8
LIBRARY_ENV = "AIRMASS_C_LIBRARY"
# File name of the library per platform (sys.platform prefix → name). The add-on zip carries
# the Linux and Windows builds and, when the build could cross-compile it, one universal macOS
# dylib (arm64 + x86_64); otherwise a Mac user builds it from source.
LIBRARY_NAMES = (("win32", "airmass_c.dll"), ("cygwin", "airmass_c.dll"), ("darwin", "libairmass_c.dylib"))
LIBRARY_NAME_DEFAULT = "libairmass_c.so"  # Linux and other ELF systems
BUILD_FROM_SOURCE = ("the Airmass repository, docs/addon.md 'Install' (cmake -S . -B build -G Ninja && "
                     "cmake --build build --target airmass_c)")

OK = 0
INVALID_ARGUMENT = 1
SCENE_ERROR = 2
SETTINGS_ERROR = 3
IO_ERROR = 4
CANCELLED = 5
UNSUPPORTED = 6
INTERNAL_ERROR = 99

_MESSAGE_SIZE = 4096
_NAN = float("nan")


class NativeError(RuntimeError):
    """A failure reported by libairmass_c (or the failure to load it)."""

    def __init__(self, status, message):
        super().__init__(message)
        self.status = status
        self.message = message

    @property
    def cancelled(self):
        return self.status == CANCELLED


class LibraryLoadError(NativeError):
    def __init__(self, message):
        super().__init__(-1, message)


# ---- struct mirrors (field order and types exactly as in airmass_c.h) ------------------------

class ConstituentOverride(ctypes.Structure):
    _fields_ = [
        ("name", ctypes.c_char_p),
        ("enabled", ctypes.c_int32),
        ("density_scale", ctypes.c_double),
        ("scale_height_m", ctypes.c_double),
    ]


class SceneSpec(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("toml", ctypes.c_char_p),
        ("preset", ctypes.c_char_p),
        ("source_name", ctypes.c_char_p),
        ("sun_elevation_deg", ctypes.c_double),
        ("sun_rotation_deg", ctypes.c_double),
        ("altitude_m", ctypes.c_double),
        ("planet_radius_m", ctypes.c_double),
        ("atmosphere_top_m", ctypes.c_double),
        ("ground_albedo", ctypes.c_double),
        ("basis", ctypes.c_int32),
        ("constituent_count", ctypes.c_uint32),
        ("constituents", ctypes.POINTER(ConstituentOverride)),
        ("has_camera", ctypes.c_int32),
        ("camera_position_m", ctypes.c_double * 3),
        ("camera_direction", ctypes.c_double * 3),
        ("camera_up", ctypes.c_double * 3),
        ("camera_fov_deg", ctypes.c_double),
        ("camera_max_distance_m", ctypes.c_double),
        ("camera_width", ctypes.c_int32),
        ("camera_height", ctypes.c_int32),
    ]


PROGRESS_FN = ctypes.CFUNCTYPE(ctypes.c_int32, ctypes.c_void_p, ctypes.c_double)


class Job(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("progress", PROGRESS_FN),
        ("user", ctypes.c_void_p),
        ("cancel", ctypes.c_void_p),
    ]


class SkyOptions(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("width", ctypes.c_int32),
        ("height", ctypes.c_int32),
        ("view_samples", ctypes.c_int32),
        ("chapman", ctypes.c_char_p),
        ("sun_disc", ctypes.c_int32),
        ("upper_only", ctypes.c_int32),
        ("threads", ctypes.c_int32),
        ("grid", ctypes.c_int32),
        ("multiple_scattering", ctypes.c_int32),
        ("multiple_grid", ctypes.c_int32),
        ("multiple_samples", ctypes.c_int32),
    ]


class SkyView(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("sun_elevation_deg", ctypes.c_double),
        ("sun_rotation_deg", ctypes.c_double),
        ("altitude_m", ctypes.c_double),
    ]


class SunLight(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("direction", ctypes.c_double * 3),
        ("irradiance_rgb", ctypes.c_double * 3),
        ("irradiance_top_rgb", ctypes.c_double * 3),
        ("transmittance_rgb", ctypes.c_double * 3),
        ("angular_diameter_deg", ctypes.c_double),
        ("below_horizon", ctypes.c_int32),
    ]


class SolarQuery(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("latitude_deg", ctypes.c_double),
        ("longitude_deg", ctypes.c_double),
        ("utc", ctypes.c_char_p),
        ("site_elevation_m", ctypes.c_double),
        ("delta_t_s", ctypes.c_double),
        ("delta_ut1_s", ctypes.c_double),
    ]


class SunPosition(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("elevation_deg", ctypes.c_double),
        ("azimuth_deg", ctypes.c_double),
        ("zenith_deg", ctypes.c_double),
        ("blender_elevation_deg", ctypes.c_double),
        ("blender_rotation_deg", ctypes.c_double),
        ("julian_day", ctypes.c_double),
        ("delta_t_s", ctypes.c_double),
    ]


class VdbOptions(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("region", ctypes.c_char_p),
        ("unit", ctypes.c_char_p),
        ("origin_center", ctypes.c_int32),
        ("voxel_size", ctypes.c_double),
        ("box", ctypes.c_double * 6),
        ("tolerance", ctypes.c_double),
        ("max_dense_mb", ctypes.c_double),
        ("tile_voxels", ctypes.c_int32),
        ("voxel_values", ctypes.c_char_p),
    ]


_MSG = ctypes.c_char_p
_SIZE = ctypes.c_size_t
_OUT = ctypes.POINTER(ctypes.c_void_p)

_SIGNATURES = {
    "airmass_abi_version": (ctypes.c_int32, []),
    "airmass_version_string": (ctypes.c_char_p, []),
    "airmass_status_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "airmass_has_vdb": (ctypes.c_int32, []),
    "airmass_string_free": (None, [ctypes.c_void_p]),
    "airmass_preset_names": (ctypes.c_int32, [_OUT, ctypes.c_void_p, _SIZE]),
    "airmass_chapman_method_names": (ctypes.c_int32, [_OUT, ctypes.c_void_p, _SIZE]),
    "airmass_scene_spec_init": (ctypes.c_int32, [ctypes.POINTER(SceneSpec)]),
    "airmass_validate_scene": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), _OUT, ctypes.c_void_p, _SIZE]),
    "airmass_cancel_token_new": (ctypes.c_void_p, []),
    "airmass_cancel_token_request": (None, [ctypes.c_void_p]),
    "airmass_cancel_token_reset": (None, [ctypes.c_void_p]),
    "airmass_cancel_token_requested": (ctypes.c_int32, [ctypes.c_void_p]),
    "airmass_cancel_token_free": (None, [ctypes.c_void_p]),
    "airmass_sky_options_init": (ctypes.c_int32, [ctypes.POINTER(SkyOptions)]),
    "airmass_render_sky": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(SkyOptions),
                                            ctypes.POINTER(ctypes.c_float), _SIZE, ctypes.POINTER(Job), _OUT,
                                            ctypes.c_void_p, _SIZE]),
    "airmass_sky_view_init": (ctypes.c_int32, [ctypes.POINTER(SkyView)]),
    "airmass_sky_session_create": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(SkyOptions),
                                                    ctypes.POINTER(Job), ctypes.POINTER(ctypes.c_void_p),
                                                    ctypes.c_void_p, _SIZE]),
    "airmass_sky_session_render": (ctypes.c_int32, [ctypes.c_void_p, ctypes.POINTER(SkyView),
                                                    ctypes.POINTER(SkyOptions), ctypes.POINTER(ctypes.c_float), _SIZE,
                                                    ctypes.POINTER(Job), _OUT, ctypes.c_void_p, _SIZE]),
    "airmass_sky_session_free": (None, [ctypes.c_void_p]),
    "airmass_sun_light_at_observer": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.c_char_p,
                                                       ctypes.POINTER(SunLight), ctypes.c_void_p, _SIZE]),
    "airmass_solar_query_init": (ctypes.c_int32, [ctypes.POINTER(SolarQuery)]),
    "airmass_solar_position": (ctypes.c_int32, [ctypes.POINTER(SolarQuery), ctypes.POINTER(SunPosition),
                                                ctypes.c_void_p, _SIZE]),
    "airmass_vdb_options_init": (ctypes.c_int32, [ctypes.POINTER(VdbOptions)]),
    "airmass_analytic_density_json": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions),
                                                       _OUT, ctypes.c_void_p, _SIZE]),
    "airmass_sun_column_table": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions),
                                                  ctypes.c_int32, ctypes.c_int32, ctypes.POINTER(ctypes.c_float),
                                                  _SIZE, ctypes.c_void_p, _SIZE]),
    "airmass_sun_ms_table": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions),
                                              ctypes.c_int32, ctypes.c_int32, ctypes.POINTER(ctypes.c_float), _SIZE,
                                              ctypes.POINTER(ctypes.c_double), ctypes.c_void_p, _SIZE]),
}


def _init_struct(init, struct, c_name):
    """Fills `struct` with the library's defaults through `init` (airmass_*_init). struct_size is
    this mirror's ctypes.sizeof: a library whose struct differs refuses it (and writes nothing), so
    a stale mirror is an error here rather than a silent misreading."""
    size = ctypes.sizeof(struct)
    struct.struct_size = size
    status = init(ctypes.byref(struct))
    if status != OK:
        raise NativeError(status, "Airmass: %s_init refused struct_size %d: the add-on's mirror of %s "
                                  "(native.py) does not match the native library '%s' (C ABI %d); install the "
                                  "add-on and its library from the same build"
                          % (c_name, size, c_name, _state.get("path") or "?", ABI_VERSION))
    return struct


_lock = threading.Lock()
_state = {"lib": None, "error": None, "path": None, "dll_directory": None}


def library_name(platform=None):
    """The library's file name on `platform` (default sys.platform)."""
    platform = sys.platform if platform is None else platform
    for prefix, name in LIBRARY_NAMES:
        if platform.startswith(prefix):
            return name
    return LIBRARY_NAME_DEFAULT


def default_library_path(platform=None):
    return os.environ.get(LIBRARY_ENV) or os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                       library_name(platform))


def _open(path, platform):
    """ctypes.CDLL(path), with the Windows DLL search path extended to the library's folder
    (Python 3.8+ no longer searches PATH or the current folder for a DLL's dependencies)."""
    if platform.startswith(("win32", "cygwin")) and hasattr(os, "add_dll_directory"):
        handle = os.add_dll_directory(os.path.dirname(os.path.abspath(path)))
        _state["dll_directory"] = handle  # keep it: closing the handle removes the folder again
    return ctypes.CDLL(path)


def _load(platform=None):
    platform = sys.platform if platform is None else platform
    path = default_library_path(platform)
    if not os.path.isfile(path):
        if platform.startswith("darwin") and not os.environ.get(LIBRARY_ENV):
            raise LibraryLoadError(
                "Airmass: this build of the add-on carries no macOS library (it has Linux and Windows x86-64 "
                "ones); build from source: %s, then put libairmass_c.dylib next to '%s' or set %s to its path"
                % (BUILD_FROM_SOURCE, os.path.dirname(path), LIBRARY_ENV))
        raise LibraryLoadError(
            "Airmass native library not found at '%s' (the add-on zip bundles it; reinstall the add-on, "
            "or set %s to its path)" % (path, LIBRARY_ENV))
    try:
        lib = _open(path, platform)
    except OSError as e:
        raise LibraryLoadError("Airmass native library '%s' failed to load: %s" % (path, e))
    try:
        for name, (restype, argtypes) in _SIGNATURES.items():
            fn = getattr(lib, name)
            fn.restype = restype
            fn.argtypes = argtypes
    except AttributeError as e:
        raise LibraryLoadError("Airmass native library '%s' is incomplete: %s" % (path, e))
    version = lib.airmass_abi_version()
    if version != ABI_VERSION:
        raise LibraryLoadError(
            "Airmass native library '%s' has C ABI version %d, this add-on needs %d: install the add-on "
            "and its library from the same build" % (path, version, ABI_VERSION))
    return lib, path


def library():
    """The loaded library; raises LibraryLoadError (cached) when it cannot be loaded."""
    with _lock:
        if _state["lib"] is None and _state["error"] is None:
            try:
                _state["lib"], _state["path"] = _load()
            except LibraryLoadError as e:
                _state["error"] = e
        if _state["error"] is not None:
            raise _state["error"]
        return _state["lib"]


def reset():
    """Forget the loaded library (or the load error) so the next call loads again.

    The shared object itself stays mapped (ctypes cannot unload it); this is for tests and
    for the preferences' "Reload library" button after the user fixed the installation."""
    with _lock:
        _state["lib"] = None
        _state["error"] = None
        _state["path"] = None


def load_error():
    """None when the library loads, else the error message."""
    try:
        library()
        return None
    except LibraryLoadError as e:
        return str(e)


def _message_buffer():
    return ctypes.create_string_buffer(_MESSAGE_SIZE)


def _check(lib, status, buf):
    if status != OK:
        text = buf.value.decode("utf-8", "replace") or lib.airmass_status_name(status).decode()
        raise NativeError(status, text)


def _take_string(lib, ptr):
    if not ptr.value:
        return ""
    try:
        return ctypes.string_at(ptr.value).decode("utf-8", "replace")
    finally:
        lib.airmass_string_free(ptr.value)


def _bytes(s):
    return None if s is None else s.encode("utf-8")


# ---- plain-Python descriptions of the C structs ---------------------------------------------

class Spec:
    """A scene for the library: `preset` or `toml` text, plus overrides (None keeps the scene's).

    Lengths in metres, angles in degrees (the C ABI's units)."""

    def __init__(self, preset=None, toml=None, source_name=None):
        self.preset = preset
        self.toml = toml
        self.source_name = source_name
        self.sun_elevation_deg = None
        self.sun_rotation_deg = None
        self.altitude_m = None
        self.planet_radius_m = None
        self.atmosphere_top_m = None
        self.ground_albedo = None
        self.basis = -1
        self.constituents = []  # (name, enabled, density_scale or None, scale_height_m or None)
        self.camera = None      # dict(position_m, direction, up, fov_deg, max_distance_m, width, height)

    def _to_c(self, lib):
        """Returns (SceneSpec, keepalive) — keepalive holds buffers the struct points to."""
        spec = SceneSpec()
        _init_struct(lib.airmass_scene_spec_init, spec, "airmass_scene_spec")
        keep = []
        spec.toml = _bytes(self.toml)
        spec.preset = _bytes(self.preset)
        spec.source_name = _bytes(self.source_name)

        def num(v):
            return _NAN if v is None else float(v)

        spec.sun_elevation_deg = num(self.sun_elevation_deg)
        spec.sun_rotation_deg = num(self.sun_rotation_deg)
        spec.altitude_m = num(self.altitude_m)
        spec.planet_radius_m = num(self.planet_radius_m)
        spec.atmosphere_top_m = num(self.atmosphere_top_m)
        spec.ground_albedo = num(self.ground_albedo)
        spec.basis = int(self.basis)
        if self.constituents:
            arr = (ConstituentOverride * len(self.constituents))()
            for i, (name, enabled, scale, height) in enumerate(self.constituents):
                encoded = _bytes(name)
                keep.append(encoded)
                arr[i].name = encoded
                arr[i].enabled = 1 if enabled else 0
                arr[i].density_scale = num(scale)
                arr[i].scale_height_m = num(height)
            keep.append(arr)
            spec.constituent_count = len(self.constituents)
            spec.constituents = ctypes.cast(arr, ctypes.POINTER(ConstituentOverride))
        if self.camera is not None:
            c = self.camera
            spec.has_camera = 1
            for i in range(3):
                spec.camera_position_m[i] = float(c["position_m"][i])
                spec.camera_direction[i] = float(c["direction"][i])
                spec.camera_up[i] = float(c["up"][i])
            spec.camera_fov_deg = float(c["fov_deg"])
            spec.camera_max_distance_m = float(c["max_distance_m"])
            spec.camera_width = int(c["width"])
            spec.camera_height = int(c["height"])
        return spec, keep


class Progress:
    """Progress and cancellation for one long call.

    `callback(fraction)` runs on the thread that made the call; returning True requests
    cancellation. `cancel()` may be called from any thread."""

    def __init__(self, callback=None):
        self.callback = callback
        self.fraction = 0.0
        self._lib = library()
        self._token = self._lib.airmass_cancel_token_new()
        if not self._token:
            raise NativeError(INTERNAL_ERROR, "out of memory (cancel token)")

    def cancel(self):
        if self._token:
            self._lib.airmass_cancel_token_request(self._token)

    @property
    def cancel_requested(self):
        return bool(self._token and self._lib.airmass_cancel_token_requested(self._token))

    def close(self):
        if self._token:
            self._lib.airmass_cancel_token_free(self._token)
            self._token = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def _job(self, lo=0.0, hi=1.0):
        """A Job for a call; its fraction f is reported as lo + (hi − lo)·f of the whole (for a
        task of several calls). Returns (job, keepalive)."""
        def trampoline(_user, fraction):
            self.fraction = lo + (hi - lo) * fraction
            if self.callback is None:
                return 0
            try:
                return 1 if self.callback(self.fraction) else 0
            except Exception:
                return 1  # a failing callback stops the work rather than being ignored

        fn = PROGRESS_FN(trampoline)
        job = Job()
        job.struct_size = ctypes.sizeof(Job)
        job.progress = fn
        job.user = None
        job.cancel = self._token
        return job, fn


# ---- API --------------------------------------------------------------------------------

def version():
    lib = library()
    return lib.airmass_version_string().decode()


def has_vdb():
    return bool(library().airmass_has_vdb())


def _string_list(fn_name):
    lib = library()
    out = ctypes.c_void_p()
    buf = _message_buffer()
    _check(lib, getattr(lib, fn_name)(ctypes.byref(out), buf, _MESSAGE_SIZE), buf)
    return [line for line in _take_string(lib, out).splitlines() if line]


def preset_names():
    return _string_list("airmass_preset_names")


def chapman_method_names():
    return _string_list("airmass_chapman_method_names")


def validate_scene(spec):
    """Validates; returns the scene as a dict (scene_to_json). Raises NativeError."""
    lib = library()
    c_spec, keep = spec._to_c(lib)
    out = ctypes.c_void_p()
    buf = _message_buffer()
    status = lib.airmass_validate_scene(ctypes.byref(c_spec), ctypes.byref(out), buf, _MESSAGE_SIZE)
    del keep
    _check(lib, status, buf)
    return json.loads(_take_string(lib, out))


def sky_height(width, height=0):
    """The height the library uses for `width` × `height` (0: width / 2, at least 2)."""
    return int(height) if int(height) > 0 else max(2, int(width) // 2)


def render_sky(spec, width=1024, height=0, view_samples=None, chapman=None, sun_disc=True, upper_only=False,
               threads=0, grid=None, multiple_scattering=True, progress=None, progress_range=(0.0, 1.0)):
    """Renders the sky in memory: (pixels, metadata). `progress_range`: the part of `progress`
    this call reports (a task of several calls).

    pixels: numpy float32 array (height, width, 4), linear Rec.709 RGBA in the sky texture's
    units, row 0 = the TOP row (straight up; Blender's image rows start at the bottom, so a
    host flips), Blender's equirectangular convention. metadata: {"airmass:version": ...,
    ...} — the strings an EXR of this sky would carry. Raises NativeError (also on cancel)."""

    lib = library()
    c_spec, keep = spec._to_c(lib)
    opts, chapman_b = _sky_options(lib, width, height, view_samples, chapman, sun_disc, upper_only, threads, grid,
                                   multiple_scattering)
    pixels, count = _sky_buffer(width, height)
    buf = _message_buffer()
    meta = ctypes.c_void_p()
    job_ptr, fn = None, None
    if progress is not None:
        job, fn = progress._job(*progress_range)
        job_ptr = ctypes.byref(job)
    status = lib.airmass_render_sky(ctypes.byref(c_spec), ctypes.byref(opts),
                                    pixels.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), count, job_ptr,
                                    ctypes.byref(meta), buf, _MESSAGE_SIZE)
    del keep, fn, chapman_b
    text = _take_string(lib, meta)  # freed whatever the status
    _check(lib, status, buf)
    metadata = json.loads(text) if text else {}
    return pixels, {str(k): str(v) for k, v in metadata.items()}


def _sky_options(lib, width=1024, height=0, view_samples=None, chapman=None, sun_disc=True, upper_only=False,
                 threads=0, grid=None, multiple_scattering=True, multiple_grid=None, multiple_samples=None):
    """(SkyOptions, keepalive) from keyword arguments (None: the library's default)."""
    opts = SkyOptions()
    _init_struct(lib.airmass_sky_options_init, opts, "airmass_sky_options")
    opts.width = int(width)
    opts.height = int(height)
    if view_samples is not None:
        opts.view_samples = int(view_samples)
    chapman_b = _bytes(chapman) if chapman else None
    opts.chapman = chapman_b
    opts.sun_disc = 1 if sun_disc else 0
    opts.upper_only = 1 if upper_only else 0
    opts.threads = int(threads)
    if grid is not None:
        opts.grid = int(grid)
    opts.multiple_scattering = 1 if multiple_scattering else 0
    if multiple_grid is not None:
        opts.multiple_grid = int(multiple_grid)
    if multiple_samples is not None:
        opts.multiple_samples = int(multiple_samples)
    return opts, chapman_b


def _sky_buffer(width, height):
    """(numpy float32 array (h, w, 4), float count) for a sky of width × height (0: width / 2)."""
    import numpy as np
    w = max(0, int(width))
    h = sky_height(width, height) if w > 0 else 0
    # A width the library refuses still needs a valid pointer: it reports the width first.
    pixels = np.zeros((max(1, h), max(1, w), 4), dtype=np.float32) if w * h == 0 else \
        np.empty((h, w, 4), dtype=np.float32)
    return pixels, w * h * 4


class SkySession:
    """One atmosphere, many suns (airmass_sky_session_*, C ABI 6): the atmosphere is compiled and
    its multiple-scattering tables computed once, here (a long call: `progress` reports and
    cancels it); render() then pays only for the sun direction. `options`: render_sky's keyword
    arguments (width, height, view_samples, chapman, sun_disc, upper_only, threads, grid,
    multiple_scattering, multiple_grid, multiple_samples) — chapman and multiple_scattering are fixed for the
    session, the rest are render()'s defaults. Thread-safe: renders may run on several threads
    at once. close() (or the garbage collector) frees it."""

    def __init__(self, spec, progress=None, progress_range=(0.0, 1.0), **options):
        self._lib = lib = library()
        self._handle = None
        self.options = dict(options)
        c_spec, keep = spec._to_c(lib)
        opts, chapman_b = _sky_options(lib, **options)
        handle = ctypes.c_void_p()
        buf = _message_buffer()
        job_ptr, fn = None, None
        if progress is not None:
            job, fn = progress._job(*progress_range)
            job_ptr = ctypes.byref(job)
        status = lib.airmass_sky_session_create(ctypes.byref(c_spec), ctypes.byref(opts), job_ptr,
                                                ctypes.byref(handle), buf, _MESSAGE_SIZE)
        del keep, fn, chapman_b
        _check(lib, status, buf)
        self._handle = handle.value

    def render(self, sun_elevation_deg=None, sun_rotation_deg=None, altitude_m=None, progress=None,
               progress_range=(0.0, 1.0), metadata=False, out=None, **options):
        """The sky for this sun and observer (None: the session's scene values), as render_sky
        returns it: (pixels, metadata) — pixels (height, width, 4) float32, row 0 the zenith.
        `options` override the session's (a preview quality: width, view_samples, grid,
        multiple_grid, ...). `out`: an array of that shape to fill instead of a new one."""
        if not self._handle:
            raise NativeError(INVALID_ARGUMENT, "sky session: closed")
        lib = self._lib
        merged = dict(self.options)
        merged.update(options)
        opts, chapman_b = _sky_options(lib, **merged)
        if out is None:
            pixels, count = _sky_buffer(merged.get("width", 1024), merged.get("height", 0))
        else:
            pixels = out
            count = out.size
            h = sky_height(merged.get("width", 1024), merged.get("height", 0))
            if out.dtype.name != "float32" or not out.flags["C_CONTIGUOUS"] or \
                    out.shape != (h, int(merged.get("width", 1024)), 4):
                raise ValueError("out: a C-contiguous float32 array of shape (%d, %d, 4), not %s %s"
                                 % (h, int(merged.get("width", 1024)), out.dtype, out.shape))
        view = SkyView()
        _init_struct(lib.airmass_sky_view_init, view, "airmass_sky_view")
        if sun_elevation_deg is not None:
            view.sun_elevation_deg = float(sun_elevation_deg)
        if sun_rotation_deg is not None:
            view.sun_rotation_deg = float(sun_rotation_deg)
        if altitude_m is not None:
            view.altitude_m = float(altitude_m)
        buf = _message_buffer()
        meta = ctypes.c_void_p()
        job_ptr, fn = None, None
        if progress is not None:
            job, fn = progress._job(*progress_range)
            job_ptr = ctypes.byref(job)
        status = lib.airmass_sky_session_render(self._handle, ctypes.byref(view), ctypes.byref(opts),
                                                pixels.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), count,
                                                job_ptr, ctypes.byref(meta) if metadata else None, buf,
                                                _MESSAGE_SIZE)
        del fn, chapman_b
        text = _take_string(lib, meta) if metadata else ""
        _check(lib, status, buf)
        info = json.loads(text) if text else {}
        return pixels, {str(k): str(v) for k, v in info.items()}

    def close(self):
        if self._handle:
            self._lib.airmass_sky_session_free(self._handle)
            self._handle = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


def sun_light(spec, chapman=None):
    """Direct sunlight at the observer: dict with direction, irradiance_rgb (W/m², the sky
    texture's RGB units), irradiance_top_rgb, transmittance_rgb, angular_diameter_deg,
    below_horizon."""
    lib = library()
    c_spec, keep = spec._to_c(lib)
    out = SunLight()
    out.struct_size = ctypes.sizeof(SunLight)
    buf = _message_buffer()
    status = lib.airmass_sun_light_at_observer(ctypes.byref(c_spec), _bytes(chapman) if chapman else None,
                                               ctypes.byref(out), buf, _MESSAGE_SIZE)
    del keep
    _check(lib, status, buf)
    return {
        "direction": tuple(out.direction),
        "irradiance_rgb": tuple(out.irradiance_rgb),
        "irradiance_top_rgb": tuple(out.irradiance_top_rgb),
        "transmittance_rgb": tuple(out.transmittance_rgb),
        "angular_diameter_deg": out.angular_diameter_deg,
        "below_horizon": bool(out.below_horizon),
    }


def solar_position(latitude_deg, longitude_deg, utc, delta_t_s=None, site_elevation_m=0.0):
    """The sun at a place and a UTC time (NREL SPA, no refraction; what `airmass sun` prints):
    dict with elevation_deg, azimuth_deg (from north, east = 90), zenith_deg,
    blender_elevation_deg, blender_rotation_deg (Sky Texture angles, +Y north), julian_day,
    delta_t_s. `utc` is ISO 8601 with a zone ("2026-06-21T04:00:00Z")."""
    lib = library()
    query = SolarQuery()
    _init_struct(lib.airmass_solar_query_init, query, "airmass_solar_query")
    utc_bytes = _bytes(utc)
    query.latitude_deg = float(latitude_deg)
    query.longitude_deg = float(longitude_deg)
    query.utc = utc_bytes
    query.site_elevation_m = float(site_elevation_m)
    query.delta_t_s = _NAN if delta_t_s is None else float(delta_t_s)
    out = SunPosition()
    out.struct_size = ctypes.sizeof(SunPosition)
    buf = _message_buffer()
    status = lib.airmass_solar_position(ctypes.byref(query), ctypes.byref(out), buf, _MESSAGE_SIZE)
    del utc_bytes
    _check(lib, status, buf)
    return {name: getattr(out, name) for name, _ in SunPosition._fields_ if name != "struct_size"}


def _vdb_options(lib, region="planet", unit="km", origin_center=False, voxel_size=None, box=None,
                 tolerance=None, max_dense_mb=None, tile_voxels=0, voxel_values="auto"):
    opts = VdbOptions()
    _init_struct(lib.airmass_vdb_options_init, opts, "airmass_vdb_options")
    keep = [_bytes(region), _bytes(unit), _bytes(voxel_values)]
    opts.region, opts.unit, opts.voxel_values = keep
    opts.origin_center = 1 if origin_center else 0
    opts.voxel_size = _NAN if voxel_size is None else float(voxel_size)
    if box is not None:
        for i in range(6):
            opts.box[i] = float(box[i])
    opts.tolerance = _NAN if tolerance is None else float(tolerance)
    opts.max_dense_mb = _NAN if max_dense_mb is None else float(max_dense_mb)
    opts.tile_voxels = int(tile_voxels)
    return opts, keep


# ---- volumes: the library plans and samples the grids, the host writes them ------------------
# (airmass_c.h "Volumes"; vdb_host.py builds the grids with Blender's own OpenVDB module.)

class VdbBlock(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("grid", ctypes.c_char_p),
        ("min", ctypes.c_int32 * 3),
        ("max", ctypes.c_int32 * 3),
        ("threads", ctypes.c_int32),
    ]


_SIGNATURES.update({
    "airmass_vdb_plan": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions), ctypes.c_char_p,
                                          ctypes.POINTER(Job), _OUT, ctypes.c_void_p, _SIZE]),
    "airmass_vdb_block_init": (ctypes.c_int32, [ctypes.POINTER(VdbBlock)]),
    "airmass_vdb_session_create": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions),
                                                    ctypes.POINTER(ctypes.c_void_p), ctypes.c_void_p, _SIZE]),
    "airmass_vdb_session_plan": (ctypes.c_int32, [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(Job), _OUT,
                                                  ctypes.c_void_p, _SIZE]),
    "airmass_vdb_session_grid_values": (ctypes.c_int32, [ctypes.c_void_p, ctypes.POINTER(VdbBlock),
                                                         ctypes.POINTER(ctypes.c_float), _SIZE, ctypes.POINTER(Job),
                                                         ctypes.c_void_p, _SIZE]),
    "airmass_vdb_session_free": (None, [ctypes.c_void_p]),
    "airmass_vdb_grid_values": (ctypes.c_int32, [ctypes.POINTER(SceneSpec), ctypes.POINTER(VdbOptions),
                                                 ctypes.POINTER(VdbBlock), ctypes.POINTER(ctypes.c_float), _SIZE,
                                                 ctypes.POINTER(Job), ctypes.c_void_p, _SIZE]),
})


class VdbSession:
    """One volume layout, its plan and all its grids' values (airmass_vdb_session_*, C ABI 8): the
    layout is resolved once, and the voxel means the plan's pass computes — once per class of
    voxels the planet's symmetry makes equal — serve every block asked afterwards (docs/vdb.md,
    Voxel values, Cost). `vdb`: _vdb_options' keywords. close() (or the garbage collector, or a
    `with` block) frees it. plan() and grid_values() may run at once on several threads; close()
    only when none is running (ctypes releases the GIL during a call)."""

    def __init__(self, spec, **vdb):
        self._lib = lib = library()
        self._handle = None
        c_spec, keep = spec._to_c(lib)
        opts, keep2 = _vdb_options(lib, **vdb)
        handle = ctypes.c_void_p()
        buf = _message_buffer()
        status = lib.airmass_vdb_session_create(ctypes.byref(c_spec), ctypes.byref(opts), ctypes.byref(handle), buf,
                                                _MESSAGE_SIZE)
        del keep, keep2
        _check(lib, status, buf)
        self._handle = handle.value

    def _open(self):
        if not self._handle:
            raise NativeError(INVALID_ARGUMENT, "vdb session: closed")
        return self._lib

    def plan(self, file_stem=None, progress=None, progress_range=(0.0, 1.0)):
        """The volume's plan: grids with their boxes, transform and metadata, files, limits
        already checked. A long call (the sampling pass)."""
        lib = self._open()
        out = ctypes.c_void_p()
        buf = _message_buffer()
        job_ptr, fn = None, None
        if progress is not None:
            job, fn = progress._job(*progress_range)
            job_ptr = ctypes.byref(job)
        stem = _bytes(file_stem) if file_stem is not None else None
        status = lib.airmass_vdb_session_plan(self._handle, stem, job_ptr, ctypes.byref(out), buf, _MESSAGE_SIZE)
        del fn, stem
        _check(lib, status, buf)
        return json.loads(_take_string(lib, out))

    def grid_values(self, grid, box_min, box_max, progress=None, progress_range=(0.0, 1.0), threads=0, out=None):
        """One grid's densities over the index box [box_min, box_max] (inclusive) as a C-ordered
        float32 numpy array a[i][j][k] = voxel box_min + (i, j, k) — what OpenVDB's Python
        `grid.copyFromArray(a, ijk=box_min)` reads; 0 where inactive. `out`: an array of that
        shape and dtype to fill instead of a new one."""
        import numpy as np
        lib = self._open()
        shape = tuple(int(b) - int(a) + 1 for a, b in zip(box_min, box_max))
        if out is None:
            out = np.empty(tuple(max(0, n) for n in shape), dtype=np.float32)
        elif out.dtype != np.float32 or not out.flags["C_CONTIGUOUS"] or out.shape != shape:
            raise ValueError("out: a C-contiguous float32 array of shape %s, not %s %s" % (shape, out.dtype, out.shape))
        block = VdbBlock()
        _init_struct(lib.airmass_vdb_block_init, block, "airmass_vdb_block")
        name = _bytes(grid)
        block.grid = name
        for a in range(3):
            block.min[a] = int(box_min[a])
            block.max[a] = int(box_max[a])
        block.threads = int(threads)
        buf = _message_buffer()
        job_ptr, fn = None, None
        if progress is not None:
            job, fn = progress._job(*progress_range)
            job_ptr = ctypes.byref(job)
        status = lib.airmass_vdb_session_grid_values(self._handle, ctypes.byref(block),
                                                     out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), out.size,
                                                     job_ptr, buf, _MESSAGE_SIZE)
        del fn, name
        _check(lib, status, buf)
        return out

    def close(self):
        if self._handle:
            self._lib.airmass_vdb_session_free(self._handle)
            self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


def vdb_plan(spec, file_stem=None, progress=None, progress_range=(0.0, 1.0), **vdb):
    """The volume's plan (VdbSession.plan of a session of its own)."""
    with VdbSession(spec, **vdb) as session:
        return session.plan(file_stem, progress, progress_range)


def vdb_grid_values(spec, grid, box_min, box_max, progress=None, progress_range=(0.0, 1.0), threads=0, out=None,
                    **vdb):
    """One grid's densities over a box (VdbSession.grid_values of a session of its own: the
    voxel means are computed afresh — a whole volume asks one session for all its blocks)."""
    with VdbSession(spec, **vdb) as session:
        return session.grid_values(grid, box_min, box_max, progress, progress_range, threads, out)


def analytic_density(spec, **vdb):
    """The analytic density description (docs/vdb.md) as a dict."""
    lib = library()
    c_spec, keep = spec._to_c(lib)
    opts, keep2 = _vdb_options(lib, **vdb)
    out = ctypes.c_void_p()
    buf = _message_buffer()
    status = lib.airmass_analytic_density_json(ctypes.byref(c_spec), ctypes.byref(opts), ctypes.byref(out), buf,
                                               _MESSAGE_SIZE)
    del keep, keep2
    _check(lib, status, buf)
    return json.loads(_take_string(lib, out))


def sun_column_table(spec, constituent_count, mu_size=256, r_size=64, **vdb):
    """The sun's columns (airmass_sun_column_table): float32 array [r_size, mu_size, count], per
    constituent of analytic_density's list (`constituent_count` of them) the mass toward the sun
    in the unit, on Bruneton's transmittance parametrisation (docs/addon.md, "Analytic Sun")."""
    import numpy as np
    lib = library()
    c_spec, keep = spec._to_c(lib)
    opts, keep2 = _vdb_options(lib, **vdb)
    out = np.zeros((int(r_size), int(mu_size), int(constituent_count)), dtype=np.float32)
    buf = _message_buffer()
    status = lib.airmass_sun_column_table(ctypes.byref(c_spec), ctypes.byref(opts), int(mu_size), int(r_size),
                                          out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), out.size, buf,
                                          _MESSAGE_SIZE)
    del keep, keep2
    _check(lib, status, buf)
    return out


def sun_ms_table(spec, mu_size=64, r_size=32, **vdb):
    """The multiple scattering of the Analytic Sun (airmass_sun_ms_table): (float32 array
    [r_size, mu_size, 3] of Hillaire's isotropic Ψ per unit top-of-atmosphere irradiance at the
    exporter's RGB wavelengths, mu_s_min of its sun axis)."""
    import numpy as np
    lib = library()
    c_spec, keep = spec._to_c(lib)
    opts, keep2 = _vdb_options(lib, **vdb)
    out = np.zeros((int(r_size), int(mu_size), 3), dtype=np.float32)
    mu_s_min = ctypes.c_double(float("nan"))
    buf = _message_buffer()
    status = lib.airmass_sun_ms_table(ctypes.byref(c_spec), ctypes.byref(opts), int(mu_size), int(r_size),
                                      out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), out.size,
                                      ctypes.byref(mu_s_min), buf, _MESSAGE_SIZE)
    del keep, keep2
    _check(lib, status, buf)
    return out, mu_s_min.value
