// The views a scene is judged on when nobody names them: the scene's own cameras (a cameras.json of the standard
// 3DGS output layout beside the model), else views guessed from where its content is. Rate control
// (convert_fitted) and the audit (rgs-audit) both take their default views from default_views().
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::audit {

/// The cameras.json the standard 3DGS output layout puts beside a model, for the scene file (or folder) at
/// `scene_path`: `<dir>/cameras.json`, where `<dir>` is the scene's folder, and, when `<dir>` is
/// `<model>/point_cloud/iteration_<digits>` (train.py's `point_cloud/iteration_N/point_cloud.ply`),
/// `<model>/cameras.json`. Nothing else is looked at. A candidate that does not exist is skipped; one that exists
/// is treated as hostile: it must be a regular file (links followed) whose real path lies inside the scene's
/// folder tree (`<model>`, else `<dir>`).
/// @return the path found (absolute, as looked up), or an empty string when neither exists; kInvalidArgument for a
///         candidate that is not a regular file or a link that leaves the scene's folder tree (naming both paths);
///         kIoError when a path cannot be examined.
Result<std::string> find_scene_cameras(const std::string& scene_path);

/// Where the guessed views (content_views) were placed, in world units.
struct ContentViewsInfo {
  /// Centre of the content: the opacity-weighted median of the means, per axis.
  float centre[3] = {0, 0, 0};
  /// Opacity-weighted quantiles of the means' distance from `centre`: a quarter, half and nine tenths of the
  /// weight lies within these radii.
  double radius_25 = 0, radius_50 = 0, radius_90 = 0;
  /// Whether the content surrounds a central core (radius_50 > kSurroundRatio · radius_25: a capture whose
  /// background spreads far beyond its subject) rather than forming one object.
  bool surrounds = false;
  /// Radius of the sphere the inward views frame: radius_25 when the content surrounds, else half the diagonal of
  /// the box of the means' weighted 5th-95th percentiles per axis (around that box's centre, `target`); when that is
  /// 0 (all the weight at one point), 3 times the largest scale of any Gaussian, else 1.
  double frame_radius = 0;
  float target[3] = {0, 0, 0};
  /// Distance of the cameras from `target`: where the frame sphere just fits the narrower field of view, and (content
  /// that surrounds a core; else the same) where it just fits the wider one.
  double distance = 0, near_distance = 0;
};

/// The content surrounds its core when half its weight lies more than this many times farther out than a quarter
/// of it: a uniform ball gives 1.26, a disc 1.41, a rod 2; Mip-NeRF 360 flowers 4.5, guitar and biker 1.5.
constexpr double kSurroundRatio = 3.0;

/// Views guessed from where `cloud`'s content is, robust to floaters: each Gaussian weighs its opacity (means that
/// are not finite are left out), the centre is the weighted median and the extent comes from weighted quantiles
/// (ContentViewsInfo), so a few far Gaussians, however far, move nothing. Six views of width × height pixels,
/// vertical field of view 50°, square pixels, up = −y (the scenes' convention, as runtime::orbit_cameras):
/// - one object: a ring around the frame sphere at the distance where it just fits the narrower field of view,
///   azimuths 60° apart, elevations alternating 0° and 20° ("guess_in_000" ...);
/// - content that surrounds a core (a capture): the cameras stand inside the content, around the core. Five look at
///   it (azimuths 72° apart, elevations 0° and 20°), three from where it just fits the narrower field of view
///   (`distance`) and two, views 1 and 3, from where it just fits the wider one (`near_distance`), as a capture's
///   cameras come at different distances; one, view 5 ("guess_out_005"), looks level and outward from `distance`
///   at the content around it (how these views compare with a capture's own: docs/AUDITS.md#default-views).
/// near_plane is min(0.2, near_distance / 20). Deterministic.
/// @return kInvalidArgument for an empty cloud, no finite mean, or a size outside [11, 32768].
Result<std::vector<runtime::Camera>> content_views(const format::GaussianCloud& cloud, uint32_t width,
                                                   uint32_t height, ContentViewsInfo* info = nullptr);

/// Views found or guessed by default_views().
struct DefaultViews {
  std::vector<runtime::Camera> cameras;
  /// The scene's own cameras.json (find_scene_cameras); empty when the views were guessed.
  std::string cameras_path;
  /// One line for the user: which views these are ("the scene's own cameras: ...cameras.json, 12 of its 173
  /// views ..." or "no cameras.json beside the scene: 6 views guessed from where its content is ...").
  std::string note;
};

/// Default views at most this many, evenly spread, of a scene's own cameras.
constexpr uint32_t kDefaultSceneViews = 12;
/// Default size of the views: guessed views width × height, the scene's cameras this wide (aspect kept).
constexpr uint32_t kDefaultViewWidth = 960, kDefaultViewHeight = 540;

/// The views a scene is judged on when no camera option names them. When find_scene_cameras(scene_path) finds a
/// cameras.json, its cameras (runtime::load_inria_cameras): every k-th so that at most kDefaultSceneViews remain
/// (`choice.limit` instead when not 0), each resized to `choice.width` × `choice.height` if given (one side: the
/// other keeps that camera's aspect), else kDefaultViewWidth wide (field of view kept); else
/// content_views(cloud, ...) at choice.width × choice.height, kDefaultViewWidth × kDefaultViewHeight by default
/// (`choice.limit` views at most). choice.cameras_path, orbit, path and fly are not used.
/// @return the errors of find_scene_cameras, of reading the cameras.json found (kIoError, kLimitExceeded,
///         kCorruptData: prefixed with the note that it was found beside the scene and how to choose other views)
///         and of content_views.
Result<DefaultViews> default_views(const std::string& scene_path, const format::GaussianCloud& cloud,
                                   const api::CameraChoice& choice = {});

}  // namespace rgs::audit
