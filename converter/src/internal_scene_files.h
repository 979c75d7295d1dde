// The files a multi-file scene names, listed without decoding it, for converter::list_scene_files (private to
// rgs_converter). Each resolves names as its reader does (detail::SceneFolder), so that every file the reader
// would open is listed, and a name the reader would refuse is refused here with the same error.
#pragma once

#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// A SOG meta.json (or its folder) and the images it names; a bundled .sog is one file.
Result<std::vector<std::string>> list_sog_files(const std::string& path);

/// A streamed SOG's lod-meta.json (or its folder), every chunk meta.json it names and their images.
Result<std::vector<std::string>> list_sog_lod_files(const std::string& path);

/// A .gltf and the buffer files it names (a GLB's external buffers too).
Result<std::vector<std::string>> list_gltf_files(const std::string& path);

}  // namespace rgs::converter::detail
