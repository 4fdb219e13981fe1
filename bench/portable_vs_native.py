#!/usr/bin/env python3
"""Portable library vs a -march build of it, in one run (docs/portable.md).

    bench/portable_vs_native.py PORTABLE_LIB NATIVE_LIB [--width W] [--repeats N] [--threads T]

Loads both libairmass_c builds (the portable one the add-on ships: baseline x86-64 with
runtime dispatch; and one compiled with -march=x86-64-v3 for this machine), renders the same
sky through the C ABI with each, alternating, and prints best-of-N wall times and their ratio,
plus the largest relative difference between the two images (they must agree: the portable
build is the same math). bench/portable_vs_native.sh builds the -march library and runs this.
Timings depend on the machine's load; the ratio is measured in the same run.
"""
import argparse
import ctypes
import sys
import time


class SceneSpec(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("toml", ctypes.c_char_p), ("preset", ctypes.c_char_p),
                ("source_name", ctypes.c_char_p), ("sun_elevation_deg", ctypes.c_double),
                ("sun_rotation_deg", ctypes.c_double), ("altitude_m", ctypes.c_double),
                ("planet_radius_m", ctypes.c_double), ("atmosphere_top_m", ctypes.c_double),
                ("ground_albedo", ctypes.c_double), ("basis", ctypes.c_int32),
                ("constituent_count", ctypes.c_uint32), ("constituents", ctypes.c_void_p),
                ("has_camera", ctypes.c_int32), ("camera_position_m", ctypes.c_double * 3),
                ("camera_direction", ctypes.c_double * 3), ("camera_up", ctypes.c_double * 3),
                ("camera_fov_deg", ctypes.c_double), ("camera_max_distance_m", ctypes.c_double),
                ("camera_width", ctypes.c_int32), ("camera_height", ctypes.c_int32)]


class SkyOptions(ctypes.Structure):
    _fields_ = [("struct_size", ctypes.c_uint32), ("width", ctypes.c_int32), ("height", ctypes.c_int32),
                ("view_samples", ctypes.c_int32), ("chapman", ctypes.c_char_p), ("sun_disc", ctypes.c_int32),
                ("upper_only", ctypes.c_int32), ("threads", ctypes.c_int32), ("grid", ctypes.c_int32),
                ("multiple_scattering", ctypes.c_int32), ("multiple_grid", ctypes.c_int32),
                ("multiple_samples", ctypes.c_int32)]


def load(path):
    lib = ctypes.CDLL(path)
    lib.airmass_render_sky.restype = ctypes.c_int32
    lib.airmass_render_sky.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t,
                                       ctypes.c_void_p, ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t]
    lib.airmass_build_info.restype = ctypes.c_int32
    lib.airmass_build_info.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_char_p, ctypes.c_size_t]
    return lib


def build_info(lib):
    out = ctypes.c_void_p()
    msg = ctypes.create_string_buffer(512)
    if lib.airmass_build_info(ctypes.byref(out), msg, 512) != 0:
        return "?"
    text = ctypes.string_at(out).decode()
    lib.airmass_string_free(out)
    return text


def render(lib, width, threads, multiple=True):
    spec = SceneSpec()
    spec.struct_size = ctypes.sizeof(spec)  # C ABI 4+ (this mirror: ABI 6): the host's size, refused if stale
    if lib.airmass_scene_spec_init(ctypes.byref(spec)) != 0:
        sys.exit("airmass_scene_spec_init refused struct_size %d: this mirror is stale" % spec.struct_size)
    spec.preset = b"earth"
    spec.sun_elevation_deg = 30.0
    opts = SkyOptions()
    opts.struct_size = ctypes.sizeof(opts)
    if lib.airmass_sky_options_init(ctypes.byref(opts)) != 0:
        sys.exit("airmass_sky_options_init refused struct_size %d: this mirror is stale" % opts.struct_size)
    opts.width, opts.height, opts.threads = width, width // 2, threads
    opts.multiple_scattering = 1 if multiple else 0
    n = width * (width // 2) * 4
    buf = (ctypes.c_float * n)()
    msg = ctypes.create_string_buffer(1024)
    t0 = time.perf_counter()
    status = lib.airmass_render_sky(ctypes.byref(spec), ctypes.byref(opts), buf, n, None, None, msg, 1024)
    seconds = time.perf_counter() - t0
    if status != 0:
        sys.exit("render failed: " + msg.value.decode())
    return seconds, buf


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("portable")
    ap.add_argument("native")
    ap.add_argument("--width", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--no-multiple", action="store_true", help="single scattering only")
    a = ap.parse_args()
    libs = {"portable": load(a.portable), "native": load(a.native)}
    best = {k: float("inf") for k in libs}
    images = {}
    for _ in range(a.repeats):
        for name, lib in libs.items():
            s, img = render(lib, a.width, a.threads, not a.no_multiple)
            best[name] = min(best[name], s)
            images[name] = img
    p, q = images["portable"], images["native"]
    diff = max(abs(x - y) / max(abs(y), 1e-30) for x, y in zip(p, q) if y > 1e-6)
    print("sky %dx%d, earth preset, sun 30 deg, defaults%s, threads %s, best of %d"
          % (a.width, a.width // 2, " but --no-multiple" if a.no_multiple else " (multiple scattering on)",
             a.threads or "all", a.repeats))
    for name in libs:
        print("  %-8s %8.3f s   %s" % (name, best[name], build_info(libs[name])))
    print("  portable / native time ratio: %.3f" % (best["portable"] / best["native"]))
    print("  largest relative difference between the images: %.2e" % diff)


if __name__ == "__main__":
    main()
