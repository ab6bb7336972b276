# The HTML report's 3D view (issue 30): three.js from node_modules (pinned in
# package-lock.json, fetched by `make deps`, which runs `npm ci`) and
# src/view3d.js become a generated C++ source of the tetopt library, so a
# report page carries everything it draws with (no network).
#
# TETOPT_VIEW3D=OFF builds without three.js: the report then says in place of
# the view that it was not built in; everything else is the same.
option(TETOPT_VIEW3D "Inline three.js (node_modules, 'make deps') into the HTML report's 3D view" ON)

set(TETOPT_VIEW3D_CPP ${CMAKE_CURRENT_BINARY_DIR}/generated/view3d_assets.cpp)
set(_view3d_app ${PROJECT_SOURCE_DIR}/src/view3d.js)
if(TETOPT_VIEW3D)
  set(_three ${PROJECT_SOURCE_DIR}/node_modules/three)
  set(_three_files ${_three}/build/three.core.min.js ${_three}/build/three.module.min.js
                   ${_three}/examples/jsm/controls/OrbitControls.js)
  foreach(f ${_three_files} ${_three}/package.json)
    if(NOT EXISTS ${f})
      message(FATAL_ERROR "tetopt: ${f} is missing. The HTML report's 3D view inlines three.js from "
        "node_modules: run 'make deps' (it runs 'npm ci' in ${PROJECT_SOURCE_DIR}; the packages are pinned in "
        "package-lock.json), or configure with -DTETOPT_VIEW3D=OFF to build reports without the 3D view.")
    endif()
  endforeach()
  # node_modules must hold the version the lockfile pins.
  file(READ ${PROJECT_SOURCE_DIR}/package-lock.json _lock)
  string(JSON _want GET "${_lock}" packages node_modules/three version)
  file(READ ${_three}/package.json _pkg)
  string(JSON _have GET "${_pkg}" version)
  if(NOT _want STREQUAL _have)
    message(FATAL_ERROR "tetopt: node_modules/three is ${_have}, package-lock.json pins ${_want}: run 'make deps' (npm ci)")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/package-lock.json ${_three}/package.json)
  list(GET _three_files 0 _core)
  list(GET _three_files 1 _module)
  list(GET _three_files 2 _orbit)
  message(STATUS "tetopt: three.js ${_have} inlined into the HTML report's 3D view")
else()
  set(_have "")
  set(_core "")
  set(_module "")
  set(_orbit "")
  set(_three_files "")
  message(STATUS "tetopt: HTML reports without the 3D view (TETOPT_VIEW3D=OFF)")
endif()
add_custom_command(OUTPUT ${TETOPT_VIEW3D_CPP}
  COMMAND ${CMAKE_COMMAND} -DOUT=${TETOPT_VIEW3D_CPP} -DAPP=${_view3d_app} -DVERSION=${_have}
          -DCORE=${_core} -DMODULE=${_module} -DORBIT=${_orbit} -P ${PROJECT_SOURCE_DIR}/cmake/embed_view3d.cmake
  DEPENDS ${PROJECT_SOURCE_DIR}/cmake/embed_view3d.cmake ${_view3d_app} ${_three_files}
  COMMENT "Embedding the HTML report's 3D view (three.js ${_have})"
  VERBATIM)
target_sources(tetopt PRIVATE ${TETOPT_VIEW3D_CPP})
# Literals of several hundred KB: -Wpedantic's -Woverlength-strings would
# warn about the ISO minimum (65536), which GCC and Clang do not have.
set_source_files_properties(${TETOPT_VIEW3D_CPP} PROPERTIES COMPILE_OPTIONS -Wno-overlength-strings)
