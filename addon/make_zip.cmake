# cmake -DSOURCE_DIR=... -DLIBRARIES=a.so;b.so [-DEXECUTABLES=airmass] [-DCOMPARE_SCRIPTS=a.py;b.py]
#       -DSTAGE_DIR=... -DOUTPUT=x.zip -P make_zip.cmake
# Stages airmass_blender/ (Python sources, manifest, libraries; executables in bin/; the
# comparison scripts in compare_scripts/, a name distinct from the module compare.py) and
# zips it with the package folder at the top of the archive (what both legacy add-on and
# extension installs expect). The zip is written beside OUTPUT and renamed over it, so a
# failed build leaves the old zip.
foreach(_v SOURCE_DIR LIBRARIES STAGE_DIR OUTPUT)
  if(NOT DEFINED ${_v})
    message(FATAL_ERROR "make_zip.cmake: ${_v} is not set")
  endif()
endforeach()
set(_pkg ${STAGE_DIR}/airmass_blender)
file(REMOVE_RECURSE ${STAGE_DIR})
file(MAKE_DIRECTORY ${_pkg})
file(GLOB _sources ${SOURCE_DIR}/*.py ${SOURCE_DIR}/*.toml)
file(COPY ${_sources} DESTINATION ${_pkg})
foreach(_lib IN LISTS LIBRARIES)
  get_filename_component(_name ${_lib} NAME)
  file(COPY_FILE ${_lib} ${_pkg}/${_name})
endforeach()
# Executables (the `airmass` CLI) in bin/. A build-tree RUNPATH (to a shared airmass_vdb, say)
# becomes $ORIGIN/.., where the libraries above sit, so the zip works without the build.
foreach(_exe IN LISTS EXECUTABLES)
  get_filename_component(_name ${_exe} NAME)
  file(MAKE_DIRECTORY ${_pkg}/bin)
  file(COPY ${_exe} DESTINATION ${_pkg}/bin
       FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
  file(READ_ELF ${_pkg}/bin/${_name} RUNPATH _runpath RPATH _rpath)
  if(_runpath OR _rpath)
    file(RPATH_SET FILE ${_pkg}/bin/${_name} NEW_RPATH "$ORIGIN/..")
  endif()
endforeach()
foreach(_script IN LISTS COMPARE_SCRIPTS)
  file(MAKE_DIRECTORY ${_pkg}/compare_scripts)
  file(COPY ${_script} DESTINATION ${_pkg}/compare_scripts)
endforeach()
get_filename_component(_out_dir ${OUTPUT} DIRECTORY)
file(MAKE_DIRECTORY ${_out_dir})
set(_tmp ${OUTPUT}.tmp.zip)
file(REMOVE ${_tmp})
execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${_tmp} --format=zip airmass_blender
                WORKING_DIRECTORY ${STAGE_DIR} RESULT_VARIABLE _rc)
if(NOT _rc EQUAL 0)
  file(REMOVE ${_tmp})
  message(FATAL_ERROR "make_zip.cmake: zipping failed (${_rc})")
endif()
file(RENAME ${_tmp} ${OUTPUT})
