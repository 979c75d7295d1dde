#include "internal_cloud.h"

#include <cstring>
#include <string>

namespace rgs::converter::detail {

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

void remove_gaussians(const std::vector<uint64_t>& drop, format::GaussianCloud* cloud) {
  const uint64_t n = cloud->size();
  const uint64_t sv = uint64_t{cloud->sh_coefficients()} * 3;
  uint64_t out = 0;
  size_t d = 0;
  for (uint64_t i = 0; i < n; ++i) {
    if (d < drop.size() && drop[d] == i) {
      ++d;
      continue;
    }
    if (out != i) {
      std::memmove(&cloud->means[out * 3], &cloud->means[i * 3], 3 * sizeof(float));
      std::memmove(&cloud->rotations[out * 4], &cloud->rotations[i * 4], 4 * sizeof(float));
      std::memmove(&cloud->scales[out * 3], &cloud->scales[i * 3], 3 * sizeof(float));
      cloud->opacities[out] = cloud->opacities[i];
      std::memmove(&cloud->sh[out * sv], &cloud->sh[i * sv], sv * sizeof(float));
    }
    ++out;
  }
  cloud->resize(out);
}

}  // namespace rgs::converter::detail
