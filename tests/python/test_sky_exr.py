"""`airmass sky` end to end: the EXR as Blender would read it (OpenImageIO, Debian's python3).

Checks channels, size, pixel type, orientation (Blender's equirectangular convention and
Sky Texture sun angles), metadata, the upper-hemisphere option, clear errors for unwritable
destinations, and that Ctrl-C leaves no file behind.
"""
import json
import math
import os
import shutil
import signal
import subprocess
import time

import numpy as np
import OpenImageIO as oiio
import pytest


def run_sky(airmass_bin, out, *args, check=True):
    cmd = [str(airmass_bin), "sky", "--preset", "earth", "-o", str(out), "--quiet", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


def read_exr(path):
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    return spec, pixels


def luminance(px):
    return 0.2126 * px[..., 0] + 0.7152 * px[..., 1] + 0.0722 * px[..., 2]


def test_exr_is_rgb_float_of_the_requested_size(airmass_bin, tmp_path):
    out = tmp_path / "sky.exr"
    run_sky(airmass_bin, out, "--width", "128", "--basis", "rgb", "--samples", "8")
    spec, px = read_exr(out)
    assert (spec.width, spec.height, spec.nchannels) == (128, 64, 3)
    assert list(spec.channelnames) == ["R", "G", "B"]
    assert spec.format == oiio.FLOAT  # 32-bit float on disk, not half
    assert px.shape == (64, 128, 3)
    assert np.all(np.isfinite(px)) and px.min() >= 0.0
    # Metadata: the scene and settings as JSON, the version.
    settings = json.loads(spec.getattribute("airmass:settings"))
    assert settings["width"] == 128 and settings["basis"] == "rgb-schuler"
    assert json.loads(spec.getattribute("airmass:scene"))
    assert spec.getattribute("airmass:version")
    assert list(tmp_path.iterdir()) == [out]  # no temporary left behind


def test_multiple_scattering_is_on_by_default_and_no_multiple_turns_it_off(airmass_bin, tmp_path):
    """The default sky includes multiple scattering (recorded in the metadata, with its table
    settings); --no-multiple gives the single-scattering sky, darker everywhere and, on the
    side away from the sun, far darker at twilight than at noon relative to it (the light
    multiple scattering carries into the Earth's shadow)."""
    ratios = {}
    for elevation in ("45", "-6"):
        imgs = {}
        for name, extra in (("ms", []), ("ss", ["--no-multiple"])):
            out = tmp_path / f"{name}{elevation}.exr"
            run_sky(airmass_bin, out, "--width", "64", "--basis", "rgb", "--samples", "8",
                    "--sun-elevation", elevation, "--sun-rotation", "0", "--no-sun-disc", *extra)
            spec, px = read_exr(out)
            settings = json.loads(spec.getattribute("airmass:settings"))
            assert settings["multiple_scattering"] is (name == "ms")
            if name == "ms":
                assert settings["multiple"]["mode"] == "orders"
                assert settings["multiple"]["table"]["azimuth"] > 0  # automatic count resolved
            else:
                assert "multiple" not in settings
            assert np.all(np.isfinite(px)) and px.min() >= 0.0
            imgs[name] = px
        sky = slice(0, 16)  # rows above the horizon (of 32)
        ms, ss = luminance(imgs["ms"][sky]), luminance(imgs["ss"][sky])
        assert np.all(ms >= ss * (1 - 1e-6)), elevation
        # Rotation 0 puts the sun toward +Y, a quarter from the left; the right half of the
        # image (columns 32-63 of 64) looks away from it.
        away = slice(32, 64)
        ratios[elevation] = ms[:, away].mean() / ss[:, away].mean()
    assert ratios["45"] > 1.1, ratios
    assert ratios["-6"] > 2.0 * ratios["45"], ratios


@pytest.mark.parametrize("rotation,elevation", [(0.0, 30.0), (90.0, 30.0), (90.0, 60.0), (200.0, 15.0)])
def test_sun_lands_where_blender_puts_it(airmass_bin, tmp_path, rotation, elevation):
    """Sky Texture rotation 0° → +Y (a quarter from the left), 90° → +X (the centre);
    top row = zenith, so the sun's row is (90° − elevation)/180° of the height down."""
    out = tmp_path / "sky.exr"
    w, h = 360, 180
    run_sky(airmass_bin, out, "--width", str(w), "--height", str(h), "--basis", "rgb", "--samples", "4",
            "--sun-rotation", str(rotation), "--sun-elevation", str(elevation))
    _, px = read_exr(out)
    y, x = np.unravel_index(np.argmax(luminance(px)), (h, w))
    # Blender: direction (cos e sin r, cos e cos r, sin e); Cycles: u = (atan2(y,x) − π)/(−2π).
    sun = (math.cos(math.radians(elevation)) * math.sin(math.radians(rotation)),
           math.cos(math.radians(elevation)) * math.cos(math.radians(rotation)))
    u = (math.atan2(sun[1], sun[0]) - math.pi) / (-2 * math.pi)
    expected_x = u * w
    expected_y = (90.0 - elevation) / 180.0 * h
    dx = (x + 0.5 - expected_x + w / 2) % w - w / 2
    assert abs(dx) <= 1.0, (x, expected_x)
    assert abs(y + 0.5 - expected_y) <= 1.0, (y, expected_y)


def test_orientation_zenith_on_top_ground_below(airmass_bin, tmp_path):
    out = tmp_path / "sky.exr"
    run_sky(airmass_bin, out, "--width", "64", "--basis", "rgb", "--samples", "8", "--sun-elevation", "45",
            "--no-sun-disc")
    _, px = read_exr(out)
    top, bottom = px[0].mean(axis=0), px[-1].mean(axis=0)
    # The zenith sky is blue (Rayleigh); straight down is the grey ground (albedo 0.1) lit by
    # the reddened direct sun and seen through 0 m of air: red over blue.
    assert top[2] > 1.5 * top[0], top
    assert bottom[0] > bottom[2], bottom
    # The horizon row pair: sky above, ground below; each row is uniform in brightness far from the sun.


def test_upper_hemisphere_leaves_the_lower_half_zero(airmass_bin, tmp_path):
    out = tmp_path / "sky.exr"
    run_sky(airmass_bin, out, "--width", "64", "--basis", "rgb", "--samples", "4", "--hemisphere", "upper")
    _, px = read_exr(out)
    h = px.shape[0]
    assert h == 32
    assert np.all(px[h // 2:] == 0.0)
    assert np.all(px[:h // 2].max(axis=(1, 2)) > 0.0)


def test_unwritable_destination_is_a_clear_error_and_no_file(airmass_bin, tmp_path):
    proc = run_sky(airmass_bin, tmp_path / "missing" / "sky.exr", "--width", "16", check=False)
    assert proc.returncode != 0
    assert "does not exist" in proc.stderr, proc.stderr
    assert not (tmp_path / "missing").exists()
    proc = run_sky(airmass_bin, "/proc/airmass-sky-test.exr", "--width", "16", "--basis", "rgb", check=False)
    assert proc.returncode != 0
    assert "/proc/airmass-sky-test.exr" in proc.stderr, proc.stderr
    assert not os.path.exists("/proc/airmass-sky-test.exr")


def test_bad_options_name_the_option(airmass_bin, tmp_path):
    for args, text in [(["--sun-elevation", "95"], "--sun-elevation"), (["--width", "0"], "width"),
                       (["--samples", "0"], "samples"), (["--chapman", "nope"], "--chapman"),
                       (["--wavelengths", "300:400:10"], "--wavelengths"), (["--basis", "rgb", "--wavelengths", "21"], "--wavelengths"),
                       (["--ms-orders", "1"], "--ms-orders"), (["--ms-samples", "0"], "--ms-samples"),
                       (["--ms-mode", "lut"], "--ms-mode")]:
        proc = run_sky(airmass_bin, tmp_path / "sky.exr", *args, check=False)
        assert proc.returncode != 0, args
        assert text in proc.stderr, (args, proc.stderr)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_leaves_no_file(airmass_bin, tmp_path):
    out = tmp_path / "sky.exr"
    # Large and spectral so that it is still running when the signal arrives.
    cmd = [str(airmass_bin), "sky", "--preset", "earth", "-o", str(out), "--width", "2048",
           "--wavelengths", "360:830:5", "--samples", "256", "--threads", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Interrupt once it is rendering: when its SIGINT handler is installed (SigCgt bit 2 in
    # /proc/PID/status; before that, start-up — loading OpenImageIO — can take seconds).
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        with open(f"/proc/{proc.pid}/status") as f:
            caught = int(f.read().split("SigCgt:")[1].split()[0], 16)
        if caught & (1 << (signal.SIGINT - 1)):
            break
        time.sleep(0.02)
    time.sleep(0.2)
    assert proc.poll() is None, "render finished before it could be interrupted"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0
    assert "cancel" in err, (proc.returncode, err)
    assert list(tmp_path.iterdir()) == []


# Blender renders its own Nishita sky with this script (shared with bench/nishita_error.py).
BLENDER_PANO = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "blender_nishita_pano.py")


@pytest.mark.skipif(shutil.which("blender") is None, reason="blender not installed")
@pytest.mark.parametrize("elevation,rotation", [(15.0, 0.0), (40.0, 90.0)])
def test_matches_blenders_own_nishita_sky(airmass_bin, tmp_path, elevation, rotation):
    """Blender 3.4 renders its Nishita Sky Texture through an equirectangular camera (one ray
    per pixel centre); `airmass sky --preset blender-nishita` with the same sun must agree in
    orientation (same brightest column) and in units (the exposure does not change when one
    replaces the other): median ratio within 3 % above 10° elevation, where Blender's
    32-step, 512×128-texture approximation is itself converged."""
    w, h = 256, 128
    script = BLENDER_PANO
    blender_exr = tmp_path / "blender.exr"
    proc = subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1", "--python", str(script),
                           "--", str(blender_exr), str(w), str(h), str(elevation), str(rotation)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and blender_exr.exists(), proc.stdout[-2000:] + proc.stderr[-2000:]
    ours_exr = tmp_path / "airmass.exr"
    proc = subprocess.run([str(airmass_bin), "sky", "--preset", "blender-nishita", "-o", str(ours_exr), "--quiet",
                           "--width", str(w), "--height", str(h), "--sun-elevation", str(elevation),
                           "--sun-rotation", str(rotation), "--altitude-km", "0.001", "--no-sun-disc",
                           "--no-multiple"],  # Blender 3.4's Nishita sky is single scattering
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    _, theirs = read_exr(blender_exr)
    _, ours = read_exr(ours_exr)
    theirs = theirs[..., :3]
    upper = h // 2 - 1  # rows above the horizon (Blender fades its sky out below)
    col_theirs = np.argmax(luminance(theirs[:upper]).max(axis=0))
    col_ours = np.argmax(luminance(ours[:upper]).max(axis=0))
    assert abs((int(col_theirs) - int(col_ours) + w // 2) % w - w // 2) <= 1, (col_theirs, col_ours)
    rows = int(h * (90 - 10) / 180)  # elevation above 10°
    ratio = ours[:rows] / np.maximum(theirs[:rows], 1e-6)
    median = np.median(ratio.reshape(-1, 3), axis=0)
    assert np.all(np.abs(median - 1.0) < 0.03), median


def test_report_sky_quick_and_its_plot(airmass_bin, tmp_path):
    """`airmass report sky --quick` writes its tables (the multiple-scattering view's too);
    scripts/plot_sky_trade.py draws the plot."""
    out = tmp_path / "report"
    proc = subprocess.run([str(airmass_bin), "report", "sky", "--quick", "--out", str(out), "--width", "32",
                           "--reference-samples", "16"], capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for name in ("sky_trade.csv", "sky_trade_conditions.csv", "sky_reference.csv", "sky_trade.md"):
        assert (out / name).stat().st_size > 0, name
    import csv
    with open(out / "sky_trade.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= 10
    for r in rows:
        assert float(r["ms_per_mpix"]) > 0
        assert 0 <= float(r["p95_above"]) < 1.0, r
    assert "Default settings" in (out / "sky_trade.md").read_text()
    # The multiple-scattering view's knobs against the tables along every pixel's ray: the
    # default view (--ms-grid 32, --ms-samples 32) within the sky budget (p95 ≤ 0.3 %;
    # measured 5e-4), every ray at 32 intervals within 0.1 % (measured 3.5e-4), and each row
    # timed.
    with open(out / "sky_ms_view.csv", newline="") as f:
        view = list(csv.DictReader(f))
    assert len(view) == 5, view
    by_knobs = {(int(r["ms_grid"]), int(r["ms_samples"]), int(r["grid"])): r for r in view}
    assert float(by_knobs[(32, 32, 0)]["p95_above"]) <= 3e-3, by_knobs[(32, 32, 0)]
    assert float(by_knobs[(32, 32, -1)]["p95_above"]) <= 3e-3, by_knobs[(32, 32, -1)]
    assert float(by_knobs[(0, 32, 0)]["p95_above"]) <= 1e-3, by_knobs[(0, 32, 0)]
    for r in view:
        assert float(r["ms_per_image"]) > 0 and float(r["max_above"]) < 0.05, r
    assert "intervals at sun" in (out / "sky_ms_view.md").read_text()
    script = os.path.join(os.path.dirname(__file__), "..", "..", "scripts", "plot_sky_trade.py")
    proc = subprocess.run(["/usr/bin/python3", script, str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (out / "sky_trade.png").stat().st_size > 10000
