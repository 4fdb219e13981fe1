# `cmake --install` for projects built on Airmass (issue 17 item 6; docs/install.md):
#   <prefix>/include/airmass/     the public headers of the libraries below and airmass_c.h
#   <prefix>/lib/                 libairmass.a, libairmass_volume.a, libairmass_vdb.a (+ libairmass_vdb_files.a, libairmass_files.a), libairmass_c.so
#   <prefix>/lib/cmake/airmass/   airmassConfig.cmake (+ ConfigVersion): find_package(airmass) gives
#       airmass::airmass     the core (C++20, static; needs glm's headers and threads)
#       airmass::volume      the OpenVDB-free volume layer (vdb_export's airmass_volume)
#       airmass::airmass_c   the C ABI (shared; no dependencies)
#       airmass::vdb_export  the OpenVDB writer (airmass_vdb), with COMPONENTS vdb_export: finds OpenVDB
#   <prefix>/lib/pkgconfig/       airmass.pc (core + volume layer) and airmass_c.pc (the C ABI)
# Included by the top CMakeLists.txt in full (non-cross) builds; the targets stay as they are
# for the build itself (only export names and install-time interfaces are added here).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(AIRMASS_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/airmass)

# ---- headers: those of the installed libraries (not image_io.hpp / terminal.hpp: airmass_image_io;
#      not compare_plan.hpp: airmass_compare, the CLI's comparison plan)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/plugin/include/airmass
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.hpp" PATTERN "image_io.hpp" EXCLUDE PATTERN "terminal.hpp" EXCLUDE
        PATTERN "compare_plan.hpp" EXCLUDE)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/vdb_export/include/airmass
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp")
install(FILES ${PROJECT_SOURCE_DIR}/plugin/capi/include/airmass/airmass_c.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/airmass)

# ---- targets
# The static libraries' private INTERFACE helpers appear in their link interface as
# $<LINK_ONLY:...>, so they are exported too (with no effect on a consumer's compile).
# Each part only when its folder was added (the top CMakeLists.txt adds those present).
set(_airmass_installed airmass airmass_header_deps airmass_warnings airmass_dispatch)
foreach(_t airmass_volume airmass_c)
  if(TARGET ${_t})
    list(APPEND _airmass_installed ${_t})
  endif()
endforeach()
if(TARGET airmass_volume)
  set_target_properties(airmass_volume PROPERTIES EXPORT_NAME volume)
endif()
set_target_properties(airmass_header_deps PROPERTIES EXPORT_NAME detail_header_deps)
set_target_properties(airmass_warnings PROPERTIES EXPORT_NAME detail_warnings)
set_target_properties(airmass_dispatch PROPERTIES EXPORT_NAME detail_dispatch)
# std::thread inside libairmass.a: a consumer links the threads library (glibc < 2.34 needs it).
find_package(Threads REQUIRED)
target_link_libraries(airmass INTERFACE $<INSTALL_INTERFACE:Threads::Threads>)

install(TARGETS ${_airmass_installed}
        EXPORT airmassTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT airmassTargets NAMESPACE airmass:: DESTINATION ${AIRMASS_INSTALL_CMAKEDIR})
if(TARGET airmass_vdb)
  set_target_properties(airmass_vdb PROPERTIES EXPORT_NAME vdb_export)
  set_target_properties(airmass_files PROPERTIES EXPORT_NAME detail_files)
  set_target_properties(airmass_vdb_files PROPERTIES EXPORT_NAME detail_vdb_files)
  install(TARGETS airmass_vdb airmass_vdb_files airmass_files
          EXPORT airmassVdbTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(EXPORT airmassVdbTargets NAMESPACE airmass:: DESTINATION ${AIRMASS_INSTALL_CMAKEDIR})
endif()

# ---- the package config
# Debian ships OpenVDB's Find module, not a package config (as vdb_export/CMakeLists.txt).
set(AIRMASS_OPENVDB_MODULE_DIR /usr/lib/x86_64-linux-gnu/cmake/OpenVDB)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/airmassConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/airmassConfig.cmake
                              INSTALL_DESTINATION ${AIRMASS_INSTALL_CMAKEDIR})
write_basic_package_version_file(${CMAKE_BINARY_DIR}/airmassConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/airmassConfig.cmake ${CMAKE_BINARY_DIR}/airmassConfigVersion.cmake
        DESTINATION ${AIRMASS_INSTALL_CMAKEDIR})

# ---- pkg-config (relocatable: paths from ${pcfiledir})
file(RELATIVE_PATH AIRMASS_PC_TO_PREFIX /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
string(REGEX REPLACE "/$" "" AIRMASS_PC_TO_PREFIX "${AIRMASS_PC_TO_PREFIX}")
foreach(_pc airmass airmass_c)
  configure_file(${CMAKE_CURRENT_LIST_DIR}/${_pc}.pc.in ${CMAKE_BINARY_DIR}/pkgconfig/${_pc}.pc @ONLY)
  install(FILES ${CMAKE_BINARY_DIR}/pkgconfig/${_pc}.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endforeach()
