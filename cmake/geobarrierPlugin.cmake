# geobarrier_add_plugin() for projects outside the geobarrier source tree (installed with the CMake package and
# included by find_package(geobarrier CONFIG)). Same call as inside the tree:
#
#   geobarrier_add_plugin(NAME name SOURCES file.cpp ...
#                         [LINK_CORE]                  link geobarrier::core (extractors using its C++ API)
#                         [OUTPUT_DIRECTORY dir]       default: ${CMAKE_BINARY_DIR}/plugins
#                         [INSTALL_DESTINATION dir]    default: lib/geobarrier/plugins under the install prefix
#                         [NO_INSTALL])
#
# builds target geobarrier-<name> as a loadable module geobarrier-<name>.so: C++17, position-independent, hidden
# visibility (only the GEOBARRIER_PLUGINS entry point is exported). Installing it into geobarrier's own prefix
# puts it where the installed program finds it with no plugin_paths and no GEOBARRIER_PLUGIN_PATH.
include_guard(GLOBAL)

function(geobarrier_add_plugin)
  cmake_parse_arguments(P "LINK_CORE;NO_INSTALL" "NAME;OUTPUT_DIRECTORY;INSTALL_DESTINATION" "SOURCES" ${ARGN})
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
  if(P_LINK_CORE)
    # The SDK then records the core's version in the plugin and the loader insists on it.
    target_link_libraries(${target} PRIVATE geobarrier::core)
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
