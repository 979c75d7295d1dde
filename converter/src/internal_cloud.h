// Checks and edits of a float GaussianCloud shared by the converter's readers and writers (private to
// rgs_converter).
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Checks that `cloud` has SH degree <= 3 and arrays sized for its Gaussian count (GaussianCloud::
/// is_consistent). Values are not looked at. @return kInvalidArgument naming the degree or every array size.
Status check_cloud_shape(const format::GaussianCloud& cloud);

/// Removes the Gaussians at the indices `drop` (ascending, each < cloud->size()), keeping the order of the
/// others; the cloud shrinks in place, without reallocating.
void remove_gaussians(const std::vector<uint64_t>& drop, format::GaussianCloud* cloud);

}  // namespace rgs::converter::detail
