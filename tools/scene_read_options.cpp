#include "scene_read_options.h"

#include <CLI/CLI.hpp>

#include <string>

#include "cli_common.h"

namespace rgs::tools {

converter::SceneReadOptions& scene_read_options() {
  static converter::SceneReadOptions options;
  return options;
}

void add_scene_read_options(CLI::App& app, bool with_spz_frame) {
  converter::SceneReadOptions& options = scene_read_options();
  app.add_option("--max-gaussians", options.max_gaussians,
                 "Refuse scenes that declare more Gaussians than this, before allocating for them (SPEC 5.5)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-decompression-ratio", options.max_decompression_ratio,
                 "Refuse scenes whose compressed data (.rgs sections, SPZ zstd/gzip streams, SOG WebP images and "
                 "ZIP entries, glTF accessors without data) decodes to more than this many bytes per byte of "
                 "input, counting inputs under 1 MiB as 1 MiB; bounds the memory a small file can demand "
                 "(SPEC 5.5; zstd allows up to 32768)")
      ->check(CLI::Range(1u, 32768u))
      ->capture_default_str();
  if (!with_spz_frame) return;
  app.add_option_function<std::string>(
         "--spz-frame",
         [&options](const std::string& name) { options.spz_frame = *converter::parse_spz_frame(name); },
         "Axes of SPZ files read or written: rub (Niantic's convention, turned to and from RoofGS's RDF) or "
         "as-stored (no turn: the PLY's axes, as splat-transform 3.7 writes and reads SPZ). Nothing in an SPZ "
         "file tells the two apart (converter/INTEROP.md)")
      ->check(CLI::IsMember({"rub", "as-stored"}))
      ->default_str("rub");
}

format::ReadOptions read_options() { return converter::rgs_read_options(scene_read_options()); }

std::string scene_formats_help() {
  std::string text = "found by its content: ";
  const std::vector<std::string> formats = converter::supported_scene_formats();
  for (size_t i = 0; i < formats.size(); ++i) text += (i ? "; " : "") + formats[i];
  return text;
}

void report_notes(const char* tool, const std::vector<std::string>& notes, bool quiet) {
  if (quiet) return;
  for (const std::string& note : notes) report_note(tool, note);
}

}  // namespace rgs::tools
