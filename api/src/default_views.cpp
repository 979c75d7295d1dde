// default_views(): the scene's own cameras.json when the standard 3DGS layout puts one beside it, else views
// guessed from where its content is (content_views, around content_frame: also what every orbit frames).
#include "rgs/api/camera.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <system_error>
#include <utility>

#include "rgs/format/half.h"

namespace rgs::api {

namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
/// The guessed views' vertical field of view (runtime::OrbitOptions' default) and elevations.
constexpr double kFovYDeg = 50, kLowElevationDeg = 0, kHighElevationDeg = 20;
/// The guessed views of content that surrounds a core: five look at the core, at the two distances
/// (ContentViewsInfo) and both elevations, one looks level and outward from the ring.
struct SurroundView {
  double azimuth_deg, elevation_deg;
  bool near, outward;
};
constexpr uint32_t kGuessedViews = 6;
constexpr SurroundView kSurroundViews[kGuessedViews] = {
    {0, kLowElevationDeg, false, false},   {72, kHighElevationDeg, true, false},
    {144, kHighElevationDeg, false, false}, {216, kLowElevationDeg, true, false},
    {288, kLowElevationDeg, false, false},  {36, 0, false, true}};
/// 3DGS's near plane, used unless the cameras stand closer than 20 times it to what they look at.
constexpr float kNearPlane = 0.2f;

std::string text(double v) {
  char s[32];
  std::snprintf(s, sizeof(s), "%.3g", v);
  return s;
}

std::string point_text(const float p[3]) { return "(" + text(p[0]) + ", " + text(p[1]) + ", " + text(p[2]) + ")"; }

std::string ordinal(uint32_t k) {
  if (k == 1) return "every camera";
  const uint32_t tens = k % 100, ones = k % 10;
  const char* suffix = tens >= 11 && tens <= 13 ? "th" : ones == 1 ? "st" : ones == 2 ? "nd" : ones == 3 ? "rd" : "th";
  return "every " + std::to_string(k) + suffix;
}

/// Whether `dir` is train.py's `point_cloud/iteration_<digits>` folder.
bool is_iteration_folder(const fs::path& dir) {
  const std::string name = dir.filename().string();
  const std::string prefix = "iteration_";
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
  if (!std::all_of(name.begin() + long(prefix.size()), name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return false;
  }
  return dir.parent_path().filename() == "point_cloud";
}

/// Whether `path` lies inside `root` (both canonical): `root`'s elements are a prefix of `path`'s.
bool is_inside(const fs::path& path, const fs::path& root) {
  auto p = path.begin();
  for (auto r = root.begin(); r != root.end(); ++r, ++p) {
    if (r->empty()) continue;  // a trailing separator
    if (p == path.end() || *p != *r) return false;
  }
  return true;
}

/// `candidate` when it exists and may be read (find_scene_cameras' rules), an empty path when it does not exist.
Result<fs::path> check_candidate(const fs::path& candidate, const fs::path& root) {
  std::error_code ec;
  const fs::file_status own = fs::symlink_status(candidate, ec);
  if (own.type() == fs::file_type::not_found) return fs::path();
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, candidate.string() + ": cannot examine it: " + ec.message());
  const fs::file_status target = fs::status(candidate, ec);
  RGS_RETURN_ERROR_IF(target.type() == fs::file_type::not_found, StatusCode::kInvalidArgument,
                      candidate.string() + ": a link to a file that does not exist");
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, candidate.string() + ": cannot examine it: " + ec.message());
  RGS_RETURN_ERROR_IF(target.type() != fs::file_type::regular, StatusCode::kInvalidArgument,
                      candidate.string() + ": not a regular file (a directory, device, socket or pipe)");
  const fs::path real = fs::canonical(candidate, ec);
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, candidate.string() + ": cannot resolve it: " + ec.message());
  const fs::path real_root = fs::canonical(root, ec);
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, root.string() + ": cannot resolve it: " + ec.message());
  RGS_RETURN_ERROR_IF(!is_inside(real, real_root), StatusCode::kInvalidArgument,
                      candidate.string() + ": a link to " + real.string() + ", outside the scene's folder " +
                          real_root.string() + "; not read");
  return candidate;
}

/// The value below which `q` of the total weight lies (`items` sorted by value; total > 0).
double weighted_quantile(const std::vector<std::pair<float, float>>& items, double total, double q) {
  double below = 0;
  for (const auto& [value, weight] : items) {
    below += weight;
    if (below >= q * total) return value;
  }
  return items.back().first;
}

/// A Gaussian's weight: its opacity rounded to FP16, as a .rgs stores it, so that a scene and its .rgs weigh alike
/// (the means are stored as they are) and every door frames the same content.
float weight_of(float opacity) { return format::half_bits_to_float(format::float_to_half_bits(opacity)); }

/// `cam` turned half a turn about its own y (down) axis, around its centre: it looks the other way, level if
/// it looked level.
runtime::Camera turned_around(runtime::Camera cam) {
  const std::array<float, 3> eye = runtime::camera_centre(cam);
  std::array<double, 9> rows;
  for (int i = 0; i < 9; ++i) rows[i] = i / 3 == 1 ? cam.rotation[i] : -cam.rotation[i];  // x and z axes reversed
  runtime::set_pose(&cam, rows, {eye[0], eye[1], eye[2]});
  return cam;
}

}  // namespace

Result<std::string> find_scene_cameras(const std::string& scene_path) {
  std::error_code ec;
  const fs::path scene = fs::absolute(fs::path(scene_path), ec).lexically_normal();
  RGS_RETURN_ERROR_IF(ec, StatusCode::kIoError, scene_path + ": cannot make the path absolute: " + ec.message());
  const fs::path dir = fs::is_directory(scene, ec) ? scene : scene.parent_path();
  std::vector<fs::path> candidates = {dir / "cameras.json"};
  fs::path root = dir;
  if (is_iteration_folder(dir)) {
    root = dir.parent_path().parent_path();
    candidates.push_back(root / "cameras.json");
  }
  // A capture's cameras named after the scene: PREFIX_cameras.json for each PREFIX of its name that ends before a
  // '_', longest first (mipnerf360_flowers_cameras.json beside mipnerf360_flowers_c3dgs.ply).
  const std::string stem = scene.stem().string();
  for (size_t cut = stem.rfind('_'); cut != std::string::npos && cut > 0; cut = stem.rfind('_', cut - 1)) {
    candidates.push_back(dir / (stem.substr(0, cut) + "_cameras.json"));
  }
  for (const fs::path& candidate : candidates) {
    Result<fs::path> found = check_candidate(candidate, root);
    if (!found.ok()) return Status(found.status()).prepend("a cameras.json beside the scene " + scene_path);
    if (!found->empty()) return found->string();
  }
  return std::string();
}

format::SceneBounds ContentFrame::sphere() const {
  format::SceneBounds sphere;
  std::copy_n(target, 3, sphere.sphere_center);
  sphere.sphere_radius = float(frame_radius);
  return sphere;
}

ContentFrame ContentFrame::of_sphere(const format::SceneBounds& bounds) {
  ContentFrame frame;
  std::copy_n(bounds.sphere_center, 3, frame.centre);
  std::copy_n(bounds.sphere_center, 3, frame.target);
  if (bounds.sphere_radius > 0) frame.frame_radius = bounds.sphere_radius;
  return frame;
}

ContentFrame content_frame(const format::GaussianCloud& cloud) {
  const size_t n = std::min(cloud.size(), cloud.opacities.size());
  const size_t step = std::max<size_t>(1, (n + kContentFrameSamples - 1) / kContentFrameSamples);
  // Opacity weights; all ones when no Gaussian has any opacity.
  std::vector<size_t> used;
  double total = 0;
  for (size_t i = 0; i < n; i += step) {
    const float* m = &cloud.means[3 * i];
    if (!std::isfinite(m[0]) || !std::isfinite(m[1]) || !std::isfinite(m[2])) continue;
    used.push_back(i);
    const float o = weight_of(cloud.opacities[i]);
    if (std::isfinite(o) && o > 0) total += o;
  }
  ContentFrame where;
  where.weighed = used.size();
  if (used.empty()) return where;
  const bool uniform = !(total > 0);
  auto weight = [&](size_t i) {
    const float o = weight_of(cloud.opacities[i]);
    return uniform ? 1.0f : std::isfinite(o) && o > 0 ? std::min(o, 1.0f) : 0.0f;
  };
  if (uniform) total = double(used.size());

  std::vector<std::pair<float, float>> items(used.size());
  double box_low[3], box_high[3];
  for (int a = 0; a < 3; ++a) {
    for (size_t j = 0; j < used.size(); ++j) items[j] = {cloud.means[3 * used[j] + a], weight(used[j])};
    std::sort(items.begin(), items.end());
    where.centre[a] = float(weighted_quantile(items, total, 0.5));
    box_low[a] = weighted_quantile(items, total, 0.05);
    box_high[a] = weighted_quantile(items, total, 0.95);
  }
  for (size_t j = 0; j < used.size(); ++j) {
    const float* m = &cloud.means[3 * used[j]];
    const double dx = double(m[0]) - where.centre[0], dy = double(m[1]) - where.centre[1],
                 dz = double(m[2]) - where.centre[2];
    items[j] = {float(std::sqrt(dx * dx + dy * dy + dz * dz)), weight(used[j])};
  }
  std::sort(items.begin(), items.end());
  where.radius_25 = weighted_quantile(items, total, 0.25);
  where.radius_50 = weighted_quantile(items, total, 0.5);
  where.surrounds = where.radius_50 > kSurroundRatio * where.radius_25;
  if (where.surrounds) {
    where.frame_radius = where.radius_25;
    std::copy_n(where.centre, 3, where.target);
  } else {
    double half_diagonal = 0;
    for (int a = 0; a < 3; ++a) {
      where.target[a] = float((box_low[a] + box_high[a]) / 2);
      half_diagonal += (box_high[a] - box_low[a]) * (box_high[a] - box_low[a]) / 4;
    }
    where.frame_radius = std::sqrt(half_diagonal);
  }
  if (!(where.frame_radius > 0) || !std::isfinite(where.frame_radius)) {
    // All the weight at one point (one Gaussian, or copies of one): frame what the Gaussians' sizes cover.
    double largest = 0;
    for (size_t i : used) {
      for (int a = 0; a < 3; ++a) {
        const float s = 3 * i + 2 < cloud.scales.size() ? cloud.scales[3 * i + a] : 0.0f;
        if (std::isfinite(s)) largest = std::max(largest, double(s));
      }
    }
    where.frame_radius = largest > 0 ? 3 * largest : 1.0;
  }
  return where;
}

Result<std::vector<runtime::Camera>> content_views(const format::GaussianCloud& cloud, uint32_t width,
                                                   uint32_t height, ContentViewsInfo* info) {
  RGS_RETURN_ERROR_IF(width < 11 || height < 11 || width > 32768 || height > 32768, StatusCode::kInvalidArgument,
                      "guessed views: image size " + std::to_string(width) + "x" + std::to_string(height) +
                          " outside [11, 32768]");
  ContentViewsInfo where;
  static_cast<ContentFrame&>(where) = content_frame(cloud);
  RGS_RETURN_ERROR_IF(where.weighed == 0, StatusCode::kInvalidArgument,
                      "guessed views: the scene has no Gaussian with a finite mean");
  const double fov_y = kFovYDeg * kPi / 180;
  const double focal = runtime::focal_from_fov(fov_y, height);
  const double fov_x = runtime::fov_from_focal(focal, width);
  const double fov_min = std::min(fov_y, fov_x), fov_max = std::max(fov_y, fov_x);
  where.distance = where.frame_radius / std::sin(fov_min / 2);
  where.near_distance = where.surrounds ? where.frame_radius / std::sin(fov_max / 2) : where.distance;
  const format::SceneBounds ring = where.sphere();
  runtime::OrbitOptions orbit;
  orbit.fov_y_deg = kFovYDeg;
  orbit.near_plane = float(std::min(double(kNearPlane), where.near_distance / 20));

  std::vector<runtime::Camera> views;
  char name[32];
  for (uint32_t v = 0; v < kGuessedViews; ++v) {
    // Content around a core: kSurroundViews; one object: a ring 60° apart, elevations alternating.
    const SurroundView one_object = {60.0 * v, v % 2 == 0 ? kLowElevationDeg : kHighElevationDeg, false, false};
    const SurroundView& view = where.surrounds ? kSurroundViews[v] : one_object;
    orbit.start_azimuth_deg = view.azimuth_deg;
    orbit.elevation_deg = view.elevation_deg;
    orbit.distance_factor = view.near ? where.near_distance / where.distance : 1.0;
    RGS_ASSIGN_OR_RETURN(std::vector<runtime::Camera> ring_view,
                         runtime::orbit_cameras(ring, 1, width, height, orbit));
    runtime::Camera cam = view.outward ? turned_around(std::move(ring_view[0])) : std::move(ring_view[0]);
    std::snprintf(name, sizeof(name), view.outward ? "guess_out_%03u" : "guess_in_%03u", v);
    cam.name = name;
    views.push_back(std::move(cam));
  }
  if (info) *info = where;
  return views;
}

Result<DefaultViews> default_views(const std::string& scene_path, const format::GaussianCloud& cloud,
                                   const api::CameraChoice& choice) {
  DefaultViews out;
  RGS_ASSIGN_OR_RETURN(out.cameras_path, find_scene_cameras(scene_path));
  if (!out.cameras_path.empty()) {
    Result<std::vector<runtime::Camera>> all = runtime::load_inria_cameras(out.cameras_path);
    if (!all.ok()) {
      return Status(all.status())
          .prepend("the cameras.json found beside the scene (choose other views with --cameras, --orbit or --path)");
    }
    const uint32_t limit = choice.limit != 0 ? choice.limit : kDefaultSceneViews;
    const auto count = uint32_t(all->size());
    const uint32_t every = (count + limit - 1) / limit;
    for (uint32_t i = 0; i < count; i += every) {
      const runtime::Camera& cam = (*all)[i];
      // Both sides unset: the camera's own size, at most kDefaultViewWidth wide.
      const uint32_t asked_width = choice.width == 0 && choice.height == 0 ? std::min(cam.width, kDefaultViewWidth)
                                                                           : choice.width;
      const auto [w, h] = runtime::keep_aspect(asked_width, choice.height, cam.width, cam.height);
      out.cameras.push_back(w == cam.width && h == cam.height ? cam : runtime::resize_camera(cam, w, h));
    }
    out.note = "views: the scene's own cameras, " + out.cameras_path + " (found beside the scene): " +
               std::to_string(out.cameras.size()) + " of its " + std::to_string(count) + " (" + ordinal(every) +
               ") at " + std::to_string(out.cameras[0].width) + "x" + std::to_string(out.cameras[0].height);
    return out;
  }
  const auto [w, h] = runtime::keep_aspect(choice.width, choice.height, kDefaultViewWidth, kDefaultViewHeight);
  ContentViewsInfo where;
  RGS_ASSIGN_OR_RETURN(out.cameras, content_views(cloud, w, h, &where));
  if (choice.limit != 0 && out.cameras.size() > choice.limit) out.cameras.resize(choice.limit);
  const std::string shape =
      where.surrounds
          ? "the content surrounds a core of radius " + text(where.frame_radius) + " around " +
                point_text(where.target) + ": cameras inside it, 4 looking at the core from " + text(where.near_distance) + " and " +
                text(where.distance) + ", 1 outward"
          : "one object of radius " + text(where.frame_radius) + " around " + point_text(where.target) +
                " (opacity-weighted 5-95th percentiles): a ring of radius " + text(where.distance);
  out.note = "views: no cameras.json beside the scene, so " + std::to_string(out.cameras.size()) +
             " views were guessed from where its content is (" + shape + ") at " + std::to_string(w) + "x" +
             std::to_string(h) + "; --cameras names the capture's own";
  return out;
}

}  // namespace rgs::api
