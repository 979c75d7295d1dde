# Memory follows what a file proves (format/SPEC.md §5.5), checked on the tools themselves.
#
# Included from tests/cli/CMakeLists.txt, this file registers the cases. Run with -P (one case), it finds
# the tool's baseline address space (the smallest multiple of 16 MiB in which `TOOL --help` runs: shared
# libraries such as OpenImageIO's take hundreds of MiB of it), then runs `prlimit --as=<baseline + 64 MiB>
# TOOL ARGS...` and checks the exit code and output. So a pass means: the tool allocated less than 64 MiB
# beyond its baseline, or reported the failed allocation as kOutOfMemory with exit 1 (never SIGABRT).
#   TOOL, ARGS ('|'-separated), EXPECT_EXIT, EXPECT_REGEX, PRLIMIT, HEADROOM_MIB (default 64);
#   STDIN_PLY (a file written first and given as standard input: an ascii PLY declaring STDIN_PLY_VERTICES
#   vertices and holding STDIN_PLY_ROWS rows of 14 zeros)
if(CMAKE_SCRIPT_MODE_FILE)
  if(NOT HEADROOM_MIB)
    set(HEADROOM_MIB 64)
  endif()
  set(baseline 0)
  foreach(mib RANGE 16 4096 16)
    math(EXPR bytes "${mib} * 1048576")
    execute_process(COMMAND ${PRLIMIT} --as=${bytes} ${TOOL} --help RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
    if(rc EQUAL 0)
      set(baseline ${mib})
      break()
    endif()
  endforeach()
  if(baseline EQUAL 0)
    message(FATAL_ERROR "${TOOL} --help does not run in 4 GiB of address space")
  endif()
  math(EXPR limit "${baseline} + ${HEADROOM_MIB}")
  math(EXPR limit_bytes "${limit} * 1048576")
  string(REPLACE "|" ";" args "${ARGS}")
  set(stdin_args)
  if(STDIN_PLY)
    set(header "ply\nformat ascii 1.0\nelement vertex ${STDIN_PLY_VERTICES}\n")
    foreach(p x y z f_dc_0 f_dc_1 f_dc_2 opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3)
      string(APPEND header "property float ${p}\n")
    endforeach()
    string(REPEAT "0 0 0 0 0 0 0 0 0 0 0 0 0 0\n" ${STDIN_PLY_ROWS} rows)
    file(WRITE ${STDIN_PLY} "${header}end_header\n${rows}")
    set(stdin_args INPUT_FILE ${STDIN_PLY})
  endif()
  execute_process(COMMAND ${PRLIMIT} --as=${limit_bytes} ${TOOL} ${args} ${stdin_args}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("address space ${limit} MiB (baseline ${baseline} + ${HEADROOM_MIB})\n"
          "exit ${rc}\n--- stdout\n${out}--- stderr\n${err}")
  if(NOT "${rc}" STREQUAL "${EXPECT_EXIT}")
    message(FATAL_ERROR "expected exit ${EXPECT_EXIT}, got ${rc}")
  endif()
  if(EXPECT_REGEX AND NOT "${out}${err}" MATCHES "${EXPECT_REGEX}")
    message(FATAL_ERROR "output does not match '${EXPECT_REGEX}'")
  endif()
  return()
endif()

# Files built by tests/format/memory_corpus.h (test_format checks they are up to date):
#   rle:   65 KB, valid, 2^26 Gaussians in zstd RLE frames (32768:1), 2 GB decoded
#   bogus: 254 KB, 2^28 Gaussians, every runtime frame fails after its first 128 KiB block
set(memory_rle ${bad}/memory/zstd_rle_2p26_gaussians.rgs)
set(memory_bogus ${bad}/memory/zstd_bogus_frames_2p28_gaussians.rgs)
find_program(RGS_PRLIMIT prlimit)

# rgs_memory_case(<name> TOOL <exe> ARGS <a|b> EXIT <n> REGEX <re>)
function(rgs_memory_case name)
  cmake_parse_arguments(ARG "" "TOOL;ARGS;EXIT;REGEX" "" ${ARGN})
  add_test(NAME cli.memory.${name}
    COMMAND ${CMAKE_COMMAND} -DTOOL=${ARG_TOOL} "-DARGS=${ARG_ARGS}" -DEXPECT_EXIT=${ARG_EXIT}
            "-DEXPECT_REGEX=${ARG_REGEX}" -DPRLIMIT=${RGS_PRLIMIT} -P ${CMAKE_CURRENT_LIST_DIR}/memory_limits.cmake)
  set_tests_properties(cli.memory.${name} PROPERTIES LABELS "cli;memory;slow" TIMEOUT 300)
endfunction()

if(RGS_SANITIZE)
  # AddressSanitizer reserves terabytes of address space for its shadow memory, so no --as limit lets a tool
  # start: the cases run in the plain build, and this one says so where the suite reports what it skipped.
  add_test(NAME cli.memory.skipped_under_sanitizers
    COMMAND ${CMAKE_COMMAND} -E echo "skipped: cli.memory.* (prlimit --as cannot apply under AddressSanitizer)")
  set_tests_properties(cli.memory.skipped_under_sanitizers PROPERTIES LABELS "cli;memory"
    SKIP_REGULAR_EXPRESSION "^skipped: ")
elseif(NOT RGS_PRLIMIT)
  message(STATUS "prlimit not found: the cli.memory.* address-space tests are not registered")
else()
  set(ratio_limit "decompression-ratio limit of 8 x 1048576 bytes.*\\[kLimitExceeded\\]")
  set(raise "--max-decompression-ratio|32768")
  # Default limits: every tool refuses the 65 KB file before allocating anything sized by it.
  rgs_memory_case(convert_rle TOOL ${convert} ARGS "${memory_rle}|${cli_dir}/memory_rle.ply" EXIT 1
    REGEX "rgs-convert: error: .*zstd_rle_2p26_gaussians.rgs: .*${ratio_limit}")
  rgs_memory_case(info_rle TOOL ${info} ARGS "--check|${memory_rle}" EXIT 1 REGEX "rgs-info: error: .*${ratio_limit}")
  rgs_memory_case(render_rle TOOL ${render}
    ARGS "${memory_rle}|--backend|cpu|--orbit|1|--width|64|--height|36|-o|${cli_dir}/memory_render" EXIT 1
    REGEX "rgs-render: error: .*${ratio_limit}")
  rgs_memory_case(audit_rle TOOL ${audit} ARGS "${sample}|${memory_rle}|--orbit|1|--width|64|--height|36" EXIT 1
    REGEX "rgs-audit: error: .*${ratio_limit}")
  # Limit raised to zstd's own 32768:1: --check streams the valid file in bounded memory; the tools that
  # need it decoded report the failed allocation as kOutOfMemory, exit 1.
  rgs_memory_case(info_rle_raised TOOL ${info} ARGS "--check|${raise}|${memory_rle}" EXIT 0 REGEX "check +ok")
  # Rate control's views too large for memory: kOutOfMemory naming the input and the view, not a worker thread.
  rgs_memory_case(convert_rate_control_huge_view TOOL ${convert}
    ARGS "${PROJECT_SOURCE_DIR}/tests/fuzz/corpus/ply_read/guitar32_le.ply|${cli_dir}/memory_fit.rgs|--target-psnr|30|--orbit|1|--width|32768|--height|32768"
    EXIT 1 REGEX "guitar32_le.ply: out of memory rendering view orbit_000 at 32768x32768 \\(12.88 GB for its RGB image alone\\) \\[kOutOfMemory\\]")
  rgs_memory_case(convert_rle_raised TOOL ${convert} ARGS "${raise}|${memory_rle}|${cli_dir}/memory_rle.ply" EXIT 1
    REGEX "rgs-convert: error: .*zstd_rle_2p26_gaussians.rgs.*\\[kOutOfMemory\\]")
  rgs_memory_case(render_rle_raised TOOL ${render}
    ARGS "${memory_rle}|${raise}|--backend|cpu|--orbit|1|--width|64|--height|36|-o|${cli_dir}/memory_render" EXIT 1
    REGEX "rgs-render: error: .*\\[kOutOfMemory\\]")
  rgs_memory_case(audit_rle_raised TOOL ${audit}
    ARGS "${sample}|${memory_rle}|${raise}|--orbit|1|--width|64|--height|36" EXIT 1
    REGEX "rgs-audit: error: .*\\[kOutOfMemory\\]")
  # A few more Gaussians than the ratio limit allows, but --max-gaussians below the count: refused by it.
  rgs_memory_case(info_rle_max_gaussians TOOL ${info} ARGS "--check|${raise}|--max-gaussians|1000000|${memory_rle}"
    EXIT 1 REGEX "67108864 Gaussians exceed the limit of 1000000 .a file you trust reads with a higher max_gaussians: --max-gaussians. \\[kLimitExceeded\\]")
  # Bogus frames claiming 2^28 Gaussians (8 GB): corrupt, found while streaming, with either limit.
  foreach(limits IN ITEMS default raised)
    if(limits STREQUAL "raised")
      set(extra "${raise}|")
      set(expect "section 1 \\(means\\).*\\[kCorruptData\\]")
    else()
      set(extra "")
      set(expect "${ratio_limit}")
    endif()
    rgs_memory_case(convert_bogus_${limits} TOOL ${convert} ARGS "${extra}${memory_bogus}|${cli_dir}/memory_bogus.ply"
      EXIT 1 REGEX "rgs-convert: error: .*zstd_bogus_frames_2p28_gaussians.rgs: .*${expect}")
    rgs_memory_case(info_bogus_${limits} TOOL ${info} ARGS "--check|${extra}${memory_bogus}" EXIT 1
      REGEX "rgs-info: error: .*${expect}")
    rgs_memory_case(render_bogus_${limits} TOOL ${render}
      ARGS "${extra}${memory_bogus}|--backend|cpu|--orbit|1|--width|64|--height|36|-o|${cli_dir}/memory_render"
      EXIT 1 REGEX "rgs-render: error: .*${expect}")
  endforeach()
  # Scenes of the other formats (tests/data/hostile, make_hostile_corpus.py), under the same ratio limit:
  # valid ones expanding past it are kLimitExceeded, declared sizes their bytes cannot hold kLimitExceeded or
  # kCorruptData, all before allocating.
  foreach(bomb IN ITEMS glb/instanced_40m.glb sog_solid_33m sog_bundle/solid_33m.sog spz/v4_rle_16m.spz
                        spz/v3_gzip_1m.spz)
    string(REGEX REPLACE "[/.]" "_" name "${bomb}")
    get_filename_component(file "${bomb}" NAME)
    rgs_memory_case(convert_${name} TOOL ${convert} ARGS "${hostile}/${bomb}|${cli_dir}/memory_${name}.ply" EXIT 1
      REGEX "rgs-convert: error: .*${file}.*\\[kLimitExceeded\\]")
  endforeach()
  foreach(bomb IN ITEMS gltf/bytelength_3gib.gltf gltf/no_bufferview_40m.gltf sog/count_40m.json
                        sog_bundle/entry_deflate_1gib.sog sog_bundle/entry_stored_1gib.sog spz/v4_garbage_40m.spz)
    string(REGEX REPLACE "[/.]" "_" name "${bomb}")
    get_filename_component(file "${bomb}" NAME)
    rgs_memory_case(convert_${name} TOOL ${convert} ARGS "${hostile}/${bomb}|${cli_dir}/memory_${name}.ply" EXIT 1
      REGEX "rgs-convert: error: .*${file}.*\\[k(LimitExceeded|CorruptData)\\]")
  endforeach()
endif()

# A PLY on standard input is held to --max-gaussians from its header, before its body is read: 24 MiB of
# rows declaring 2^28 + 1 vertices within 16 MiB of address space.
if(RGS_PRLIMIT AND NOT RGS_SANITIZE)
  add_test(NAME cli.memory.convert_stdin_ply_over_max_gaussians
    COMMAND ${CMAKE_COMMAND} -DTOOL=${convert} "-DARGS=-|${cli_dir}/memory_stdin.rgs" -DEXPECT_EXIT=1
            "-DEXPECT_REGEX=rgs-convert: error: -: PLY declares 268435457 vertices, above the limit of 268435456 .refused from its header, before its data is read. .kLimitExceeded."
            -DPRLIMIT=${RGS_PRLIMIT} -DHEADROOM_MIB=16 -DSTDIN_PLY=${cli_dir}/memory_stdin_2p28.ply
            -DSTDIN_PLY_VERTICES=268435457 -DSTDIN_PLY_ROWS=900000 -P ${CMAKE_CURRENT_LIST_DIR}/memory_limits.cmake)
  set_tests_properties(cli.memory.convert_stdin_ply_over_max_gaussians PROPERTIES LABELS "cli;memory;slow" TIMEOUT 300)
endif()

# --max-gaussians below a real scene's count.
rgs_cli_case(memory_max_gaussians
  CMD "${render}|--max-gaussians|1000|${cli_dir}/guitar.rgs|--orbit|1|-o|${cli_dir}/memory_max"
  EXIT 1 REGEX "guitar.rgs: 90854 Gaussians exceed the limit of 1000 .a file you trust reads with a higher max_gaussians: --max-gaussians. \\[kLimitExceeded\\]" REQUIRES guitar_rgs)
rgs_cli_case(memory_max_gaussians_help CMD "${info}|--help" REGEX "--max-gaussians.*--max-decompression-ratio")

# --memory-limit: an input whose estimated peak is above it is refused before it is read, the output untouched,
# unless it is a binary PLY converted with levels of detail, which is built out of core (and refused when the
# limit cannot hold one chunk's build); with room, the level-of-detail file is written and checks; values that
# are no size are usage errors.
set(interop_spz ${PROJECT_SOURCE_DIR}/tests/data/interop/guitar_256_splat_transform_v4.spz)
rgs_cli_case(convert_memory_limit_refused
  CMD "${convert}|${interop_spz}|${cli_dir}/memory_limit_refused.rgs|--lod-levels|auto|--memory-limit|16MiB" EXIT 1
  REGEX "guitar_256_splat_transform_v4.spz: converting it is estimated to need [0-9.]+ MiB of memory, above the memory limit of 16.0 MiB \\(the input is read whole: only a binary PLY converted with levels of detail is read in batches\\). raise it with memory_limit \\(--memory-limit\\) \\[kLimitExceeded\\]"
  GUARD ${cli_dir}/memory_limit_refused.rgs)
if(NOT RGS_SANITIZE)
  rgs_cli_case(convert_out_of_core
    CMD "${convert}|${sample}|${cli_dir}/out_of_core.rgs|--lod-levels|auto|--lod-chunk|4096|--memory-limit|72MiB"
    REGEX "built out of core: 1 partition of at most [0-9,]+ Gaussians in a memory limit of 75,497,472 bytes"
    OUTPUT ${cli_dir}/out_of_core.rgs SETUP out_of_core)
  rgs_cli_case(convert_out_of_core_checks CMD "${info}|--check|${cli_dir}/out_of_core.rgs"
    REGEX "check +ok" REQUIRES out_of_core)
  # Another process rewrites the PLY while the out-of-core build reads it in passes: exit 1 naming the change, or
  # exit 0 with the file of one of the two versions; never a signal, never a mixed file.
  add_test(NAME cli.convert_out_of_core_input_rewritten
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/test_out_of_core_rewrite.py ${convert} ${sample}
            ${cli_dir}/out_of_core_rewrite 40)
  set_tests_properties(cli.convert_out_of_core_input_rewritten PROPERTIES LABELS "cli;memory;slow" TIMEOUT 600)
  # Standard input is held whole: endless streams stop at what --memory-limit allows a PLY read whole, in memory
  # below the limit.
  add_test(NAME cli.convert_stdin_memory_limit
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/test_stdin_memory_limit.py ${convert}
            ${cli_dir}/stdin_memory_limit)
  set_tests_properties(cli.convert_stdin_memory_limit PROPERTIES LABELS "cli;memory" TIMEOUT 300)
else()
  # The limit bounds the whole process, and a sanitized rgs-convert holds more than 72 MiB before it converts.
  add_test(NAME cli.convert_out_of_core.skipped_under_sanitizers
    COMMAND ${CMAKE_COMMAND} -E echo "skipped: cli.convert_out_of_core, cli.convert_out_of_core_input_rewritten and \
cli.convert_stdin_memory_limit and cli.edit_lod_out_of_core (a sanitized tool holds more than its limit)")
  set_tests_properties(cli.convert_out_of_core.skipped_under_sanitizers PROPERTIES LABELS cli
    SKIP_REGULAR_EXPRESSION "^skipped: ")
endif()
rgs_cli_case(convert_out_of_core_too_small
  CMD "${convert}|${sample}|${cli_dir}/out_of_core_small.rgs|--lod-levels|auto|--memory-limit|16MiB" EXIT 1
  REGEX "guitar.ply: the out-of-core build has [0-9]+ bytes of memory, below the [0-9]+ that chunks of 65536 Gaussians need. raise the memory limit .--memory-limit. or make the chunks smaller .--lod-chunk. \\[kLimitExceeded\\]"
  GUARD ${cli_dir}/out_of_core_small.rgs)
rgs_cli_case(convert_memory_limit_room
  CMD "${convert}|-q|${sample}|${cli_dir}/memory_limit_room.rgs|--lod-levels|auto|--memory-limit|1GiB"
  OUTPUT ${cli_dir}/memory_limit_room.rgs SETUP memory_limit_room)
rgs_cli_case(convert_memory_limit_room_checks CMD "${info}|--check|${cli_dir}/memory_limit_room.rgs"
  REGEX "check +ok" REQUIRES memory_limit_room)
foreach(value IN ITEMS 0 -1 4x 1.5GiB 18446744073709551616)
  string(MAKE_C_IDENTIFIER "${value}" value_name)
  rgs_cli_case(convert_memory_limit_bad_${value_name}
    CMD "${convert}|${sample}|${cli_dir}/memory_limit_bad_${value_name}.rgs|--memory-limit|${value}" EXIT 2
    REGEX "rgs-convert: error: --memory-limit: " ABSENT ${cli_dir}/memory_limit_bad_${value_name}.rgs)
endforeach()

# scripts/make_big_scene.py (docs/LOD.md#scenes-larger-than-memory): the sample tiled twice, streaming, converts
# with levels of detail to twice its Gaussians; without its arguments it prints its usage, exit 2.
rgs_cli_case(make_big_scene_tiles
  CMD "${Python3_EXECUTABLE}|${PROJECT_SOURCE_DIR}/scripts/make_big_scene.py|${sample}|${cli_dir}/guitar_x2.ply|2"
  REGEX "guitar_x2.ply: 181708 Gaussians \\(2 copies of " OUTPUT ${cli_dir}/guitar_x2.ply SETUP guitar_x2)
rgs_cli_case(make_big_scene_converts
  CMD "${convert}|${cli_dir}/guitar_x2.ply|${cli_dir}/guitar_x2_lod.rgs|--lod-levels|auto|--memory-limit|1GiB"
  REGEX "gaussians +181,708 .*levels of detail" OUTPUT ${cli_dir}/guitar_x2_lod.rgs REQUIRES guitar_x2)
rgs_cli_case(make_big_scene_usage CMD "${Python3_EXECUTABLE}|${PROJECT_SOURCE_DIR}/scripts/make_big_scene.py|${sample}"
  EXIT 2 REGEX "Usage: scripts/make_big_scene.py SOURCE.ply OUTPUT.ply COPIES")

# Every loading path applies the value rules of SPEC §4.3-4.6: the CPU render and the audit refuse files
# whose checksums are valid but whose values are not (as rgs-convert and rgs-info --check do above).
foreach(name IN ITEMS nan_mean zero_rotation negative_linear_scale opacity_above_one)
  rgs_cli_case(values_render_${name}
    CMD "${render}|${bad}/${name}.rgs|--backend|cpu|--orbit|1|--width|64|--height|36|-o|${cli_dir}/values_${name}"
    EXIT 1 REGEX "rgs-render: error: .*${name}.rgs: section [0-9]+ \\([a-z]+\\): Gaussian [0-9]+: .*\\[kCorruptData\\]")
  rgs_cli_case(values_audit_${name} CMD "${audit}|${sample}|${bad}/${name}.rgs|--orbit|1|--width|64|--height|36"
    EXIT 1 REGEX "rgs-audit: error: .*${name}.rgs: section [0-9]+ \\([a-z]+\\): Gaussian [0-9]+: .*\\[kCorruptData\\]")
endforeach()
