"""`airmass vdb` read back with Debian's pyopenvdb (what Blender 3.4's Python sees).

Values at voxel centres are compared with the analytic profiles re-implemented here from
the grid's own metadata (airmass:profile), so a reader needs nothing but the file.
Small boxes and coarse voxels keep this fast.
"""
import json
import math
import shutil
import subprocess

import numpy as np
import pytest

vdb = pytest.importorskip("pyopenvdb")

BOX = "-10,-10,-1,10,10,62"  # km, through the whole atmosphere above the origin


def run(airmass_bin, *args, check=True):
    p = subprocess.run([str(airmass_bin), *map(str, args)], capture_output=True, text=True, timeout=300)
    if check and p.returncode != 0:
        raise AssertionError(f"airmass {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stderr}")
    return p


def profile_density(profile, h):
    """The relative density of an `airmass:profile` JSON at altitude h (same unit)."""
    t = profile["type"]
    h = np.asarray(h, dtype=float)
    if t == "exponential":
        return np.exp(-(h - profile["reference_altitude"]) / profile["scale_height"])
    if t == "tent":
        b, p, top = profile["bottom"], profile["peak"], profile["top"]
        up = (h - b) / (p - b)
        down = (top - h) / (top - p)
        return np.where((h <= b) | (h >= top), 0.0, np.where(h <= p, up, down))
    if t == "piecewise_linear":
        k = np.array(profile["knots"], dtype=float)
        inside = (h >= k[0, 0]) & (h <= k[-1, 0])
        return np.where(inside, np.maximum(0.0, np.interp(h, k[:, 0], k[:, 1])), 0.0)
    if t == "constant":
        top = profile["top"] if profile["top"] is not None else np.inf
        return np.where((h >= profile["bottom"]) & (h <= top), profile["value"], 0.0)
    raise AssertionError(f"unknown profile type {t}")


def active_voxels(grid):
    ijk, values = [], []
    for item in grid.citerOnValues():
        assert item.count == 1, "grids are built from leaves: no active tiles"
        ijk.append(item.min)
        values.append(item.value)
    return np.array(ijk, dtype=float), np.array(values, dtype=float)


REQUIRED_KEYS = {
    "airmass:length_unit": str,
    "airmass:planet_radius": float,
    "airmass:planet_center": tuple,
    "airmass:atmosphere_top": float,
    "airmass:profile": str,
    "airmass:scattering_rgb": tuple,
    "airmass:absorption_rgb": tuple,
    "airmass:phase": str,
    "airmass:g": float,
    "airmass:spectral_basis": str,
    "airmass:version": str,
    "airmass:voxel_size": float,
    "airmass:rgb_wavelengths_nm": tuple,
}


@pytest.fixture(scope="module")
def exported(airmass_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("vdb")
    out = d / "atmosphere.vdb"
    # point values: each voxel the density at its centre (the default `auto` averages Mie at 2 km:
    # tests/test_vdb.cpp and test_voxel_average.cpp check those means)
    run(airmass_bin, "vdb", "--preset", "earth", "--region", "box", "--box", BOX, "--voxel-size", "2",
        "--voxel-values", "point", "-o", out, "--analytic", d / "atmosphere.json", "--pov", d / "atmosphere.inc", "-q")
    grids, file_meta = vdb.readAll(str(out))
    return d, {g.name: g for g in grids}, file_meta


def test_grids_are_fog_volumes_named_after_the_constituents(exported):
    _, grids, _ = exported
    assert set(grids) == {"rayleigh", "mie", "ozone"}
    for g in grids.values():
        assert g.gridClass == vdb.GridClass.FOG_VOLUME
        assert g.activeVoxelCount() > 0


def test_values_at_voxel_centres_equal_the_analytic_density(exported):
    _, grids, _ = exported
    for name, g in grids.items():
        meta = g.metadata
        profile = json.loads(meta["airmass:profile"])
        center = np.array(meta["airmass:planet_center"])
        ijk, values = active_voxels(g)
        world = np.array([g.transform.indexToWorld(tuple(map(int, c))) for c in ijk])
        h = np.linalg.norm(world - center, axis=1) - meta["airmass:planet_radius"]
        expected = profile_density(profile, h)
        # float32 storage: half an ulp of the value, plus the rounding of the altitude
        np.testing.assert_allclose(values, expected, rtol=3e-7, atol=0, err_msg=name)
        assert np.all(h <= meta["airmass:atmosphere_top"] - meta["airmass:planet_radius"] + 1e-9)


def test_metadata_is_complete(exported):
    _, grids, file_meta = exported
    for name, g in grids.items():
        meta = g.metadata
        for key, typ in REQUIRED_KEYS.items():
            assert key in meta, f"{name}: {key} missing"
            assert isinstance(meta[key], typ), f"{name}: {key} is {type(meta[key]).__name__}"
        assert meta["airmass:length_unit"] == "km"
        assert meta["airmass:planet_radius"] == pytest.approx(6360.0)
        assert meta["airmass:atmosphere_top"] == pytest.approx(6420.0)
        assert len(meta["airmass:scattering_rgb"]) == 3
        assert meta["airmass:voxel_values"] == "point"
    # Rayleigh at 550 nm: 1.24062e-6 m^-1 (lambda / 1 um)^-4, per km
    ray = grids["rayleigh"].metadata
    assert ray["airmass:scattering_rgb"][1] == pytest.approx(1.24062e-6 * 0.55**-4 * 1000, rel=1e-12)
    assert ray["airmass:phase"] == "rayleigh"
    assert grids["mie"].metadata["airmass:g"] == pytest.approx(0.8)
    assert "airmass:scene" in file_meta and json.loads(file_meta["airmass:scene"])


def test_transform_places_the_planet_centre_where_the_scene_says(exported):
    _, grids, _ = exported
    g = grids["rayleigh"]
    assert g.metadata["airmass:planet_center"] == pytest.approx((0.0, 0.0, -6360.0))
    assert g.transform.voxelSize() == pytest.approx((2.0, 2.0, 2.0))
    assert g.transform.indexToWorld((0, 0, 0)) == pytest.approx((0.0, 0.0, 0.0))
    acc = g.getConstAccessor()
    assert acc.getValue((0, 0, 0)) == pytest.approx(1.0, rel=1e-7)            # on the surface
    assert acc.getValue((0, 0, 4)) == pytest.approx(math.exp(-1.0), rel=1e-7)  # 8 km = one scale height


def test_center_origin_moves_the_frame(airmass_bin, tmp_path):
    out = tmp_path / "c.vdb"
    run(airmass_bin, "vdb", "--preset", "earth", "--region", "box", "--origin", "center", "--box",
        "-4,-4,6358,4,4,6370", "--voxel-size", "2", "-o", out, "-q")
    g = {g.name: g for g in vdb.readAll(str(out))[0]}["rayleigh"]
    assert g.metadata["airmass:planet_center"] == pytest.approx((0.0, 0.0, 0.0))
    assert g.getConstAccessor().getValue((0, 0, 3180)) == pytest.approx(1.0, rel=1e-7)  # z = 6360 km


def test_analytic_json_matches_the_grid_metadata(exported):
    d, grids, _ = exported
    desc = json.loads((d / "atmosphere.json").read_text())
    assert desc["length_unit"] == "km"
    for c in desc["constituents"]:
        meta = grids[c["name"]].metadata
        assert c["profile"] == json.loads(meta["airmass:profile"])
        assert tuple(c["scattering_rgb"]) == pytest.approx(meta["airmass:scattering_rgb"])
        assert tuple(c["absorption_rgb"]) == pytest.approx(meta["airmass:absorption_rgb"])


@pytest.mark.skipif(shutil.which("povray") is None, reason="povray not installed")
def test_pov_include_renders_a_blue_sky(exported, tmp_path):
    """The include parses in POV-Ray 3.7 and its media scatter blue more than red."""
    d, _, _ = exported
    scene = tmp_path / "sky.pov"
    scene.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1 }}
#include "{d / 'atmosphere.inc'}"
camera {{ location <0, 0.01, 0> look_at <1, 0.35, 0> angle 20 }}
light_source {{ <0, 1e5, 1e5> rgb 1 parallel point_at <0, 0, 0> }}
object {{ Airmass_Container }}
""")
    out = tmp_path / "sky.png"
    p = subprocess.run(["povray", f"+I{scene}", f"+O{out}", "+W8", "+H8", "-D", "-V", "+FN", "-GA"],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    oiio = pytest.importorskip("OpenImageIO")
    px = oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)
    mean = px.reshape(-1, px.shape[-1])[:, :3].mean(axis=0)
    assert mean[2] > mean[0] > 0, f"mean RGB {mean}"


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--region", "box", "--box", BOX, "--voxel-size", "0"], "--voxel-size"),
        (["--region", "box", "--box", BOX, "--voxel-size", "-2"], "--voxel-size"),
        (["--region", "box", "--box", "0,0,100,10,10,110", "--voxel-size", "2"], "region outside the atmosphere"),
        (["--region", "view", "--voxel-size", "4"], "[camera]"),
    ],
)
def test_bad_input_is_a_clear_error_and_leaves_no_file(airmass_bin, tmp_path, args, fragment):
    out = tmp_path / "x.vdb"
    p = run(airmass_bin, "vdb", "--preset", "earth", *args, "-o", out, check=False)
    assert p.returncode == 2
    assert fragment in p.stderr
    assert list(tmp_path.iterdir()) == []


def test_camera_inside_the_planet_is_refused(airmass_bin, tmp_path):
    earth = run(airmass_bin, "vdb", "--preset", "earth", "--dry-run", "--region", "box", "--box", BOX,
                "--voxel-size", "4", "--json").stdout
    assert json.loads(earth)["active_voxels"] > 0
    scene = tmp_path / "s.toml"
    # The earth preset with a camera 10 m below the ground (docs/scene.md, "Inheriting a preset").
    scene.write_text('preset = "earth"\n[camera]\nposition_km = [0.0, 0.0, -0.01]\n')
    out = tmp_path / "x.vdb"
    p = run(airmass_bin, "vdb", scene, "--region", "view", "--voxel-size", "4", "-o", out, check=False)
    assert p.returncode == 2
    assert "camera inside the planet" in p.stderr, p.stderr
    assert not out.exists()


def test_unwritable_output_is_refused_before_building(airmass_bin, tmp_path):
    p = run(airmass_bin, "vdb", "--preset", "earth", "--region", "box", "--box", BOX, "--voxel-size", "2",
            "-o", tmp_path / "missing" / "x.vdb", check=False)
    assert p.returncode == 2
    assert "does not exist" in p.stderr
    assert list(tmp_path.iterdir()) == []
