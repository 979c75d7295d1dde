// Cameras from the conventions applications use: INRIA/COLMAP, OpenCV K + [R|t], OpenGL and Vulkan view +
// projection matrices. Each builder returns a runtime::Camera (COLMAP frame, x right, y down, z forward;
// pixel centres at integer coordinates: px = fx·x/z + cx − 0.5, runtime/camera.h).
// And the views a scene is judged on when nobody names them (default_views): the scene's own cameras (a
// cameras.json of the standard 3DGS output layout beside the model), else views guessed from where its content
// is. Rate control (ConvertOptions::target) and the audit (rgs-audit) both take their default views from it.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/api/scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::api {

using runtime::Camera;

/// A cameras.json entry with its numbers as written, and the file's one reader (runtime::read_inria_cameras: every
/// entry checked, hostile input bounded); make_cameras and default_views load the same file through it. The viewer
/// reads the camera of a view message with its per-camera half (runtime::parse_inria_camera).
using runtime::InriaCamera;
using runtime::NamedInriaCamera;
using runtime::parse_inria_camera;
using runtime::read_inria_cameras;

/// Settings every camera builder takes.
struct CameraOptions {
  /// Gaussians at view depth z ≤ near_plane (world units) are culled; 0.2 is the 3DGS rasterizer's value.
  /// The near and far planes of a projection matrix are not used: 3DGS has no far plane, and a
  /// projection's near plane (often 0.01) would keep Gaussians 3DGS culls.
  float near_plane = 0.2f;
  /// Label of the camera (messages, file names).
  std::string name;
};

/// INRIA 3DGS cameras.json entry: `rotation` camera-to-world, row-major [3, 3] (its columns are the camera
/// axes in world coordinates), `position` the camera centre (world units), fx, fy in pixels, principal point
/// at the image centre. R = rotationᵀ, t = −R·position (runtime::camera_from_inria, as cameras.json is loaded).
/// @return kInvalidArgument (validate_camera(): non-orthonormal rotation, focal ≤ 0, size 0 or > 32768, ...).
Result<Camera> camera_from_inria(const std::array<double, 9>& rotation_c2w, const std::array<double, 3>& position,
                                 double fx, double fy, uint32_t width, uint32_t height,
                                 const CameraOptions& options = {});

/// COLMAP images.txt / cameras.txt (PINHOLE or SIMPLE_PINHOLE): `qvec` the world-to-camera rotation as a unit
/// quaternion (w, x, y, z) (normalized here; zero-norm is an error), `tvec` the world-to-camera translation,
/// fx, fy, cx, cy in COLMAP's pixel convention (origin at the top-left corner of the image, so the centre of
/// the top-left pixel is (0.5, 0.5); cx = width/2 is the image centre). p_cam = R(q)·p + t.
/// @return kInvalidArgument (zero quaternion, validate_camera()).
Result<Camera> camera_from_colmap(const std::array<double, 4>& qvec_wxyz, const std::array<double, 3>& tvec,
                                  double fx, double fy, double cx, double cy, uint32_t width, uint32_t height,
                                  const CameraOptions& options = {});

/// OpenCV: intrinsics K, row-major [3, 3] = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], and extrinsics [R|t]
/// (world to camera, x right, y down, z forward: p_cam = R·p + t, R row-major [3, 3]). OpenCV puts pixel
/// centres at integer coordinates (cx = (width − 1)/2 is the image centre), so the camera's cx is K's + 0.5
/// (likewise cy). Distortion is not modelled.
/// @return kInvalidArgument (non-zero skew K[0][1], K's last row not (0, 0, 1), validate_camera()).
Result<Camera> camera_from_opencv(const std::array<double, 9>& K, const std::array<double, 9>& R,
                                  const std::array<double, 3>& t, uint32_t width, uint32_t height,
                                  const CameraOptions& options = {});

/// Which clip-space convention a projection matrix follows.
enum class ClipConvention {
  /// OpenGL: clip y points up (window row 0 at the bottom, y_ndc = +1 at the top of the image), depth −1..1.
  kOpenGL,
  /// Vulkan: clip y points down (y_ndc = −1 at the top row), depth 0..1 (both the usual GLM
  /// GLM_FORCE_DEPTH_ZERO_TO_ONE + flipped P[1][1] matrices and y-up matrices rendered with a negative
  /// viewport height are described by the matrix's own sign of P[1][1] under this convention).
  kVulkan,
};

/// A 4×4 matrix in OpenGL memory order: column-major, element (row r, column c) at index 4·c + r (what
/// glm::value_ptr gives and glUniformMatrix4fv takes with transpose = GL_FALSE).
using Mat4ColumnMajor = std::array<float, 16>;

/// OpenGL / Vulkan camera: `view` world to eye (eye frame x right, y up, camera looking down −z: the
/// glm::lookAt convention), `projection` a perspective matrix (glm::perspective, glm::frustum, or an
/// off-centre one) in `convention`. The COLMAP camera is R = diag(1, −1, −1)·V₃ₓ₃, t = diag(1, −1, −1)·V_t;
/// with P = projection (P[r][c] row r, column c): fx = P[0][0]·W/2, cx = W/2·(1 − P[0][2]); OpenGL
/// fy = P[1][1]·H/2, cy = H/2·(1 + P[1][2]); Vulkan fy = −P[1][1]·H/2, cy = H/2·(1 − P[1][2]).
/// The image is width × height pixels, top row first, whatever the API's window origin.
/// @return kInvalidArgument (not a perspective projection: P's last row not (0, 0, −1, 0), non-zero
/// P[0][1] or P[1][0] (skew), a resulting focal length ≤ 0 (e.g. a Vulkan matrix passed as OpenGL, which
/// would flip the image), a view matrix with scale or shear (validate_camera()), non-finite values).
Result<Camera> camera_from_view_projection(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection,
                                           uint32_t width, uint32_t height, ClipConvention convention,
                                           const CameraOptions& options = {});

/// camera_from_view_projection(..., ClipConvention::kOpenGL, ...).
Result<Camera> camera_from_opengl(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection, uint32_t width,
                                  uint32_t height, const CameraOptions& options = {});

/// camera_from_view_projection(..., ClipConvention::kVulkan, ...).
Result<Camera> camera_from_vulkan(const Mat4ColumnMajor& view, const Mat4ColumnMajor& projection, uint32_t width,
                                  uint32_t height, const CameraOptions& options = {});

/// The OpenGL view matrix (column-major, as camera_from_opengl reads it) of `camera`: the inverse of the
/// conversion above (for drawing other geometry with the same camera).
Mat4ColumnMajor opengl_view_matrix(const Camera& camera);

/// An OpenGL projection matrix (column-major) for `camera` with the given depth range (0 < z_near < z_far);
/// camera_from_opengl(opengl_view_matrix(c), opengl_projection_matrix(c, n, f), W, H) gives c back.
Mat4ColumnMajor opengl_projection_matrix(const Camera& camera, float z_near, float z_far);

/// Which views to render.
struct CameraChoice {
  /// INRIA cameras.json; empty: an orbit.
  std::string cameras_path;
  uint32_t every = 1;  ///< every k-th camera of the file
  uint32_t limit = 0;  ///< at most this many key views of the file, or views of an orbit or path (0 = all)
  /// With cameras_path: this many views flown through the file's cameras (after `every` and `limit`) in order
  /// (runtime::fly_through_cameras: a centripetal Catmull–Rom spline through their centres at steady speed,
  /// rotations slerped), at width × height as for the file's cameras; 0: the file's cameras themselves.
  /// Needs cameras_path.
  uint32_t fly = 0;
  uint32_t orbit = 0;  ///< orbit camera count when cameras_path is empty
  /// Camera path view count (runtime::path_cameras: a rising spiral, near and far) when cameras_path is
  /// empty; used instead of `orbit` when not 0.
  uint32_t path = 0;
  /// Requested size; 0 = default (cameras: the file's own; orbit: `orbit_width` × `orbit_height`). With only
  /// one side given, the other keeps the default's aspect ratio.
  uint32_t width = 0, height = 0;
  uint32_t orbit_width = 1920, orbit_height = 1080;
};

/// Builds the cameras: runtime::load_inria_cameras (field of view kept on resize), flown through with
/// runtime::fly_through_cameras when `fly` is set (keys whose sizes differ are first resized to the first key's
/// size, field of view kept), or runtime::path_cameras or runtime::orbit_cameras around `frame`'s sphere (the
/// robust guess of content_frame, e.g. SceneInfo::content; near plane min(0.2, frame_radius / 20)).
/// Errors: those of the loaders and of fly_through_cameras (prefixed with the cameras path: e.g. fewer than 2
/// cameras left after `every` and `limit`); kInvalidArgument for an orbit of 0 cameras or `fly` without
/// cameras_path.
Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const ContentFrame& frame);

// The views a scene is judged on when no camera option names them (default_views).

/// The cameras.json the standard 3DGS output layout puts beside a model, for the scene file (or folder) at
/// `scene_path`: `<dir>/cameras.json`, where `<dir>` is the scene's folder, and, when `<dir>` is
/// `<model>/point_cloud/iteration_<digits>` (train.py's `point_cloud/iteration_N/point_cloud.ply`),
/// `<model>/cameras.json`; then `<dir>/PREFIX_cameras.json` for each PREFIX of the scene's name (without its
/// extension) that ends before a `_`, longest first (a capture's cameras named after it:
/// `mipnerf360_flowers_cameras.json` beside `mipnerf360_flowers_c3dgs.ply`). Nothing else is looked at. The first
/// that exists is taken. A candidate that does not exist is skipped; one that exists
/// is treated as hostile: it must be a regular file (links followed) whose real path lies inside the scene's
/// folder tree (`<model>`, else `<dir>`).
/// @return the path found (absolute, as looked up), or an empty string when neither exists; kInvalidArgument for a
///         candidate that is not a regular file or a link that leaves the scene's folder tree (naming both paths);
///         kIoError when a path cannot be examined.
Result<std::string> find_scene_cameras(const std::string& scene_path);

/// Where the guessed views (content_views) were placed, in world units: the content's frame, and the distance of the
/// cameras from `target`: where the frame sphere just fits the narrower field of view, and (content that surrounds a
/// core; else the same) where it just fits the wider one.
struct ContentViewsInfo : ContentFrame {
  double distance = 0, near_distance = 0;
};

/// Views guessed from where `cloud`'s content is (content_frame: robust to floaters). Six views of width × height pixels,
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
                                   const CameraChoice& choice = {});

}  // namespace rgs::api
