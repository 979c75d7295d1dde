#include "read_limits_option.h"

#include <CLI/CLI.hpp>

#include <string>

namespace rgs::tools {

void add_read_limit_options(CLI::App& app, format::ReadLimits& limits) {
  app.add_option("--max-gaussians", limits.max_gaussians,
                 "Refuse scenes that declare more Gaussians than this, before allocating for them (SPEC 5.5)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-decompression-ratio", limits.max_decompression_ratio,
                 "Refuse scenes whose compressed data (.rgs sections, SPZ zstd/gzip streams, SOG WebP images and "
                 "ZIP entries, glTF accessors without data) decodes to more than this many bytes per byte of "
                 "input, counting inputs under 1 MiB as 1 MiB; bounds the memory a small file can demand "
                 "(SPEC 5.5; zstd allows up to 32768)")
      ->check(CLI::Range(1u, 32768u))
      ->capture_default_str();
}

format::ReadLimits& read_limits() {
  static format::ReadLimits limits;
  return limits;
}

format::ReadOptions read_options() {
  format::ReadOptions options;
  options.limits = read_limits();
  return options;
}

}  // namespace rgs::tools
