#!/usr/bin/env python3
"""The add-on zip installs on every platform its manifest names (docs/portable.md).

    check_zip.py airmass_blender.zip

Fails unless the zip holds airmass_blender/ with bl_info (legacy install, Blender 3.x) and a
blender_manifest.toml (extension, 4.2+) whose `platforms` list is exactly what the zip
carries: linux-x64 <=> libairmass_c.so, windows-x64 <=> airmass_c.dll, macos-* <=> a dylib.
Linux and Windows must both be there, and no other shared library (one file per platform). The
zip must also carry the comparison's plan data (compare_scripts/plan.json), which the add-on's
Paths checkboxes read.
"""
import re
import sys
import zipfile


def main():
    path = sys.argv[1]
    names = set(zipfile.ZipFile(path).namelist())
    problems = []
    def has(n):
        return ("airmass_blender/" + n) in names
    for required in ("__init__.py", "native.py", "compat.py", "blender_manifest.toml", "libairmass_c.so",
                     "airmass_c.dll", "compare_scripts/plan.json"):
        if not has(required):
            problems.append("missing airmass_blender/" + required)
    init = zipfile.ZipFile(path).read("airmass_blender/__init__.py").decode() if has("__init__.py") else ""
    if "bl_info" not in init:
        problems.append("__init__.py has no bl_info (legacy add-on install)")
    manifest = zipfile.ZipFile(path).read("airmass_blender/blender_manifest.toml").decode() \
        if has("blender_manifest.toml") else ""
    m = re.search(r"^platforms\s*=\s*\[([^\]]*)\]", manifest, re.M)
    listed = set(re.findall(r'"([^"]+)"', m.group(1))) if m else set()
    carried = set()
    if has("libairmass_c.so"):
        carried.add("linux-x64")
    if has("airmass_c.dll"):
        carried.add("windows-x64")
    if has("libairmass_c.dylib"):
        carried |= {"macos-arm64", "macos-x64"}
    libs = sorted(n for n in names if re.search(r"\.(so(\.\d+)*|dll|dylib)$", n))
    # bin/ holds the `airmass` CLI (Compare with Native runs it as a process) and its OpenVDB
    # writer module; Blender loads neither.
    extra = [n for n in libs if n not in ("airmass_blender/libairmass_c.so", "airmass_blender/airmass_c.dll",
                                          "airmass_blender/libairmass_c.dylib",
                                          "airmass_blender/bin/libairmass_vdb_module.so")]
    if extra:
        problems.append("libraries beyond the one per platform: %s" % extra)
    if listed != carried:
        problems.append("manifest platforms %s, but the zip carries libraries for %s" % (sorted(listed), sorted(carried)))
    print("zip: %d files; platforms listed %s; libraries for %s" % (len(names), sorted(listed), sorted(carried)))
    for p in problems:
        print("FAIL: " + p)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
