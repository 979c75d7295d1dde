// RoofGS preprocess and duplication as separate stages, and the keys of the optional depth order.
#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

__global__ void __launch_bounds__(detail::kBlockSize)
    depth_sort_keys_kernel(const float* means, uint32_t count, FrameParams frame, uint32_t* keys,
                           uint32_t* values) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const float mean[3] = {means[3 * uint64_t(i)], means[3 * uint64_t(i) + 1], means[3 * uint64_t(i) + 2]};
  float p_cam[3];
  world_to_camera(frame.view_rotation, frame.view_translation, mean, p_cam);
  // Positive floats order like their bit patterns; culled depths go last.
  keys[i] = p_cam[2] > frame.near_plane && isfinite(p_cam[2]) ? float_as_uint(p_cam[2]) : 0xffffffffu;
  values[i] = i;
}

template <bool kCompact>
__global__ void __launch_bounds__(detail::kBlockSize)
    preprocess_roofgs_kernel(GaussianSource src, FrameParams frame, RoofgsFrame roofgs, const uint32_t* order,
                             RoofgsProjected out) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  uint32_t g = 0;
  detail::ProjectedRegs p{};
  detail::TileWalk walk{};
  // Every lane takes part: the tile count is shared by the warp.
  const bool visible = detail::preprocess_gaussian<kCompact>(src, t, order, frame, roofgs, &g, &p, &walk);
  if (t >= src.count) return;
  if (!visible) {
    out.radii[g] = 0;
    out.tiles_touched[t] = 0;
    return;
  }
  detail::store_projected(p, g, out);
  out.cov2d[3 * uint64_t(g)] = p.cov.xx;
  out.cov2d[3 * uint64_t(g) + 1] = p.cov.xy;
  out.cov2d[3 * uint64_t(g) + 2] = p.cov.yy;
  out.snug_t[g] = p.snug_t;
  out.depth_bins[g] = p.depth_bin;
  out.tiles_touched[t] = p.tiles;
}

__global__ void __launch_bounds__(detail::kBlockSize)
    duplicate_roofgs_kernel(RoofgsProjected in, const uint64_t* offsets, const uint32_t* order, uint32_t count,
                            FrameParams frame, RoofgsFrame roofgs, LargeGaussianList large, detail::PairSink sink) {
  const uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count || in.tiles_touched[t] == 0) return;
  const uint32_t g = order != nullptr ? order[t] : t;
  const detail::PairSource source{g, in.depth_bins[g], in.depths[g], t == 0 ? 0 : offsets[t - 1]};
  detail::emit_or_defer(detail::load_tile_walk(in, g, frame, roofgs), source, uint32_t(in.tiles_touched[t]), sink,
                        large, frame, roofgs);
}

}  // namespace

cudaError_t depth_sort_keys(const float* means, uint32_t count, const FrameParams& frame, uint32_t* keys,
                            uint32_t* values, cudaStream_t stream) {
  if (count == 0) return cudaSuccess;
  depth_sort_keys_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(means, count, frame, keys,
                                                                                       values);
  return detail::launch_result();
}

cudaError_t preprocess_roofgs(const GaussianSource& source, const FrameParams& frame, const RoofgsFrame& roofgs,
                              const uint32_t* order, const RoofgsProjected& out, cudaStream_t stream) {
  if (source.count == 0) return cudaSuccess;
  const unsigned blocks = detail::blocks_for(source.count);
  if (roofgs.compact) {
    preprocess_roofgs_kernel<true><<<blocks, detail::kBlockSize, 0, stream>>>(source, frame, roofgs, order, out);
  } else {
    preprocess_roofgs_kernel<false><<<blocks, detail::kBlockSize, 0, stream>>>(source, frame, roofgs, order, out);
  }
  return detail::launch_result();
}

cudaError_t duplicate_roofgs(const RoofgsProjected& projected, const uint64_t* offsets, const uint32_t* order,
                             uint32_t count, const FrameParams& frame, const RoofgsFrame& roofgs,
                             const LargeGaussianList& large, uint64_t* keys64, uint32_t* keys32, uint32_t* values,
                             cudaStream_t stream) {
  const cudaError_t zeroed = cudaMemsetAsync(large.count, 0, sizeof(uint32_t), stream);
  if (zeroed != cudaSuccess || count == 0) return zeroed;
  duplicate_roofgs_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
      projected, offsets, order, count, frame, roofgs, large, detail::PairSink{~uint64_t{0}, keys64, keys32, values});
  return detail::launch_result();
}

}  // namespace rgs::kernels
