// The source of load(): the file opened and identified once, a .rgs mapped for its sink to read as it needs, any
// other format read whole.
#include "../internal_load.h"

namespace rgs::api::detail {

Result<LoadScene> open_load_scene(const std::string& path, const LoadOptions& options) {
  LoadScene scene;
  scene.name = path;
  if (format::is_rgs_path(path)) {
    auto opened = format::RgsFile::open(path, converter::rgs_read_options(options.read_options));
    if (!opened.ok()) return naming(opened.status(), path);
    scene.rgs.emplace(std::move(opened).value());
    return scene;
  }
  RGS_ASSIGN_OR_RETURN(scene.input, converter::read_scene(path, options.read_options));
  return scene;
}

}  // namespace rgs::api::detail
