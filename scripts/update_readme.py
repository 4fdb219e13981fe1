#!/usr/bin/python3
"""Copy the measured tables and images the main command produced into README.md.

    scripts/update_readme.py OUT_DIR

README.md holds blocks delimited by `<!-- BEGIN name -->` / `<!-- END name -->`; each
block is replaced by the named file from OUT_DIR (see BLOCKS). Images named in IMAGES
are copied to docs/images/ so the README can show them. Nothing in README is typed by
hand between the markers: every number there comes from the last run of the command.
"""
import os
import re
import shutil
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# block name -> file under OUT_DIR (Markdown)
BLOCKS = {
    "chapman_trade": "chapman/chapman_trade.md",
    "sky_trade": "sky/sky_trade.md",
    "vdb_trade": "vdb/vdb_trade.md",
    "compare": "compare/summary.md",
}
# files under OUT_DIR -> docs/images/NAME
IMAGES = {
    "chapman/chapman_error.png": "chapman_error.png",
    "sky/sky_pareto.png": "sky_pareto.png",
    "vdb/vdb_trade.png": "vdb_trade.png",
}


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    readme_path = os.path.join(ROOT, "README.md")
    text = open(readme_path, encoding="utf-8").read()
    for name, rel in BLOCKS.items():
        src = os.path.join(out, rel)
        if not os.path.exists(src):
            continue
        body = open(src, encoding="utf-8").read().strip()
        pattern = re.compile(r"(<!-- BEGIN %s -->\n).*?(\n<!-- END %s -->)" % (name, name), re.S)
        text, n = pattern.subn(lambda m: m.group(1) + body + m.group(2), text)
        print(f"update_readme: {name}: {'updated' if n else 'no markers in README'}", file=sys.stderr)
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
                shutil.copyfile(os.path.join(gallery, f), os.path.join(img_dir, f))
    tmp = readme_path + ".tmp"
    open(tmp, "w", encoding="utf-8").write(text)
    os.replace(tmp, readme_path)


if __name__ == "__main__":
    main()
