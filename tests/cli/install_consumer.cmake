# Installs the build into a scratch prefix, builds samples/ against it with find_package(RoofGS) as an
# outside project would, and runs the samples on a .rgs file: read_scene, and render_frame on the CPU (a
# CUDA build's consumer is built the same way and links the CUDA runtime through RoofGS::runtime; it renders
# on the GPU with DEVICE=cuda on a host with a device).
#   BUILD_DIR, SOURCE_DIR, WORK_DIR, RGS_FILE [, DEVICE (cpu)]
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
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/samples -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/rgs_sample_read_scene ${RGS_FILE})
run(${WORK_DIR}/build/rgs_sample_render_frame ${RGS_FILE} ${DEVICE} ${WORK_DIR}/frame.ppm)
