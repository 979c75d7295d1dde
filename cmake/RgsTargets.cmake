# Per-target build settings: warnings, sanitizers, and the common shape of every RoofGS library.
function(rgs_set_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion>)
  if(RGS_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>)
  endif()
endfunction()

if(RGS_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# RGS_BUILD_FUZZERS (clang only): every C/C++ target, the libraries included, is built with ASan + UBSan and
# libFuzzer's coverage instrumentation without its main (-fsanitize=fuzzer-no-link), so the fuzzers are
# guided by the edges of the parsers and decoders and not only by those of their harness. tests/fuzz links
# the fuzz_* executables with -fsanitize=fuzzer; the replay executables get the sanitizer runtimes only.
if(RGS_BUILD_FUZZERS)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "RGS_BUILD_FUZZERS needs clang (libFuzzer): configure with CC=clang CXX=clang++")
  endif()
  add_compile_options(
    "$<$<COMPILE_LANGUAGE:C,CXX>:-fsanitize=fuzzer-no-link,address,undefined;-fno-omit-frame-pointer>"
    "$<$<COMPILE_LANGUAGE:C,CXX>:-fno-sanitize-recover=undefined>")
  add_link_options(-fsanitize=address,undefined)
endif()

# rgs_add_library(<layer> SOURCES <files...>): the library rgs_<layer> with alias rgs::<layer>, C++17,
# position-independent, include/ public (build and install interfaces) and src/ private, project warnings.
function(rgs_add_library layer)
  cmake_parse_arguments(ARG "" "" "SOURCES" ${ARGN})
  set(target rgs_${layer})
  add_library(${target} ${ARG_SOURCES})
  add_library(rgs::${layer} ALIAS ${target})
  target_compile_features(${target} PUBLIC cxx_std_17)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON EXPORT_NAME ${layer})
  target_include_directories(${target}
    PUBLIC
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE src)
  rgs_set_warnings(${target})
endfunction()
