# install(EXPORT RoofGSTargets NAMESPACE RoofGS::) with config and version files, so consumers write
# find_package(RoofGS) and link RoofGS::api (or the expert libraries RoofGS::format, ::converter, ::runtime, and
# the asset audit RoofGS::audit).
# tests/cli/install_consumer.cmake builds samples/ against the installed tree.
include(CMakePackageConfigHelpers)

set(RGS_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/RoofGS)
set(rgs_export_targets rgs_format rgs_converter rgs_xxhash rgs_draco)
foreach(t IN ITEMS rgs_kernels_shared rgs_runtime rgs_kernels rgs_api rgs_audit)
  if(TARGET ${t})
    list(APPEND rgs_export_targets ${t})
  endif()
endforeach()

# The xxHash archive is found at build time; consumers link it by name.
target_link_libraries(rgs_xxhash INTERFACE "$<INSTALL_INTERFACE:xxhash>")
set_target_properties(rgs_xxhash PROPERTIES EXPORT_NAME xxhash)
# Likewise the Draco archive (archive codecs of rgs_format).
target_link_libraries(rgs_draco INTERFACE "$<INSTALL_INTERFACE:draco>")
set_target_properties(rgs_draco PROPERTIES EXPORT_NAME draco)

install(TARGETS ${rgs_export_targets} EXPORT RoofGSTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
foreach(dir IN ITEMS format converter runtime kernels api audit)
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
endforeach()
install(FILES ${PROJECT_BINARY_DIR}/generated/rgs/config.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rgs)
install(EXPORT RoofGSTargets NAMESPACE RoofGS:: DESTINATION ${RGS_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RoofGSConfig.cmake.in
  ${PROJECT_BINARY_DIR}/RoofGSConfig.cmake INSTALL_DESTINATION ${RGS_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/RoofGSConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/RoofGSConfig.cmake ${PROJECT_BINARY_DIR}/RoofGSConfigVersion.cmake
  DESTINATION ${RGS_CMAKE_DIR})
