// The render stage of the product (kernels::render_baseline, kernels::render_roofgs): the variants of the
// render kernels (render_kernels.cuh) that the presets reach.
#include "render_kernels.cuh"

namespace rgs::kernels {
namespace {

/// The folded variants the presets reach: with binary16 blending sub-tile culling on or off, with FP32 blending
/// culling off (FP32 blending with culling is a lab variant: raster_variant_compiled).
template <bool kFastExp, bool kHalf>
void launch_folded(const FoldedLists& lists, const RenderInputs& in, const FrameParams& frame, float sigma,
                   const RasterOptions& raster, const ImageView& image, cudaStream_t stream) {
  static_assert(kFastExp || !kHalf);
  if (!raster.subtile_culling) {
    launch_folded<kFastExp, Cull::kNone, kHalf>(lists, in, frame, sigma, image, stream);
    return;
  }
  if constexpr (kHalf) launch_folded<kFastExp, Cull::kBlock, kHalf>(lists, in, frame, sigma, image, stream);
}

}  // namespace

bool raster_variant_compiled(const RasterOptions& raster) { return !is_lab_variant(raster); }

cudaError_t render_baseline(const uint64_t* ranges, const uint32_t* sorted_values, const ProjectedArrays& projected,
                            const FrameParams& frame, const ImageView& image, cudaStream_t stream) {
  const RenderInputs in{reinterpret_cast<const float2*>(projected.means2d),
                        reinterpret_cast<const float4*>(projected.conic_opacity), projected.rgb, nullptr,
                        projected.depths};
  launch_pixel<false, false>(ranges, sorted_values, in, frame, 0.f, image, stream);
  return detail::launch_result();
}

cudaError_t render_roofgs(const uint64_t* ranges, const TileChunks& chunks, const uint32_t* sorted_values,
                          const RoofgsProjected& projected, const FrameParams& frame, const RoofgsFrame& roofgs,
                          const RasterOptions& raster, const ImageView& image, cudaStream_t stream) {
  if (!raster_variant_compiled(raster)) return cudaErrorNotSupported;
  const RenderInputs in{reinterpret_cast<const float2*>(projected.means2d),
                        reinterpret_cast<const float4*>(projected.conic_opacity), nullptr,
                        reinterpret_cast<const float4*>(projected.colour_log_opacity), projected.depths};
  const float sigma = roofgs.fast_exp_sigma;
  const bool half = raster.folded && raster.fast_exp && raster.half_blend;
  if (chunks.chunk_pairs != 0 && !half) return cudaErrorInvalidValue;  // chunk records are binary16
  const FoldedLists lists{ranges, chunks, sorted_values};
  if (half) {
    launch_folded<true, true>(lists, in, frame, sigma, raster, image, stream);
  } else if (raster.folded && raster.fast_exp) {
    launch_folded<true, false>(lists, in, frame, sigma, raster, image, stream);
  }
  return detail::launch_result();
}

}  // namespace rgs::kernels
