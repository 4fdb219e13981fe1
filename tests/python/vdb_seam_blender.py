"""Run inside Blender (tests/python/test_vdb_seams.py starts it): renders sets of .vdb files
with Cycles, an Emission-only volume (strength = the grid's value, no absorption), so each
pixel is the integral of the density along its ray; an orthographic camera looks down -Z.
One Volume object per file, render clipping 0 (as the add-on sets it). Writes each render's
pixels (the red channel, float) as a .npy file.

    blender -b --factory-startup --python-exit-code 1 --python vdb_seam_blender.py -- \\
        --jobs jobs.json

jobs.json: {"camera": {"center": [x, y, z], "scale": s, "pixels": n}, "grid": name,
            "samples": n, "step": world-space ray-marching step, "names": "v0_{k}" (the Volume
            names, k = the file's index in "files"),
            "renders": [{"files": [...], "seed": k, "out": "x.npy", "names": [...] (optional: these
            names instead)}, ...]}
Each render also writes <out>.names.json: the names and Cycles' face offsets (below) per file.
"""
import argparse
import json
import os
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--jobs", required=True)
args = ap.parse_args(argv)
with open(args.jobs) as f:
    jobs = json.load(f)

scene = bpy.context.scene
for ob in list(scene.objects):
    bpy.data.objects.remove(ob, do_unlink=True)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = int(jobs["samples"])
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
scene.cycles.max_bounces = 0
scene.cycles.volume_bounces = 0
scene.cycles.transparent_max_bounces = int(os.environ.get("SEAM_TRANSPARENT", "8"))
scene.render.film_transparent = False
px = int(jobs["camera"]["pixels"])
scene.render.resolution_x = scene.render.resolution_y = px
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world

cam_data = bpy.data.cameras.new("cam")
cam_data.type = "ORTHO"
cam_data.ortho_scale = float(jobs["camera"]["scale"])
cam_data.clip_start = 1e-3
cam_data.clip_end = 1e7
cam = bpy.data.objects.new("cam", cam_data)
c = jobs["camera"]["center"]
cam.location = (c[0], c[1], c[2])
scene.collection.objects.link(cam)
scene.camera = cam

mat = bpy.data.materials.new("emission")
mat.use_nodes = True
nt = mat.node_tree
nt.nodes.clear()
out = nt.nodes.new("ShaderNodeOutputMaterial")
em = nt.nodes.new("ShaderNodeEmission")
at = nt.nodes.new("ShaderNodeAttribute")
at.attribute_name = jobs["grid"]
em.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
nt.links.new(at.outputs["Fac"], em.inputs["Strength"])
nt.links.new(em.outputs["Emission"], out.inputs["Volume"])

# Cycles before 5.0 shifts each volume's mesh by (0.1 * hash(name) / dim) object units per axis
# (dim: the padded topology's voxels; scene/volume.cpp, face_overlap_avoidance) so that the
# coincident faces of overlapping volumes differ. Where two tiles' meshes had coplanar faces and
# their shifts agreed to a few float ulps, one tile was missed along those rays (docs/vdb.md
# "Tiling"); tiles now sit on shifted index lattices so that neighbours' faces are >= 1 voxel
# apart, whatever the names. The names are given (jobs["names"]); the offsets are reported.
M32 = 0xFFFFFFFF


def _rot(x, k):
    return ((x << k) | (x >> (32 - k))) & M32


def cycles_name_hash(name):
    """Cycles' hash_uint_to_float(hash_string(name)) (util/hash.h)."""
    kx = 0
    for ch in name.encode():
        kx = (kx * 37 + ch) & M32
    a = b = c = (0xdeadbeef + (1 << 2) + 13) & M32
    a = (a + kx) & M32
    c ^= b; c = (c - _rot(b, 14)) & M32; a ^= c; a = (a - _rot(c, 11)) & M32; b ^= a; b = (b - _rot(a, 25)) & M32
    c ^= b; c = (c - _rot(b, 16)) & M32; a ^= c; a = (a - _rot(c, 4)) & M32; b ^= a; b = (b - _rot(a, 14)) & M32
    c ^= b; c = (c - _rot(b, 24)) & M32
    return float(np.float32(c) / np.float32(4294967295.0))


def face_offsets(files, grid_name, names):
    """Cycles' face_overlap_avoidance offset per file and axis, for the report."""
    import pyopenvdb as vdb
    out = []
    for path, name in zip(files, names):
        g = vdb.read(path, grid_name)
        lo, hi = g.evalActiveVoxelBoundingBox()
        dim = np.array(hi) - np.array(lo) + 1 + 2  # padded by one voxel each side
        out.append([float(x) for x in 0.1 * cycles_name_hash(name) / dim])
    return out


for r_i, job in enumerate(jobs["renders"]):
    for ob in [o for o in scene.objects if o.type == "VOLUME"]:
        bpy.data.objects.remove(ob, do_unlink=True)
    for vol in list(bpy.data.volumes):  # else a name in use gets ".001" (another Cycles hash)
        bpy.data.volumes.remove(vol)
    names = job.get("names") or [jobs.get("names", "v%d_{k}" % r_i).format(k=k) for k in range(len(job["files"]))]
    with open(job["out"] + ".names.json", "w") as f:
        json.dump({"names": names, "face_offsets": face_offsets(job["files"], jobs["grid"], names)}, f)
    for i, path in enumerate(job["files"]):
        vol = bpy.data.volumes.new(names[i])
        assert vol.name == names[i], (vol.name, names[i])
        vol.filepath = path
        vol.render.clipping = 0.0
        vol.render.precision = "FULL"
        vol.render.space = "WORLD"
        vol.render.step_size = float(jobs["step"])
        vol.materials.append(mat)
        ob = bpy.data.objects.new(names[i], vol)
        scene.collection.objects.link(ob)
    scene.cycles.seed = int(job["seed"])
    exr = job["out"] + ".exr"
    scene.render.filepath = exr
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(exr)
    a = np.empty(len(img.pixels), dtype=np.float32)
    img.pixels.foreach_get(a)
    a = a.reshape(img.size[1], img.size[0], img.channels)[:, :, 0]
    np.save(job["out"], a)
    bpy.data.images.remove(img)
    os.remove(exr)
