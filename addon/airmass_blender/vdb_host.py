"""The atmosphere's OpenVDB grids, written through the running Blender's own OpenVDB module.

The native library carries no OpenVDB (it must load in any Blender): it plans the volume and
returns each grid's densities as dense float blocks (native.VdbSession: its plan, then each
block's values; airmass_c.h "Volumes", "VDB sessions"). This module turns them into grids and
files with the OpenVDB Python module the running Blender has:

    Blender ≥ 4.4 (OpenVDB 12, nanobind)  `openvdb`
    Blender 3.x – 4.3, Debian's 3.4       `pyopenvdb`

— the same calls in both (FloatGrid, copyFromArray(array, ijk, tolerance), the transform,
gridClass, metadata items, write(filename, grids, metadata)). The values are copied block by
block (slabs of whole 8-voxel leaves along i) with tolerance 0: a voxel is active exactly when
the library's value is nonzero, as in the grids `airmass vdb` writes, so both give the same
grids, transforms and metadata. Tiled volumes also get the library's guard voxels (the plan's
guard_value, the smallest normal float, at the other tiles' values next to a tile's; see
with_guards and docs/vdb.md "Tiling"), computed here with numpy from the same blocks.

Files are written atomically: each to a hidden temporary in the destination folder, all moved
into place (os.replace) only after the last was written; a failure or a cancel removes the
temporaries, so nothing half-made is left. Pure Python (numpy + the OpenVDB module, no bpy):
it runs on the operator's worker thread.
"""

import errno
import importlib
import itertools
import os

from . import native

MODULE_NAMES = ("openvdb", "pyopenvdb")
NO_MODULE_MESSAGE = ("this Blender has no OpenVDB Python module (neither 'openvdb' nor 'pyopenvdb' imports); "
                     "use the Analytic volume instead")

# Share of the progress bar taken by the plan (the library's sampling pass); the blocks take the rest.
# Measured in Blender 3.4 (the earth preset, voxel size automatic, 2 cores, 2026-12-07): the plan
# ends at 28 % of the time of a Camera View export (0.25 of 0.90 s, 8.5 M voxels) and at 21 % of a
# Whole Planet one (1.56 of 7.28 s, 16.2 M voxels); the blocks' progress is then close to linear.
PLAN_SHARE = 0.25
# Largest dense block requested at once (floats): 16 MiB.
BLOCK_FLOATS = 4 << 20

_counter = itertools.count()


def openvdb_module():
    """The OpenVDB Python module of this Blender, or None."""
    for name in MODULE_NAMES:
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        grid = getattr(module, "FloatGrid", None)
        if grid is not None and hasattr(grid, "copyFromArray") and hasattr(module, "write") \
                and hasattr(module, "createLinearTransform"):
            return module
    return None


def unavailable_reason():
    """None when VDB volumes can be written here, else the message for the user."""
    return None if openvdb_module() is not None else NO_MODULE_MESSAGE


class NoOpenVdbModule(RuntimeError):
    pass


def require_module():
    module = openvdb_module()
    if module is None:
        raise NoOpenVdbModule(NO_MODULE_MESSAGE)
    return module


def temporary_path(dest):
    """A hidden temporary beside `dest` (same folder, so os.replace is atomic)."""
    folder, name = os.path.split(dest)
    stem, ext = os.path.splitext(name)
    return os.path.join(folder, ".%s.airmass-tmp-%d-%d%s" % (stem, os.getpid(), next(_counter), ext))


def slabs(bbox_min, bbox_max, max_floats=BLOCK_FLOATS, offset=0):
    """Index boxes splitting [bbox_min, bbox_max] along i at multiples of 8 plus `offset` (the
    grid's index offset along i: its OpenVDB leaves stay whole), each of at most max_floats voxels
    unless a single 8-voxel layer is larger."""
    ny = bbox_max[1] - bbox_min[1] + 1
    nz = bbox_max[2] - bbox_min[2] + 1
    layers = max(1, max_floats // max(1, ny * nz * 8))  # 8-voxel layers per slab
    out = []
    i = bbox_min[0]
    while i <= bbox_max[0]:
        end = min(bbox_max[0], ((i - offset) // 8 + layers) * 8 - 1 + offset)
        out.append(((i, bbox_min[1], bbox_min[2]), (end, bbox_max[1], bbox_max[2])))
        i = end + 1
    return out


def meta_value(value, kind):
    """A plan metadata value as the Python type OpenVDB's module stores with that type."""
    if kind == "string":
        return str(value)
    if kind == "double":
        return float(value)
    if kind == "int32":
        return int(value)
    if kind == "vec3d":
        return tuple(float(x) for x in value)
    if kind == "vec3i":
        return tuple(int(x) for x in value)
    raise ValueError("unknown metadata type %r" % kind)


def metadata_of(entry):
    types = entry["metadata_types"]
    return {k: meta_value(v, types[k]) for k, v in entry["metadata"].items()}


def make_transform(vdb, transform):
    """OpenVDB's linear transform of the plan (voxel size, translation)."""
    v = transform["voxel_size"]
    t = transform.get("translation", (0.0, 0.0, 0.0))
    if v[0] == v[1] == v[2] and not any(t):
        return vdb.createLinearTransform(float(v[0]))
    return vdb.createLinearTransform([[float(x) for x in row] for row in transform["matrix"]])


class _Reporter:
    """Overall progress of a several-call task on one native.Progress (its fraction, its callback,
    its cancel token)."""

    def __init__(self, progress):
        self.progress = progress

    def at(self, fraction):
        p = self.progress
        if p is None:
            return
        p.fraction = fraction
        if p.callback is not None:
            try:
                stop = p.callback(fraction)
            except Exception:  # noqa: BLE001 — a failing callback stops the work
                stop = True
            if stop:
                p.cancel()
        self.check()

    def check(self):
        if self.progress is not None and self.progress.cancel_requested:
            raise native.NativeError(native.CANCELLED, "VDB volume cancelled")


class Written:
    """What write_volume made: the plan, the files (vdb files then the manifest), the module
    used, and the previous files it replaced (kept as hidden hard links until the caller
    keeps the new ones — keep() — or puts the previous ones back — restore())."""

    def __init__(self, plan, files, vdb_files, module_name, previous=()):
        self.plan = plan
        self.files = files
        self.vdb_files = vdb_files
        self.module_name = module_name
        self.previous = dict(previous)  # destination -> its previous file's hidden link

    def keep(self):
        """The new files stay: the previous ones' links go."""
        for link in self.previous.values():
            _remove_quietly(link)
        self.previous = {}

    def restore(self):
        """A later step failed: each destination gets its previous file back (or none)."""
        for dest in self.files:
            link = self.previous.get(dest)
            try:
                if link is not None:
                    os.replace(link, dest)
                else:
                    os.remove(dest)
            except OSError:
                pass
        self.previous = {}


def _remove_quietly(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _keep_previous(dest):
    """A hidden hard link to `dest`'s current file (None if there is none), so that replacing
    `dest` can be undone; a copy where the filesystem has no hard links."""
    if not os.path.isfile(dest):
        return None
    link = temporary_path(dest)
    try:
        os.link(dest, link)
    except OSError:
        import shutil
        shutil.copy2(dest, link)
    return link


def tile_cube(plan, grid):
    """The index box (min, max) of the lattice cube holding `grid`'s tile, or None for one tile."""
    tiling = plan.get("tiling") or {}
    t = int(tiling.get("tile_voxels", 0))
    if t <= 0:
        return None
    base = tiling["base"]
    lo = [b + ((m - b) // t) * t for m, b in zip(grid["bbox_min"], base)]
    return lo, [x + t - 1 for x in lo]


def with_guards(values, origin, cube, guard_value):
    """The tile's array from the whole grid's `values` (a box at index `origin`): its values inside
    the tile's `cube`, `guard_value` at the other tiles' nonzero voxels within one voxel (26
    neighbours) of a nonzero value inside, 0 elsewhere (airmass/volume.hpp, kVolumeGuardValue)."""
    import numpy as np
    shape = values.shape
    inside = np.zeros(shape, dtype=bool)
    sl = tuple(slice(max(0, c0 - o), max(0, min(n, c1 - o + 1))) for c0, c1, o, n in zip(cube[0], cube[1], origin, shape))
    inside[sl] = True
    nonzero = values != 0
    mine = nonzero & inside
    near = np.zeros((shape[0] + 2, shape[1] + 2, shape[2] + 2), dtype=bool)
    for dx in (0, 1, 2):
        for dy in (0, 1, 2):
            for dz in (0, 1, 2):
                near[dx:dx + shape[0], dy:dy + shape[1], dz:dz + shape[2]] |= mine
    near = near[1:-1, 1:-1, 1:-1]
    out = np.where(inside, values, np.float32(0)).astype(np.float32, copy=False)
    guards = near & ~inside & nonzero
    out[guards] = np.float32(guard_value)
    return out, int(np.count_nonzero(guards))


def build_grid(vdb, session, plan, grid, reporter, done, total):
    """One grid of the plan, filled block by block. `done`/`total`: dense voxels for progress.
    Several tiles: the blocks cover the grid's dense box (values and guards); each is fetched with
    one more layer on either side along i (clipped to the box), so that a guard's neighbours in
    the next block are seen."""
    g = vdb.FloatGrid(0.0)
    g.name = grid["name"]
    # The tile's own lattice (docs/vdb.md "Tiling"): the plan's boxes are in the common lattice;
    # this grid's voxel (i, j, k) is common voxel (i, j, k) + index_offset, and its transform (the
    # file's) translates by index_offset voxels. Absent, or (0, 0, 0), for a single tile.
    offset = [int(x) for x in grid.get("index_offset", (0, 0, 0))]
    g.transform = make_transform(vdb, plan["files"][grid["tile"]].get("transform", plan["transform"]))
    g.gridClass = vdb.GridClass.FOG_VOLUME
    if str(g.gridClass) != plan["grid_class"]:
        raise RuntimeError("this OpenVDB names the fog volume class %r, the plan %r" % (g.gridClass, plan["grid_class"]))
    # Full 32-bit floats (thin air needs the mantissa) is OpenVDB's default; setting it would add
    # an "is_saved_as_half_float" metadata item the library's grids do not have.
    cube = tile_cube(plan, grid)
    box_min = grid.get("dense_bbox_min", grid["bbox_min"]) if cube else grid["bbox_min"]
    box_max = grid.get("dense_bbox_max", grid["bbox_max"]) if cube else grid["bbox_max"]
    guards = 0
    for lo, hi in slabs(box_min, box_max, offset=offset[0]):
        n = (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1)
        start = PLAN_SHARE + (1.0 - PLAN_SHARE) * done / total
        end = PLAN_SHARE + (1.0 - PLAN_SHARE) * (done + n) / total
        reporter.check()
        if cube is None:
            values = session.grid_values(grid["name"], lo, hi, progress=reporter.progress,
                                         progress_range=(start, end))
        else:
            flo = (max(box_min[0], lo[0] - 1), lo[1], lo[2])
            fhi = (min(box_max[0], hi[0] + 1), hi[1], hi[2])
            fetched = session.grid_values(grid["name"], flo, fhi, progress=reporter.progress,
                                          progress_range=(start, end))
            tiled, _ = with_guards(fetched, flo, cube, plan["guard_value"])
            values = tiled[lo[0] - flo[0]:hi[0] - flo[0] + 1].copy()
            guards += int((values == tiled.dtype.type(plan["guard_value"])).sum())
            del fetched, tiled
        g.copyFromArray(values, ijk=tuple(int(x) - o for x, o in zip(lo, offset)), tolerance=0.0)
        del values
        done += n
        reporter.at(end)
    for key, value in metadata_of(grid).items():
        g[key] = value
    if g.activeVoxelCount() != grid["active_voxels"] + guards:
        raise RuntimeError("grid '%s' of tile %d has %d active voxels, the plan %d (+ %d guards)" % (
            grid["name"], grid["tile"], g.activeVoxelCount(), grid["active_voxels"], guards))
    return g, done


def _check_not_truncated(path):
    """OpenVDB's write never looks at its stream afterwards: on a full disk it returns after a
    short write, leaving a truncated file. Such a write leaves the filesystem without a free
    block (for this user), so that is refused as ENOSPC — a complete file that filled the disk
    exactly is refused too, which is safe."""
    st = os.statvfs(os.path.dirname(path) or ".")
    if (st.f_bfree if os.geteuid() == 0 else st.f_bavail) == 0:
        raise OSError(errno.ENOSPC, "No space left on device: '%s' may be incomplete" % os.path.basename(path))


def write_volume(spec, folder, stem, progress=None, **options):
    """Plans the volume, fills every grid and writes every file of the plan into `folder`
    atomically. `options`: native._vdb_options keywords (region, unit, voxel_size, box,
    tolerance, max_dense_mb, tile_voxels, voxel_values). Raises NoOpenVdbModule,
    native.NativeError (the library's refusals; status CANCELLED when cancelled), OSError;
    leaves no file then."""
    vdb = require_module()
    reporter = _Reporter(progress)
    # One session for the plan and every block: the voxel means its pass computes serve them all.
    with native.VdbSession(spec, **options) as session:
        return _write_volume(vdb, session, folder, stem, reporter, progress)


def _write_volume(vdb, session, folder, stem, reporter, progress):
    plan = session.plan(stem, progress=progress, progress_range=(0.0, PLAN_SHARE))
    reporter.at(PLAN_SHARE)
    total = max(1, sum(int(g["dense_voxels"]) for g in plan["grids"]))  # the dense boxes (with guards)
    pending = []  # (temporary, destination)
    previous = {}  # destination -> hidden link to the file it replaces
    try:
        done = 0
        for f in plan["files"]:
            grids = []
            for index in f["grids"]:
                g, done = build_grid(vdb, session, plan, plan["grids"][index], reporter, done, total)
                grids.append(g)
            dest = os.path.join(folder, f["name"])
            tmp = temporary_path(dest)
            pending.append((tmp, dest))
            vdb.write(tmp, grids, metadata=metadata_of(f))
            _check_not_truncated(tmp)
            del grids
        manifest = plan.get("manifest")
        if manifest:
            dest = os.path.join(folder, manifest["name"])
            tmp = temporary_path(dest)
            pending.append((tmp, dest))
            with open(tmp, "w", encoding="utf-8") as out:
                out.write(manifest["text"])
        reporter.check()  # the last chance to cancel: nothing is in place yet
        for _tmp, dest in pending:
            link = _keep_previous(dest)
            if link is not None:
                previous[dest] = link
        for tmp, dest in pending:
            os.replace(tmp, dest)
    except BaseException:
        for tmp, _dest in pending:
            _remove_quietly(tmp)
        for link in previous.values():
            _remove_quietly(link)
        raise
    files = [dest for _tmp, dest in pending]
    return Written(plan, files, [f for f in files if f.endswith(".vdb")], vdb.__name__, previous)
