"""`airmass pov`: POV-Ray 3.7 scenes rendered headless and compared with the native image.

* orientation: the sky_sphere is swapped for an image whose pixels hold their own (u, v);
  every rendered pixel must read the texel of its own direction, the direction computed
  here from Blender's camera conventions (independent of the C++ camera code);
* pov_sky: the sky texture as sky_sphere against the native physical image of the same
  camera with Cycles' Box filter (`airmass render --pixel-filter box --multiple`, what
  `airmass compare` calls native_physical_box): mean relative error <= 1 %, p95 <= 3 %;
* the example scenes (ground noon, sunset with the sun below the horizon, 10 km) render
  along every path without a POV-Ray error and without NaN;
* bad input is refused, naming the option, before any file is written.
"""
import math
import pathlib
import shutil

import numpy as np
import pytest

oiio = pytest.importorskip("OpenImageIO")
pytestmark = pytest.mark.skipif(shutil.which("povray") is None, reason="povray not installed")

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "compare"


from pov_test_io import read_exr, run, write_exr


def povray(scene, width, height, *extra):
    """Renders scene.pov from its folder (POV-Ray's I/O restrictions) into <stem>.out.exr."""
    out = scene.with_name(scene.stem + ".out.exr")
    run(["povray", f"+I{scene.name}", f"+O{out.name}", "+FE", f"+W{width}", f"+H{height}", "-D", "-V", "-GA",
         *extra], cwd=scene.parent)
    return read_exr(out)


def rel_error(test, ref):
    floor = 1e-3 * ref.mean()
    return (test - ref) / np.maximum(ref, floor)


def blender_camera_directions(position_dir, up, fov_deg, width, height):
    """Unit directions through every pixel centre, Blender's perspective camera (sensor fit
    AUTO, fov along the larger side), scene frame (Z up); shape (H, W, 3)."""
    d = np.asarray(position_dir, float)
    d /= np.linalg.norm(d)
    right = np.cross(d, up)
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, d)
    f = 0.5 * max(width, height) / math.tan(math.radians(fov_deg) / 2)
    x = np.arange(width) + 0.5 - width / 2
    y = height / 2 - (np.arange(height) + 0.5)
    v = d[None, None, :] * f + right[None, None, :] * x[None, :, None] + cam_up[None, None, :] * y[:, None, None]
    return v / np.linalg.norm(v, axis=2, keepdims=True)


def test_sky_sphere_orientation_picks_each_directions_texel(airmass_bin, tmp_path):
    """A rendered direction reads the sky pixel of the same direction (Blender's equirectangular
    convention: u = (atan2(y, x) - pi) / (-2 pi) from the left, the top row at +Z)."""
    W, H, fov = 48, 32, 100.0
    direction, up = (1.0, 0.6, 0.45), (0.0, 0.0, 1.0)
    scene = tmp_path / "o.pov"
    run([airmass_bin, "pov", "--preset", "earth", "--path", "sky", "-o", scene, "--width", W, "--height", H,
         "--fov", fov, "--camera-direction", ",".join(map(str, direction)), "--camera-up", "0,0,1",
         "--sky-width", 64, "-q"])
    # The same sky_sphere reading an image whose texels hold their own (u, v).
    tw, th = 512, 256
    uv = np.zeros((th, tw, 3))
    uv[:, :, 0] = ((np.arange(tw) + 0.5) / tw)[None, :]
    uv[:, :, 1] = ((np.arange(th) + 0.5) / th)[:, None]
    write_exr(tmp_path / "o.sky.exr", uv)
    img = povray(scene, W, H)
    d = blender_camera_directions(direction, up, fov, W, H)
    u = (np.arctan2(d[..., 1], d[..., 0]) - math.pi) / (-2 * math.pi)
    v_top = np.arccos(np.clip(d[..., 2], -1, 1)) / math.pi
    # Half-float output: 2^-11 relative; bilinear texel interpolation is exact on these ramps.
    assert np.abs(img[..., 0] - u).max() < 2e-3
    assert np.abs(img[..., 1] - v_top).max() < 2e-3


def test_pov_sky_matches_the_native_box_filtered_image(airmass_bin, tmp_path):
    """pov_sky vs native_physical_box on the ground-noon camera at 64 x 36."""
    W, H = 64, 36
    src = EXAMPLES / "ground-noon.toml"
    scene = tmp_path / "s.pov"
    run([airmass_bin, "pov", src, "--path", "sky", "-o", scene, "--width", W, "--height", H, "-q"])
    text = scene.read_text()
    assert "sky_sphere" in text and "media" not in text.split("sky_sphere")[1]
    # Anti-aliasing as the file's own command line says: every pixel the mean of a 9 x 9 grid.
    flags = text.split("// Render from this folder:")[1].split("\n")[0].split()[-4:]
    assert flags == ["+A0.0", "+AM1", "+R9", "-J"], flags
    pov = povray(scene, W, H, *flags)
    native = tmp_path / "native.exr"
    run([airmass_bin, "render", src, "-o", native, "--width", W, "--height", H, "--pixel-filter", "box",
         "--multiple", "-q"])
    ref = read_exr(native)
    assert np.isfinite(pov).all() and pov.shape == ref.shape
    e = np.abs(rel_error(pov, ref))
    mean, p95 = e.mean(), np.percentile(e, 95)
    print(f"pov_sky vs native_physical_box {W}x{H}: mean {mean:.4%}, p95 {p95:.4%}, max {e.max():.4%}")
    assert mean <= 0.01
    assert p95 <= 0.03


@pytest.mark.parametrize("example", ["ground-noon", "sunset", "altitude-10km"])
@pytest.mark.parametrize("path", ["sky", "analytic", "df3"])
def test_example_scenes_render_without_error_or_nan(airmass_bin, tmp_path, example, path):
    W, H = 24, 14
    scene = tmp_path / "e.pov"
    extra = ["--media-intervals", 12] if path != "sky" else []
    if path == "df3":
        extra += ["--voxel-size", 2]
    run([airmass_bin, "pov", EXAMPLES / f"{example}.toml", "--path", path, "-o", scene, "--width", W, "--height", H,
         "-q", *extra])
    img = povray(scene, W, H)
    assert np.isfinite(img).all()
    assert (img >= 0).all()
    if example != "sunset":
        assert img.mean() > 0


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--path", "df3", "--voxel-size", "0.0005"], "--voxel-size"),
        (["--path", "analytic", "--media-intervals", "0"], "--media-intervals"),
        (["--path", "sky", "--voxel-size", "1"], "--voxel-size"),
        (["--path", "sky", "--width", "0"], "--width"),
    ],
)
def test_bad_input_is_refused_before_any_file(airmass_bin, tmp_path, args, fragment):
    p = run([airmass_bin, "pov", EXAMPLES / "ground-noon.toml", "-o", tmp_path / "x.pov", *args], check=False)
    assert p.returncode == 2, p.stderr
    assert fragment in p.stderr
    assert list(tmp_path.iterdir()) == []


def render_passes(airmass_bin, tmp_path, path, example, W, H):
    """The scene's split passes (one per scatterer, docs/povray.md) summed, and the .pov text."""
    scene = tmp_path / f"{path}.pov"
    run([airmass_bin, "pov", EXAMPLES / f"{example}.toml", "--path", path, "-o", scene, "--width", W, "--height", H,
         "-q"])
    text = scene.read_text()
    passes = [int(k) for k in
              text.split("Declare=Airmass_Pass=K with K in:")[1].split("\n")[0].replace("(", " ").split()
              if k.isdigit()]
    assert passes, text
    total = 0
    for k in passes:
        img = povray(scene, W, H, f"Declare=Airmass_Pass={k}")
        total = total + img
    return total, text


@pytest.mark.parametrize("path", ["analytic", "df3"])
def test_pov_media_match_the_povray_matched_native(airmass_bin, tmp_path, path):
    """pov_analytic / pov_df3 (split passes, the automatic media sampling) against
    `airmass render --renderer-matched --matched-renderer povray --rgb-model renderer` (Rayleigh
    kept, Mie as HG of the one rule, three wavelengths lit by the sun's RGB irradiance); df3 with
    the medium cut to the exported box. POV-Ray's method 3 without jitter is deterministic: no
    noise to subtract, the error is its sampling bias (docs/povray.md)."""
    W, H = 16, 9
    src = EXAMPLES / "ground-noon.toml"
    pov, text = render_passes(airmass_bin, tmp_path, path, "ground-noon", W, H)
    native = tmp_path / "matched.exr"
    extra = []
    if path == "df3":
        box = text.split("// airmass:medium_box_km = ")[1].split()[0]
        extra = [f"--box={box}"]
    run([airmass_bin, "render", src, "-o", native, "--width", W, "--height", H, "--renderer-matched",
         "--matched-renderer", "povray", "--rgb-model", "renderer", "-q", *extra])
    ref = read_exr(native)
    assert np.isfinite(pov).all()
    e = rel_error(pov, ref)
    mean, p95, signed = np.abs(e).mean(), np.percentile(np.abs(e), 95), e.mean()
    print(f"pov_{path} (split) vs native matched {W}x{H}: mean {mean:.3%}, p95 {p95:.3%}, signed {signed:.3%}")
    assert mean <= 0.03
