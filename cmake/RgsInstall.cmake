# install(EXPORT rgsTargets NAMESPACE rgs::) with config and version files, so consumers can write
# find_package(rgs) and link rgs::format / rgs::converter. samples/ is built against it by a test.
include(CMakePackageConfigHelpers)

set(RGS_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/rgs)
set(rgs_export_targets rgs_format rgs_converter rgs_xxhash)
foreach(t IN ITEMS rgs_kernels_shared rgs_runtime rgs_kernels)
  if(TARGET ${t})
    list(APPEND rgs_export_targets ${t})
  endif()
endforeach()

# The xxHash archive is found at build time; consumers link it by name.
target_link_libraries(rgs_xxhash INTERFACE "$<INSTALL_INTERFACE:xxhash>")

install(TARGETS ${rgs_export_targets} EXPORT rgsTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
foreach(dir IN ITEMS format converter runtime kernels)
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endforeach()
install(FILES ${PROJECT_BINARY_DIR}/generated/rgs/config.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rgs)
install(EXPORT rgsTargets NAMESPACE rgs:: DESTINATION ${RGS_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/rgsConfig.cmake.in
  ${PROJECT_BINARY_DIR}/rgsConfig.cmake INSTALL_DESTINATION ${RGS_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/rgsConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/rgsConfig.cmake ${PROJECT_BINARY_DIR}/rgsConfigVersion.cmake
  DESTINATION ${RGS_CMAKE_DIR})
