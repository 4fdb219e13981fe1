"""The add-on's VDB path against `airmass vdb`.

The Blender add-on writes its .vdb files itself: libairmass_c (no OpenVDB in it) plans the
volume and returns dense blocks, the add-on's vdb_host copies them into grids of Blender's own
OpenVDB Python module (Debian's pyopenvdb in Blender 3.4) and writes them. Here Blender 3.4
runs that path (tests/python/vdb_host_blender.py) for a box, a camera view and a tiled shell,
and every file must equal the one `airmass vdb` writes for the same scene and options: the
same file names, grid names, classes, transforms, file and grid metadata (keys, types,
values), active voxels and values (to float round-off: the library and the CLI are separate
builds of the same code). Also: the C ABI's refusals name the field and its range.
"""
import ctypes
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

vdb = pytest.importorskip("pyopenvdb")

REPO = pathlib.Path(__file__).resolve().parents[2]
GUARD = np.finfo(np.float32).tiny  # airmass/volume.hpp kVolumeGuardValue
BOX = (-10.0, -10.0, -1.0, 10.0, 10.0, 62.0)
# The earth preset with a camera 2 m up looking +X, 2° up, 60° over 320×180, 100 km.
VIEW_TOML = """preset = "earth"
[camera]
position_km = [0.0, 0.0, 0.002]
direction = [1.0, 0.0, 0.035]
up = [0.0, 0.0, 1.0]
fov_deg = 60.0
width = 320
height = 180
max_distance_km = 100.0
"""

CASES = {
    "box": {"cli": ["--preset", "earth", "--region", "box", "--box", ",".join("%g" % x for x in BOX),
                    "--voxel-size", "2"],
            "host": {"preset": "earth", "options": {"region": "box", "box": list(BOX), "voxel_size": 2.0}}},
    "view": {"cli": ["{scene}", "--region", "view", "--voxel-size", "1.5"],
             "host": {"toml": VIEW_TOML, "source_name": "{scene}", "options": {"region": "view", "voxel_size": 1.5}}},
    "tiled": {"cli": ["--preset", "earth", "--region", "planet", "--voxel-size", "50", "--tile-voxels", "64"],
              "host": {"preset": "earth", "options": {"region": "planet", "voxel_size": 50.0, "tile_voxels": 64}}},
}


def _native(lib):
    """The add-on's ctypes binding (pure Python) on the build's library."""
    sys.path.insert(0, str(REPO / "addon" / "airmass_blender"))
    sys.dont_write_bytecode = True
    try:
        import native  # noqa: E402
    finally:
        sys.path.pop(0)
    os.environ[native.LIBRARY_ENV] = str(lib)
    native.reset()
    return native


@pytest.fixture(scope="module")
def library(airmass_build):
    lib = airmass_build / "lib" / "libairmass_c.so"
    if not lib.is_file():
        pytest.fail(f"{lib} not built (target airmass_c)")
    return lib


@pytest.fixture(scope="module")
def written(airmass_bin, library, tmp_path_factory):
    blender = shutil.which("blender")
    if blender is None:
        pytest.skip("blender not installed")
    d = tmp_path_factory.mktemp("vdb_host")
    scene = d / "view.toml"
    scene.write_text(VIEW_TOML)
    host_cases = {}
    for name, case in CASES.items():
        out = d / "cli" / name
        out.mkdir(parents=True)
        args = [a.replace("{scene}", str(scene)) for a in case["cli"]]
        p = subprocess.run([str(airmass_bin), "vdb", *args, "-o", str(out / "atmosphere.vdb"), "-q"],
                           capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, p.stderr
        h = dict(case["host"], stem="atmosphere")
        if "source_name" in h:
            h["source_name"] = h["source_name"].replace("{scene}", str(scene))
        host_cases[name] = h
    (d / "cases.json").write_text(json.dumps(host_cases))
    (d / "host").mkdir()
    p = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1",
                        "--python", str(REPO / "tests" / "python" / "vdb_host_blender.py"), "--",
                        "--addon", str(REPO / "addon"), "--lib", str(library), "--cases", str(d / "cases.json"),
                        "--out", str(d / "host")],
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    report = json.loads((d / "host" / "report.json").read_text())
    return d, report


def active_set(grid):
    out = set()
    for item in grid.citerOnValues():
        lo, hi = item.min, item.max
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                for k in range(lo[2], hi[2] + 1):
                    out.add((i, j, k))
    return out


def dense(grid, lo, hi):
    a = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), dtype=np.float32)
    grid.copyToArray(a, ijk=lo)
    return a


def same_metadata(a, b, what):
    assert set(a) == set(b), f"{what}: keys {sorted(set(a) ^ set(b))}"
    for k in a:
        assert type(a[k]) is type(b[k]), f"{what} {k}: {type(a[k]).__name__} vs {type(b[k]).__name__}"
        if isinstance(a[k], tuple):  # Vec3i (airmass:index_offset) vs Vec3d metadata
            assert [type(x) for x in a[k]] == [type(x) for x in b[k]], f"{what} {k}: {a[k]!r} vs {b[k]!r}"
        assert a[k] == b[k], f"{what} {k}: {a[k]!r} vs {b[k]!r}"


def test_blender_used_its_own_openvdb_module(written):
    _, report = written
    assert report["module"] == ("openvdb" if tuple(report["blender"]) >= (4, 4, 0) else "pyopenvdb"), report
    for name, r in report["cases"].items():
        f = r["fractions"]
        assert f and f[-1] == 1.0 and f == sorted(f), (name, f)


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_add_on_path_writes_the_files_airmass_vdb_writes(written, name):
    d, report = written
    cli, host = d / "cli" / name, d / "host" / name
    files = sorted(os.listdir(cli))
    assert sorted(os.listdir(host)) == files  # the same names, and no temporary left
    assert sorted(report["cases"][name]["files"]) == files
    if name == "tiled":
        assert len(files) > 5 and "atmosphere.tiles.json" in files
        assert json.loads((host / "atmosphere.tiles.json").read_text()) == \
            json.loads((cli / "atmosphere.tiles.json").read_text())
    total_active = 0
    for f in files:
        if not f.endswith(".vdb"):
            continue
        grids_c, meta_c = vdb.readAll(str(cli / f))
        grids_h, meta_h = vdb.readAll(str(host / f))
        same_metadata(meta_c, meta_h, f"{f} file metadata")
        gc = {g.name: g for g in grids_c}
        gh = {g.name: g for g in grids_h}
        assert sorted(gc) == sorted(gh) and len(gc) == len(grids_c) and gc, f"{f}: grids {sorted(gc)} vs {sorted(gh)}"
        for gname in gc:
            a, b = gc[gname], gh[gname]
            what = f"{f}:{gname}"
            assert a.gridClass == b.gridClass == vdb.GridClass.FOG_VOLUME, what
            assert a.saveFloatAsHalf == b.saveFloatAsHalf is False, what
            assert a.transform.voxelSize() == b.transform.voxelSize(), what
            for ijk in ((0, 0, 0), (1, -2, 3), (-7, 11, 5)):
                assert a.transform.indexToWorld(ijk) == b.transform.indexToWorld(ijk), (what, ijk)
            same_metadata(dict(a.metadata), dict(b.metadata), what)
            assert a.activeVoxelCount() == b.activeVoxelCount() > 0, what
            assert a.evalActiveVoxelBoundingBox() == b.evalActiveVoxelBoundingBox(), what
            assert active_set(a) == active_set(b), what
            lo, hi = a.evalActiveVoxelBoundingBox()
            va, vb = dense(a, lo, hi), dense(b, lo, hi)
            np.testing.assert_allclose(vb, va, rtol=2.5e-7, atol=0, err_msg=what)
            # Tiles hold guard voxels (the smallest normal float) beyond the plan's values.
            guards = int((va == np.float32(GUARD)).sum())
            assert (guards > 0) == (name == "tiled"), (what, guards)
            total_active += a.activeVoxelCount() - guards
    assert total_active == report["cases"][name]["plan_active_voxels"]


# ---- the C ABI's refusals (no Blender needed) ----------------------------------------------------

def _expect(call, status, *needles):
    from_native = None
    try:
        call()
    except Exception as e:  # noqa: BLE001
        from_native = e
    assert from_native is not None, f"no error (expected {needles})"
    assert getattr(from_native, "status", None) == status, (from_native, getattr(from_native, "status", None))
    for n in needles:
        assert n in str(from_native), (str(from_native), n)


def test_c_abi_refuses_bad_block_requests_naming_the_field(library):
    native = _native(library)
    spec = native.Spec(preset="earth")
    opts = {"region": "box", "box": BOX, "voxel_size": 2.0}
    plan = native.vdb_plan(spec, file_stem="a", **opts)
    rb = plan["request_bounds"]
    g = plan["grids"][0]
    lo, hi = g["bbox_min"], g["bbox_max"]
    ok = native.vdb_grid_values(spec, g["name"], lo, hi, **opts)
    assert ok.shape == tuple(g["dim"]) and int((ok != 0).sum()) == g["active_voxels"]
    bad = native.INVALID_ARGUMENT
    _expect(lambda: native.vdb_grid_values(spec, "dust", lo, hi, **opts), bad, 'block.grid = "dust"', '"rayleigh"')
    _expect(lambda: native.vdb_grid_values(spec, g["name"], (rb["min"][0] - 1, lo[1], lo[2]), hi, **opts), bad,
            "block.min[0] = %d" % (rb["min"][0] - 1), "must be in [%d, %d]" % (rb["min"][0], rb["max"][0]))
    _expect(lambda: native.vdb_grid_values(spec, g["name"], lo, (hi[0], hi[1], rb["max"][2] + 5), **opts), bad,
            "block.max[2] = %d" % (rb["max"][2] + 5), "request_bounds")
    _expect(lambda: native.vdb_grid_values(spec, g["name"], (0, 3, 0), (0, 2, 0), **opts), bad,
            "block.min[1] = 3 > block.max[1] = 2")
    _expect(lambda: native.vdb_grid_values(spec, g["name"], lo, hi, threads=-2, **opts), bad, "block.threads = -2")
    # Raw calls a careless host could make: a wrong float_count, a NULL block, an unknown struct size.
    lib = native.library()
    c_spec, keep = spec._to_c(lib)
    c_opts, keep2 = native._vdb_options(lib, **opts)
    block = native.VdbBlock()
    native._init_struct(lib.airmass_vdb_block_init, block, "airmass_vdb_block")
    assert block.struct_size == ctypes.sizeof(native.VdbBlock) and block.max[0] == -1
    name = g["name"].encode()
    block.grid = name
    for a in range(3):
        block.min[a], block.max[a] = lo[a], hi[a]
    n = math.prod(g["dim"])
    values = (ctypes.c_float * (n + 1))()
    msg = ctypes.create_string_buffer(512)
    st = lib.airmass_vdb_grid_values(ctypes.byref(c_spec), ctypes.byref(c_opts), ctypes.byref(block), values, n + 1,
                                     None, msg, 512)
    assert st == bad and b"float_count = %d: must be nx x ny x nz" % (n + 1) in msg.value, msg.value
    assert b"= %d" % n in msg.value, msg.value
    st = lib.airmass_vdb_grid_values(ctypes.byref(c_spec), ctypes.byref(c_opts), None, values, n, None, msg, 512)
    assert st == bad and b"block: NULL" in msg.value, msg.value
    block.struct_size = 8
    st = lib.airmass_vdb_grid_values(ctypes.byref(c_spec), ctypes.byref(c_opts), ctypes.byref(block), values, n,
                                     None, msg, 512)
    assert st == bad and b"block.struct_size = 8" in msg.value, msg.value
    block.struct_size = ctypes.sizeof(native.VdbBlock)
    st = lib.airmass_vdb_grid_values(ctypes.byref(c_spec), ctypes.byref(c_opts), ctypes.byref(block), values, n,
                                     None, msg, 512)
    assert st == native.OK, msg.value
    assert np.array_equal(np.ctypeslib.as_array(values)[:n].reshape(ok.shape), ok)
    del keep, keep2
    # The plan refuses what `airmass vdb` refuses, with the option's name.
    _expect(lambda: native.vdb_plan(spec, file_stem="a", max_dense_mb=0.01, **opts), native.SETTINGS_ERROR,
            "--max-dense-mb")
    _expect(lambda: native.vdb_plan(spec, file_stem="a/b", **opts), bad, 'file_stem = "a/b"')
    # Cancelled through the job: the plan and a block.
    for call in (lambda p: native.vdb_plan(spec, progress=p, **opts),
                 lambda p: native.vdb_grid_values(spec, g["name"], lo, hi, progress=p, **opts)):
        p = native.Progress(None)
        p.cancel()
        try:
            _expect(lambda: call(p), native.CANCELLED, "cancel")
        finally:
            p.close()


def test_vdb_session_serves_the_plan_and_every_block(library):
    """native.VdbSession (C ABI 8): the plan and the blocks of one layout from one session give the
    stateless calls' values, the planet's voxel means computed once (a planet at 200-km voxels: a
    few seconds' worth of means otherwise asked per block); a closed session is refused by name."""
    native = _native(library)
    spec = native.Spec(preset="earth")
    opts = {"region": "planet", "voxel_size": 200.0, "voxel_values": "average"}
    with native.VdbSession(spec, **opts) as session:
        plan = session.plan("p")
        assert {g["name"] for g in plan["grids"]} == {"rayleigh", "mie", "ozone"}
        for g in plan["grids"]:
            assert g["metadata"]["airmass:voxel_values"] == "average"
            lo, hi = g["bbox_min"], g["bbox_max"]
            got = session.grid_values(g["name"], lo, hi)
            assert int((got != 0).sum()) == g["active_voxels"] > 0
            assert np.array_equal(got, native.vdb_grid_values(spec, g["name"], lo, hi, **opts)), g["name"]
    _expect(lambda: session.plan("p"), native.INVALID_ARGUMENT, "vdb session: closed")
    _expect(lambda: native.VdbSession(spec, voxel_values="mean"), native.INVALID_ARGUMENT, "--voxel-values",
            "auto, average or point")
