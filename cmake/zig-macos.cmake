# Cross-compiling the core and the C ABI for macOS (arm64 or x86_64) with Zig 0.11 on Linux.
# scripts/build-macos.sh uses it; docs/portable.md says why. Built here, never run on a Mac here.
#
# It needs AIRMASS_ZIG_WRAPPERS, a folder holding the wrappers build-macos.sh writes:
#   cc, c++      `zig cc` / `zig c++ -target <arch>-macos.<min>` — compiling, and linking executables
#                (Zig's own Mach-O linker). c++ links a dylib (-dynamiclib) with ld64.lld-14 instead,
#                against Zig's static libc++/libc++abi and its libSystem.tbd: Zig 0.11's linker has no
#                -exported_symbol, so it would export all of libc++ from our dylib.
#   ar, ranlib   `zig ar` / `zig ranlib` (Mach-O archives)
# and AIRMASS_MACOS_ARCH (arm64 or x86_64).
foreach(_v AIRMASS_ZIG_WRAPPERS AIRMASS_MACOS_ARCH)
  if(NOT DEFINED ${_v} AND DEFINED ENV{${_v}})
    set(${_v} "$ENV{${_v}}")
  endif()
  if(NOT DEFINED ${_v})
    message(FATAL_ERROR "cmake/zig-macos.cmake needs ${_v} (scripts/build-macos.sh sets it)")
  endif()
endforeach()
# try_compile projects read this file again: hand the two settings on.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES AIRMASS_ZIG_WRAPPERS AIRMASS_MACOS_ARCH)

set(CMAKE_SYSTEM_NAME Darwin)
set(CMAKE_SYSTEM_PROCESSOR ${AIRMASS_MACOS_ARCH})
set(CMAKE_SYSTEM_VERSION 20.0)  # Darwin 20 = macOS 11
# Off a Mac, CMake's Darwin files find no macOS version (sw_vers), so they declare no -rpath
# flag and would refuse @rpath install names; zig-macos-rules.cmake, read after them, declares it.
# The dylib is then named @rpath/libairmass_c.dylib, as on a Mac.
set(CMAKE_USER_MAKE_RULES_OVERRIDE ${CMAKE_CURRENT_LIST_DIR}/zig-macos-rules.cmake)
set(CMAKE_C_COMPILER ${AIRMASS_ZIG_WRAPPERS}/cc)
set(CMAKE_CXX_COMPILER ${AIRMASS_ZIG_WRAPPERS}/c++)
set(CMAKE_AR ${AIRMASS_ZIG_WRAPPERS}/ar CACHE FILEPATH "Mach-O archiver (zig ar)")
set(CMAKE_RANLIB ${AIRMASS_ZIG_WRAPPERS}/ranlib CACHE FILEPATH "Mach-O ranlib (zig ranlib)")
# The wrappers pass -target; CMake's own -arch / -isysroot / -mmacosx-version-min stay off.
set(CMAKE_OSX_ARCHITECTURES "" CACHE STRING "" FORCE)
set(CMAKE_OSX_SYSROOT "" CACHE PATH "" FORCE)
set(CMAKE_OSX_DEPLOYMENT_TARGET "" CACHE STRING "" FORCE)
# Nothing is found on the host: the header-only dependencies come through AIRMASS_HEADER_DEPS_DIR.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
