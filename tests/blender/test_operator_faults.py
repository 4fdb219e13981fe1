"""Every add-on operator leaves the previous result on any failure (issue 17 item 4):

    blender -b --factory-startup --python-exit-code 1 \\
        --python tests/blender/test_operator_faults.py -- --zip build/addon/airmass_blender.zip [-k NAME]

For Generate Sky, Bake Sky Animation, the analytic volume, the VDB volume and Compare with
Native: a first run succeeds (Compare: a previous result folder is put in place), then the same
operator fails —

  * invalid      a bad scene value (a scale height of 0), refused before any work;
  * readonly     the Output Folder read-only (a read-only tmpfs as root, mode 0555 else);
  * full         a full disk: the Output Folder a tmpfs holding the previous files and one
                 page more (root only);
  * forced       an exception inside the operator's last step (after its files are written),
                 as a Blender API failure would raise —

and afterwards the datablocks (counts, names, the World's image and its pixels, each
atmosphere object's data and material, the actions, the Sun lamp's values and keyframes at
every frame of the scene), the files of the Output Folder (bytes) and the Compare report
setting are what they were. Helpers come from run_addon_tests.py.
"""

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run_addon_tests as rt  # noqa: E402  (its main() runs only as Blender's script)

check = rt.check
TESTS = []


def test(fn):
    TESTS.append(fn)
    return fn


def _can_mount():
    if os.geteuid() != 0:
        return False
    t = tempfile.mkdtemp()
    try:
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", t], capture_output=True).returncode:
            return False
        subprocess.run(["umount", t], check=True)
        return True
    finally:
        os.rmdir(t)


CAN_MOUNT = _can_mount()


def lamp_state(scene):
    """The Sun lamp the add-on uses (Sun Sync, Bake): its values at every frame of the scene
    (evaluated, so its keyframes count), or None without one."""
    obj = _mod("sun").find_lamp(scene)
    if obj is None:
        return None
    current = scene.frame_current
    out = [obj.name, obj.data.name]
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        out.append((f, obj.data.energy, tuple(obj.data.color), obj.data.angle, tuple(obj.matrix_world.col[2])))
    scene.frame_set(current)
    return out


def state(scene, out):
    """What a failure must not change."""
    env = None
    if scene.world is not None and scene.world.node_tree is not None:
        env = scene.world.node_tree.nodes.get("Airmass Sky")
    image = env.image if env is not None else None
    files = {}
    for f in rt.files_in(out):
        with open(f, "rb") as fh:
            files[f] = fh.read()
    return {
        "counts": rt.data_snapshot(),
        "objects": sorted((o.name, o.data.name if o.data else None,
                           o.active_material.name if o.active_material else None) for o in bpy.data.objects),
        "images": sorted(i.name for i in bpy.data.images),
        "world_image": image.name if image is not None else None,
        "world_pixels": tuple(rt._image_pixels(image).ravel()[:4096]) if image is not None else None,
        "files": files,
        "compare_report": scene.airmass.compare_report,
        "actions": sorted(a.name for a in bpy.data.actions),
        "lamp": lamp_state(scene),
        "world": scene.world.name if scene.world is not None else None,
    }


def expect_failure_keeps(scene, out, op, needle, what):
    before = state(scene, out)
    try:
        op()
    except RuntimeError as e:
        check(needle.lower() in str(e).lower(), "%s: error %r lacks %r" % (what, str(e), needle))
    else:
        raise AssertionError("%s: no error (expected %r)" % (what, needle))
    after = state(scene, out)
    for key in before:
        if key == "files":
            changed = sorted(f for f in set(before[key]) | set(after[key]) if before[key].get(f) != after[key].get(f))
            check(not changed, "%s: files changed: %s" % (what, changed))
        else:
            check(after[key] == before[key], "%s: %s changed: %r -> %r" % (what, key, before[key], after[key]))


@contextlib.contextmanager
def read_only(folder):
    """`folder` (holding the previous result) read-only for the duration."""
    if CAN_MOUNT:
        saved = tempfile.mkdtemp()
        shutil.copytree(folder, saved, dirs_exist_ok=True)
        subprocess.run(["mount", "-t", "tmpfs", "tmpfs", folder], check=True)
        try:
            shutil.copytree(saved, folder, dirs_exist_ok=True)
            subprocess.run(["mount", "-o", "remount,ro", folder], check=True)
            yield True
        finally:
            subprocess.run(["umount", "-l", folder], check=False)
            shutil.rmtree(saved, ignore_errors=True)
    elif os.geteuid() != 0:
        os.chmod(folder, 0o555)
        try:
            yield True
        finally:
            os.chmod(folder, 0o755)
    else:
        print("    (root without mount: read-only case skipped)")
        yield False


@contextlib.contextmanager
def full_disk(folder):
    """`folder` on a tmpfs holding its files and one free page (root only; else skipped)."""
    if not CAN_MOUNT:
        print("    (no mount: full-disk case skipped)")
        yield False
        return
    saved = tempfile.mkdtemp()
    shutil.copytree(folder, saved, dirs_exist_ok=True)
    pages = sum(-(-os.path.getsize(f) // 4096) for f in rt.files_in(saved)) + 1
    subprocess.run(["mount", "-t", "tmpfs", "-o", "size=%d" % (pages * 4096), "tmpfs", folder], check=True)
    try:
        shutil.copytree(saved, folder, dirs_exist_ok=True)
        yield True
    finally:
        subprocess.run(["umount", "-l", folder], check=False)
        shutil.rmtree(saved, ignore_errors=True)


@contextlib.contextmanager
def patched(module, name, exc_message):
    old = getattr(module, name)

    def fail(*_a, **_k):
        raise RuntimeError(exc_message)

    setattr(module, name, fail)
    try:
        yield
    finally:
        setattr(module, name, old)


def _mod(name):
    return __import__(rt.ADDON + "." + name, fromlist=["x"])


def bad_scale_height(scene):
    mie = next(c for c in scene.airmass.constituents if c.name == "mie")
    mie.scale_height = 0.0
    return lambda: setattr(mie, "scale_height", mie.preset_scale_height)


def each_fault(scene, out, op, what, change, forced, file_faults=True, full_disk_needle="space"):
    """After a first successful `op`, every fault must keep its result: a bad scale height, then
    (with `change()` applied, so a new result would differ) a read-only and a full Output Folder
    (file_faults) and `forced` = (module, function) raising; finally `op` works again."""
    check(op() == {"FINISHED"}, "%s: the first run failed" % what)
    restore = bad_scale_height(scene)
    expect_failure_keeps(scene, out, op, "scale_height_km", what + " invalid")
    restore()
    change()
    if file_faults:
        check(rt.files_in(out), "%s: no file written to the Output Folder" % what)
        with read_only(out) as ro:
            if ro:
                expect_failure_keeps(scene, out, op, "not writable", what + " readonly")
        with full_disk(out) as full:
            if full:
                expect_failure_keeps(scene, out, op, full_disk_needle, what + " full disk")
    with patched(_mod(forced[0]), forced[1], "forced failure"):
        expect_failure_keeps(scene, out, op, "forced failure", what + " forced")
    check(op() == {"FINISHED"}, "%s after the failures" % what)


@test
def test_generate_sky_keeps_the_previous_sky():
    scene, out = rt.fresh_scene("fault_sky")
    scene.airmass.sky_width = 64
    each_fault(scene, out, lambda: bpy.ops.airmass.generate_sky(), "sky",
               lambda: setattr(scene.airmass, "sky_width", 128), ("world", "wire_world"))


@test
def test_bake_keeps_the_previous_bake():
    """Bake Sky Animation (two frames, the sun from place and time): the previous EXR sequence,
    manifest, World and its sequence image, and the keyframed Sun lamp stay. Forced: the World's
    wiring, after the frames were renamed into place and the lamp keyframed (all rolled back)."""
    scene, out = rt.fresh_scene("fault_bake")
    s = scene.airmass
    s.bake_sun_source = "PLACE_TIME"
    s.latitude, s.longitude, s.date, s.utc_hours = 48.859375, 2.34375, "2026-06-21", 6.0
    s.minutes_per_frame = 30.0
    scene.frame_start, scene.frame_end = 1, 2
    s.sky_width = 64
    each_fault(scene, out, lambda: bpy.ops.airmass.bake_sky_animation(), "bake",
               lambda: setattr(scene.airmass, "sky_width", 128), ("world", "wire_world"))


@test
def test_analytic_volume_keeps_the_previous_volume():
    scene, out = rt.fresh_scene("fault_analytic")
    each_fault(scene, out, lambda: bpy.ops.airmass.create_volume(mode="ANALYTIC"), "analytic",
               lambda: None, ("volume", "shell_geometry"), file_faults=False)


@test
def test_vdb_volume_keeps_the_previous_volume():
    scene, out = rt._vdb_view_scene("fault_vdb")
    scene.airmass.voxel_size = 2.0
    each_fault(scene, out, lambda: bpy.ops.airmass.create_volume(mode="VDB"), "vdb",
               lambda: setattr(scene.airmass, "voxel_size", 1.5), ("volume", "build_material"),
               full_disk_needle="no space left")


@test
def test_compare_keeps_the_previous_result():
    scene, out = rt._compare_setup("fault_compare", {"SKY_TEXTURE"})
    folder = os.path.join(out, "%s_compare" % bpy.path.clean_name(scene.name))
    os.makedirs(folder)
    for name in ("report.md", "summary.json", "job.json"):
        with open(os.path.join(folder, name), "w") as f:
            f.write("previous %s\n" % name)
    scene.airmass.compare_report = os.path.join(folder, "report.md")
    op = lambda: bpy.ops.airmass.compare()  # noqa: E731
    restore = bad_scale_height(scene)
    expect_failure_keeps(scene, out, op, "scale_height_km", "compare invalid")
    restore()
    with read_only(out) as ro:
        if ro:
            expect_failure_keeps(scene, out, op, "not writable", "compare readonly")
    # The CLI fails (its only path refused): the temporary folder goes, the previous stays.
    scene.airmass.compare_paths = {"VDB_VOLUME"}
    scene.airmass.view_distance, scene.airmass.max_dense_mb = 1000.0, 1.0
    expect_failure_keeps(scene, out, op, "every path failed", "compare cli failure")


if __name__ == "__main__":
    rt.run_tests(TESTS, sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [], "test_operator_faults.py")
