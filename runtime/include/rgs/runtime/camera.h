// Pinhole cameras for the renderers: the camera model, INRIA cameras.json loading, orbits and camera paths.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rgs/format/metadata.h"
#include "rgs/format/status.h"

namespace rgs::runtime {

/// A pinhole camera in the COLMAP/INRIA convention the 3DGS scenes were trained with
/// (docs/DESIGN.md#cameras-and-projection; $RGS_DATA_DIR/SOURCES.md): camera frame x right, y down, z forward;
/// no distortion.
///
/// - World to camera: p_cam = R·p + t, R = `rotation` (row-major [3, 3], orthonormal, det +1), t =
///   `translation` (world units). The camera centre is −Rᵀ·t (camera_centre()).
/// - Projection to pixels: px = fx·x/z + cx − 0.5, py = fy·y/z + cy − 0.5, so pixel (i, j) has its centre at
///   integer coordinates (i, j). cx = width/2, cy = height/2 is the 3DGS case (principal point at the image
///   centre); loaders and orbit_cameras() produce exactly that.
/// - EWA clamp (3DGS clamps x/z, y/z to ±1.3·tan(fov/2) before the Jacobian): taken per side from the actual
///   image extents, x/z ∈ [−1.3·cx/fx, 1.3·(width − cx)/fx] and y/z ∈ [−1.3·cy/fy, 1.3·(height − cy)/fy]
///   (kernels/shared/projection.h ewa_clamp_for). For cx = width/2 both sides are 1.3·tan(fov_x/2).
/// - Gaussians with view-space depth z ≤ near_plane are culled (3DGS: 0.2).
struct Camera {
  /// World-to-camera rotation R, row-major [3, 3].
  std::array<float, 9> rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  /// World-to-camera translation t (world units).
  std::array<float, 3> translation = {0, 0, 0};
  /// Focal lengths in pixels.
  float fx = 0, fy = 0;
  /// Principal point in pixels, measured from the image's left/top edge (see the projection above).
  float cx = 0, cy = 0;
  /// Image size in pixels; any size ≥ 1 (not only multiples of 16).
  uint32_t width = 0, height = 0;
  /// Depth (view-space z, world units) at and below which Gaussians are culled.
  float near_plane = 0.2f;
  /// Label for file names and messages (cameras.json img_name, or "orbit_007").
  std::string name;
};

/// Camera centre in world coordinates, −Rᵀ·t (computed in double, rounded to float).
std::array<float, 3> camera_centre(const Camera& camera);

/// Sets `camera`'s pose from the world-to-camera rotation `rows` (row-major [3, 3]) and the camera centre `eye`
/// (world units): rotation = rows, translation = −rows·eye, both computed in double and rounded to float.
void set_pose(Camera* camera, const std::array<double, 9>& rows, const std::array<double, 3>& eye);

/// Moves `camera` with a scene moved by p' = scale·rotation·p + offset (`rotation` row-major [3, 3], orthonormal;
/// scale > 0): its centre goes where the motion takes a point, its view turns with `rotation` and its near plane
/// scales, so it sees the moved scene as it saw the scene before (an edit's motion: converter::edit_motion).
void move_camera(Camera* camera, const std::array<double, 9>& rotation, double scale,
                 const std::array<double, 3>& offset);

/// The size of a view asked as `width` × `height` where 0 means "keep the aspect ratio of ref_width × ref_height":
/// both given, as given; one 0, derived from the other (rounded, clamped to [1, 32769] so that validate_camera
/// refuses what is too large); both 0, the reference size.
std::array<uint32_t, 2> keep_aspect(uint32_t width, uint32_t height, uint32_t ref_width, uint32_t ref_height);

/// Field of view (radians) that a focal length `focal` (pixels) gives over `pixels` pixels:
/// 2·atan(pixels / (2·focal)).
double fov_from_focal(double focal, double pixels);

/// Focal length (pixels) that gives field of view `fov_rad` over `pixels` pixels: pixels / (2·tan(fov/2)).
double focal_from_fov(double fov_rad, double pixels);

/// Checks that a camera can be rendered: width and height in [1, 32768], fx, fy finite and > 0, cx, cy and
/// the translation finite, near_plane finite and > 0, rotation orthonormal with det +1 (to 1e−3).
/// @return kInvalidArgument naming the first problem.
Status validate_camera(const Camera& camera);

/// The same view at another resolution, keeping the field of view on each axis and the principal point's
/// relative position: fx' = fx·W'/W, fy' = fy·H'/H, cx' = cx·W'/W, cy' = cy·H'/H (3DGS -r does this).
/// `width`, `height` ≥ 1; the aspect ratio may change (pixels then become non-square).
Camera resize_camera(const Camera& camera, uint32_t width, uint32_t height);

/// Which cameras of a cameras.json to load, and at what resolution.
struct InriaCameraOptions {
  /// Take every k-th camera of the file (0, k, 2k, ...); 1 = all. Must be ≥ 1.
  uint32_t every_kth = 1;
  /// If not empty: exactly these file indices, in this order (every_kth must then be 1).
  std::vector<uint32_t> indices;
  /// Output resolution. Both 0: the file's width/height divided by `downscale` and rounded (3DGS -r).
  /// One of them 0: derived from the other keeping the file's aspect ratio (rounded). Field of view kept.
  uint32_t width = 0, height = 0;
  /// Resolution divisor used when width and height are 0; must be finite and > 0. 8 gives the 1/8
  /// resolution the flowers scene was trained at (5025×3312 → 628×414).
  double downscale = 1.0;
  /// near_plane of the produced cameras.
  float near_plane = 0.2f;
};

/// A camera of an INRIA 3DGS cameras.json with its numbers as written: `rotation_c2w` camera-to-world, row-major
/// [3, 3] (the JSON's "rotation" rows; its columns are the camera axes in world coordinates), `position` the camera
/// centre (world units), fx, fy in pixels for width × height, principal point at the image centre, COLMAP camera
/// frame (x right, y down, z forward). The Camera it stands for has R = rotation_c2wᵀ and t = −R·position.
struct InriaCamera {
  std::array<double, 9> rotation_c2w = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::array<double, 3> position = {0, 0, 0};
  double fx = 0, fy = 0;
  uint32_t width = 0, height = 0;
};

/// The Camera `c` stands for at out_width × out_height: R = rotation_c2wᵀ, t = −R·position (double, then float),
/// the field of view kept (fx' = fx·W'/W, fy' = fy·H'/H), principal point at the image centre. Not validated
/// (validate_camera()); no name.
Camera camera_from_inria(const InriaCamera& c, uint32_t out_width, uint32_t out_height, float near_plane);

/// Parses one camera object of a cameras.json (`width`, `height`, `position`, `rotation`, `fx`, `fy`; other keys
/// ignored), given as JSON text, with the checks read_inria_cameras makes of every entry but sides up to
/// max_width × max_height. Messages name the keys in double quotes ("fx"), position and rotation as key_prefix +
/// their name (the viewer's "camera.position"), with no file name.
/// @return kCorruptData (not JSON, not an object, a key missing or of the wrong type, a value out of range, a
/// rotation that is not one), kLimitExceeded (read_inria_cameras' bounds on the text).
Result<InriaCamera> parse_inria_camera(std::string_view json_object, uint32_t max_width, uint32_t max_height,
                                       const std::string& key_prefix = "");

/// One entry of a cameras.json: its camera and its label (the entry's "img_name", else "camera_<index>").
struct NamedInriaCamera {
  std::string name;
  InriaCamera camera;
};

/// Reads an INRIA 3DGS cameras.json (a JSON array of {id, img_name, width, height, position[3], rotation[3][3],
/// fx, fy}) as written: every number kept as the file gives it (so that a camera sent elsewhere and back renders
/// the image load_inria_cameras gives). The one reader of the format; load_inria_cameras builds on it. Every entry
/// is checked, whichever a caller later selects: width and height integers in [1, 32768], fx and fy in (0, 1e6],
/// position components finite and within ±1e9, rotation finite and orthonormal with det +1 (validate_camera()).
/// Hostile input is bounded before it is used: files up to 64 MiB, at most 100000 cameras and 8 levels of nesting
/// (both refused while parsing, before the tree they would build).
/// @return the entries in file order. Errors name `path` (and the camera index): kIoError (cannot open or read),
/// kLimitExceeded (a limit above), kCorruptData (not JSON, not an array, empty, a field missing or of the wrong
/// type, a value out of range).
Result<std::vector<NamedInriaCamera>> read_inria_cameras(const std::string& path);

/// Loads the cameras of an INRIA 3DGS cameras.json (read_inria_cameras: its checks and limits) for rendering:
/// R = rotationᵀ and t = −R·position (double, then float); fx, fy in pixels; principal point at the image centre
/// (cx = W/2, cy = H/2); the subset and size `options` ask for.
/// @return the selected cameras in order. Errors: those of read_inria_cameras, kCorruptData naming the camera for
/// a size above 32768 from `options`, kInvalidArgument (bad options, an index beyond the camera count).
Result<std::vector<Camera>> load_inria_cameras(const std::string& path, const InriaCameraOptions& options = {});

/// Same as load_inria_cameras on JSON text in memory; `name` is used in error messages.
Result<std::vector<Camera>> parse_inria_cameras(const std::string& json_text, const std::string& name,
                                                const InriaCameraOptions& options = {});

/// How orbit_cameras() places its ring.
struct OrbitOptions {
  /// Vertical field of view in degrees, (0, 180).
  double fov_y_deg = 50.0;
  /// Height of the ring above the horizontal plane through the target, in degrees, (−89, 89). "Up" is −y
  /// (the scenes' +y points down, $RGS_DATA_DIR/SOURCES.md), so a positive elevation looks down on the scene.
  double elevation_deg = 20.0;
  /// Camera distance as a multiple of the distance at which the bounding sphere just fits the narrower field
  /// of view (r / sin(fov_min/2)). Below 1 moves in (sphere radii are inflated by floaters). Must be > 0.
  double distance_factor = 1.0;
  /// Azimuth of the first camera in degrees; cameras follow at 360/count spacing. Azimuth 0 with elevation
  /// 0 sits on the −z side of the target looking along +z.
  double start_azimuth_deg = 0.0;
  /// near_plane of the produced cameras.
  float near_plane = 0.2f;
};

/// A ring of `count` cameras looking at the centre of `bounds.sphere` from distance
/// distance_factor·r/sin(min(fov_x, fov_y)/2), equally spaced in azimuth around the world −y (up) axis,
/// width × height pixels, square pixels (fx = fy), principal point at the image centre. Deterministic. Names
/// are "orbit_000", "orbit_001", ...
/// @return kInvalidArgument for count 0, a zero size, non-finite or non-positive sphere radius or options
/// out of range.
Result<std::vector<Camera>> orbit_cameras(const format::SceneBounds& bounds, uint32_t count, uint32_t width,
                                          uint32_t height, const OrbitOptions& options = {});

/// How path_cameras() moves around the scene.
struct PathOptions {
  /// Revolutions around the target over the whole path.
  double turns = 2.0;
  /// Elevation (OrbitOptions::elevation_deg) rising linearly from the first view to the last.
  double elevation_first_deg = 5.0, elevation_last_deg = 60.0;
  /// Distance (OrbitOptions::distance_factor) swinging between these three times over the path, so that near
  /// and far views come at every height: far at the first view, near at 1/6 of the path, far at 1/3, ...
  double distance_near = 0.3, distance_far = 1.0;
};

/// A spiral of `count` views for benchmarks (views a scene's own cameras do not show): view i of orbit
/// `base` at azimuth base.start_azimuth_deg + 360·turns·i/count, with the elevation and distance of `path`
/// at t = i/count (distance far + (near − far)·(1 − cos 6πt)/2). Deterministic; names "path_000", ...
/// @return kInvalidArgument as orbit_cameras(), for a distance ≤ 0 or an elevation outside (−89, 89).
Result<std::vector<Camera>> path_cameras(const format::SceneBounds& bounds, uint32_t count, uint32_t width,
                                         uint32_t height, const PathOptions& path = {},
                                         const OrbitOptions& base = {});

/// How fly_through_cameras() shapes its path.
struct FlyThroughOptions {
  /// Knot exponent α of the Catmull–Rom spline through the key centres: knot i + 1 lies |cᵢ₊₁ − cᵢ|^α after
  /// knot i (cᵢ the key centres, world units). 0.5, the centripetal spline, never forms a cusp or a loop inside
  /// a segment however unevenly the keys are spaced (Yuksel, Schaefer and Keyser, "Parameterization and
  /// applications of Catmull–Rom curves", CAD 2011); 0 is the uniform spline, which overshoots where long and
  /// short key steps meet; 1 is the chordal spline. All three are the same curve when the keys are evenly
  /// spaced. Must be in [0, 1].
  double spline_alpha = 0.5;
};

/// `count` views flown through the key cameras `keys` in order (e.g. a scene's capture cameras, which lie inside
/// it and keep its up direction), for benchmarks of views the keys do not show.
///
/// - Path: the camera centres (−Rᵀ·t, world units) follow the Catmull–Rom spline with knot exponent
///   `options.spline_alpha` (centripetal by default) through the key centres, written as cubic Hermite segments
///   that share each key's tangent, so the path is C1 in the knot parameter. The end keys take the chord to
///   their one neighbour as tangent. A key whose centre coincides with the previous key's starts a segment of
///   length zero (no NaNs; the path stops there, the tangents on either side are one-sided).
/// - Spacing: views are evenly spaced by the arc length of that path (tabulated with 256 chords a segment,
///   interpolated between them), not by key index, so the speed is steady: view v lies at arc length
///   L·v/(count − 1) from the first key's centre, L the path's length. If every key centre coincides (L = 0),
///   views are spaced by key index instead.
/// - Rotations: the world-to-camera rotation R (row-major [3, 3], Camera::rotation) is the shortest-arc slerp of
///   the two keys' unit quaternions at the view's parameter u ∈ [0, 1] within its segment; the translation is
///   t = −R·c for the view's centre c. A segment of length zero gets no view, so its turn happens between two
///   consecutive views.
/// - View 0 has exactly the first key's rotation and translation, view count − 1 (count ≥ 2) the last key's.
/// - Intrinsics (fx, fy, cx, cy, width, height, near_plane) are the first key's, for every view.
///
/// Computed in double, rounded to float. Deterministic; names "fly_000", "fly_001", ...
/// @return kInvalidArgument for count 0, fewer than 2 keys, an invalid key (validate_camera, naming the key),
/// keys of different image sizes (resize them first: resize_camera), or spline_alpha outside [0, 1].
Result<std::vector<Camera>> fly_through_cameras(const std::vector<Camera>& keys, uint32_t count,
                                                const FlyThroughOptions& options = {});

}  // namespace rgs::runtime
