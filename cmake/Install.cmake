# `cmake --install` layout: the public headers (include/trilevel/*.hpp only), libtrilevel, the
# `trilevel` CLI and a CMake package, so that a simulator can do
#   find_package(trilevel 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE trilevel::trilevel)
include(CMakePackageConfigHelpers)

set(TRILEVEL_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/trilevel)

# A shared build gets libtrilevel.so.0 (ABI follows the major version, like the package version).
set_target_properties(trilevel PROPERTIES VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR})
install(TARGETS trilevel EXPORT trilevelTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS trilevel_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# A shared libtrilevel is found next to the installed CLI wherever the prefix is moved.
set_target_properties(trilevel_cli PROPERTIES INSTALL_RPATH $ORIGIN/../${CMAKE_INSTALL_LIBDIR})
# Only the public interface: src/ and host/ headers are private and never installed.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/trilevel DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.hpp")

install(EXPORT trilevelTargets NAMESPACE trilevel:: DESTINATION ${TRILEVEL_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/trilevelConfig.cmake.in
  ${PROJECT_BINARY_DIR}/generated/trilevelConfig.cmake INSTALL_DESTINATION ${TRILEVEL_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/generated/trilevelConfigVersion.cmake
  COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/generated/trilevelConfig.cmake
  ${PROJECT_BINARY_DIR}/generated/trilevelConfigVersion.cmake DESTINATION ${TRILEVEL_CMAKE_DIR})
