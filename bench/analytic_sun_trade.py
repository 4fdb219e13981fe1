"""The Analytic Sun lighting's error against cost, inside headless Blender with the add-on enabled
(bench/analytic_sun_trade.sh runs it; docs/addon.md, "Analytic Sun").

    blender -b --factory-startup --addons airmass_blender --python bench/analytic_sun_trade.py -- \\
        --work DIR --out TABLE.md

1. The sun's columns table: transmittance by the material's bilinear lookup against the masses by
   quadrature (composite 8-point Gauss–Legendre, written out here), per table size.
2. Cycles renders of the add-on's analytic volume per Step against `airmass render` of the same
   physics and camera (the bundled CLI), sky pixels only; and Volume Scatter at the same samples
   against its own reference (`--renderer-matched`).
"""

import argparse
import importlib
import math
import os
import subprocess
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--work", required=True)
ap.add_argument("--out", required=True)
args = ap.parse_args(argv)

native = importlib.import_module("airmass_blender.native")
props = importlib.import_module("airmass_blender.properties")
volume = importlib.import_module("airmass_blender.volume")
compare = importlib.import_module("airmass_blender.compare")

TABLE_SIZES = [(64, 16), (128, 32), (volume.SUN_COLUMNS_MU, volume.SUN_COLUMNS_R), (512, 128), (1024, 256)]
STEPS_KM = [1.0, 2.0, 4.0, 8.0]  # the whole-planet shell's smallest step is ≈ 1.3 km (docs/addon.md)
WIDTH, HEIGHT, SAMPLES = 96, 54, 16
CASES = [  # name, sun elevation, sun rotation, camera heading, camera pitch (degrees)
    ("day, sun 8°", 8.0, 30.0, 60.0, 22.0),
    ("sunset, sun −1°, looking away", -1.0, 270.0, 90.0, 12.0),
]


def log(msg):
    print("analytic_sun_trade: " + msg, flush=True)


def profile_values(p, h):
    if p["type"] == "exponential":
        return np.exp(-(h - p.get("reference_altitude", 0.0)) / p["scale_height"])
    if p["type"] == "tent":
        b, k, t = p["bottom"], p["peak"], p["top"]
        return np.maximum(0.0, np.minimum((h - b) / (k - b), (t - h) / (t - k)))
    raise SystemExit("analytic_sun_trade: profile type %s not written out here" % p["type"])


def masses_by_quadrature(r, mu, R, top, constituents, pieces=512):
    """∫ρ ds toward the sun to the top for points (r, μ): composite 8-point Gauss–Legendre."""
    x, w = np.polynomial.legendre.leggauss(8)
    t_top = -r * mu + np.sqrt(np.maximum(0.0, (r * mu) ** 2 + top * top - r * r))
    u = (np.arange(pieces)[:, None] + 0.5 * (x[None, :] + 1.0)).ravel() / pieces  # nodes on [0, 1]
    weights = np.tile(0.5 * w, pieces) / pieces
    out = np.zeros((len(r), len(constituents)))
    for lo in range(0, len(r), 256):
        sl = slice(lo, lo + 256)
        t = t_top[sl, None] * u[None, :]
        h = np.sqrt(r[sl, None] ** 2 + t * t + 2.0 * r[sl, None] * mu[sl, None] * t) - R
        for k, c in enumerate(constituents):
            rho = np.where(h <= top - R, profile_values(c["profile"], h), 0.0)
            out[sl, k] = (rho * weights[None, :]).sum(axis=1) * t_top[sl]
    return out


def bilinear(table, x_mu, x_r):
    """The material's lookup: texel (i, j) at x_mu = i/(W−1), x_r = j/(H−1), clamped to the edge."""
    n_r, n_mu, _ = table.shape
    x, y = np.clip(x_mu, 0, 1) * (n_mu - 1), np.clip(x_r, 0, 1) * (n_r - 1)
    i0, j0 = np.minimum(np.floor(x).astype(int), n_mu - 2), np.minimum(np.floor(y).astype(int), n_r - 2)
    fx, fy = (x - i0)[:, None], (y - j0)[:, None]
    return ((1 - fx) * (1 - fy) * table[j0, i0] + fx * (1 - fy) * table[j0, i0 + 1]
            + (1 - fx) * fy * table[j0 + 1, i0] + fx * fy * table[j0 + 1, i0 + 1])


def table_trade(lines):
    s = bpy.context.scene.airmass
    s.preset = "earth"
    spec = props.make_spec(s)
    d = native.analytic_density(spec, unit="km")
    R, top = float(d["planet_radius"]), float(d["atmosphere_top"])
    cons = d["constituents"]
    H = math.sqrt(top * top - R * R)
    rng = np.random.default_rng(19)
    n = 4000
    h = (top - R) * rng.random(n) ** 2  # denser near the ground, where the air is
    r = R + h
    rho = np.sqrt(r * r - R * R)
    lowest = np.arcsin(-rho / r) + math.radians(0.3)  # the sun at least 0.3° above the planet's horizon
    elev = lowest + (0.5 * math.pi - lowest) * rng.random(n) ** 2  # denser near the horizon
    mu = np.sin(elev)
    t0 = time.time()
    exact = masses_by_quadrature(r, mu, R, top, cons)
    log("quadrature of %d sun rays: %.1f s" % (n, time.time() - t0))
    ext = np.array([[c["scattering_rgb"][ch] + c["absorption_rgb"][ch] for ch in range(3)] for c in cons])  # [k, ch]
    t_exact = np.exp(-exact @ ext)
    d_top = -r * mu + np.sqrt((r * mu) ** 2 + H * H - rho * rho)
    x_mu = (d_top - (top - r)) / (rho + H - (top - r))
    x_r = rho / H
    lines += ["**The sun's columns table** (earth, %d points: altitude 0–60 km denser near the ground, the sun "
              "0.3°–90° above the planet's horizon denser near it): |ΔT| / T of the transmittance "
              "exp(−Σ σt m) per channel, where T > 10⁻³; the table's cost is the library call "
              "(`airmass_sun_column_table`) and the image's size." % n, "",
              "| table (μ × r texels) | p50 | p95 | max | library call | image |", "|---|---|---|---|---|---|"]
    for n_mu, n_r in TABLE_SIZES:
        t0 = time.perf_counter()
        table = native.sun_column_table(spec, len(cons), mu_size=n_mu, r_size=n_r, unit="km").astype(np.float64)
        ms = 1e3 * (time.perf_counter() - t0)
        t_look = np.exp(-bilinear(table, x_mu, x_r) @ ext)
        ok = t_exact > 1e-3
        rel = np.abs(t_look - t_exact)[ok] / t_exact[ok]
        default = " (default)" if (n_mu, n_r) == (volume.SUN_COLUMNS_MU, volume.SUN_COLUMNS_R) else ""
        lines.append("| %d × %d%s | %.2g %% | %.2g %% | %.2g %% | %.0f ms | %.0f KiB |" % (
            n_mu, n_r, default, 100 * np.median(rel), 100 * np.percentile(rel, 95), 100 * rel.max(), ms,
            n_mu * n_r * 16 / 1024.0))
    lines.append("")


def setup_scene(case, lighting, step_km, multiple=False):
    name, elevation, rotation, heading, pitch = case
    bpy.ops.wm.read_homefile(use_empty=False)
    scene = bpy.context.scene
    for o in list(bpy.data.objects):
        if o.type in ("MESH", "LIGHT"):
            bpy.data.objects.remove(o)
    s = scene.airmass
    s.preset = "earth"
    s.output_folder = os.path.join(args.work, "airmass")
    s.sun_elevation, s.sun_rotation = math.radians(elevation), math.radians(rotation)
    cam = scene.camera
    cam.location = (0.0, 0.0, 0.002)
    cam.rotation_mode = "XYZ"
    cam.rotation_euler = (math.radians(90.0 + pitch), 0.0, math.radians(-heading))
    cam.data.sensor_fit = "AUTO"
    cam.data.lens = 0.5 * cam.data.sensor_width / math.tan(math.radians(30.0))  # 60° across
    cam.data.clip_start = 1e-4
    s.volume_lighting = lighting
    s.volume_multiple = multiple
    s.volume_region, s.step_km = "PLANET", step_km
    assert bpy.ops.airmass.sun_sync() == {"FINISHED"}
    assert bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    obj = next(o for o in scene.objects if o.get("airmass_role") == "atmosphere")
    size = float(np.mean(np.array(obj.dimensions)))
    got_step = 0.1 * size * obj.active_material.cycles.volume_step_rate
    cy = scene.cycles
    scene.render.engine = "CYCLES"
    cy.device, cy.samples, cy.seed, cy.use_denoising = "CPU", SAMPLES, 7, False
    cy.use_adaptive_sampling = False
    cy.max_bounces, cy.volume_bounces, cy.diffuse_bounces = 2, 0, 1
    cy.pixel_filter_type, cy.filter_width = "BOX", 1.0
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = WIDTH, HEIGHT, 100
    r.image_settings.file_format, r.image_settings.color_depth = "OPEN_EXR", "32"
    r.use_file_extension = False
    return scene, cam, got_step


def load_rgb(path):
    img = bpy.data.images.load(path, check_existing=False)
    try:
        px = np.array(img.pixels[:], dtype=np.float64).reshape(img.size[1], img.size[0], 4)[::-1, :, :3]
    finally:
        bpy.data.images.remove(img)
    return px


def sky_rows(scene, cam):
    """Rows whose every pixel is above the horizon (centre ray > 1.5 pixel heights up)."""
    m = cam.matrix_world.to_3x3()
    frame = [Vector(v) for v in cam.data.view_frame(scene=scene)]
    tl, tr, bl = frame[3], frame[0], frame[2]
    el = [math.degrees(math.asin((m @ (tl + (tr - tl) * 0.5 + (bl - tl) * ((j + 0.5) / HEIGHT))).normalized().z))
          for j in range(HEIGHT)]
    pixel = abs(el[0] - el[-1]) / (HEIGHT - 1)
    return np.array(el) > 1.5 * pixel


NATIVE = {}


def native_image(case, matched, scene, cam, multiple=None):
    """`airmass render` of the case; multiple: None, "isotropic_lut" or "orders"."""
    key = (case[0], matched, multiple)
    if key in NATIVE:
        return NATIVE[key]
    m = cam.matrix_world.to_3x3()
    d, u = m @ Vector((0.0, 0.0, -1.0)), m @ Vector((0.0, 1.0, 0.0))
    out = os.path.join(args.work, "native_%d_%d_%s.exr" % (CASES.index(case), matched, multiple))
    cmd = [compare.cli_path(), "render", "--preset", "earth", "--sun-elevation", repr(case[1]),
           "--sun-rotation", repr(case[2]), "--rgb-model", "renderer", "--pixel-filter", "box",
           "--width", str(WIDTH), "--height", str(HEIGHT), "--camera-position-km", "0,0,0.002",
           "--camera-direction", "%.9f,%.9f,%.9f" % tuple(d), "--camera-up", "%.9f,%.9f,%.9f" % tuple(u),
           "--fov", "60", "--samples", "64", "--threads", "2", "--quiet", "-o", out]
    if matched:
        cmd.insert(2, "--renderer-matched")
    if multiple:
        cmd += ["--multiple", "--ms-mode", multiple, "--no-cache"]
    subprocess.run(cmd, check=True, timeout=600)
    NATIVE[key] = load_rgb(out)
    return NATIVE[key]


def render_trade(lines):
    lines += ["**Cycles against the library's render of the same physics** (Blender %s, CPU, 2 threads, %d × %d, "
              "%d spp, Box filter, one seed; analytic volume of the whole planet; sky pixels only): Analytic Sun "
              "against `airmass render --rgb-model renderer` (the scene's phases), Volume Scatter (Phase Mixing "
              "*One Dithered Scatter*) against the same with `--renderer-matched` (Henyey–Greenstein, what it "
              "renders). Error per pixel and channel |Δ| / max(native, 10⁻³ · its mean); render wall time."
              % (bpy.app.version_string, WIDTH, HEIGHT, SAMPLES), "",
              "With Multiple Scattering the image is compared twice: with `--multiple --ms-mode isotropic_lut` "
              "(the same Hillaire Ψ: Cycles' and the table's error) and with `--multiple` (the library's orders "
              "tables, its default and most accurate: the error of the isotropic shortcut itself).", "",
              "| case | lighting | step asked → got | reference | mean | p95 | render |",
              "|---|---|---|---|---|---|---|"]
    for case in CASES:
        runs = ([("SUN_EMISSION", s, False) for s in STEPS_KM] + [("SUN_EMISSION", STEPS_KM[1], True)]
                + [("SCATTER", STEPS_KM[0], False)])
        for lighting, step, multiple in runs:
            scene, cam, got = setup_scene(case, lighting, step, multiple)
            path = os.path.join(args.work, "cycles.exr")
            scene.render.filepath = path
            t0 = time.time()
            bpy.ops.render.render(write_still=True)
            seconds = time.time() - t0
            cyc = load_rgb(path)
            rows = sky_rows(scene, cam)
            label = {"SUN_EMISSION": "Analytic Sun", "SCATTER": "Volume Scatter"}[lighting]
            if multiple:
                label += " + multiple scattering"
            refs = ([("isotropic_lut", "native isotropic-lut"), ("orders", "native orders tables")] if multiple
                    else [(None, "native, renderer-matched" if lighting == "SCATTER" else "native single")])
            for ms_mode, ref_label in refs:
                ref = native_image(case, lighting == "SCATTER", scene, cam, ms_mode)
                a, b = cyc[rows], ref[rows]
                rel = np.abs(a - b) / np.maximum(b, 1e-3 * b.mean())
                lines.append("| %s | %s | %.3g → %.3g km | %s | %.2g %% | %.2g %% | %.1f s |" % (
                    case[0], label, step, got, ref_label, 100 * rel.mean(), 100 * np.percentile(rel, 95), seconds))
                log("%s, %s, step %.3g km, %s: mean %.3g %%, %.1f s" % (case[0], label, got, ref_label,
                                                                        100 * rel.mean(), seconds))
    lines.append("")


def main():
    lines = ["Made by `bench/analytic_sun_trade.sh` (%s)." % time.strftime("%Y-%m-%d"), ""]
    table_trade(lines)
    render_trade(lines)
    with open(args.out + ".tmp", "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(args.out + ".tmp", args.out)


main()
