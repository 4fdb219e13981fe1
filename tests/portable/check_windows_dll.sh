#!/usr/bin/env bash
# The Windows DLL the add-on ships (docs/portable.md) imports only Windows system DLLs and
# exports exactly the functions the Linux library exports.
# Usage: check_windows_dll.sh airmass_c.dll libairmass_c.so
set -euo pipefail
dll="$1"; so="$2"
[ -f "$dll" ] || { echo "FAIL: no Windows DLL at $dll (scripts/build-windows.sh makes it)"; exit 1; }
fail=0
imports=$(x86_64-w64-mingw32-objdump -p "$dll" | sed -n 's/.*DLL Name: \(.*\)/\1/p' | sort -u | tr '\n' ' ')
echo "imports: $imports"
for d in $imports; do
  case "${d,,}" in
    kernel32.dll|msvcrt.dll|user32.dll|advapi32.dll|ntdll.dll|bcrypt.dll|ws2_32.dll|api-ms-win-*) ;;
    *) echo "FAIL: imports $d, which is not a Windows system DLL"; fail=1 ;;
  esac
done
dll_exports=$(x86_64-w64-mingw32-objdump -p "$dll" | sed -n '/\[Ordinal\/Name Pointer\] Table/,/^$/p' | grep -o 'airmass_[a-z0-9_]*' | sort)
so_exports=$(nm -D --defined-only "$so" | awk '$2 == "T" && $3 ~ /^airmass_/ {print $3}' | sort)
if [ "$dll_exports" != "$so_exports" ]; then
  echo "FAIL: the DLL's exports differ from the Linux library's:"
  diff <(echo "$so_exports") <(echo "$dll_exports") || true
  fail=1
fi
echo "exports: $(echo "$dll_exports" | grep -c airmass_) airmass_* functions, as the Linux library"
[ $fail -eq 0 ] && echo "check_windows_dll: ok" || echo "check_windows_dll: FAILED"
exit $fail
