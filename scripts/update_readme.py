#!/usr/bin/python3
"""Copy the measured tables and images the main command produced into README.md.

    scripts/update_readme.py OUT_DIR

README.md and the docs in DOCUMENTS hold blocks delimited by `<!-- BEGIN name -->` /
`<!-- END name -->`; each block is replaced by the named file from OUT_DIR (see BLOCKS). Images named in IMAGES
are copied to docs/images/ so the README can show them. Nothing in README is typed by
hand between the markers: every number there comes from the last run of the command.
"""
import os
import re
import shutil
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Markdown files whose marked blocks are replaced (README and the docs that show the same tables)
DOCUMENTS = ["README.md", "docs/sky.md", "docs/vdb.md", "docs/multiple_scattering.md", "docs/compare.md"]
# block name -> file under OUT_DIR (Markdown)
BLOCKS = {
    "chapman_trade": "chapman/chapman_trade.md",
    "sky_trade": "sky/sky_trade.md",
    "sky_ms_view": "sky/sky_ms_view.md",
    "sky_trade_blender_nishita": "sky-blender-nishita/sky_trade.md",
    "sky_trade_earth_hazy": "sky-earth-hazy/sky_trade.md",
    "sky_trade_mars": "sky-mars/sky_trade.md",
    "vdb_trade": "vdb/vdb_trade.md",
    "vdb_tolerance": "vdb/vdb_tolerance.md",
    "ms_trade": "ms/ms_trade.md",
    "ms_presets": "ms/ms_presets.md",
    "compare": "compare/report.md#Summary",  # the report's "## Summary" section
    "gallery": "gallery/gallery.md",
}
# files under OUT_DIR -> docs/images/NAME
IMAGES = {
    "chapman/chapman_error.png": "chapman_error.png",
    "sky/sky_pareto.png": "sky_pareto.png",
    "vdb/vdb_trade.png": "vdb_trade.png",
    "ms/ms_trade.png": "ms_trade.png",
    "compare/png/sky_texture_side_by_side.png": "compare_sky_texture.png",
    "compare/png/analytic_volume_side_by_side.png": "compare_analytic_volume.png",
    "compare/png/vdb_volume_side_by_side.png": "compare_vdb_volume.png",
    "compare/png/analytic_volume_ms_side_by_side.png": "compare_analytic_volume_ms.png",
}


def update_blocks(path, out):
    """Replaces every known block that `path` has markers for; returns the names updated."""
    text = open(path, encoding="utf-8").read()
    done = []
    for name, rel in BLOCKS.items():
        rel, _, section = rel.partition("#")
        src = os.path.join(out, rel)
        if not os.path.exists(src):
            continue
        body = open(src, encoding="utf-8").read().strip()
        if section:  # only that "## " section, without its heading
            m = re.search(r"^## %s\n(.*?)(?=^## |\Z)" % re.escape(section), body, re.S | re.M)
            if not m:
                continue
            body = m.group(1).strip()
        if name == "gallery":  # its images live in docs/images/ as sky_<name>.png
            prefix = "" if os.path.dirname(path).endswith("docs") else "docs/"
            body = re.sub(r"\]\(([\w-]+)\.png\)", r"](%simages/sky_\1.png)" % prefix, body)
        # An empty block (END on the line after BEGIN) is filled too.
        pattern = re.compile(r"(<!-- BEGIN %s -->\n)(?:.*?\n)?(<!-- END %s -->)" % (name, name), re.S)
        text, n = pattern.subn(lambda m: m.group(1) + body + "\n" + m.group(2), text)
        if n:
            done.append(name)
    tmp = path + ".tmp"
    open(tmp, "w", encoding="utf-8").write(text)
    os.replace(tmp, path)
    return done


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    for rel in DOCUMENTS:
        done = update_blocks(os.path.join(ROOT, rel), out)
        print("update_readme: %s: %s" % (rel, ", ".join(done) or "nothing to update"), file=sys.stderr)
    img_dir = os.path.join(ROOT, "docs", "images")
    os.makedirs(img_dir, exist_ok=True)
    for rel, name in IMAGES.items():
        src = os.path.join(out, rel)
        if os.path.exists(src):
            shutil.copyfile(src, os.path.join(img_dir, name))
    gallery = os.path.join(out, "gallery")
    if os.path.isdir(gallery):
        for f in sorted(os.listdir(gallery)):
            if f.endswith(".png"):
                shutil.copyfile(os.path.join(gallery, f), os.path.join(img_dir, "sky_" + f))

if __name__ == "__main__":
    main()
