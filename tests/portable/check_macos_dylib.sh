#!/usr/bin/env bash
# The macOS library the add-on ships (docs/portable.md), checked without a Mac: it was built here by
# cross-compilation (scripts/build-macos.sh) and is never run by this project's CI.
#   * a universal Mach-O dylib with exactly the arm64 and x86_64 slices;
#   * each slice loads only /usr/lib/libSystem.B.dylib (libc++ is linked statically);
#   * each slice exports exactly the functions the Linux library exports (Mach-O names carry a
#     leading underscore), and nothing else — no libc++ symbol;
#   * the arm64 slice carries a code signature (LC_CODE_SIGNATURE; macOS on Apple silicon refuses
#     to load unsigned arm64 code), and each slice names a minimum macOS (LC_BUILD_VERSION).
# Usage: check_macos_dylib.sh libairmass_c.dylib libairmass_c.so   (exit 77: no dylib, outside CI)
set -euo pipefail
dylib="$1"; so="$2"
if [ ! -f "$dylib" ]; then
  if [ -n "${CI:-}" ]; then echo "FAIL: no macOS library at $dylib (scripts/build-macos.sh makes it)"; exit 1; fi
  echo "SKIP: no macOS library at $dylib (scripts/build-macos.sh makes it; a failure under CI)"; exit 77
fi
fail=0
archs=$(llvm-lipo-14 -archs "$dylib" 2>&1) || { echo "FAIL: $dylib is not a Mach-O file: $archs"; exit 1; }
echo "architectures: $archs"
if [ "$(echo $archs | tr ' ' '\n' | sort | paste -sd' ')" != "arm64 x86_64" ]; then
  echo "FAIL: expected exactly the arm64 and x86_64 slices"; fail=1
fi
so_exports=$(nm -D --defined-only "$so" | awk '$2 == "T" && $3 ~ /^airmass_/ {print "_" $3}' | sort)
for arch in arm64 x86_64; do
  echo "$archs" | grep -qw "$arch" || continue
  headers=$(llvm-objdump-14 --macho --arch="$arch" --private-headers "$dylib")
  filetype=$(echo "$headers" | awk '$1 ~ /^MH_MAGIC/ {print $5; exit}')
  [ "$filetype" = "DYLIB" ] || { echo "FAIL: $arch slice is a Mach-O $filetype, not a DYLIB"; fail=1; }
  loads=$(echo "$headers" | awk '/cmd LC_(LOAD|LOAD_WEAK|REEXPORT|LAZY_LOAD|LOAD_UPWARD)_DYLIB$/ {getline; getline; print $2}' | sort -u)
  echo "$arch: loads $(echo $loads)"
  for d in $loads; do
    [ "$d" = "/usr/lib/libSystem.B.dylib" ] || { echo "FAIL: $arch slice loads $d (only libSystem is allowed)"; fail=1; }
  done
  [ -n "$loads" ] || { echo "FAIL: $arch slice loads no libSystem"; fail=1; }
  minos=$(echo "$headers" | awk '/cmd LC_BUILD_VERSION/ {f=1} f && $1 == "minos" {print $2; exit}')
  [ -n "$minos" ] || { echo "FAIL: $arch slice has no LC_BUILD_VERSION"; fail=1; }
  signed=$(echo "$headers" | grep -c 'cmd LC_CODE_SIGNATURE' || true)
  id=$(echo "$headers" | awk '/cmd LC_ID_DYLIB$/ {getline; getline; print $2; exit}')
  [ "$id" = "@rpath/libairmass_c.dylib" ] || { echo "FAIL: $arch slice is named $id, not @rpath/libairmass_c.dylib"; fail=1; }
  echo "$arch: $filetype $id, minimum macOS $minos, code signature: $([ "$signed" -gt 0 ] && echo yes || echo no)"
  if [ "$arch" = arm64 ] && [ "$signed" -eq 0 ]; then
    echo "FAIL: the arm64 slice has no LC_CODE_SIGNATURE (ad-hoc signature)"; fail=1
  fi
  # Every external defined symbol (nm -g -U: exported), whatever its name.
  exports=$(llvm-nm-14 --arch="$arch" -g -U -j "$dylib" | sort)
  if [ "$exports" != "$so_exports" ]; then
    echo "FAIL: the $arch slice's exports differ from the Linux library's (< Linux, > macOS):"
    diff <(echo "$so_exports") <(echo "$exports") | head -20 || true
    fail=1
  fi
  echo "$arch: exports $(echo "$exports" | grep -c '^_airmass_') _airmass_* functions, as the Linux library; $(echo "$exports" | grep -vc '^_airmass_' || true) other"
done
[ $fail -eq 0 ] && echo "check_macos_dylib: ok (built, not run)" || echo "check_macos_dylib: FAILED"
exit $fail
