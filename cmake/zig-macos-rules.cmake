# Read after CMake's Darwin platform files in the Zig macOS cross build (cmake/zig-macos.cmake sets
# CMAKE_USER_MAKE_RULES_OVERRIDE): the -rpath flag those files declare only on a Mac.
set(CMAKE_SHARED_LIBRARY_RUNTIME_C_FLAG "-Wl,-rpath,")
set(CMAKE_SHARED_LIBRARY_RUNTIME_CXX_FLAG "-Wl,-rpath,")
