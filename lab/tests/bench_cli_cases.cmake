# rgs-bench's command-line cases, included by tests/cli/CMakeLists.txt (its rgs_cli_case, cli_dir and the
# guitar_rgs fixture) when the lab is built with CUDA: argument checks need no GPU; a run needs one (else the
# reason, exit 1).
set(bench $<TARGET_FILE:rgs-bench>)
rgs_cli_case(bench_help CMD "${bench}|--help"
  REGEX "roofline.*--resolution.*--warmup.*--repeat.*--mode.*baseline.*--replicate.*--json")
rgs_cli_case(bench_bad_resolution CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--resolution|1920by1080" EXIT 2
  REGEX "--resolution: resolution '1920by1080' is not WIDTHxHEIGHT")
rgs_cli_case(bench_zero_resolution CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--resolution|0x1080" EXIT 2
  REGEX "resolution '0x1080' is not WIDTHxHEIGHT with sides in \\[1, 32768\\]")
rgs_cli_case(bench_unknown_mode CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--mode|roofgs+" EXIT 2
  REGEX "--mode: roofgs\\+ not in")
rgs_cli_case(bench_no_views CMD "${bench}|${cli_dir}/guitar.rgs" EXIT 2 REGEX "one of --cameras, --orbit or --path")
rgs_cli_case(bench_run
  CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--resolution|160x90|--warmup|1|--repeat|2|--json|${cli_dir}/bench.json"
  EXIT 1 REGEX "rgs-bench: error: no usable CUDA device"
  ALT_EXIT 0 ALT_REGEX "faithful +160x90 +[0-9.]+ +[0-9.]+ +[0-9.]+ +[0-9.]+ +[0-9.]+ +[0-9.]+ +[0-9,]+.*peaks +memory [0-9.]+ GB/s.*faithful +160x90 +render .*(memory|compute)"
  REQUIRES guitar_rgs)
# --replicate K: K >= 1 and K x Gaussians <= 2^31 - 1; the count is checked on the host, before the device.
rgs_cli_case(bench_replicate_zero CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--replicate|0" EXIT 2
  REGEX "--replicate: Value 0 not in range 1 to 2147483647")
rgs_cli_case(bench_replicate_negative CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--replicate|-4" EXIT 2
  REGEX "--replicate: Value -4 not in range")
rgs_cli_case(bench_replicate_not_a_number CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--replicate|many" EXIT 2
  REGEX "--replicate: Value many not in range")
rgs_cli_case(bench_replicate_overflow CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--replicate|30000" EXIT 1
  REGEX "rgs-bench: error: --replicate 30000: .*guitar.rgs: 30000 copies of 90854 Gaussians = 2725620000 exceed the 32-bit Gaussian count limit of 2147483647 \\[kLimitExceeded\\]"
  REQUIRES guitar_rgs)
rgs_cli_case(bench_replicate_missing_file CMD "${bench}|${cli_dir}/nope.rgs|--orbit|2|--replicate|2" EXIT 1
  REGEX "rgs-bench: error: .*nope.rgs: .*\\[kIoError\\]")
rgs_cli_case(bench_replicate_run
  CMD "${bench}|${cli_dir}/guitar.rgs|--orbit|2|--replicate|2|--resolution|160x90|--warmup|1|--repeat|2"
  EXIT 1 REGEX "rgs-bench: error: no usable CUDA device"
  ALT_EXIT 0 ALT_REGEX "gaussians +181,708 = 2 copies of 90,854"
  REQUIRES guitar_rgs)
