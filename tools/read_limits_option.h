// The read-limit options of every tool that reads scenes (--max-gaussians, --max-decompression-ratio),
// defined once so that their names, defaults and help text agree across tools (format/SPEC.md §5.5).
#pragma once

#include "rgs/format/reader.h"

namespace CLI {
class App;
}  // namespace CLI

namespace rgs::tools {

/// Adds `--max-gaussians N` and `--max-decompression-ratio R` to `app`, bound to `limits`
/// (format::ReadLimits::max_gaussians and max_decompression_ratio; defaults as in SPEC §5.5, shown in
/// --help). Both only ever need raising for a genuine file that exceeds them.
void add_read_limit_options(CLI::App& app, format::ReadLimits& limits);

/// The read limits of this process: format::ReadLimits' defaults until the command line changes them
/// (`add_read_limit_options(app, read_limits())` in a tool's main). The tools' scene loading
/// (load_scene, load_gpu_scene, replicate_scene_file) reads every format with them.
format::ReadLimits& read_limits();

/// ReadOptions carrying read_limits(), checksums verified.
format::ReadOptions read_options();

}  // namespace rgs::tools
