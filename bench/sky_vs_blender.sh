#!/usr/bin/env bash
# Sky texture speed against Blender's own Nishita sky, both measured in this run.
#
#   bench/sky_vs_blender.sh [BUILD_DIR] [REPEATS] [THREADS]
#
# Baseline: Blender 3.4 (Debian's `blender`, Cycles CPU, denoising off) renders an 8×8 frame,
# 1 sample, once with a flat World and once with a Nishita Sky Texture World; the World's
# importance-map sampling is off in both, so the difference of the two render times is the
# sky precompute (512×128 upper hemisphere, 21 wavelengths, 32 view steps). Timed inside
# Blender around bpy.ops.render.render, best of REPEATS, `-t THREADS`.
#
# Airmass (single scattering, --no-multiple, like Blender's Nishita; then the default sky
# with multiple scattering for its cost): `airmass sky --preset blender-nishita` over the same upper hemisphere (512 px
# wide, 128 rows above the horizon: --width 512 --height 256 --hemisphere upper), with the
# default settings and with 32 view samples (Blender's count); and the 2048×1024 full-sphere
# RGB sky (target ≤ 1 s on 2 cores). Times are the tool's own "s render" figure (scene ready
# → image in memory; the EXR write and process start-up are reported separately as wall
# time), best of REPEATS, --threads THREADS. Prints a table with ratios to the baseline.
set -euo pipefail

BUILD=${1:-build}
REPEATS=${2:-3}
THREADS=${3:-2}
AIRMASS="$BUILD/bin/airmass"
[ -x "$AIRMASS" ] || { echo "sky_vs_blender: no airmass binary at $AIRMASS (give the build dir)" >&2; exit 2; }
command -v blender >/dev/null || { echo "sky_vs_blender: blender not found (scripts/setup.sh installs it)" >&2; exit 2; }

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

cat >"$TMP/blender_sky.py" <<'EOF'
import sys
import time

import bpy

sky = "--sky" in sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else False
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 1
scene.cycles.use_denoising = False  # Debian's Blender has no OpenImageDenoise
scene.render.resolution_x = 8
scene.render.resolution_y = 8
scene.render.resolution_percentage = 100
world = bpy.data.worlds.new("airmass_bench")
scene.world = world
world.use_nodes = True
world.cycles.sampling_method = "NONE"  # no background importance map in either run
nodes = world.node_tree.nodes
if sky:
    tex = nodes.new("ShaderNodeTexSky")
    tex.sky_type = "NISHITA"
    world.node_tree.links.new(tex.outputs["Color"], nodes["Background"].inputs["Color"])
t0 = time.perf_counter()
bpy.ops.render.render(write_still=False)
print("AIRMASS_RENDER_SECONDS %.6f" % (time.perf_counter() - t0))
EOF

# best_of N cmd...: the smallest value printed after "AIRMASS_RENDER_SECONDS".
blender_best() {
  local best="" t
  for _ in $(seq "$REPEATS"); do
    t=$(blender -b --factory-startup -t "$THREADS" --python-exit-code 1 --python "$TMP/blender_sky.py" -- "$@" 2>&1 |
        sed -n 's/^AIRMASS_RENDER_SECONDS //p')
    [ -n "$t" ] || { echo "sky_vs_blender: blender run failed" >&2; exit 1; }
    best=$(python3 -c "print(min(float('$t'), float('${best:-inf}')))")
  done
  echo "$best"
}

# airmass_best args...: best "s render" and best wall time of `airmass sky` over REPEATS.
airmass_best() {
  local best="" wall_best="" out t0 t1 t wall
  for _ in $(seq "$REPEATS"); do
    t0=$(date +%s.%N)
    out=$("$AIRMASS" sky -o "$TMP/sky.exr" --threads "$THREADS" "$@" 2>&1)
    t1=$(date +%s.%N)
    t=$(echo "$out" | sed -n 's/.*, \([0-9.]*\) s render).*/\1/p')
    [ -n "$t" ] || { echo "sky_vs_blender: airmass sky failed: $out" >&2; exit 1; }
    wall=$(python3 -c "print($t1 - $t0)")
    best=$(python3 -c "print(min(float('$t'), float('${best:-inf}')))")
    wall_best=$(python3 -c "print(min(float('$wall'), float('${wall_best:-inf}')))")
  done
  echo "$best $wall_best"
}

echo "sky_vs_blender: $REPEATS repeats, $THREADS threads, $(nproc) CPUs, load average $(cut -d' ' -f1-3 /proc/loadavg)"
flat=$(blender_best)
sky=$(blender_best --sky)
baseline=$(python3 -c "print(max($sky - $flat, 1e-6))")

# Single scattering like Blender's Nishita (--no-multiple), then the default sky with
# multiple scattering for its cost.
read -r def def_wall < <(airmass_best --preset blender-nishita --width 512 --height 256 --hemisphere upper --no-multiple)
read -r s32 s32_wall < <(airmass_best --preset blender-nishita --width 512 --height 256 --hemisphere upper --samples 32 --no-multiple)
read -r rgb rgb_wall < <(airmass_best --preset earth --basis rgb --width 2048 --height 1024 --no-multiple)
read -r spec spec_wall < <(airmass_best --preset earth --width 2048 --height 1024 --no-multiple)
read -r ms ms_wall < <(airmass_best --preset earth --width 2048 --height 1024)
# The coarse sky grid whose error bench/nishita_error.py measures below Blender's own.
read -r g16 g16_wall < <(airmass_best --preset blender-nishita --width 512 --height 256 --hemisphere upper --grid 16 --no-multiple)

python3 - "$flat" "$sky" "$baseline" "$def" "$def_wall" "$s32" "$s32_wall" "$rgb" "$rgb_wall" "$spec" "$spec_wall" "$THREADS" "$ms" "$ms_wall" "$g16" "$g16_wall" <<'EOF'
import sys
flat, sky, base, d, dw, s32, s32w, rgb, rgbw, spec, specw = map(float, sys.argv[1:12])
threads = sys.argv[12]
ms, msw, g16, g16w = map(float, sys.argv[13:17])
print(f"Blender 3.4 render, flat World        {flat:8.3f} s")
print(f"Blender 3.4 render, Nishita World     {sky:8.3f} s")
print(f"Blender Nishita precompute (baseline) {base:8.3f} s   (512x128 upper hemisphere, 21 wavelengths, 32 steps)")
print()
print(f"| airmass sky ({threads} threads) | render s | x Blender precompute | wall s (start-up + EXR write) |")
print("|---|---|---|---|")
print(f"| blender-nishita 512x128 upper, defaults | {d:.4f} | {d / base:.2f} | {dw:.3f} |")
print(f"| blender-nishita 512x128 upper, 32 samples | {s32:.4f} | {s32 / base:.2f} | {s32w:.3f} |")
print(f"| blender-nishita 512x128 upper, --grid 16 | {g16:.4f} | {g16 / base:.3f} | {g16w:.3f} |")
print(f"| earth 2048x1024 full sphere, RGB basis | {rgb:.4f} | {rgb / base:.2f} | {rgbw:.3f} |")
print(f"| earth 2048x1024 full sphere, spectral-48 | {spec:.4f} | {spec / base:.2f} | {specw:.3f} |")
print(f"| earth 2048x1024 full sphere, spectral-48, multiple scattering (the default) | {ms:.4f} | {ms / base:.2f} | {msw:.3f} |")
print()
print(f"2048x1024 full-sphere RGB <= 1 s on {threads} threads: {'yes' if rgb <= 1.0 else 'NO'} ({rgb:.3f} s)")
print(f"blender-nishita hemisphere, --grid 16, <= 1/10 of Blender's precompute: {'yes' if g16 <= 0.1 * base else 'NO'} "
      f"({g16 / base:.3f}; its error against Blender's: bench/nishita_error.py)")
EOF
