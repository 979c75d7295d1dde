# One file, one image: samples/guitar.ply and the .rgs rgs-convert writes from it render to the same bytes on
# the CPU with the same preset and camera, through every route that loads a scene (api::load: a PLY is
# quantized in memory as rgs-convert writes it):
#   - rgs-render (--orbit 1, --format ppm): the PLY's image equals the .rgs's;
#   - the C++ sample render_frame (its own OpenGL camera): the PLY's image equals the .rgs's;
#   - Python (roofgs.load(...).render(..., format="rgba8") of the same orbit camera): both equal rgs-render's
#     PPM pixels; skipped, with the reason printed, without the module or NumPy.
#   - rgs-audit (--save-renders, the faithful preset of every audit): its render of the .rgs equals rgs-render's
#     faithful image of the .rgs and of the PLY (its source render is the unquantized baseline, so not compared);
#   CONVERT, RENDER, AUDIT, SAMPLE, PLY, WORK_DIR [, PYTHON, PYTHON_MODULE_DIR]
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
endfunction()
function(expect_same a b what)
  file(SHA256 ${a} ha)
  file(SHA256 ${b} hb)
  if(NOT ha STREQUAL hb)
    message(FATAL_ERROR "${what}: ${a} and ${b} differ")
  endif()
  message("same bytes: ${what}")
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(rgs ${WORK_DIR}/guitar.rgs)
run(${CONVERT} ${PLY} ${rgs})

foreach(input IN ITEMS ply rgs)
  if(input STREQUAL ply)
    set(file ${PLY})
  else()
    set(file ${rgs})
  endif()
  run(${RENDER} ${file} --backend cpu --preset fastest --orbit 1 --width 160 --height 90 --format ppm
      -o ${WORK_DIR}/render_${input})
  file(GLOB ppm ${WORK_DIR}/render_${input}/*.ppm)
  list(LENGTH ppm count)
  if(NOT count EQUAL 1)
    message(FATAL_ERROR "rgs-render wrote ${count} PPM files in ${WORK_DIR}/render_${input}")
  endif()
  set(render_${input} ${ppm})
  run(${RENDER} ${file} --backend cpu --preset faithful --orbit 1 --width 160 --height 90 --format ppm
      -o ${WORK_DIR}/faithful_${input})
  if(SAMPLE)
    run(${SAMPLE} ${file} cpu ${WORK_DIR}/sample_${input}.ppm)
  endif()
endforeach()
expect_same(${render_ply} ${render_rgs} "rgs-render of the PLY and of its .rgs")
expect_same(${WORK_DIR}/faithful_ply/orbit_000.ppm ${WORK_DIR}/faithful_rgs/orbit_000.ppm
            "rgs-render --preset faithful of the PLY and of its .rgs")
run(${AUDIT} ${PLY} ${rgs} --label converted --backend cpu --orbit 1 --width 160 --height 90 --no-report --quiet
    --save-renders ${WORK_DIR}/audit --format ppm)
expect_same(${WORK_DIR}/audit/converted/orbit_000.ppm ${WORK_DIR}/faithful_rgs/orbit_000.ppm
            "rgs-audit's render of the .rgs and rgs-render's (faithful)")
if(SAMPLE)
  expect_same(${WORK_DIR}/sample_ply.ppm ${WORK_DIR}/sample_rgs.ppm "render_frame of the PLY and of its .rgs")
else()
  message("skipped: render_frame (samples not built: RGS_BUILD_SAMPLES=OFF)")
endif()

if(NOT PYTHON OR NOT PYTHON_MODULE_DIR OR NOT EXISTS ${PYTHON_MODULE_DIR})
  message("skipped: Python (the roofgs module is not built)")
  return()
endif()
file(WRITE ${WORK_DIR}/render.py [=[
import sys
try:
    import numpy  # noqa: F401  (the module returns images as NumPy arrays)
except ImportError:
    print("skipped: Python (no NumPy)")
    sys.exit(0)
import roofgs
ply, rgs, reference = sys.argv[1:4]
with open(reference, "rb") as f:
    data = f.read()
header = data.split(b"\n", 3)  # P6, width height, 255, pixels
expected = header[3]
for path in (ply, rgs):
    scene = roofgs.load(path, device="cpu")
    camera = scene.orbit_cameras(1, 160, 90)[0]
    image = scene.render(camera, preset="fastest", format="rgba8")
    got = numpy.asarray(image)[..., :3].astype(numpy.uint8).tobytes()
    if got != expected:
        print(f"Python render of {path} differs from rgs-render's {reference}")
        sys.exit(1)
print("same bytes: Python renders of the PLY and of its .rgs and rgs-render's")
]=])
execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${PYTHON_MODULE_DIR}
                        ${PYTHON} ${WORK_DIR}/render.py ${PLY} ${rgs} ${render_ply}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "Python: ${out}\n${err}")
endif()
