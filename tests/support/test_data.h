// Locating test data: files shipped in the repository, and real scenes from $RGS_DATA_DIR.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include <doctest/doctest.h>

namespace rgs::test {

/// The shipped SH-degree-3 test scene (repository path): 8,000 Gaussians of samples/guitar.ply (the
/// headstock) with SH bands 1-3 filled by the deterministic rule of tests/data/make_guitar_sh3.py.
inline constexpr const char* kGuitarSh3 = "tests/data/guitar_sh3.ply";

/// Absolute path of a file in the repository (e.g. "samples/guitar.ply").
inline std::string repo_path(const std::string& relative) {
  return (std::filesystem::path(RGS_SOURCE_DIR) / relative).string();
}

/// Directory of the real scenes that are not shipped (RGS_DATA_DIR, default data/ in the checkout).
inline std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("RGS_DATA_DIR"); env && *env) return env;
  return RGS_DEFAULT_DATA_DIR;
}

/// Path of a shared scene, or "" after printing a visible "skipped" message when it is not available.
inline std::string shared_scene(const std::string& file) {
  const auto path = shared_data_dir() / file;
  if (!std::filesystem::exists(path)) {
    MESSAGE("skipped: " << file << " not found in " << shared_data_dir().string()
                        << " (set RGS_DATA_DIR to the folder with the real scenes)");
    return {};
  }
  return path.string();
}

}  // namespace rgs::test
