#!/usr/bin/env bash
# The Linux library the add-on ships loads in official Blender builds (docs/portable.md):
#   * it needs only glibc's own libraries (and at most libgcc_s);
#   * no glibc symbol version above GLIBC_2.28 (Rocky Linux 8, official Blender's baseline);
#   * it exports exactly the airmass_* functions of airmass_c.h, nothing of the C++ runtime.
# Usage: check_linux_library.sh libairmass_c.so
set -euo pipefail
lib="$1"
header="$(dirname "$0")/../../plugin/capi/include/airmass/airmass_c.h"
fail=0
needed=$(readelf -d "$lib" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p' | sort | tr '\n' ' ')
echo "NEEDED: $needed"
for n in $needed; do
  case "$n" in
    libc.so.6|libm.so.6|libpthread.so.0|libdl.so.2|librt.so.1|ld-linux-x86-64.so.2|libgcc_s.so.1) ;;
    *) echo "FAIL: needs $n, which is not part of glibc"; fail=1 ;;
  esac
done
highest=$(objdump -T "$lib" | grep -o 'GLIBC_[0-9][0-9.]*' | sort -Vu | tail -1)
echo "highest glibc symbol version: $highest"
newer=$(objdump -T "$lib" | grep -E 'GLIBC_2\.(29|[3-9][0-9])' || true)
if [ -n "$newer" ]; then
  echo "FAIL: symbols newer than GLIBC_2.28:"; echo "$newer"; fail=1
fi
exported=$(nm -D --defined-only "$lib" | awk '$2 == "T" && $3 ~ /^airmass_/ {print $3}' | sort)
other=$(nm -D --defined-only "$lib" | awk '$3 !~ /^airmass_/ {print $3}' | sort -u || true)
if [ -n "$other" ]; then
  echo "FAIL: exports other than airmass_*:"; echo "$other" | head -20; fail=1
fi
declared=$(grep -o 'AIRMASS_C_API [^(]*(' "$header" | grep -o 'airmass_[a-z0-9_]*($' | tr -d '(' | sort)
if [ "$exported" != "$declared" ]; then
  echo "FAIL: exported functions differ from airmass_c.h:"
  diff <(echo "$declared") <(echo "$exported") || true
  fail=1
fi
echo "exports: $(echo "$exported" | wc -l) airmass_* functions"
[ $fail -eq 0 ] && echo "check_linux_library: ok" || echo "check_linux_library: FAILED"
exit $fail
