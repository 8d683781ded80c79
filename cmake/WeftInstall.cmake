# Install rules and an exported package: a user's project does
#   find_package(weft CONFIG REQUIRED)   target_link_libraries(app PRIVATE weft::weft_graph)
# linking the module target of each module it imports: CMake builds a consumer's BMIs only
# for module targets linked directly (and what they link), not through the INTERFACE umbrella
# weft::weft. tests/consumer/ (ctest -R test_consumer) installs and builds such a project.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
get_property(weft_libs GLOBAL PROPERTY WEFT_LIBRARIES)
install(TARGETS weft ${weft_libs} EXPORT weftTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  FILE_SET CXX_MODULES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/weft/modules
  CXX_MODULES_BMI DESTINATION ${CMAKE_INSTALL_LIBDIR}/weft/bmi)
install(EXPORT weftTargets NAMESPACE weft:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/weft
  CXX_MODULES_DIRECTORY modules)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/weftConfig.cmake.in
  ${PROJECT_BINARY_DIR}/weftConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/weft
  PATH_VARS CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/weftConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/weftConfig.cmake ${PROJECT_BINARY_DIR}/weftConfigVersion.cmake
  ${PROJECT_SOURCE_DIR}/cmake/WeftShaders.cmake DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/weft)
# weft_add_shaders for plugins built out of tree, and the GLSL their shaders include.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/shaders/ DESTINATION ${CMAKE_INSTALL_DATADIR}/weft/shaders)
