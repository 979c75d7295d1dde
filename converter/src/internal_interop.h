// Helpers shared by the scene readers and writers (and the edits and levels): activations, quaternion-matrix
// conversions, frame flips, cloud checks and input hygiene (private to rgs_converter).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "rgs/converter/interop.h"
#include "rgs/format/file_io.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/little_endian.h"
#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// SH degree-0 basis constant (docs/DESIGN.md#spherical-harmonics): f_dc = (colour − 0.5) / kShC0.
constexpr double kShC0 = 0.28209479177387814;
/// logit(1 − 1e-6): readers of 8-bit alphas clamp opacities of exactly 0 or 1 to ±this (±13.8155).
constexpr double kMaxOpacityLogit = 13.815509557963773;

/// The INRIA load activations as every reader applies them, in double and rounded to float32: opacity =
/// sigmoid(logit), ±inf giving exactly 1 and 0; scale = exp(log scale), +inf beyond float32's range.
inline float activate_opacity(float logit) { return static_cast<float>(1.0 / (1.0 + std::exp(-double(logit)))); }
inline float activate_scale(float log_scale) {
  const double s = std::exp(double(log_scale));
  return s > double(std::numeric_limits<float>::max()) ? std::numeric_limits<float>::infinity() : float(s);
}

/// The row-major matrix of the quaternion q (w, x, y, z) as 3DGS builds a Gaussian's rotation (a rotation when q is
/// unit; the formula is applied as is).
inline std::array<double, 9> quaternion_matrix(const double q[4]) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

/// The quaternion (w, x, y, z) of the rotation matrix r, not normalized: the branch on the largest of the trace
/// and the diagonal keeps the division well conditioned.
inline void matrix_quaternion(const double r[3][3], double q[4]) {
  const double tr = r[0][0] + r[1][1] + r[2][2];
  if (tr > 0) {
    const double u = std::sqrt(tr + 1.0) * 2;
    q[0] = 0.25 * u, q[1] = (r[2][1] - r[1][2]) / u, q[2] = (r[0][2] - r[2][0]) / u, q[3] = (r[1][0] - r[0][1]) / u;
  } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
    const double u = std::sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]) * 2;
    q[0] = (r[2][1] - r[1][2]) / u, q[1] = 0.25 * u, q[2] = (r[0][1] + r[1][0]) / u, q[3] = (r[0][2] + r[2][0]) / u;
  } else if (r[1][1] > r[2][2]) {
    const double u = std::sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]) * 2;
    q[0] = (r[0][2] - r[2][0]) / u, q[1] = (r[0][1] + r[1][0]) / u, q[2] = 0.25 * u, q[3] = (r[1][2] + r[2][1]) / u;
  } else {
    const double u = std::sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]) * 2;
    q[0] = (r[1][0] - r[0][1]) / u, q[1] = (r[0][2] + r[2][0]) / u, q[2] = (r[1][2] + r[2][1]) / u, q[3] = 0.25 * u;
  }
}

/// Axis signs taking one frame to another: x' = sx·x, y' = sy·y, z' = sz·z (each ±1).
struct AxisFlip {
  float s[3] = {1, 1, 1};
  bool identity() const { return s[0] > 0 && s[1] > 0 && s[2] > 0; }
};

/// Parses a three-letter frame name of the flip-only family ("RDF", "RUB", "LUF", ...: x Right/Left,
/// y Up/Down, z Back/Front) into the flip that takes it to RDF. False for any other string.
bool flip_to_rdf(const std::string& frame, AxisFlip* flip);

/// Applies an axis flip to every Gaussian of `cloud`: means x' = S·x; the rotation matrix R' = S·R·S,
/// which for a unit quaternion (w, x, y, z) keeps w and scales (x, y, z) by (sy·sz, sx·sz, sx·sy)
/// (for a proper rotation S that is the vector part rotated by S); scales unchanged (S·diag·S = diag);
/// SH coefficient k >= 1 multiplied by the parity of its basis polynomial under S (docs/DESIGN.md#spherical-harmonics:
/// y, z, x, xy, yz, 1, xz, 1, y, xyz, y, z, x, z, x up to sign and even factors).
void apply_axis_flip(const AxisFlip& flip, format::GaussianCloud* cloud);

/// False for ±inf and NaN, from the bits (also where the compiler may assume finite math).
inline bool finite_bits(float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  return (u & 0x7f800000u) != 0x7f800000u;
}

/// The InputHygiene rules (docs/INPUT_HYGIENE.md) for Gaussian `i` of `cloud`, whose values are activated: counts
/// its non-finite values (means, SH, scales, rotation; a NaN opacity) and a zero-norm quaternion into `h` and
/// normalizes a finite, non-zero quaternion. @return whether the Gaussian is invalid (a policy keeps or drops it).
inline bool check_gaussian(format::GaussianCloud* cloud, size_t i, InputHygiene* h) {
  const size_t sv = size_t{cloud->sh_coefficients()} * 3;
  uint64_t bad = 0;
  for (int a = 0; a < 3; ++a) bad += !finite_bits(cloud->means[i * 3 + a]) + !finite_bits(cloud->scales[i * 3 + a]);
  for (size_t j = 0; j < sv; ++j) bad += !finite_bits(cloud->sh[i * sv + j]);
  bad += std::isnan(cloud->opacities[i]);
  float* q = cloud->rotations.data() + i * 4;
  bool zero_norm = false;
  uint64_t q_bad = 0;
  for (int a = 0; a < 4; ++a) q_bad += !finite_bits(q[a]);
  if (q_bad == 0) {
    double n2 = 0;
    for (int a = 0; a < 4; ++a) n2 += static_cast<double>(q[a]) * q[a];
    // A norm² that is zero or subnormal in float32 cannot be normalized by float code (the INRIA loader's
    // F.normalize would leave a non-unit quaternion), so such rotations are invalid.
    zero_norm = n2 < static_cast<double>(std::numeric_limits<float>::min());
    const double inv = zero_norm ? 1.0 : 1.0 / std::sqrt(n2);
    for (int a = 0; a < 4 && !zero_norm; ++a) q[a] = static_cast<float>(q[a] * inv);
  }
  bad += q_bad;
  h->nonfinite_values += bad;
  h->gaussians_with_nonfinite += bad != 0;
  h->zero_norm_quaternions += zero_norm;
  return bad != 0 || zero_norm;
}

/// Checks that `cloud` has SH degree <= 3 and arrays sized for its Gaussian count (GaussianCloud::
/// is_consistent). Values are not looked at. @return kInvalidArgument naming the degree or every array size.
Status check_cloud_shape(const format::GaussianCloud& cloud);

/// Applies `policy` to the Gaussians at the indices `invalid` (ascending; `hygiene` already counts them):
/// records the first in hygiene->first_invalid_index, then fails with kCorruptData naming it as `what`
/// (kReject), or removes them from `cloud` in place, keeping the order of the others (kSanitize).
Status apply_invalid_policy(InvalidPolicy policy, const char* what, const std::vector<uint64_t>& invalid,
                            format::GaussianCloud* cloud, InputHygiene* hygiene);

/// Normalizes the quaternions of `cloud` and applies the InputHygiene rules of the PLY reader
/// (docs/INPUT_HYGIENE.md): counts non-finite values (means, SH, scales, rotations; NaN opacity) and
/// zero-norm quaternions, then fails with kCorruptData (kReject, same message as read_ply) or drops
/// those Gaussians (kSanitize). `what` names a Gaussian in messages ("splat", "vertex").
Status finish_hygiene(InvalidPolicy policy, const char* what, format::GaussianCloud* cloud, InputHygiene* hygiene);

/// Adds the counts of `part` (dropped Gaussians included) to `total`; total's first_invalid_index becomes
/// part's + `offset` (the Gaussians before part's input) when total has none.
void add_hygiene(const InputHygiene& part, uint64_t offset, InputHygiene* total);

/// XXH64 (seed 0) over the little-endian bytes of `hashes`: the hash of an input made of several files.
uint64_t combine_hashes(const std::vector<uint64_t>& hashes);

inline std::string prefix(const std::string& name) { return name.empty() ? std::string() : name + ": "; }

/// kLimitExceeded "<head><count> <unit>, above the limit of <limit><tail>" when count > limit, else ok: the
/// readers' one form of a refused size ("SPZ declares 5 Gaussians, above the limit of 4").
inline Status check_limit(const std::string& head, uint64_t count, const char* unit, uint64_t limit,
                          const char* tail = "") {
  if (count <= limit) return Status();
  return Status(StatusCode::kLimitExceeded, head + std::to_string(count) + " " + unit + ", above the limit of " +
                                                std::to_string(limit) + tail);
}

/// Runs `fn` (returning Result<T>), prefixing errors with `name` and turning allocation failures and
/// stray exceptions into statuses (libraries never throw across their API).
template <typename T, typename Fn>
Result<T> guarded(const std::string& name, const char* activity, Fn&& fn) {
  try {
    Result<T> r = fn();
    if (!r.ok()) {
      Status s = std::move(r).status();
      if (!name.empty()) s.prepend(name);
      return s;
    }
    return r;
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, prefix(name) + "out of memory while " + activity);
  } catch (const std::length_error&) {
    return Status(StatusCode::kOutOfMemory, prefix(name) + "out of memory while " + activity);
  } catch (const std::exception& e) {
    // Exceptions of the JSON parser can quote the input: keep the message short.
    return Status(StatusCode::kCorruptData, prefix(name) + activity + " failed: " + std::string(e.what()).substr(0, 160));
  }
}

/// guarded() over a reader's `size` bytes at `data`: kInvalidArgument for null data of non-zero size, else `fn`.
template <typename T, typename Fn>
Result<T> guarded_bytes(const uint8_t* data, size_t size, const std::string& name, const char* activity, Fn&& fn) {
  return guarded<T>(name, activity, [&]() -> Result<T> {
    if (data == nullptr && size != 0) return Status(StatusCode::kInvalidArgument, "null data with non-zero size");
    return fn();
  });
}

/// The InteropScene of a .splat or .ksplat file (`format`) of `file_bytes`, its cloud sized for `count` Gaussians of
/// SH `degree`. The writers of both copy the PLY's axes: stored RDF, which convert_frame leaves as it is.
inline InteropScene rdf_interop_scene(const char* format, uint64_t file_bytes, uint64_t count, uint32_t degree,
                                      const InteropReadOptions& options) {
  InteropScene scene;
  scene.format = format;
  scene.file_bytes = file_bytes;
  scene.declared_gaussians = count;
  scene.stored_frame = "RDF";
  scene.frame_converted = options.convert_frame;  // RDF to RDF: nothing to do
  scene.cloud.sh_degree = degree;
  scene.cloud.resize(static_cast<size_t>(count));
  return scene;
}

/// Refuses the cloud of a .splat or .ksplat file (`format`, as messages name it) that holds a negative scale: their
/// writers store exp of the log scale, so it is damage. Then applies the hygiene rules.
inline Status finish_splat_scene(const std::string& format, const InteropReadOptions& options, InteropScene* scene) {
  const std::vector<float>& scales = scene->cloud.scales;
  const auto first = std::find_if(scales.begin(), scales.end(), [](float s) { return s < 0; });
  RGS_RETURN_ERROR_IF(first != scales.end(), StatusCode::kCorruptData,
                      format + ": Gaussian " + std::to_string((first - scales.begin()) / 3) +
                          " has a negative scale (" + std::to_string(*first) + "; negative scale values: " +
                          std::to_string(std::count_if(first, scales.end(), [](float s) { return s < 0; })) +
                          " of " + std::to_string(scales.size()) + "): a damaged file, or another format");
  return finish_hygiene(options.invalid_policy, "splat", &scene->cloud, &scene->hygiene);
}

/// PlayCanvas's smallest-three quaternions (compressed PLY, SOG): the components other than `largest`, in
/// w x y z order, are stored(0), stored(1), stored(2) (doubles); the largest is what makes the norm 1. Writes the
/// quaternion, renormalized, to out[0..3].
template <typename Stored>
void decode_smallest_three(int largest, Stored&& stored, float* out) {
  double q[4];
  double sum = 0;
  for (int c = 0, k = 0; c < 4; ++c) {
    if (c == largest) continue;
    q[c] = stored(k++);
    sum += q[c] * q[c];
  }
  q[largest] = std::sqrt(std::max(0.0, 1.0 - sum));
  const double inv = 1.0 / std::sqrt(sum + q[largest] * q[largest]);
  for (int c = 0; c < 4; ++c) out[c] = static_cast<float>(q[c] * inv);
}

/// The SPZ and glTF writers' precondition: check_cloud_shape, and every value finite.
/// Errors: kInvalidArgument.
Status check_writable_cloud(const format::GaussianCloud& cloud);

/// The SPZ and glTF writers' serialize_* step: runs `serialize(Summary*)` (returning Result<std::vector<uint8_t>>,
/// the file's bytes) under guarded("", activity), filling `summary`, or a local one when it is null.
template <typename Summary, typename Serialize>
Result<std::vector<uint8_t>> serialize_guarded(const char* activity, Summary* summary, Serialize&& serialize) {
  Summary local;
  return guarded<std::vector<uint8_t>>("", activity, [&]() { return serialize(summary ? summary : &local); });
}

/// The SPZ and glTF writers' file step: runs `serialize(Summary*)` under guarded(path, activity) and writes the
/// bytes it returns to `path` through `files`. Errors: guarded's, then files.write's.
template <typename Summary, typename Serialize>
Result<Summary> write_serialized(const std::string& path, const char* activity, format::FileSink& files,
                                 Serialize&& serialize) {
  Summary summary;
  RGS_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes,
                       guarded<std::vector<uint8_t>>(path, activity, [&]() { return serialize(&summary); }));
  RGS_RETURN_IF_ERROR(files.write(path, bytes.data(), bytes.size()));
  return summary;
}

}  // namespace rgs::converter::detail
