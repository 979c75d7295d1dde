// Gaussians imported from a caller's device arrays (value checks, AABB, normalized quaternions, SH degree
// reduction or RGB → DC), and rendered frames split into gsplat's planar outputs. The checks are those of a
// file's Gaussians on the host (converter::scene_from_cloud, docs/INPUT_HYGIENE.md), operation for operation:
// quaternions are normalized in float64 as there, so the imported values equal the host's bit for bit.
#include <cub/device/device_scan.cuh>

#include <algorithm>
#include <cfloat>

#include "launch_util.cuh"
#include "rgs/kernels/array_io.h"
#include "rgs/kernels/shared/spherical_harmonics.h"

namespace rgs::kernels {
namespace {

/// Blocks of the grid-stride import passes: enough to fill the device, few enough that the per-warp atomics
/// of the totals stay cheap.
constexpr unsigned kImportBlocks = 1024;

__device__ inline bool finite_value(float v) { return (__float_as_uint(v) & 0x7f800000u) != 0x7f800000u; }

/// Value j of Gaussian i's imported SH block ((sh_degree + 1)² · 3 values).
__device__ inline float color_value(const GaussianImportSource& s, uint64_t i, uint32_t j) {
  if (s.rgb) return (s.colors[i * 3 + j] - 0.5f) / kShC0;
  return s.colors[i * uint64_t(s.color_coefficients) * 3 + j];
}

/// The checks of one Gaussian; q receives its normalized quaternion when it has one.
struct GaussianCheck {
  unsigned nonfinite = 0;
  bool zero_norm = false;
  bool negative_scale = false;
  bool bad_opacity = false;
  __device__ bool valid() const { return nonfinite == 0 && !zero_norm; }
};

__device__ GaussianCheck check_gaussian(const GaussianImportSource& s, uint64_t i, float q[4]) {
  GaussianCheck c;
  for (int a = 0; a < 3; ++a) c.nonfinite += !finite_value(s.means[i * 3 + a]);
  const uint32_t values = (s.sh_degree + 1) * (s.sh_degree + 1) * 3;
  for (uint32_t j = 0; j < values; ++j) c.nonfinite += !finite_value(color_value(s, i, j));
  for (int a = 0; a < 3; ++a) {
    const float v = s.scales[i * 3 + a];
    c.nonfinite += !finite_value(v);
    c.negative_scale = c.negative_scale || v < 0;
  }
  const float o = s.opacities[i];
  c.nonfinite += o != o;
  c.bad_opacity = o < 0 || o > 1;
  bool q_finite = true;
  for (int a = 0; a < 4; ++a) {
    q[a] = s.rotations[i * 4 + a];
    const bool f = finite_value(q[a]);
    c.nonfinite += !f;
    q_finite = q_finite && f;
  }
  if (q_finite) {
    double n2 = 0;
    for (int a = 0; a < 4; ++a) n2 += static_cast<double>(q[a]) * q[a];
    if (n2 < static_cast<double>(FLT_MIN)) {
      c.zero_norm = true;
    } else {
      const double inv = 1.0 / sqrt(n2);
      for (int a = 0; a < 4; ++a) q[a] = static_cast<float>(q[a] * inv);
    }
  }
  return c;
}

__device__ inline unsigned long long warp_sum(unsigned long long v) {
  for (int offset = 16; offset > 0; offset /= 2) v += __shfl_xor_sync(0xffffffffu, v, offset);
  return v;
}
__device__ inline unsigned long long warp_min(unsigned long long v) {
  for (int offset = 16; offset > 0; offset /= 2) v = min(v, __shfl_xor_sync(0xffffffffu, v, offset));
  return v;
}
__device__ inline unsigned warp_min(unsigned v) {
  for (int offset = 16; offset > 0; offset /= 2) v = min(v, __shfl_xor_sync(0xffffffffu, v, offset));
  return v;
}
__device__ inline unsigned warp_max(unsigned v) {
  for (int offset = 16; offset > 0; offset /= 2) v = max(v, __shfl_xor_sync(0xffffffffu, v, offset));
  return v;
}
__device__ inline double warp_max(double v) {
  for (int offset = 16; offset > 0; offset /= 2) v = fmax(v, __shfl_xor_sync(0xffffffffu, v, offset));
  return v;
}

__global__ void reset_totals_kernel(GaussianImportTotals* t) {
  t->nonfinite_values = 0;
  t->gaussians_with_nonfinite = 0;
  t->zero_norm_quaternions = 0;
  t->invalid = 0;
  t->first_invalid = kNoGaussian;
  t->first_negative_scale = kNoGaussian;
  t->first_bad_opacity = kNoGaussian;
  for (int a = 0; a < 3; ++a) {
    t->aabb_min_key[a] = ~0u;
    t->aabb_max_key[a] = 0;
  }
  t->radius2_bits = 0;
}

// The warp reductions follow the grid-stride loop, which every lane leaves, so all 32 lanes take part.
__global__ void __launch_bounds__(detail::kBlockSize)
    check_gaussians_kernel(GaussianImportSource s, GaussianImportTotals* t, unsigned* valid) {
  unsigned long long nonfinite = 0, with_nonfinite = 0, zero_norm = 0, invalid = 0;
  unsigned long long first_invalid = kNoGaussian, first_negative = kNoGaussian, first_opacity = kNoGaussian;
  unsigned lo[3] = {~0u, ~0u, ~0u}, hi[3] = {0, 0, 0};
  const uint64_t stride = uint64_t(gridDim.x) * blockDim.x;
  for (uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x; i < s.count; i += stride) {
    float q[4];
    const GaussianCheck c = check_gaussian(s, i, q);
    nonfinite += c.nonfinite;
    with_nonfinite += c.nonfinite != 0;
    zero_norm += c.zero_norm;
    if (c.negative_scale) first_negative = min(first_negative, static_cast<unsigned long long>(i));
    if (c.bad_opacity) first_opacity = min(first_opacity, static_cast<unsigned long long>(i));
    if (valid != nullptr) valid[i] = c.valid() ? 1u : 0u;
    if (!c.valid()) {
      ++invalid;
      first_invalid = min(first_invalid, static_cast<unsigned long long>(i));
      continue;
    }
    for (int a = 0; a < 3; ++a) {
      const unsigned key = ordered_float_key(__float_as_uint(s.means[i * 3 + a]));
      lo[a] = min(lo[a], key);
      hi[a] = max(hi[a], key);
    }
  }
  nonfinite = warp_sum(nonfinite);
  with_nonfinite = warp_sum(with_nonfinite);
  zero_norm = warp_sum(zero_norm);
  invalid = warp_sum(invalid);
  first_invalid = warp_min(first_invalid);
  first_negative = warp_min(first_negative);
  first_opacity = warp_min(first_opacity);
  for (int a = 0; a < 3; ++a) {
    lo[a] = warp_min(lo[a]);
    hi[a] = warp_max(hi[a]);
  }
  if ((threadIdx.x & 31) != 0) return;
  if (nonfinite != 0) atomicAdd(&t->nonfinite_values, nonfinite);
  if (with_nonfinite != 0) atomicAdd(&t->gaussians_with_nonfinite, with_nonfinite);
  if (zero_norm != 0) atomicAdd(&t->zero_norm_quaternions, zero_norm);
  if (invalid != 0) atomicAdd(&t->invalid, invalid);
  if (first_invalid != kNoGaussian) atomicMin(&t->first_invalid, first_invalid);
  if (first_negative != kNoGaussian) atomicMin(&t->first_negative_scale, first_negative);
  if (first_opacity != kNoGaussian) atomicMin(&t->first_bad_opacity, first_opacity);
  for (int a = 0; a < 3; ++a) {
    if (lo[a] != ~0u) atomicMin(&t->aabb_min_key[a], lo[a]);
    if (hi[a] != 0) atomicMax(&t->aabb_max_key[a], hi[a]);
  }
}

__global__ void __launch_bounds__(detail::kBlockSize)
    gather_gaussians_kernel(GaussianImportSource s, GaussianImportTarget t, GaussianImportTotals* totals) {
  double radius2 = 0;
  const uint32_t values = (s.sh_degree + 1) * (s.sh_degree + 1) * 3;
  const uint64_t stride = uint64_t(gridDim.x) * blockDim.x;
  for (uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x; i < s.count; i += stride) {
    float q[4];
    const GaussianCheck c = check_gaussian(s, i, q);
    if (t.offsets != nullptr && !c.valid()) continue;
    const uint64_t o = t.offsets != nullptr ? t.offsets[i] : i;
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const float m = s.means[i * 3 + a];
      t.means[o * 3 + a] = m;
      const double d = static_cast<double>(m) - static_cast<double>(t.center[a]);
      d2 += d * d;
    }
    radius2 = fmax(radius2, d2);
    for (int a = 0; a < 4; ++a) t.rotations[o * 4 + a] = q[a];
    for (int a = 0; a < 3; ++a) t.scales[o * 3 + a] = s.scales[i * 3 + a];
    t.opacities[o] = s.opacities[i];
    for (uint32_t j = 0; j < values; ++j) t.sh[o * values + j] = color_value(s, i, j);
  }
  radius2 = warp_max(radius2);
  if ((threadIdx.x & 31) == 0 && radius2 > 0) {
    atomicMax(&totals->radius2_bits, static_cast<unsigned long long>(__double_as_longlong(radius2)));
  }
}

__global__ void __launch_bounds__(detail::kBlockSize) planar_output_kernel(PlanarOutputParams p) {
  const uint64_t pixel = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (pixel >= uint64_t(p.width) * p.height) return;
  const float4 v = reinterpret_cast<const float4*>(p.rgba)[pixel];
  const bool with_depth = p.depth_mode != PlanarDepth::kNone;
  const uint32_t channels = (p.rgb ? 3u : 0u) + (with_depth ? 1u : 0u);
  float* out = p.colors + pixel * channels;
  if (p.rgb) {
    out[0] = v.x;
    out[1] = v.y;
    out[2] = v.z;
  }
  if (with_depth) {
    const float d = p.depth[pixel];
    out[channels - 1] = p.depth_mode == PlanarDepth::kAccumulated ? d * v.w : d;
  }
  p.alphas[pixel] = v.w;
}

unsigned import_blocks(uint64_t count) { return std::min(detail::blocks_for(count), kImportBlocks); }

}  // namespace

cudaError_t launch_check_gaussians(const GaussianImportSource& source, GaussianImportTotals* totals,
                                   unsigned int* valid, cudaStream_t stream) {
  reset_totals_kernel<<<1, 1, 0, stream>>>(totals);
  const cudaError_t reset = detail::launch_result();
  if (reset != cudaSuccess || source.count == 0) return reset;
  check_gaussians_kernel<<<import_blocks(source.count), detail::kBlockSize, 0, stream>>>(source, totals, valid);
  return detail::launch_result();
}

size_t compact_offsets_scratch_bytes(uint64_t count) {
  size_t bytes = 0;
  cub::DeviceScan::ExclusiveSum(nullptr, bytes, static_cast<const unsigned*>(nullptr),
                                static_cast<unsigned*>(nullptr), uint32_t(count));
  return bytes;
}

cudaError_t launch_compact_offsets(const unsigned int* valid, unsigned int* offsets, uint64_t count, void* scratch,
                                   size_t scratch_bytes, cudaStream_t stream) {
  if (count == 0) return cudaSuccess;
  const cudaError_t scan = cub::DeviceScan::ExclusiveSum(scratch, scratch_bytes, valid, offsets, uint32_t(count), stream);
  if (scan != cudaSuccess) return scan;
  return detail::launch_result();
}

cudaError_t launch_gather_gaussians(const GaussianImportSource& source, const GaussianImportTarget& target,
                                    GaussianImportTotals* totals, cudaStream_t stream) {
  const cudaError_t reset = cudaMemsetAsync(&totals->radius2_bits, 0, sizeof(totals->radius2_bits), stream);
  if (reset != cudaSuccess || source.count == 0) return reset;
  gather_gaussians_kernel<<<import_blocks(source.count), detail::kBlockSize, 0, stream>>>(source, target, totals);
  return detail::launch_result();
}

cudaError_t launch_planar_output(const PlanarOutputParams& params, cudaStream_t stream) {
  const uint64_t pixels = uint64_t(params.width) * params.height;
  if (pixels == 0) return cudaSuccess;
  planar_output_kernel<<<detail::blocks_for(pixels), detail::kBlockSize, 0, stream>>>(params);
  return detail::launch_result();
}

}  // namespace rgs::kernels
