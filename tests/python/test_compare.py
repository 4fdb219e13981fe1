"""Render vs native (docs/compare.md): `airmass render`, and a small `airmass compare` in
headless Blender that asserts the comparison's thresholds.

Run by CTest as  /usr/bin/python3 -m pytest tests/python --airmass-build=<build dir>.

What is checked, and against what:
  * camera conventions — a panoramic render equals `airmass sky` bit for bit (same evaluator,
    sky.hpp's equirectangular mapping); a perspective render equals the sky texture sampled
    along directions computed here from Blender's documented camera model (sensor fit,
    36 mm sensor, −Z forward, pixel centres), for AUTO, HORIZONTAL and VERTICAL fits;
  * the medium cut to a box (the VDB comparison's reference) — with a box holding the whole
    atmosphere it equals the evaluator to 2e-4 (an independent integrator: Gauss–Legendre
    panels with closed-form optical depths vs the evaluator's sampling maps);
  * extremes — sun below the horizon, at the zenith and nadir, a camera in space, exactly on
    the ground: finite, non-negative images; bad input is refused with the field named;
  * Blender (skipped when `blender` is missing): a 24×14 comparison of the three paths on the
    ground-at-noon scene. Asserted: sky texture mean relative error ≤ 0.5 % and 95th
    percentile ≤ 2 %; volume paths (renderer-matched reference, split renders) mean relative
    error ≤ 3 % + the measured Monte Carlo noise, and the RMS error beyond noise ≤ 3 %; no
    NaN anywhere; summary.json complete. The physically exact native image vs Blender is
    recorded, not asserted. A sunset-below-the-horizon run checks that every path copes.
  * multiple scattering (skipped without `blender`): a 24×14 analytic_volume_ms run, Cycles
    with volume and diffuse bounces against native_matched_ms — the same bounds as the
    single-scattering volume paths, and the same image against the single-scattering
    reference off by > 10 % beyond noise (measured 41 %), so the check can fail.
"""

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

OpenImageIO = pytest.importorskip("OpenImageIO")

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
EXAMPLES = os.path.join(REPO, "examples", "compare")


def read(path):
    buf = OpenImageIO.ImageBuf(str(path))
    px = buf.get_pixels(OpenImageIO.FLOAT)
    assert px is not None, buf.geterror()
    return np.asarray(px[:, :, :3], dtype=np.float64)


def run(cmd, check=True, timeout=900):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=timeout)
    if check and p.returncode != 0:
        raise AssertionError("%s failed (%d):\n%s\n%s" % (" ".join(map(str, cmd)), p.returncode, p.stdout, p.stderr))
    return p


def scene_file(tmp_path, name, camera, sun=(20.0, 30.0), extra=""):
    """`camera` = (position in metres, direction, up, fov_deg, width, height); the file takes km."""
    pos, direction, up, fov, w, h = camera
    pos = [x / 1000.0 for x in pos]
    text = """preset = "earth"
%s
[sun]
elevation_deg = %r
azimuth_deg = %r
[camera]
position_km = [%r, %r, %r]
direction = [%r, %r, %r]
up = [%r, %r, %r]
fov_deg = %r
max_distance_km = 40.0
width = %d
height = %d
""" % (extra, sun[0], sun[1], *pos, *direction, *up, fov, w, h)
    p = tmp_path / (name + ".toml")
    p.write_text(text)
    return p


# ---- Blender's camera model, written from its documentation (independent of camera.cpp) ----

def blender_pixel_directions(position, direction, up, fov_deg, width, height, fit="AUTO", sensor=(36.0, 24.0)):
    f = np.asarray(direction, float)
    f /= np.linalg.norm(f)
    r = np.cross(f, np.asarray(up, float))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    horizontal = {"AUTO": width > height, "HORIZONTAL": True, "VERTICAL": False}[fit]
    sensor_mm = sensor[1] if fit == "VERTICAL" else sensor[0]
    # fov_deg is the field of view along the fitted side; focal length = sensor / (2 tan(fov/2))
    focal_mm = 0.5 * sensor_mm / math.tan(math.radians(fov_deg) / 2)
    pixel_mm = sensor_mm / (width if horizontal else height)
    xs = (np.arange(width) + 0.5 - width / 2) * pixel_mm
    ys = (height / 2 - (np.arange(height) + 0.5)) * pixel_mm
    X, Y = np.meshgrid(xs, ys)
    d = X[..., None] * r + Y[..., None] * u + focal_mm * f
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def sample_equirect_nearest(img, d):
    """The texel of a Blender equirectangular image holding direction d (sky.hpp's mapping)."""
    H, W = img.shape[:2]
    u = (np.arctan2(d[..., 1], d[..., 0]) - math.pi) / (-2 * math.pi)
    v = (np.arccos(np.clip(d[..., 2], -1, 1)) - math.pi) / (-math.pi)
    x = np.clip(np.floor(u * W).astype(int), 0, W - 1)
    y = np.clip(np.floor((1 - v) * H).astype(int), 0, H - 1)
    return img[y, x], u * W - x - 0.5, (1 - v) * H - y - 0.5


# ---- native renders -----------------------------------------------------------------------------

def test_panoramic_render_is_the_sky_texture(airmass_bin, tmp_path):
    scene = scene_file(tmp_path, "pano", ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 60.0, 128, 64))
    run([airmass_bin, "render", scene, "-q", "--panoramic", "-o", tmp_path / "pano.exr", "--samples", "32"])
    run([airmass_bin, "sky", scene, "-q", "-o", tmp_path / "sky.exr", "--width", "128", "--grid", "0", "--no-multiple",
         "--no-sun-disc", "--samples", "32"])
    a, b = read(tmp_path / "pano.exr"), read(tmp_path / "sky.exr")
    assert a.shape == b.shape == (64, 128, 3)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("fit,size,direction", [
    ("auto", (96, 54), (1.0, 0.3, 0.25)),      # landscape: the width is fitted
    ("auto", (40, 72), (-0.2, 1.0, 0.1)),      # portrait: AUTO fits the height with the sensor *width*
    ("horizontal", (40, 72), (0.6, -0.8, 0.3)),
    ("vertical", (96, 54), (1.0, 0.0, 0.5)),   # the sensor *height* (24 mm) spans the height
])
def test_perspective_camera_follows_blender(airmass_bin, tmp_path, fit, size, direction):
    """Each pixel of a perspective render equals the sky at the direction Blender's camera model
    gives its centre (a 2048-wide texture sampled at the texel it falls in, near texel centres)."""
    w, h = size
    cam = ((0.0, 0.0, 0.0), direction, (0.0, 0.0, 1.0), 50.0, w, h)
    scene = scene_file(tmp_path, "persp", cam)
    run([airmass_bin, "render", scene, "-q", "-o", tmp_path / "p.exr", "--samples", "16", "--sensor-fit", fit])
    run([airmass_bin, "sky", scene, "-q", "-o", tmp_path / "sky.exr", "--width", "2048", "--grid", "0", "--no-multiple",
         "--no-sun-disc", "--samples", "16"])
    img, sky = read(tmp_path / "p.exr"), read(tmp_path / "sky.exr")
    assert img.shape == (h, w, 3)
    d = blender_pixel_directions(*cam, fit=fit.upper())
    texel, dx, dy = sample_equirect_nearest(sky, d)
    # Compare only pixels whose direction is near a texel centre (there the texel is the exact
    # value for a direction within 0.075 texel = 0.013°), away from the horizon. (A 4096-wide
    # texture and 0.15 texel is the same 0.013° at four times the cost.)
    near = (np.abs(dx) < 0.075) & (np.abs(dy) < 0.075) & (np.abs(d[..., 2]) > 0.02)
    assert near.sum() > 10
    rel = np.abs(img[near] / texel[near] - 1)
    assert rel.max() < 2e-3, rel.max()
    # A camera model off by a pixel would differ by far more: the sky gradient is >1 %/pixel here.


def test_box_pixel_filter_is_the_pixel_mean(airmass_bin, tmp_path):
    """--pixel-filter box (the sky texture comparison's reference) equals the mean of a 32×32
    block of pixel-centre rays of a 32× larger image of the same camera: to 1e-3 away from the
    horizon (the midpoint rule's error on a smooth sky), and to the block's own resolution of
    the ground-sky jump (1/32 px × the jump) in the horizon row."""
    k, w, h = 32, 8, 6
    cam = ((0.0, 0.0, 2.0), (1.0, 0.0, 0.02), (0.0, 0.0, 1.0), 20.0, w, h)
    scene = scene_file(tmp_path, "box", cam)
    common = ["-q", "--samples", "16"]
    run([airmass_bin, "render", scene, "-o", tmp_path / "box.exr", "--pixel-filter", "box"] + common)
    run([airmass_bin, "render", scene, "-o", tmp_path / "fine.exr", "--width", str(k * w), "--height", str(k * h)]
        + common)
    box, fine = read(tmp_path / "box.exr"), read(tmp_path / "fine.exr")
    mean = fine.reshape(h, k, w, k, 3).mean(axis=(1, 3))
    rel = np.abs(box / mean - 1)
    # Pixel rows holding the ground-sky jump: a step of > 10 % between adjacent fine rows
    # (the sky changes by < 1 % per fine row).
    g = fine[..., 1].mean(axis=1)
    steps = np.abs(np.diff(g) / g[1:]) > 0.1
    horizon = np.zeros(h, bool)
    for i in np.nonzero(steps)[0]:
        horizon[i // k] = horizon[(i + 1) // k] = True
    assert 1 <= horizon.sum() <= 2, horizon
    assert rel[~horizon].max() < 1e-3, rel[~horizon].max()
    assert rel[horizon].max() < 0.5 / k, rel[horizon].max()
    # and one ray per pixel centre differs in the horizon row by far more than that
    centre = fine[k // 2::k, k // 2::k]
    assert np.abs(centre[horizon] / mean[horizon] - 1).max() > 2 * (0.5 / k)


def test_box_holding_everything_equals_the_evaluator(airmass_bin, tmp_path):
    scene = os.path.join(EXAMPLES, "ground-noon.toml")
    common = ["-q", "--width", "48", "--renderer-matched", "--rgb-model", "renderer"]
    run([airmass_bin, "render", scene, "-o", tmp_path / "full.exr", "--samples", "256"] + common)
    run([airmass_bin, "render", scene, "-o", tmp_path / "box.exr", "--box", "-1e5,-1e5,-1e5,1e5,1e5,1e5"] + common)
    a, b = read(tmp_path / "full.exr"), read(tmp_path / "box.exr")
    rel = np.abs(b / a - 1)
    assert rel.max() < 2e-4, rel.max()


def test_box_cuts_the_medium(airmass_bin, tmp_path):
    """A box that holds only the first kilometres: less sky, the same ground shading direction."""
    scene = os.path.join(EXAMPLES, "ground-noon.toml")
    common = ["-q", "--width", "32", "--renderer-matched", "--rgb-model", "renderer"]
    run([airmass_bin, "render", scene, "-o", tmp_path / "full.exr"] + common)
    run([airmass_bin, "render", scene, "-o", tmp_path / "box.exr", "--box", "-5,-5,-1,5,5,2"] + common)
    a, b = read(tmp_path / "full.exr"), read(tmp_path / "box.exr")
    sky = slice(0, 8)
    assert np.all(b[sky] < a[sky])
    assert np.all(b[sky] > 0)


@pytest.mark.parametrize("elevation", [-90.0, -30.0, -4.0, -0.5, 0.0, 0.5, 90.0])
@pytest.mark.parametrize("height_m", [0.0, 2.0, 10000.0, 400000.0, 2.0e7])
def test_extremes_are_finite(airmass_bin, tmp_path, elevation, height_m):
    cam = ((0.0, 0.0, height_m), (1.0, 0.0, -0.3), (0.0, 0.0, 1.0), 90.0, 24, 16)
    scene = scene_file(tmp_path, "x", cam, sun=(elevation, 45.0))
    for extra in ([], ["--renderer-matched", "--rgb-model", "renderer"], ["--box", "-50,-50,-5,50,50,60"]):
        out = tmp_path / "x.exr"
        run([airmass_bin, "render", scene, "-q", "-o", out, "--samples", "8"] + extra)
        img = read(out)
        assert np.all(np.isfinite(img)) and np.all(img >= 0)
        if elevation <= -30.0 and height_m < 1e5:
            # single scattering of a sun 30° below the horizon: only the sunlit upper atmosphere
            assert img.max() < 1e-2


def test_bad_input_names_the_field(airmass_bin, tmp_path):
    scene = os.path.join(EXAMPLES, "ground-noon.toml")
    p = run([airmass_bin, "render", scene, "-o", tmp_path / "x.exr", "--camera-position-km", "0,0,-0.005"], check=False)
    assert p.returncode != 0 and "below the planet surface" in p.stderr
    p = run([airmass_bin, "render", scene, "-o", tmp_path / "x.exr", "--box", "1,2,3"], check=False)
    assert p.returncode != 0 and "--box" in p.stderr
    p = run([airmass_bin, "render", scene, "-o", tmp_path / "x.exr", "--fov", "180"], check=False)
    assert p.returncode != 0 and "--fov" in p.stderr
    p = run([airmass_bin, "render", scene, "-o", tmp_path / "x.exr", "--camera-up", "1,0,0.12"], check=False)
    assert p.returncode != 0 and "camera.up" in p.stderr
    assert not (tmp_path / "x.exr").exists()
    p = run([airmass_bin, "compare", scene, "-o", tmp_path / "c", "--paths", "sky"], check=False)
    assert p.returncode != 0 and "--paths" in p.stderr


# ---- Blender ---------------------------------------------------------------------------------------

needs_blender = pytest.mark.skipif(shutil.which("blender") is None, reason="blender is not installed")

SUMMARY_KEYS = ("mean_rel_err", "p95_rel_err", "max_rel_err", "noise_rel", "blender_seconds", "native_seconds")


def compare(airmass_bin, scene, out, *args, timeout=900):
    run([airmass_bin, "compare", scene, "-o", out, "-q", "--threads", "2"] + [str(a) for a in args], timeout=timeout)
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


@pytest.fixture(scope="module")
def noon(airmass_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("compare") / "noon"
    summary = compare(airmass_bin, os.path.join(EXAMPLES, "ground-noon.toml"), out, "--width", 24, "--samples", 32,
                      "--seeds", 2, "--step", 2, "--volume-modes", "split")
    return out, summary


@needs_blender
def test_compare_writes_every_path(noon):
    out, summary = noon
    assert set(summary["paths"]) == {"sky_texture", "analytic_volume", "vdb_volume"}
    for path, e in summary["paths"].items():
        assert "error" not in e, (path, e.get("error"))
        for k in SUMMARY_KEYS:
            assert k in e and math.isfinite(e[k]), (path, k)
    text = open(os.path.join(out, "report.md")).read()
    for path in summary["paths"]:
        assert os.path.isfile(os.path.join(out, "png", path + "_side_by_side.png"))
        assert os.path.isfile(os.path.join(out, "png", path + "_error.png"))
        assert "## " + path in text


@needs_blender
def test_compare_images_have_no_nan(noon):
    out, _ = noon
    for name in os.listdir(out):
        if name.endswith(".exr") and not name.startswith("sky"):
            img = read(os.path.join(out, name))
            assert np.all(np.isfinite(img)), name
            assert np.all(img >= 0), name


@needs_blender
def test_sky_texture_path_thresholds(noon):
    e = noon[1]["paths"]["sky_texture"]
    assert e["mean_rel_err"] <= 0.005, e
    assert e["p95_rel_err"] <= 0.02, e


@needs_blender
@pytest.mark.parametrize("path", ["analytic_volume", "vdb_volume"])
def test_volume_paths_agree_beyond_noise(noon, path):
    e = noon[1]["paths"][path]
    assert e["reference"].startswith("native_matched")
    assert e["blender_mode"] == "split"
    assert e["mean_rel_err"] <= 0.03 + e["noise_rel"], e
    assert e["bias_beyond_noise"] <= 0.03, e
    assert abs(e["signed_mean_rel_err"]) <= 0.03, e
    # documented, not asserted: the physically exact image vs Blender, and the phase gap
    assert "vs_physical" in e
    assert "phase_function" in noon[1]["native_gaps"]


@needs_blender
def test_sun_below_the_horizon_in_every_path(airmass_bin, tmp_path):
    """Twilight (sun 4° below the horizon): every path runs, no NaN, the report is complete."""
    scene = scene_file(tmp_path, "twilight", ((0.0, 0.0, 2.0), (1.0, 0.0, 0.3), (0.0, 0.0, 1.0), 60.0, 16, 9),
                       sun=(-4.0, 90.0))
    out = tmp_path / "twilight"
    summary = compare(airmass_bin, scene, out, "--samples", 16, "--seeds", 2, "--step", 2,
                      "--volume-modes", "split,rgb,rgb_dither", "--max-distance", 20, "--paths", "sky_texture,analytic_volume,analytic_volume_ms,vdb_volume",
                      "--ms-modes", "dither")
    assert set(summary["paths"]) == {"sky_texture", "analytic_volume", "analytic_volume_ms", "vdb_volume"}
    for path in ("analytic_volume", "vdb_volume"):
        for k in ("rgb_render", "rgb_dither_render"):
            assert math.isfinite(summary["paths"][path][k]["mean_rel_err"]), (path, k)
    for path, e in summary["paths"].items():
        assert "error" not in e, (path, e.get("error"))
        for k in SUMMARY_KEYS:
            assert math.isfinite(e[k]), (path, k)
    for name in os.listdir(out):
        if name.endswith(".exr"):
            assert np.all(np.isfinite(read(os.path.join(out, name)))), name


@needs_blender
def test_multiple_scattering_path_agrees_beyond_noise(airmass_bin, tmp_path):
    """Cycles with volume and diffuse bounces (one dithered Volume Scatter per grey channel
    render) against native_matched_ms at noon on the ground, where multiple scattering is
    ≈ 25 % of the image (most of the ground's light, a fifth of the sky's)."""
    out = tmp_path / "ms"
    summary = compare(airmass_bin, os.path.join(EXAMPLES, "ground-noon.toml"), out, "--width", 24, "--samples", 64,
                      "--seeds", 4, "--step", 2, "--paths", "analytic_volume_ms")
    e = summary["paths"]["analytic_volume_ms"]
    assert "error" not in e, e.get("error")
    assert e["reference"] == "native_matched_ms" and e["blender_mode"] == "dither"
    # measured at 64 × 36: mean 2.6 % against 2.9 % noise, 0.5 % beyond noise, signed −0.5 %
    assert e["mean_rel_err"] <= 0.03 + e["noise_rel"], e
    assert e["bias_beyond_noise"] <= 0.03, e
    assert abs(e["signed_mean_rel_err"]) <= 0.02, e
    # The check sees multiple scattering: against single scattering the same image is far off.
    assert summary["native_gaps"]["multiple_scattering"]["mean_rel_err"] > 0.1
    assert e["vs_single_scattering"]["bias_beyond_noise"] > 0.1, e["vs_single_scattering"]
    assert e["vs_single_scattering"]["signed_mean_rel_err"] > 0.1
    # Cycles 3.4's phase-summing bias (one Volume Scatter per constituent) is measured, not asserted.
    assert "closures_render" in e and math.isfinite(e["closures_render"]["signed_mean_rel_err"])
    assert "## analytic_volume_ms" in open(os.path.join(out, "report.md")).read()


@needs_blender
def test_a_failing_path_is_recorded_not_fatal(airmass_bin, tmp_path):
    """The VDB of a camera in orbit does not fit Blender 3.4's dense grids: that path records an
    error, the sky texture path still runs and the report is written."""
    out = tmp_path / "orbit"
    summary = compare(airmass_bin, os.path.join(EXAMPLES, "orbit-400km.toml"), out, "--width", 16,
                      "--paths", "sky_texture,vdb_volume")
    assert "error" in summary["paths"]["vdb_volume"]
    assert "error" not in summary["paths"]["sky_texture"]
    assert os.path.isfile(os.path.join(out, "report.md"))


# ---- the report without the system Python (docs/compare.md, "The report") ------------------------------

REPORT_PY = os.path.join(REPO, "compare", "report.py")
BACKEND_LINE = "Made by report.py"  # the one line of report.md that names the backends
# Official Blender builds bundle numpy but neither matplotlib nor OpenImageIO; Debian's Blender
# sees the system's, so this makes them unimportable in Blender's Python (sys.modules[name] =
# None makes `import name` raise ImportError), run before report.py (--python-expr comes first).
HIDE_MODULES = "import sys; sys.modules.update(dict.fromkeys(('matplotlib', 'OpenImageIO'), None))"


def _backend_line(report_md):
    lines = [ln for ln in report_md.splitlines() if ln.startswith(BACKEND_LINE)]
    assert len(lines) == 1, lines
    return lines[0]


def _same_numbers(a, b, where="summary"):
    """Where two summary.json values differ beyond float round-off, or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return "%s: keys %s" % (where, sorted(set(a) ^ set(b)))
        return next((d for d in (_same_numbers(a[k], b[k], where + "." + k) for k in a) if d), None)
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return where + ": lengths"
        return next((d for d in (_same_numbers(x, y, "%s[%d]" % (where, i)) for i, (x, y) in enumerate(zip(a, b)))
                     if d), None)
    if isinstance(a, float) or isinstance(b, float):
        ok = isinstance(a, (int, float)) and isinstance(b, (int, float)) and \
            abs(a - b) <= 1e-9 * max(abs(a), abs(b)) + 1e-15
        return None if ok else "%s: %r vs %r" % (where, a, b)
    return None if a == b else "%s: %r vs %r" % (where, a, b)


def blender_version():
    p = run([shutil.which("blender"), "--version"])
    return p.stdout.split()[1]  # "Blender 3.4.1 ..." (bpy.app.version_string)


def read_png(path):
    buf = OpenImageIO.ImageBuf(str(path))
    px = buf.get_pixels(OpenImageIO.UINT8)
    assert px is not None, buf.geterror()
    return np.asarray(px, dtype=np.int64)


@needs_blender
def test_report_in_blender_equals_report_in_python(noon, tmp_path):
    """The report of one comparison folder (the noon run's renders), made three ways: the system
    Python (OpenImageIO, matplotlib), the same without matplotlib (numpy figures), and Blender's
    own Python with neither matplotlib nor OpenImageIO importable (bpy's image API, numpy
    figures, as in official Blender builds). summary.json must agree to float round-off,
    report.md line for line but for the line naming the backends, the plain images pixel for
    pixel (colour management: EXR read as data, PNG written through the Standard view)."""
    src, _ = noon
    skip = shutil.ignore_patterns("sky.exr", "*.vdb", "*.log", "report.md", "summary.json", "png")
    runs = {
        "python": [sys.executable, REPORT_PY, "{dir}"],
        "python_numpy_figures": [sys.executable, "-c",
                                 "import runpy, sys; sys.modules['matplotlib'] = None; sys.argv = sys.argv[1:]; "
                                 "runpy.run_path(sys.argv[0], run_name='__main__')", REPORT_PY, "{dir}"],
        "blender": [shutil.which("blender"), "-b", "--factory-startup", "--python-exit-code", "1",
                    "--python-expr", HIDE_MODULES, "--python", REPORT_PY, "--", "{dir}"],
    }
    expect = {"python": ("read and written with OpenImageIO", "matplotlib"),
              "python_numpy_figures": ("read and written with OpenImageIO", "numpy"),
              "blender": ("read and written with Blender %s" % blender_version(), "numpy")}
    out = {}
    for name, cmd in runs.items():
        d = tmp_path / name
        shutil.copytree(src, d, ignore=skip)
        run([str(c).replace("{dir}", str(d)) for c in cmd], timeout=300)
        text = (d / "report.md").read_text(encoding="utf-8")
        line = _backend_line(text)
        images, figures = expect[name]
        assert images in line and ("image API (bpy)" in line) == (name == "blender"), (name, line)
        assert ("figures drawn with matplotlib" if figures == "matplotlib" else "figures composed with numpy") in line, \
            (name, line)
        with open(d / "summary.json") as f:
            out[name] = (d, json.load(f), [ln for ln in text.splitlines() if not ln.startswith(BACKEND_LINE)])
        assert not [f for f in os.listdir(d) if ".tmp" in f] and not [f for f in os.listdir(d / "png") if ".tmp" in f]
    ref_dir, ref_summary, ref_lines = out["python"]
    assert set(ref_summary["paths"]) == {"sky_texture", "analytic_volume", "vdb_volume"}
    for name, (d, summary, lines) in out.items():
        assert _same_numbers(ref_summary, summary) is None, (name, _same_numbers(ref_summary, summary))
        assert lines == ref_lines, (name, [(a, b) for a, b in zip(ref_lines, lines) if a != b][:3])
        assert sorted(os.listdir(d / "png")) == sorted(os.listdir(ref_dir / "png")), name
        for path in ref_summary["paths"]:
            for kind in ("native", "blender"):
                a, b = read_png(ref_dir / "png" / ("%s_%s.png" % (path, kind))), \
                    read_png(d / "png" / ("%s_%s.png" % (path, kind)))
                assert a.shape == b.shape == (14, 24, 3), (name, path, kind, a.shape, b.shape)
                assert np.abs(a - b).max() <= 1, (name, path, kind, np.abs(a - b).max())
    # The numpy side by side holds the native image enlarged (nearest neighbour) as its first
    # panel; the numpy error map is blue where Blender is darker and red where brighter.
    d = out["blender"][0]
    native = read_png(d / "png" / "sky_texture_native.png")
    sbs = read_png(d / "png" / "sky_texture_side_by_side.png")
    s = -(-256 // 24)
    pad = max(4, s)
    assert sbs.shape == (14 * s + 2 * pad, 2 * (24 * s + pad) + pad, 3), sbs.shape
    panel = sbs[pad:pad + 14 * s, pad:pad + 24 * s]
    assert np.array_equal(panel, np.repeat(np.repeat(native, s, axis=0), s, axis=1))
    err = read_png(d / "png" / "analytic_volume_error.png")[pad:pad + 14 * s, pad:pad + 24 * s]
    assert (err[..., 2] - err[..., 0]).max() > 60 and (err[..., 0] - err[..., 2]).max() > 60  # both signs occur


def _stand_in(path, text):
    path.write_text(text)
    path.chmod(0o755)
    return path


@needs_blender
def test_compare_needs_no_system_python(airmass_bin, tmp_path):
    """`airmass compare` with its defaults (no --python) on a machine whose python3 is no use:
    `python3` and `python` on PATH are stand-ins that fail (and leave a mark), PYTHONPATH holds
    OpenImageIO and matplotlib that fail to import, and `blender` on PATH is Debian's Blender
    with matplotlib and OpenImageIO hidden (like an official build: numpy only). The renders
    and the report run in that Blender; the report says so."""
    real_blender = shutil.which("blender")
    bin_dir, stubs = tmp_path / "bin", tmp_path / "site"
    bin_dir.mkdir()
    mark = tmp_path / "python-was-run"
    for name in ("python3", "python"):
        _stand_in(bin_dir / name, "#!/bin/sh\necho \"$0 $*\" >> '%s'\necho 'stand-in python: no numpy, no "
                                  "OpenImageIO' >&2\nexit 1\n" % mark)
    _stand_in(bin_dir / "blender", """#!/bin/bash
# Debian's Blender with matplotlib and OpenImageIO unimportable in its Python
args=()
for a in "$@"; do
  if [ "$a" = "--python" ]; then args+=(--python-expr "%s"); fi
  args+=("$a")
done
exec '%s' "${args[@]}"
""" % (HIDE_MODULES, real_blender))
    for mod in ("OpenImageIO", "matplotlib"):
        (stubs / mod).mkdir(parents=True)
        (stubs / mod / "__init__.py").write_text("raise ImportError('stand-in: %s is not installed')\n" % mod)
    env = dict(os.environ, PATH=str(bin_dir) + os.pathsep + os.environ.get("PATH", ""), PYTHONPATH=str(stubs))
    # the stand-ins work: the system Python as found on PATH, and /usr/bin/python3 with this PYTHONPATH
    assert subprocess.run(["python3", "-c", "import numpy"], env=env, capture_output=True).returncode != 0
    assert mark.exists()
    mark.unlink()
    for mod in ("OpenImageIO", "matplotlib"):
        assert subprocess.run([sys.executable, "-c", "import " + mod], env=env, capture_output=True).returncode != 0
    out = tmp_path / "out"
    p = subprocess.run([str(airmass_bin), "compare", os.path.join(EXAMPLES, "ground-noon.toml"), "-o", str(out), "-q",
                        "--threads", "2", "--paths", "sky_texture", "--width", "16", "--sky-samples", "4"],
                       env=env, capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, (p.stdout, p.stderr, (out / "report.log").read_text() if (out / "report.log").exists()
                               else "no report.log")
    assert not mark.exists(), mark.read_text()
    with open(out / "summary.json") as f:
        e = json.load(f)["paths"]["sky_texture"]
    assert "error" not in e, e["error"]
    for k in SUMMARY_KEYS:
        assert math.isfinite(e[k]), k
    line = _backend_line((out / "report.md").read_text(encoding="utf-8"))
    assert "'s image API (bpy)" in line and "figures composed with numpy" in line, line
    assert "Blender" in (out / "report.log").read_text()
    for kind in ("side_by_side", "error", "native", "blender"):
        assert (out / "png" / ("sky_texture_%s.png" % kind)).is_file(), kind


def _cheap_compare(airmass_bin, out, *args):
    """A comparison with no Blender render (the orbit's VDB is refused): native images and the
    report only, ≈ 3 s."""
    return run([airmass_bin, "compare", os.path.join(EXAMPLES, "orbit-400km.toml"), "-o", out, "-q", "--width", 16,
                "--threads", "2", "--paths", "vdb_volume"] + list(args), check=False, timeout=300)


@needs_blender
def test_report_failure_is_reported_and_leaves_no_report(airmass_bin, tmp_path):
    """A report that fails — report.py raising inside Blender (the default), or a --python that
    cannot run it — fails the command with the report log's last lines in the message, and
    leaves the folder's earlier comparison exactly as it was (no report of these renders, no
    staging folder, no temporary file)."""
    scripts = tmp_path / "scripts"
    shutil.copytree(os.path.join(REPO, "compare"), scripts, ignore=shutil.ignore_patterns("__pycache__"))
    text = (scripts / "report.py").read_text(encoding="utf-8")
    hook = "    summary, images = analyse(d, job)\n"
    assert hook in text
    (scripts / "report.py").write_text(text.replace(hook, hook + "    raise RuntimeError('injected report failure')\n"),
                                       encoding="utf-8")
    python = _stand_in(tmp_path / "python-standin", "#!/bin/sh\necho 'stand-in python: no module named numpy' >&2\n"
                                                    "exit 3\n")
    for name, args, words in (
            ("blender", ["--scripts", scripts], ["compare/report.py in Blender", "exit status 1",
                                                  "RuntimeError: injected report failure"]),
            ("python", ["--python", python], ["compare/report.py in --python " + str(python), "exit status 3",
                                               "stand-in python: no module named numpy"])):
        out = tmp_path / name
        out.mkdir()
        for stale in ("report.md", "summary.json", "job.json"):
            (out / stale).write_text("from an earlier run\n")
        p = _cheap_compare(airmass_bin, out, *args)
        assert p.returncode != 0, (name, p.stderr)
        for w in words:
            assert w in p.stderr, (name, w, p.stderr)
        assert "last lines of report.log" in p.stderr, (name, p.stderr)
        assert _set(out) == {n: b"from an earlier run\n" for n in ("report.md", "summary.json", "job.json")}, \
            (name, sorted(_set(out)))
        assert _staging(out) == [] and not [f for f in os.listdir(out) if ".tmp" in f], (name, os.listdir(tmp_path))
    # and the same comparison with the real report.py succeeds in Blender
    out = tmp_path / "ok"
    p = _cheap_compare(airmass_bin, out)
    assert p.returncode == 0, p.stderr
    with open(out / "summary.json") as f:
        assert "error" in json.load(f)["paths"]["vdb_volume"]
    assert "'s image API (bpy)" in _backend_line((out / "report.md").read_text(encoding="utf-8"))


# ---- the output set appears whole (docs/reliability.md, "Faults") ----------------------------------------

def _set(out):
    """{path relative to out: bytes} of every file of a comparison folder."""
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def _staging(out):
    """compare's staging (and fallback's old) folders beside out."""
    return sorted(n for n in os.listdir(out.parent) if n.startswith("." + out.name + ".airmass-"))


def _sky_argv(airmass_bin, out, *args):
    return [str(airmass_bin), "compare", os.path.join(EXAMPLES, "ground-noon.toml"), "-o", str(out), "-q",
            "--threads", "2", "--paths", "sky_texture", "--width", "16", "--sky-samples", "4", *map(str, args)]


def _previous_set(airmass_bin, out):
    """An earlier comparison in out, with files a sky_texture run does not make (atmosphere.vdb,
    native_matched_box.exr): native renders and inputs only, ≈ 1 s."""
    run([airmass_bin, "compare", "--preset", "earth", "-o", out, "-q", "--no-blender", "--width", 16, "--height", 9,
         "--view-samples", 2, "--threads", 2, "--paths", "vdb_volume", "--voxel-size", 2])
    before = _set(out)
    assert {"atmosphere.vdb", "native_matched_box.exr", "job.json"} <= set(before), sorted(before)
    return before


def _check_sky_set(out):
    """out holds a complete sky_texture comparison and nothing of the earlier one; its JSON
    names files in out, not in the staging folder it was made in."""
    after = _set(out)
    assert {"job.json", "summary.json", "report.md", "sky.exr", "blender_sky_texture.log"} <= set(after), sorted(after)
    assert "atmosphere.vdb" not in after and "native_matched_box.exr" not in after, sorted(after)
    with open(out / "job.json") as f:
        assert json.load(f)["sky_texture"]["file"] == str(out / "sky.exr")
    for name, data in after.items():
        if name.endswith((".json", ".md")):
            assert b".airmass-stage-" not in data, name
    assert _staging(out) == []


@needs_blender
def test_a_rerun_replaces_the_whole_set(airmass_bin, tmp_path):
    out = tmp_path / "cmp"
    _previous_set(airmass_bin, out)
    run(_sky_argv(airmass_bin, out))
    _check_sky_set(out)


def _stopped_in_blender(airmass_bin, tmp_path, sig):
    """An earlier comparison in tmp_path/cmp; a sky_texture run signalled while Blender renders.
    Returns (earlier set, out, process, its stderr, its staging folder)."""
    out = tmp_path / "cmp"
    before = _previous_set(airmass_bin, out)
    events = tmp_path / "events.jsonl"
    proc = subprocess.Popen(_sky_argv(airmass_bin, out, "--progress-json", events), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    stage = out.parent / (".cmp.airmass-stage-%d" % proc.pid)
    log = None
    deadline = time.monotonic() + 300
    while log is None and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
        for ln in events.read_text().splitlines() if events.exists() else []:
            e = json.loads(ln)
            if e["event"] == "render_start" and e["step"] == "blender sky_texture":
                log = e["log"]  # written where the run works: the staging folder
    assert log is not None, proc.communicate()
    assert os.path.dirname(log) == str(stage) and os.path.isfile(log)
    while "Blender" not in open(log, errors="replace").read() and time.monotonic() < deadline:
        time.sleep(0.1)  # Blender has started
    assert _set(out) == before  # nothing published yet
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert _set(out) == before, err
    return before, out, proc, err, stage


@needs_blender
def test_ctrl_c_mid_run_keeps_the_previous_set(airmass_bin, tmp_path):
    _, out, proc, err, _ = _stopped_in_blender(airmass_bin, tmp_path, signal.SIGINT)
    assert proc.returncode != 0 and "cancel" in err, (proc.returncode, err)
    assert _staging(out) == []


@needs_blender
def test_kill_9_mid_run_keeps_the_previous_set_and_the_next_run_cleans_up(airmass_bin, tmp_path):
    _, out, proc, _, stage = _stopped_in_blender(airmass_bin, tmp_path, signal.SIGKILL)
    assert _staging(out) == [stage.name]  # what kill -9 leaves: named, beside out
    run(_sky_argv(airmass_bin, out))
    _check_sky_set(out)
