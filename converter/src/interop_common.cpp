// Frame flips, cloud checks and input hygiene shared by the scene readers and writers, and the SPZ frame
// choice (interop.h).
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "internal_interop.h"

namespace rgs::converter::detail {

namespace {

/// Exponents (x, y, z) mod 2 of the polynomial of SH basis k = 1..15 (docs/DESIGN.md#spherical-harmonics):
/// only the parity matters under an axis flip, and the even factors (x², 2z² − x² − y², ...) keep sign.
constexpr uint8_t kShParity[16][3] = {
    {0, 0, 0},  // 0: constant
    {0, 1, 0},  // 1: y
    {0, 0, 1},  // 2: z
    {1, 0, 0},  // 3: x
    {1, 1, 0},  // 4: xy
    {0, 1, 1},  // 5: yz
    {0, 0, 0},  // 6: 2z² − x² − y²
    {1, 0, 1},  // 7: xz
    {0, 0, 0},  // 8: x² − y²
    {0, 1, 0},  // 9: y(3x² − y²)
    {1, 1, 1},  // 10: xyz
    {0, 1, 0},  // 11: y(4z² − x² − y²)
    {0, 0, 1},  // 12: z(2z² − 3x² − 3y²)
    {1, 0, 0},  // 13: x(4z² − x² − y²)
    {0, 0, 1},  // 14: z(x² − y²)
    {1, 0, 0},  // 15: x(x² − 3y²)
};

}  // namespace

Status check_cloud_shape(const format::GaussianCloud& cloud) {
  if (cloud.sh_degree > 3) {
    return Status(StatusCode::kInvalidArgument, "cloud SH degree " + std::to_string(cloud.sh_degree) + " > 3");
  }
  if (!cloud.is_consistent()) {
    return Status(StatusCode::kInvalidArgument,
                  "cloud arrays are inconsistent: " + std::to_string(cloud.means.size()) + " mean values, " +
                      std::to_string(cloud.rotations.size()) + " rotation values, " +
                      std::to_string(cloud.scales.size()) + " scale values, " +
                      std::to_string(cloud.opacities.size()) + " opacities, " + std::to_string(cloud.sh.size()) +
                      " SH values at SH degree " + std::to_string(cloud.sh_degree));
  }
  return Status();
}

Status apply_invalid_policy(InvalidPolicy policy, const char* what, const std::vector<uint64_t>& invalid,
                            format::GaussianCloud* cloud, InputHygiene* h) {
  h->first_invalid_index = invalid.empty() ? -1 : static_cast<int64_t>(invalid.front());
  if (invalid.empty()) return Status();
  if (policy == InvalidPolicy::kReject) {
    return Status(StatusCode::kCorruptData,
                  std::to_string(h->gaussians_with_nonfinite) + " Gaussians have non-finite values (" +
                      std::to_string(h->nonfinite_values) + " values) and " + std::to_string(h->zero_norm_quaternions) +
                      " have zero-norm quaternions (first: " + what + " " + std::to_string(h->first_invalid_index) +
                      "); rerun with --sanitize to drop them");
  }
  cloud->remove_gaussians(invalid);
  h->dropped_gaussians = invalid.size();
  return Status();
}

bool flip_to_rdf(const std::string& frame, AxisFlip* flip) {
  if (frame.size() != 3) return false;
  const char x = frame[0], y = frame[1], z = frame[2];
  if ((x != 'R' && x != 'L') || (y != 'U' && y != 'D') || (z != 'F' && z != 'B')) return false;
  flip->s[0] = x == 'R' ? 1.0f : -1.0f;
  flip->s[1] = y == 'D' ? 1.0f : -1.0f;
  flip->s[2] = z == 'F' ? 1.0f : -1.0f;
  return true;
}

void apply_axis_flip(const AxisFlip& flip, format::GaussianCloud* cloud) {
  if (flip.identity()) return;
  const float* s = flip.s;
  const float qs[3] = {s[1] * s[2], s[0] * s[2], s[0] * s[1]};
  const uint32_t k_count = cloud->sh_coefficients();
  float sh_sign[16];
  for (uint32_t k = 0; k < 16; ++k) {
    float sign = 1.0f;
    for (int a = 0; a < 3; ++a) {
      if (kShParity[k][a]) sign *= s[a];
    }
    sh_sign[k] = sign;
  }
  const size_t n = cloud->size();
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) cloud->means[i * 3 + a] *= s[a];
    for (int a = 0; a < 3; ++a) cloud->rotations[i * 4 + 1 + a] *= qs[a];
    float* sh = cloud->sh.data() + i * k_count * 3;
    for (uint32_t k = 1; k < k_count; ++k) {
      for (int c = 0; c < 3; ++c) sh[k * 3 + c] *= sh_sign[k];
    }
  }
}

Status finish_hygiene(InvalidPolicy policy, const char* what, format::GaussianCloud* cloud, InputHygiene* h) {
  std::vector<uint64_t> invalid;
  for (size_t i = 0; i < cloud->size(); ++i) {
    if (check_gaussian(cloud, i, h)) invalid.push_back(i);
  }
  return apply_invalid_policy(policy, what, invalid, cloud, h);
}

Status check_writable_cloud(const format::GaussianCloud& cloud) {
  RGS_RETURN_IF_ERROR(check_cloud_shape(cloud));
  auto check = [](const std::vector<float>& v, const char* name) -> Status {
    for (size_t j = 0; j < v.size(); ++j) {
      if (!finite_bits(v[j])) {
        return Status(StatusCode::kInvalidArgument,
                      std::string("cloud has a non-finite ") + name + " value at index " + std::to_string(j));
      }
    }
    return Status();
  };
  RGS_RETURN_IF_ERROR(check(cloud.means, "mean"));
  RGS_RETURN_IF_ERROR(check(cloud.rotations, "rotation"));
  RGS_RETURN_IF_ERROR(check(cloud.scales, "scale"));
  RGS_RETURN_IF_ERROR(check(cloud.opacities, "opacity"));
  RGS_RETURN_IF_ERROR(check(cloud.sh, "SH"));
  return Status();
}

}  // namespace rgs::converter::detail

namespace rgs::converter {

const char* spz_frame_name(SpzFrame frame) { return frame == SpzFrame::kAsStored ? "as-stored" : "rub"; }

std::optional<SpzFrame> parse_spz_frame(std::string_view name) {
  if (name == "rub") return SpzFrame::kRub;
  if (name == "as-stored") return SpzFrame::kAsStored;
  return std::nullopt;
}

std::string spz_frame_note(SpzFrame frame, bool writing) {
  if (writing) {
    return frame == SpzFrame::kRub
               ? "frame: stored as RUB (y and z negated), Niantic's convention; splat-transform 3.7 shows such "
                 "a file upside down (write for it with spz frame as-stored)"
               : "frame: the PLY's axes stored unturned (spz frame as-stored), as splat-transform 3.7 reads "
                 "them; readers that follow Niantic's convention show the file upside down";
  }
  return frame == SpzFrame::kRub
             ? "SPZ axes read as RUB, Niantic's convention, and turned to RDF; a file from splat-transform 3.7 "
               "holds the PLY's axes and then shows upside down: read it with spz frame as-stored"
             : "SPZ axes read as stored (spz frame as-stored): the PLY's axes, as splat-transform 3.7 writes "
               "them; a file that follows Niantic's convention then shows upside down";
}

}  // namespace rgs::converter
