// Stage 5 of the 3DGS baseline (renderCUDA): one 16×16 thread block per tile, one thread per pixel,
// Gaussians fetched in batches of 256 into shared memory, front-to-back blending. Per-pixel rules and their
// order are the CPU reference's blend_tile_baseline (runtime/src/cpu_renderer.cpp).
#include "launch_util.cuh"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/tile_culling.h"

namespace rgs::kernels {
namespace {

constexpr int kTilePixels = kTileSize * kTileSize;

template <bool kWithDepth>
__global__ void __launch_bounds__(kTilePixels)
    render_baseline_kernel(const uint64_t* __restrict__ ranges, const uint32_t* __restrict__ values,
                           const float2* __restrict__ means2d, const float4* __restrict__ conic_opacity,
                           const float* __restrict__ rgb, const float* __restrict__ depths, FrameParams frame,
                           float4* __restrict__ out_rgba, float* __restrict__ out_depth) {
  const uint32_t tile = blockIdx.y * frame.tiles_x + blockIdx.x;
  const uint32_t px = blockIdx.x * kTileSize + threadIdx.x;
  const uint32_t py = blockIdx.y * kTileSize + threadIdx.y;
  const uint32_t rank = threadIdx.y * kTileSize + threadIdx.x;
  const bool inside = px < frame.width && py < frame.height;
  bool done = !inside;
  const float pixf_x = static_cast<float>(px), pixf_y = static_cast<float>(py);

  const uint64_t begin = ranges[2 * uint64_t(tile)], end = ranges[2 * uint64_t(tile) + 1];

  __shared__ uint32_t collected_id[kTilePixels];
  __shared__ float2 collected_xy[kTilePixels];
  __shared__ float4 collected_conic_opacity[kTilePixels];

  float T = 1.f;
  float C[3] = {0.f, 0.f, 0.f};
  float depth_sum = 0.f, weight_sum = 0.f;

  for (uint64_t batch = begin; batch < end; batch += kTilePixels) {
    // The whole block stops once every pixel is done (this also separates the batches' shared-memory use).
    if (__syncthreads_count(done) == kTilePixels) break;
    const uint64_t p = batch + rank;
    if (p < end) {
      const uint32_t id = values[p];
      collected_id[rank] = id;
      collected_xy[rank] = means2d[id];
      collected_conic_opacity[rank] = conic_opacity[id];
    }
    __syncthreads();
    const int in_batch = static_cast<int>(end - batch < kTilePixels ? end - batch : kTilePixels);
    for (int j = 0; !done && j < in_batch; ++j) {
      const float2 xy = collected_xy[j];
      const float4 co = collected_conic_opacity[j];
      const float power = baseline_power(Conic{co.x, co.y, co.z}, xy.x - pixf_x, xy.y - pixf_y);
      if (power > 0.f) continue;
      const float alpha = fminf(kAlphaMax, co.w * expf(power));
      if (alpha < kAlphaMin) continue;
      const float test_T = T * (1.f - alpha);
      if (test_T < kTransmittanceMin) {
        done = true;
        continue;
      }
      const uint32_t id = collected_id[j];
      for (int c = 0; c < 3; ++c) C[c] += rgb[3 * id + c] * alpha * T;
      if (kWithDepth) {
        const float w = alpha * T;
        depth_sum += depths[id] * w;
        weight_sum += w;
      }
      T = test_T;
    }
  }

  if (inside) {
    const uint64_t pix = uint64_t(py) * frame.width + px;
    out_rgba[pix] = make_float4(C[0] + T * frame.background[0], C[1] + T * frame.background[1],
                                C[2] + T * frame.background[2], 1.f - T);
    if (kWithDepth) out_depth[pix] = weight_sum > 0.f ? depth_sum / weight_sum : 0.f;
  }
}

}  // namespace

cudaError_t render_baseline(const uint64_t* ranges, const uint32_t* sorted_values, const ProjectedArrays& projected,
                            const FrameParams& frame, const ImageView& image, cudaStream_t stream) {
  const dim3 grid(frame.tiles_x, frame.tiles_y);
  const dim3 block(kTileSize, kTileSize);
  const auto* means2d = reinterpret_cast<const float2*>(projected.means2d);
  const auto* conic_opacity = reinterpret_cast<const float4*>(projected.conic_opacity);
  auto* rgba = reinterpret_cast<float4*>(image.rgba);
  if (image.depth != nullptr) {
    render_baseline_kernel<true><<<grid, block, 0, stream>>>(ranges, sorted_values, means2d, conic_opacity,
                                                             projected.rgb, projected.depths, frame, rgba,
                                                             image.depth);
  } else {
    render_baseline_kernel<false><<<grid, block, 0, stream>>>(ranges, sorted_values, means2d, conic_opacity,
                                                              projected.rgb, projected.depths, frame, rgba,
                                                              nullptr);
  }
  return detail::launch_result();
}

}  // namespace rgs::kernels
