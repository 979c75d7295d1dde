# Installs the build into a scratch prefix, builds samples/ against it with find_package(RoofGS) as an
# outside project would, and runs the samples on a .rgs file: read_scene, and render_frame on the CPU (a
# CUDA build's consumer is built the same way and links the CUDA runtime through RoofGS::runtime; it renders
# on the GPU with DEVICE=cuda on a host with a device).
#   BUILD_DIR, SOURCE_DIR, WORK_DIR, RGS_FILE, CXX (the C++ compiler) [, DEVICE (cpu), CUDA_INCLUDE (-I of the CUDA
#   headers in a CUDA build)]
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
  message("${out}")
endfunction()
if(NOT DEVICE)
  set(DEVICE cpu)
endif()
file(REMOVE_RECURSE ${WORK_DIR})
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
# The installed surface: at most 8 front-door headers, and every installed header compiles on its own against
# the installed tree (nothing it includes was left out).
file(GLOB api_headers ${WORK_DIR}/prefix/include/rgs/api/*.h)
list(LENGTH api_headers api_count)
if(api_count GREATER 8)
  message(FATAL_ERROR "${api_count} front-door headers installed (at most 8): ${api_headers}")
endif()
file(GLOB_RECURSE installed_headers RELATIVE ${WORK_DIR}/prefix/include ${WORK_DIR}/prefix/include/rgs/*.h)
list(LENGTH installed_headers header_count)
foreach(h IN LISTS installed_headers)
  file(WRITE ${WORK_DIR}/alone.cpp "#include \"${h}\"\n")
  run(${CXX} -std=c++17 -fsyntax-only -I${WORK_DIR}/prefix/include ${CUDA_INCLUDE} ${WORK_DIR}/alone.cpp)
endforeach()
message("installed headers: ${header_count}, of them ${api_count} front-door headers, each compiling alone")
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/samples -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/rgs_sample_read_scene ${RGS_FILE})
run(${WORK_DIR}/build/rgs_sample_render_frame ${RGS_FILE} ${DEVICE} ${WORK_DIR}/frame.ppm)
