"""The comparison renders the material users get (issue 13, item 3), run inside headless Blender:

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_material_graph.py -- \\
        --zip build/addon/airmass_blender.zip --cli build/plugin/cli/airmass --scripts compare

For every preset:
  1. `airmass compare --preset P --paths analytic_volume --no-blender` (a 16×9 camera) writes
     job.json — the constituents with their g_hg, the native renders (native_matched records the
     Henyey–Greenstein g it rendered with), the plan — and its progress events;
  2. the add-on (installed from the zip) makes its analytic volume with Phase Mixing DITHER and
     SEPARATE, and compare/blender_render.py builds its rgb_dither and rgb materials from the job;
  3. each pair must be the same node graph (material.graph_dump: nodes, types, settings, unlinked
     inputs' default values, custom properties, links), and every Volume Scatter's anisotropy —
     the dithered one's per scatterer — must equal the job's g_hg and native_matched's g.
Negative controls show the dump notices a changed constant or an extra closure. Exit status 1
(through --python-exit-code) when any check fails.
"""

import argparse
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import traceback

import bpy

ADDON = "airmass_blender"
failures = []


def check(cond, message):
    if not cond:
        raise AssertionError(message)


def close(a, b, rel=1e-6, what=""):
    check(abs(a - b) <= rel * max(abs(a), abs(b), 1e-12), "%s: %r != %r" % (what, a, b))


def install_addon(zip_path, tmp):
    scripts = os.path.join(tmp, "scripts")
    os.makedirs(scripts, exist_ok=True)
    fp = bpy.context.preferences.filepaths
    if hasattr(fp, "script_directories"):  # Blender 4.2+
        entry = fp.script_directories.new()
        entry.directory = scripts
    else:
        fp.script_directory = scripts
    check(bpy.ops.preferences.addon_install(filepath=zip_path, target="PREFS", overwrite=True) == {"FINISHED"},
          "addon_install failed")
    bpy.utils.refresh_script_paths()
    bpy.ops.preferences.addon_enable(module=ADDON)
    return os.path.join(scripts, "addons", ADDON)


def load_blender_render(scripts):
    spec = importlib.util.spec_from_file_location("airmass_compare_blender_render",
                                                  os.path.join(scripts, "blender_render.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_compare(cli, preset, out):
    events = os.path.join(out, "progress.jsonl")
    cmd = [cli, "compare", "--preset", preset, "-o", out, "--paths", "analytic_volume", "--no-blender",
           "--width", "16", "--height", "9", "--view-samples", "4", "--threads", "1", "--quiet",
           "--progress-json", events]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=600, check=False)
    check(r.returncode == 0, "%s failed (%d): %s" % (" ".join(cmd), r.returncode, r.stdout.decode()[-2000:]))
    with open(os.path.join(out, "job.json")) as f:
        job = json.load(f)
    with open(events) as f:
        lines = [json.loads(ln) for ln in f if ln.strip()]
    return job, lines


def check_events(lines, job):
    """Every step announced and closed once, in order, with index / total; done {ok} last."""
    check(lines and lines[-1] == {"event": "done", "ok": True}, "last event %r" % (lines[-1:],))
    starts = [e for e in lines if e["event"] == "render_start"]
    dones = [e for e in lines if e["event"] == "render_done"]
    total = starts[0]["total"]
    check([e["index"] for e in starts] == list(range(total)), "render_start indices %r" % starts)
    check([e["index"] for e in dones] == list(range(total)), "render_done indices %r" % dones)
    check(all(e["ok"] for e in dones), "a step failed: %r" % dones)
    steps = [e["step"] for e in starts]
    check(steps == ["native_physical", "native_hg_spectral", "native_matched"], "steps %r" % steps)
    check(all(e["total"] == total for e in lines if "total" in e), "total changes")
    prog = [e for e in lines if e["event"] == "progress"]
    check(prog and all(0 < e["done"] <= e["of"] == job["camera"]["height"] for e in prog), "progress %r" % prog)
    plan = job["plan"]
    check([p["name"] for p in plan["all_paths"]] == ["sky_texture", "analytic_volume", "analytic_volume_ms",
                                                     "vdb_volume", "pov_sky", "pov_analytic", "pov_df3"],
          "plan paths %r" % plan["all_paths"])
    check([p["renderer"] for p in plan["all_paths"]] == ["blender"] * 4 + ["povray"] * 3,
          "plan renderers %r" % plan["all_paths"])
    scatterers = sum(1 for c in job["constituents"] if max(c["scattering_rgb"]) > 0)
    modes = job["volume_modes"]
    want = job["seeds"]["analytic_volume"] * sum(3 * scatterers if m == "split" else 1 for m in modes)
    check(plan["blender_renders"] == {"analytic_volume": want}, "planned renders %r, want %d" %
          (plan["blender_renders"], want))


def addon_material(preset, mixing):
    bpy.ops.wm.read_homefile(use_empty=True)
    s = bpy.context.scene.airmass
    s.preset = preset
    s.volume_region = "PLANET"
    s.add_ground = False
    s.phase_mixing = mixing
    check(bpy.ops.airmass.create_volume(mode="ANALYTIC") == {"FINISHED"}, "create_volume %s %s" % (preset, mixing))
    objs = [o for o in bpy.context.scene.objects if o.get("airmass_role") == "atmosphere"]
    check(len(objs) == 1, "%d atmosphere objects" % len(objs))
    check(tuple(objs[0].matrix_world.translation) == (0.0, 0.0, 0.0), "the add-on's domain is not at the origin")
    return objs[0].active_material


def dithered_g(mat):
    """The anisotropies the dithered Volume Scatter picks from, in scatterer order: g0 + the
    MULTIPLY_ADD steps chosen(u) · (g_j − g_{j−1})."""
    sock = mat.node_tree.nodes["scatter (dithered)"].inputs["Anisotropy"]
    steps = []
    while sock.is_linked:
        node = sock.links[0].from_node
        check(node.bl_idname == "ShaderNodeMath" and node.operation == "MULTIPLY_ADD", "anisotropy chain %s" % node)
        steps.append(node.inputs[1].default_value)
        sock = node.inputs[2]
    g = [sock.default_value]
    for step in reversed(steps):
        g.append(g[-1] + step)
    return g


def first_difference(a, b, where=""):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return "%s/%s only in %s" % (where, k, "the add-on" if k in a else "the comparison")
            d = first_difference(a[k], b[k], "%s/%s" % (where, k))
            if d:
                return d
        return None
    if a != b:
        return "%s: add-on %r, comparison %r" % (where, a, b)
    return None


def test_preset(preset, ctx):
    out = os.path.join(ctx.tmp, preset)
    os.makedirs(out)
    job, lines = run_compare(ctx.cli, preset, out)
    check_events(lines, job)
    br = ctx.blender_render
    # The comparison finds the builder: the job's addon_dir (the source add-on folder here),
    # the installed zip's layout (compare_scripts/ inside the package) and the source tree.
    check(os.path.isfile(os.path.join(job["addon_dir"], ADDON, "material.py")), "no material.py under addon_dir %s"
          % job["addon_dir"])
    zipped = br.material_module_candidates({}, here=os.path.join(ctx.installed, "compare_scripts"))
    check(os.path.isfile(os.path.join(zipped[0], ADDON, "material.py")), "zip layout: %r" % zipped)
    check(os.path.isfile(os.path.join(ctx.installed, "compare_scripts", "blender_render.py")),
          "the zip has no compare_scripts/blender_render.py")
    source = br.material_module_candidates({}, here=ctx.scripts)
    check(os.path.isfile(os.path.join(source[-1], ADDON, "material.py")), "source layout: %r" % source)
    br.MATERIAL, where = br.load_material_module(job)
    material = br.MATERIAL
    matched_g = job["native"]["native_matched"]["henyey_greenstein_g"]
    scatterers = [c for c in job["constituents"] if max(c["scattering_rgb"]) > 0]
    for c in job["constituents"]:
        # The one rule: the library's g_hg (job, native_matched) and the add-on's Python mirror.
        close(c["g_hg"], matched_g[c["name"]], rel=1e-12, what="%s %s: job g_hg vs native_matched" % (preset, c["name"]))
        close(c["g_hg"], material.compat.hg_anisotropy(c["phase"], c["g"]), rel=1e-12,
              what="%s %s: library vs compat.hg_anisotropy" % (preset, c["name"]))
    dumps = {}
    for mixing, mode in (("DITHER", "rgb_dither"), ("SEPARATE", "rgb")):
        user = addon_material(preset, mixing)
        user_dump = material.graph_dump(user)
        bpy.ops.wm.read_homefile(use_empty=True)  # the comparison builds in a scene of its own
        planet = job["planet"]
        control = br.VolumeControl(job, material.analytic_density(planet["center"], planet["radius"],
                                                                  planet["top"] - planet["radius"],
                                                                  job["constituents"]), "test")
        ours = control.material(mode)
        ours_dump = material.graph_dump(ours)
        diff = first_difference(user_dump, ours_dump)
        check(diff is None, "%s %s: the add-on's and the comparison's materials differ: %s" % (preset, mixing, diff))
        check(len(user_dump["nodes"]) > 10 and user_dump["links"], "%s: an empty dump" % preset)
        dumps[mode] = (ours, ours_dump, control)
        # The g the graph gives Cycles is the g native_matched rendered with.
        nodes = ours.node_tree.nodes
        if "scatter (dithered)" in nodes:
            got = dithered_g(ours)
            want = [matched_g[c["name"]] for c in scatterers]
            check(len(got) == len(want), "%s: dithered g %r vs %r" % (preset, got, want))
            for a, b in zip(got, want):
                close(a, b, rel=1e-6, what="%s dithered g" % preset)
        else:
            for c in scatterers:
                node = nodes["%s scatter" % c["name"]]
                close(node.inputs["Anisotropy"].default_value, matched_g[c["name"]], rel=1e-6,
                      what="%s %s scatter anisotropy (%s)" % (preset, c["name"], mixing))
    # Negative controls: the dump sees an extra closure and a changed constant.
    ours, ours_dump, control = dumps["rgb"]
    split_mat = control.material("split")
    split = material.graph_dump(split_mat)
    check(first_difference(ours_dump, split) is not None, "%s: stand-ins not seen by the dump" % preset)
    control.use("split")
    control.set_split(0, control.scatterers[0])
    check(first_difference(split, material.graph_dump(split_mat)) is not None,
          "%s: a changed closure constant is not seen by the dump" % preset)
    print("  %s: graphs equal (%d nodes DITHER, %d SEPARATE); g %s" % (
        preset, len(dumps["rgb_dither"][1]["nodes"]), len(ours_dump["nodes"]),
        ", ".join("%s %.6g" % (n, g) for n, g in sorted(matched_g.items()))))


class Ctx:
    pass


def test_path_list(ctx):
    """One list of paths: the add-on's (compare.path_list / blender_paths, asked of the CLI the
    zip bundles) is `airmass compare --list-paths --json` of the CLI under test, its Paths
    checkboxes are the Blender paths of that list, and without a CLI it says why."""
    r = subprocess.run([ctx.cli, "compare", "--list-paths", "--json"], stdout=subprocess.PIPE, timeout=60,
                       check=True)
    listed = json.loads(r.stdout)["paths"]
    want = [p["name"] for p in listed if p["renderer"] == "blender"]
    cmp = importlib.import_module(ADDON + ".compare")
    check(cmp.path_list() == listed, "the add-on's path list %r != the CLI's %r" % (cmp.path_list(), listed))
    check(cmp.blender_paths() == want, "blender_paths %r, want %r" % (cmp.blender_paths(), want))
    items = bpy.context.scene.airmass.bl_rna.properties["compare_paths"].enum_items
    check(sorted(i.identifier.lower() for i in items) == sorted(want), "Paths checkboxes %r, want %r" %
          ([i.identifier for i in items], want))
    # Each checkbox keeps the bit compare/plan.json fixes for it (saved .blend files store the bits).
    flags = {p["name"].upper(): p["addon_flag"] for p in listed if p["renderer"] == "blender"}
    check({i.identifier: i.value for i in items} == flags, "Paths checkbox bits %r, want %r" %
          ({i.identifier: i.value for i in items}, flags))
    check({"SKY_TEXTURE": 1, "ANALYTIC_VOLUME": 2, "VDB_VOLUME": 4, "ANALYTIC_VOLUME_MS": 8} == flags,
          "the Paths bits moved: %r (a saved .blend would select other paths)" % flags)
    old = os.environ.get(cmp.CLI_ENV)
    os.environ[cmp.CLI_ENV] = os.path.join(ctx.tmp, "no-such-airmass")
    try:
        try:
            cmp.path_list()
            check(False, "path_list without a CLI did not raise")
        except cmp.NotAvailable as e:
            check("not available" in str(e) and "no-such-airmass" in str(e), "NotAvailable says %r" % str(e))
    finally:
        if old is None:
            os.environ.pop(cmp.CLI_ENV, None)
        else:
            os.environ[cmp.CLI_ENV] = old


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="test_material_graph.py")
    ap.add_argument("--zip", required=True)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--scripts", required=True, help="the compare/ folder of the source tree")
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    ctx = Ctx()
    ctx.cli = os.path.abspath(args.cli)
    ctx.scripts = os.path.abspath(args.scripts)
    ctx.tmp = tempfile.mkdtemp(prefix="airmass-material-graph-")
    try:
        ctx.installed = install_addon(os.path.abspath(args.zip), ctx.tmp)
        ctx.blender_render = load_blender_render(ctx.scripts)
        native = importlib.import_module(ADDON + ".native")
        presets = native.preset_names()
        check(len(presets) >= 5, "presets %r" % presets)
        try:
            test_path_list(ctx)
            print("PASS material path list")
        except Exception:  # noqa: BLE001
            traceback.print_exc()
            failures.append("path list")
            print("FAIL material path list")
        for preset in presets:
            try:
                test_preset(preset, ctx)
                print("PASS material graph %s" % preset)
            except Exception:  # noqa: BLE001
                traceback.print_exc()
                failures.append(preset)
                print("FAIL material graph %s" % preset)
    finally:
        if args.keep:
            print("kept", ctx.tmp)
        else:
            shutil.rmtree(ctx.tmp, ignore_errors=True)
    if failures:
        raise SystemExit("material graph test failed: " + ", ".join(failures))
    print("all material graph tests passed")


main()
