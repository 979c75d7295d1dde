// RoofGS preprocess and duplication as separate stages (kernels::PreprocessRoofgsStage, DuplicateRoofgsStage):
// the fused kernel's twin, which no preset uses.
#include "internal_lab_stages.h"
#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

template <bool kCompact, int kDegree>
__global__ void __launch_bounds__(detail::kBlockSize)
    preprocess_roofgs_kernel(GaussianSource src, FrameParams frame, RoofgsFrame roofgs, RoofgsProjected out,
                             unsigned long long* large_pairs) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  detail::ProjectedRegs p;  // every field read is written first (preprocess_gaussian sets tiles)
  detail::TileWalk walk;  // read only for visible Gaussians
  __shared__ detail::LongWalks<detail::kBlockSize> long_walks;
  // Every thread takes part: the long walks' tile counts are shared by the block.
  const bool visible = detail::preprocess_gaussian<kCompact>(src, g, frame, roofgs, long_walks, &p, &walk);
  detail::count_large_pairs(p.tiles, large_pairs);
  if (g >= src.count) return;
  if (!visible) {
    out.radii[g] = 0;
    out.tiles_touched[g] = 0;
    return;
  }
  detail::store_projected(p, g, out);
  detail::shade_gaussian<kCompact, kDegree>(src, g, frame, p.log_opacity, out);
  out.cov2d[3 * uint64_t(g)] = p.cov.xx;
  out.cov2d[3 * uint64_t(g) + 1] = p.cov.xy;
  out.cov2d[3 * uint64_t(g) + 2] = p.cov.yy;
  out.snug_t[g] = p.snug_t;
  out.depth_bins[g] = p.depth_bin;
  out.tiles_touched[g] = p.tiles;
}

__global__ void __launch_bounds__(detail::kBlockSize)
    duplicate_roofgs_kernel(RoofgsProjected in, const uint64_t* offsets, uint32_t count, FrameParams frame,
                            RoofgsFrame roofgs, LargeGaussianList large, detail::PairSink sink) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g >= count || in.tiles_touched[g] == 0) return;
  const detail::PairSource source{g, in.depth_bins[g], in.depths[g], g == 0 ? 0 : offsets[g - 1]};
  detail::emit_or_defer(detail::load_tile_walk(in, g, frame, roofgs), source, uint32_t(in.tiles_touched[g]), sink,
                        large, frame, roofgs);
}

}  // namespace
}  // namespace rgs::kernels

namespace rgs::lab {

using kernels::FrameParams;
using kernels::GaussianSource;
using kernels::LargeGaussianList;
using kernels::RoofgsFrame;
using kernels::RoofgsProjected;
namespace detail = kernels::detail;

cudaError_t preprocess_roofgs(const GaussianSource& source, const FrameParams& frame, const RoofgsFrame& roofgs,
                              const RoofgsProjected& out, unsigned long long* large_pairs, cudaStream_t stream) {
  const cudaError_t zeroed = cudaMemsetAsync(large_pairs, 0, sizeof(*large_pairs), stream);
  if (zeroed != cudaSuccess || source.count == 0) return zeroed;
  const unsigned blocks = detail::blocks_for(source.count);
  const uint32_t degree = roofgs.compact ? source.compact.sh_degree : source.fp32.sh_degree;
  const cudaError_t launched = detail::with_sh_degree(degree, [&](auto d) {
    if (roofgs.compact) {
      kernels::preprocess_roofgs_kernel<true, decltype(d)::value><<<blocks, detail::kBlockSize, 0, stream>>>(source, frame, roofgs, out,
                                                                                       large_pairs);
    } else {
      kernels::preprocess_roofgs_kernel<false, decltype(d)::value><<<blocks, detail::kBlockSize, 0, stream>>>(source, frame, roofgs,
                                                                                        out, large_pairs);
    }
  });
  return launched != cudaSuccess ? launched : detail::launch_result();
}

cudaError_t duplicate_roofgs(const RoofgsProjected& projected, const uint64_t* offsets, uint32_t count,
                             const FrameParams& frame, const RoofgsFrame& roofgs,
                             const LargeGaussianList& large, uint64_t* keys64, uint32_t* keys32, uint32_t* values,
                             cudaStream_t stream) {
  const cudaError_t zeroed = cudaMemsetAsync(large.count, 0, sizeof(*large.count), stream);
  if (zeroed != cudaSuccess || count == 0) return zeroed;
  kernels::duplicate_roofgs_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
      projected, offsets, count, frame, roofgs, large, detail::PairSink{~uint64_t{0}, keys64, keys32, values});
  return detail::launch_result();
}

}  // namespace rgs::lab
