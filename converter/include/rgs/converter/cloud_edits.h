// Edits of a scene on its way through a conversion: rgs-convert's --translate, --rotate, --scale, --filter-nan,
// --filter, --crop-box and --crop-sphere (and their -outside forms), --decimate, api::ConvertOptions::edits and
// Python's edits=. One parser (parse_edit_action) turns the command line's spelling into an EditAction for all of
// them; apply_edit acts on a float cloud (docs/DESIGN.md#the-scene-pipeline, README "Editing on the way").
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// What an edit does.
enum class EditKind : uint8_t {
  kTranslate = 0,   ///< means += (x, y, z)
  kRotate = 1,      ///< means, rotations and SH bands 1..3 rotated about the origin
  kScale = 2,       ///< means and linear scales multiplied by s (log scales + ln s)
  kFilterNan = 3,   ///< drop Gaussians with any non-finite value
  kFilter = 4,      ///< keep Gaussians whose property compares true with a value
  kCropBox = 5,     ///< keep Gaussians whose mean is inside (or outside) an axis-aligned box
  kCropSphere = 6,  ///< keep Gaussians whose mean is inside (or outside) a sphere
  kDecimate = 7,    ///< merge Gaussians by the level-of-detail rule down to a count or fraction
};

/// The comparison of a kFilter edit: lt le gt ge eq ne (also written < <= > >= == !=).
enum class EditCompare : uint8_t { kLt = 0, kLe, kGt, kGe, kEq, kNe };

/// One edit, as parse_edit_action makes it (or built in code and checked by check_edit_action).
struct EditAction {
  EditKind kind = EditKind::kTranslate;
  /// The numbers, finite, by kind (scene units are those of the means):
  /// - kTranslate [3]: x, y, z offset, scene units.
  /// - kRotate [4]: the rotation as a unit quaternion w, x, y, z (within 1e-3 of norm 1; applied normalized).
  ///   The command line's Euler angles are turned into one by parse_edit_action.
  /// - kScale [1]: s > 0, uniform about the origin.
  /// - kFilter [1]: the value the property is compared with, rounded to float32 as the property is held.
  /// - kCropBox [6]: min x, y, z then max x, y, z, scene units, min <= max per axis; inside means min <= p <= max.
  /// - kCropSphere [4]: centre x, y, z and radius r > 0, scene units; inside means |p - centre| <= r.
  /// - kDecimate [1]: at most N Gaussians (an integer N >= 1) or a FRACTION in (0, 1) of them (rounded, at least 1).
  /// - kFilterNan: none.
  std::vector<double> values;
  /// kFilter: the property compared, named as in an INRIA PLY but read from the cloud's activated values: x, y,
  /// z (means); opacity (after the sigmoid, in [0, 1]); scale_0..2 (after exp, linear); rot_0..3 (the normalized
  /// quaternion w, x, y, z); f_dc_0..2 (SH coefficient 0 of R, G, B); red, green, blue (the DC colour 0.5 +
  /// 0.28209479·f_dc, what splat-transform's -V f_dc_0..2 compares); f_rest_K (K = 0..44, channel-major as in the
  /// PLY: coefficient K mod (n-1) + 1 of channel K div (n-1), n = (degree+1)² of the scene at that point).
  std::string property;
  EditCompare compare = EditCompare::kLt;
  /// kCropBox, kCropSphere: keep the Gaussians outside instead of inside (the boundary counts as inside).
  bool outside = false;
  /// The action as given, "NAME VALUE" ("rotate 0,90,0"), for messages, the report and the provenance.
  std::string text;
};

/// Parses one action in rgs-convert's spelling: `name` is the option without its dashes (translate, rotate, scale,
/// filter-nan, filter, crop-box, crop-box-outside, crop-sphere, crop-sphere-outside), `value` its argument ("" for
/// filter-nan):
/// - translate "x,y,z"; scale "s";
/// - rotate "x,y,z": Euler angles in degrees about the fixed world axes, applied x first, then y, then z
///   (extrinsic x-y-z, the same as intrinsic z-y'-x''): R = Rz(z)·Ry(y)·Rx(x), right-handed (a positive angle
///   turns counter-clockwise seen from the axis' positive end); or rotate "w,x,y,z": a unit quaternion;
/// - filter "NAME OP VALUE" (three words separated by spaces; NAME as EditAction::property, OP one of lt le gt ge
///   eq ne < <= > >= == !=);
/// - crop-box "minx,miny,minz,maxx,maxy,maxz", crop-sphere "cx,cy,cz,r", and their -outside forms;
/// - decimate "N" (an integer >= 1) or "FRACTION" (in (0, 1)).
/// Numbers are decimal (strtod), separated by commas, spaces around them allowed.
/// @return kInvalidArgument naming the action and its value ("rotate '1,1,0,0': ...") for an unknown name or
///         property, a number that is not one or not finite, a wrong count of numbers, a quaternion that is not a
///         rotation (norm not within 1e-3 of 1), a scale or radius that is not positive, a box with min > max, a
///         decimation that is neither an integer >= 1 nor a fraction in (0, 1).
Result<EditAction> parse_edit_action(const std::string& name, const std::string& value);

/// `action.text` when set, else the action in parse_edit_action's spelling with its numbers at full precision (a
/// rotation as its quaternion): "rotate '0.70710678118654757,0,0.70710678118654757,0'".
std::string edit_action_text(const EditAction& action);

/// The edits of a .rgs provenance's "options" entry (its " edits=" part: edit_action_text of each, joined by "; ",
/// as the conversion that wrote the file recorded them), parsed back in order; empty when it has none.
/// kInvalidArgument when that part is not such a list.
Result<std::vector<EditAction>> parse_recorded_edits(const std::string& options);

/// Checks an action's values as parse_edit_action does (for actions built in code): the count by kind, every
/// number finite, the quaternion's norm, s > 0, r > 0, min <= max, a known property.
/// @return kInvalidArgument naming the action (its `text`, else its kind).
Status check_edit_action(const EditAction& action);

/// Where edits move the scene: p' = scale·rotation·p + offset.
struct EditMotion {
  std::array<double, 9> rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major
  double scale = 1;
  std::array<double, 3> offset = {0, 0, 0};  ///< scene units
};

/// The motion of `edits` (checked, as apply_edit takes them), in order: their translations, rotations and scales
/// composed; the other kinds move nothing. What moves a view given in the source's frame with the scene.
EditMotion edit_motion(const std::vector<EditAction>& edits);

/// Applies `action` to `cloud` in place, keeping the order of the Gaussians it keeps. A rotation turns the means
/// about the origin (p' = R·p, in double), left-multiplies each quaternion (q' = q_R·q, normalized) and rotates the
/// SH bands 1..3 by their Wigner D-matrices (sh_rotation.h) so that each Gaussian shows the same colour towards
/// the rotated directions; translate and scale change means (and scales) in double, rounded to float32.
/// Decimation to a target T leaves a scene of at most T as it is; a larger one is quantized (quantize()'s defaults),
/// its levels built (build_lod: 16 levels, chunks of at most max(T / 16, 64) Gaussians, eight times more while the
/// coarsest levels exceed T), and it becomes the cut a renderer under a budget of T splats draws: from the full
/// detail, the chunk whose next level has the smallest error (ties: the lower chunk) moves one level coarser while
/// the total exceeds T. So T - chunk size < count <= T, in chunk order, dequantized as the .rgs holds it
/// (docs/LOD.md#decimation).
/// @return the number of Gaussians removed (0 for translate, rotate, scale); kInvalidArgument for an action
///         check_edit_action refuses, an inconsistent cloud, or f_rest_K beyond the cloud's SH degree.
Result<uint64_t> apply_edit(format::GaussianCloud* cloud, const EditAction& action);

}  // namespace rgs::converter
