// The scene-reading options of every tool that reads scenes (--max-gaussians, --max-decompression-ratio,
// --spz-frame), defined once so that their names, defaults and help text agree across tools
// (format/SPEC.md §5.5, converter/INTEROP.md).
#pragma once

#include <string>
#include <vector>

#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"

namespace CLI {
class App;
}  // namespace CLI

namespace rgs::tools {

/// How this process reads scenes: converter::SceneReadOptions' defaults until the command line changes them
/// (add_scene_read_options). Every tool's scene loading passes it to the library's loaders.
converter::SceneReadOptions& scene_read_options();

/// Adds `--max-gaussians N`, `--max-decompression-ratio R` (defaults as in SPEC §5.5) and
/// `--spz-frame rub|as-stored` (converter::SpzFrame; tools that read only .rgs leave it out) to `app`, bound to
/// scene_read_options(); shown in --help.
void add_scene_read_options(CLI::App& app, bool with_spz_frame = true);

/// format::ReadOptions with scene_read_options()' limits, checksums verified: for opening a .rgs directly.
format::ReadOptions read_options();

/// The input formats every scene-reading tool accepts, found by content (converter::supported_scene_formats),
/// as one sentence for --help.
std::string scene_formats_help();

/// Prints each of `notes` as "<tool>: note: ..." on standard error, unless `quiet`.
void report_notes(const char* tool, const std::vector<std::string>& notes, bool quiet = false);

}  // namespace rgs::tools
