# geobarrier_add_plugin() for projects outside the geobarrier source tree (installed with the CMake package and
# included by find_package(geobarrier CONFIG)). Same call as inside the tree:
#
#   geobarrier_add_plugin(NAME name SOURCES file.cpp ...
#                         [KIT]                        compile in geobarrier::kit, the extractor kit (fields,
#                                                      tensor lines, curves), its symbols hidden: no libgeobarrier
#                         [LINK_CORE]                  link geobarrier::core (extractors using its C++ API)
#                         [OUTPUT_DIRECTORY dir]       default: ${CMAKE_BINARY_DIR}/plugins
#                         [INSTALL_DESTINATION dir]    default: lib/geobarrier/plugins under the install prefix
#                         [NO_INSTALL]
#                         [PORTABLE])                  compile for the baseline CPU of the target (see below)
#
# builds target geobarrier-<name> as a loadable module geobarrier-<name>.so: C++17, position-independent, hidden
# visibility (only the GEOBARRIER_PLUGINS entry point is exported). Installing it into geobarrier's own prefix
# puts it where the installed program finds it with no plugin_paths and no GEOBARRIER_PLUGIN_PATH.
#
# Fast by default: the plugin is compiled with the code-generation flags of geobarrier's own built-in plugins
# (GEOBARRIER_PLUGIN_COMPILE_OPTIONS, recorded by the install: -march=native -ffp-contract=off when geobarrier was
# built with GEOBARRIER_NATIVE, the default; -march=<level> -ffp-contract=off for a build with GEOBARRIER_MARCH=<level>,
# e.g. x86-64-v3; none for a baseline build). The SDK's fused Runge-Kutta step then uses the machine's widest vectors
# and its FMA instructions, like the built-ins: without them an out-of-tree plugin runs the flow map slower than the
# same code built in the tree (scripts/bench-plugin-template times the two). A plugin package meant for other
# machines opts out with PORTABLE, or for
# every plugin of the project with -DGEOBARRIER_PLUGIN_NATIVE=OFF.
include_guard(GLOBAL)

option(GEOBARRIER_PLUGIN_NATIVE
  "geobarrier_add_plugin: compile plugins with the code-generation flags of geobarrier's built-in plugins" ON)
if(NOT DEFINED GEOBARRIER_PLUGIN_COMPILE_OPTIONS)
  set(GEOBARRIER_PLUGIN_COMPILE_OPTIONS "")
endif()
# The recorded flags may name an option this project's compiler lacks (another compiler than geobarrier's): keep
# only those it accepts, and say which were dropped.
if(GEOBARRIER_PLUGIN_COMPILE_OPTIONS AND CMAKE_CXX_COMPILER_LOADED)
  include(CheckCXXCompilerFlag)
  set(_geobarrier_accepted "")
  foreach(_flag IN LISTS GEOBARRIER_PLUGIN_COMPILE_OPTIONS)
    string(MAKE_C_IDENTIFIER "GEOBARRIER_CXX_ACCEPTS${_flag}" _var)
    check_cxx_compiler_flag(${_flag} ${_var})
    if(${_var})
      list(APPEND _geobarrier_accepted ${_flag})
    else()
      message(WARNING "geobarrier_add_plugin: the compiler does not accept ${_flag}; plugins are built without it "
                      "and may run slower than geobarrier's built-in plugins")
    endif()
  endforeach()
  set(GEOBARRIER_PLUGIN_COMPILE_OPTIONS ${_geobarrier_accepted})
endif()

function(geobarrier_add_plugin)
  cmake_parse_arguments(P "LINK_CORE;KIT;NO_INSTALL;PORTABLE" "NAME;OUTPUT_DIRECTORY;INSTALL_DESTINATION" "SOURCES"
                        ${ARGN})
  if(P_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "geobarrier_add_plugin: unknown arguments: ${P_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT P_NAME MATCHES "^[a-z0-9][a-z0-9-]*$")
    message(FATAL_ERROR "geobarrier_add_plugin: NAME '${P_NAME}' must match [a-z0-9][a-z0-9-]* (as plugin names do)")
  endif()
  if(NOT P_SOURCES)
    message(FATAL_ERROR "geobarrier_add_plugin(NAME ${P_NAME}): no SOURCES")
  endif()
  if(NOT P_OUTPUT_DIRECTORY)
    set(P_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/plugins)
  endif()
  if(NOT P_INSTALL_DESTINATION)
    set(P_INSTALL_DESTINATION lib/geobarrier/plugins)
  endif()

  set(target geobarrier-${P_NAME})
  add_library(${target} MODULE ${P_SOURCES})
  target_link_libraries(${target} PRIVATE geobarrier::headers)
  if(GEOBARRIER_PLUGIN_NATIVE AND NOT P_PORTABLE)
    target_compile_options(${target} PRIVATE ${GEOBARRIER_PLUGIN_COMPILE_OPTIONS})
  endif()
  if(P_LINK_CORE)
    if(NOT TARGET nlohmann_json::nlohmann_json)
      message(FATAL_ERROR "geobarrier_add_plugin(NAME ${P_NAME} LINK_CORE): geobarrier::core needs the package "
                          "nlohmann_json (its public headers include nlohmann/json.hpp), which was not found: install it "
                          "(Debian: nlohmann-json3-dev) or point CMAKE_PREFIX_PATH at it")
    endif()
    # The SDK then records the core's version in the plugin and the loader insists on it.
    target_link_libraries(${target} PRIVATE geobarrier::core)
  endif()
  if(P_KIT)
    if(NOT TARGET geobarrier::kit OR NOT TARGET nlohmann_json::nlohmann_json OR NOT TARGET OpenMP::OpenMP_CXX)
      message(FATAL_ERROR "geobarrier_add_plugin(NAME ${P_NAME} KIT): geobarrier::kit needs the packages "
                          "nlohmann_json and OpenMP (C++), which were not both found: install them (Debian: "
                          "nlohmann-json3-dev; OpenMP comes with GCC) or point CMAKE_PREFIX_PATH at them")
    endif()
    # Compiled in with its symbols hidden: the plugin never binds to libgeobarrier's copies, and needs no core library.
    target_link_libraries(${target} PRIVATE geobarrier::kit)
    target_link_options(${target} PRIVATE LINKER:--exclude-libs,libgeobarrier_kit.a)
  endif()
  set_target_properties(${target} PROPERTIES
    PREFIX "" OUTPUT_NAME ${target} SUFFIX ".so"
    LIBRARY_OUTPUT_DIRECTORY ${P_OUTPUT_DIRECTORY}
    POSITION_INDEPENDENT_CODE ON
    C_VISIBILITY_PRESET hidden CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
    INSTALL_RPATH_USE_LINK_PATH ON)
  if(NOT P_NO_INSTALL)
    install(TARGETS ${target} LIBRARY DESTINATION ${P_INSTALL_DESTINATION})
  endif()
endfunction()
