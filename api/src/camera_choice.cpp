// The views of a run: a CameraChoice (cameras.json, orbit, path, fly-through) turned into cameras.
#include "rgs/api/camera.h"

#include <algorithm>

namespace rgs::api {

Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const ContentFrame& frame) {
  std::vector<runtime::Camera> cameras;
  RGS_RETURN_ERROR_IF(choice.fly > 0 && choice.cameras_path.empty(), StatusCode::kInvalidArgument,
                      "--fly " + std::to_string(choice.fly) +
                          " needs --cameras: the views are flown through the cameras of that file");
  if (!choice.cameras_path.empty()) {
    runtime::InriaCameraOptions options;
    options.every_kth = choice.every;
    options.width = choice.width;
    options.height = choice.height;
    RGS_ASSIGN_OR_RETURN(cameras, runtime::load_inria_cameras(choice.cameras_path, options));
  } else {
    RGS_RETURN_ERROR_IF(choice.orbit == 0 && choice.path == 0, StatusCode::kInvalidArgument,
                        "--orbit needs at least 1 camera");
    const auto [w, h] = runtime::keep_aspect(choice.width, choice.height, choice.orbit_width, choice.orbit_height);
    runtime::OrbitOptions orbit;
    orbit.near_plane = float(std::min(double(orbit.near_plane), frame.frame_radius / 20));
    RGS_ASSIGN_OR_RETURN(cameras, choice.path > 0 ? runtime::path_cameras(frame.sphere(), choice.path, w, h, {}, orbit)
                                                  : runtime::orbit_cameras(frame.sphere(), choice.orbit, w, h, orbit));
  }
  if (choice.limit > 0 && cameras.size() > choice.limit) cameras.resize(choice.limit);
  if (choice.fly > 0) {  // through the file's cameras (checked above)
    // A file may mix image sizes; the views take the first key's intrinsics, so the keys share its size.
    for (runtime::Camera& key : cameras) {
      if (key.width != cameras[0].width || key.height != cameras[0].height) {
        key = runtime::resize_camera(key, cameras[0].width, cameras[0].height);
      }
    }
    Result<std::vector<runtime::Camera>> flown = runtime::fly_through_cameras(cameras, choice.fly);
    if (!flown.ok()) return Status(flown.status()).prepend(choice.cameras_path);
    return flown;
  }
  return cameras;
}

}  // namespace rgs::api
