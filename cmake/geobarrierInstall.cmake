# Packaging of an install: the exported targets and find_package(geobarrier CONFIG) files, the installed
# geobarrier_add_plugin() helper, a pkg-config file, and the plugin template and tutorial. Included by the root
# CMakeLists.txt after every target exists.
include(CMakePackageConfigHelpers)

set(GEOBARRIER_INSTALL_CMAKE_DIR lib/cmake/geobarrier)
set(GEOBARRIER_INSTALL_PLUGIN_DIR lib/geobarrier/plugins)
set(GEOBARRIER_INSTALL_BIN_DIR bin)

install(EXPORT geobarrierTargets NAMESPACE geobarrier:: DESTINATION ${GEOBARRIER_INSTALL_CMAKE_DIR}
        FILE geobarrierTargets.cmake)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/geobarrierConfig.cmake.in
  ${PROJECT_BINARY_DIR}/cmake/geobarrierConfig.cmake
  INSTALL_DESTINATION ${GEOBARRIER_INSTALL_CMAKE_DIR}
  PATH_VARS GEOBARRIER_INSTALL_PLUGIN_DIR GEOBARRIER_INSTALL_BIN_DIR)
# 0.x: only the same minor version promises the same C++ API; ABI-only plugins check the ABI at load time anyway.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cmake/geobarrierConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cmake/geobarrierConfig.cmake
        ${PROJECT_BINARY_DIR}/cmake/geobarrierConfigVersion.cmake ${PROJECT_SOURCE_DIR}/cmake/geobarrierPlugin.cmake
        DESTINATION ${GEOBARRIER_INSTALL_CMAKE_DIR})

# The plugin ABI version, read from the header, for the pkg-config file.
file(STRINGS ${PROJECT_SOURCE_DIR}/core/include/geobarrier/abi.h _abi_lines REGEX "#define GB_ABI_VERSION_M(AJ|IN)OR ")
string(REGEX REPLACE ".*MAJOR ([0-9]+)u.*" "\\1" _abi_major "${_abi_lines}")
string(REGEX REPLACE ".*MINOR ([0-9]+)u.*" "\\1" _abi_minor "${_abi_lines}")
set(GEOBARRIER_ABI_VERSION "${_abi_major}.${_abi_minor}")
string(JOIN " " GEOBARRIER_PLUGIN_CFLAGS ${GEOBARRIER_PLUGIN_COMPILE_OPTIONS})
configure_file(${PROJECT_SOURCE_DIR}/cmake/geobarrier.pc.in ${PROJECT_BINARY_DIR}/geobarrier.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/geobarrier.pc DESTINATION lib/pkgconfig)

install(DIRECTORY ${PROJECT_SOURCE_DIR}/examples/plugin-template/ DESTINATION share/geobarrier/plugin-template
        PATTERN "build" EXCLUDE PATTERN "out" EXCLUDE)
# Every document, with the pictures they show: the installed plugins.md links to the experiment format, which links to
# the extractors and the robustness notes, and so on (test_plugin_tutorial checks that every link resolves).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION share/doc/geobarrier FILES_MATCHING PATTERN "*.md")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/images/ DESTINATION share/doc/geobarrier/images)
