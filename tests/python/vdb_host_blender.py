"""Run inside Blender (tests/python/test_vdb_host.py starts it): writes volumes through the
add-on's own path — native.vdb_plan / vdb_grid_values from libairmass_c and vdb_host with this
Blender's OpenVDB Python module — for each case of a JSON file, and records what it did.

    blender -b --factory-startup --python-exit-code 1 --python vdb_host_blender.py -- \\
        --addon ADDON_PARENT_DIR --lib libairmass_c.so --cases cases.json --out OUT_DIR
"""
import argparse
import json
import os
import sys

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--addon", required=True, help="folder holding the airmass_blender package")
ap.add_argument("--lib", required=True)
ap.add_argument("--cases", required=True)
ap.add_argument("--out", required=True)
args = ap.parse_args(argv)

os.environ["AIRMASS_C_LIBRARY"] = os.path.abspath(args.lib)
sys.dont_write_bytecode = True  # keep the source tree clean
sys.path.insert(0, os.path.abspath(args.addon))
import bpy  # noqa: E402,F401  (this is Blender's Python)
from airmass_blender import native, vdb_host  # noqa: E402

report = {"blender": list(bpy.app.version), "module": None, "cases": {}}
module = vdb_host.openvdb_module()
report["module"] = module.__name__ if module else None
with open(args.cases) as f:
    cases = json.load(f)
for name, case in cases.items():
    spec = native.Spec(preset=case.get("preset"), toml=case.get("toml"), source_name=case.get("source_name"))
    folder = os.path.join(args.out, name)
    os.makedirs(folder, exist_ok=True)
    fractions = []
    progress = native.Progress(lambda f: fractions.append(f) and False)
    try:
        written = vdb_host.write_volume(spec, folder, case["stem"], progress=progress, **case["options"])
    finally:
        progress.close()
    report["cases"][name] = {"files": [os.path.basename(p) for p in written.files],
                             "plan_active_voxels": written.plan["active_voxels"],
                             "fractions": fractions}
with open(os.path.join(args.out, "report.json"), "w") as f:
    json.dump(report, f)
