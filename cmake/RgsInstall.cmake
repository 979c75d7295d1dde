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
# Headers: the front door (rgs/api/*.h), the audit's, those the samples include, and every header they include,
# found by following the #include "rgs/..." lines. A header only tests, benchmarks or the lab use is not installed.
set(_rgs_header_roots format converter runtime kernels api audit)
file(GLOB _rgs_install_queue RELATIVE ${PROJECT_SOURCE_DIR}/api/include ${PROJECT_SOURCE_DIR}/api/include/rgs/api/*.h)
file(GLOB _rgs_audit_headers RELATIVE ${PROJECT_SOURCE_DIR}/audit/include ${PROJECT_SOURCE_DIR}/audit/include/rgs/audit/*.h)
file(STRINGS ${PROJECT_SOURCE_DIR}/samples/read_scene.cpp _rgs_sample_includes REGEX "^#include \"rgs/")
file(STRINGS ${PROJECT_SOURCE_DIR}/samples/render_frame.cpp _rgs_sample_includes2 REGEX "^#include \"rgs/")
list(APPEND _rgs_install_queue ${_rgs_audit_headers})
foreach(line IN LISTS _rgs_sample_includes _rgs_sample_includes2)
  string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" h "${line}")
  list(APPEND _rgs_install_queue ${h})
endforeach()
set(_rgs_installed_headers)
while(_rgs_install_queue)
  list(POP_FRONT _rgs_install_queue h)
  if(h IN_LIST _rgs_installed_headers)
    continue()
  endif()
  set(_found "")
  foreach(lib IN LISTS _rgs_header_roots)
    if(EXISTS ${PROJECT_SOURCE_DIR}/${lib}/include/${h})
      set(_found ${PROJECT_SOURCE_DIR}/${lib}/include/${h})
    endif()
  endforeach()
  if(NOT _found)
    continue()  # rgs/config.h, generated below
  endif()
  list(APPEND _rgs_installed_headers ${h})
  file(STRINGS ${_found} _cuda_include REGEX "^#include <cuda_runtime_api.h>")
  if(_cuda_include AND NOT RGS_WITH_CUDA)
    continue()  # a GPU header (audit's CUDA metrics) in a build without CUDA
  endif()
  get_filename_component(_dir ${h} DIRECTORY)
  install(FILES ${_found} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/${_dir})
  file(STRINGS ${_found} _includes REGEX "^#include \"rgs/")
  foreach(line IN LISTS _includes)
    string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" inc "${line}")
    list(APPEND _rgs_install_queue ${inc})
  endforeach()
endwhile()
install(FILES ${PROJECT_BINARY_DIR}/generated/rgs/config.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rgs)
install(EXPORT RoofGSTargets NAMESPACE RoofGS:: DESTINATION ${RGS_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RoofGSConfig.cmake.in
  ${PROJECT_BINARY_DIR}/RoofGSConfig.cmake INSTALL_DESTINATION ${RGS_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/RoofGSConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/RoofGSConfig.cmake ${PROJECT_BINARY_DIR}/RoofGSConfigVersion.cmake
  DESTINATION ${RGS_CMAKE_DIR})
