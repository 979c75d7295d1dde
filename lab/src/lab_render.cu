// The render kernel's lab variants (kernels::is_lab_variant), compiled from the product's templates
// (kernels/src/render_kernels.cuh): the RoofGS pixel kernel (expf or the fast exp), the folded kernel without
// the fast exp, and the folded kernel with FP32 blending and sub-tile culling.
#include "internal_lab_stages.h"
#include "render_kernels.cuh"
#include "rgs/lab/roofgs_stages.h"

namespace rgs::lab {

cudaError_t render_roofgs_all(const uint64_t* ranges, const kernels::TileChunks& chunks,
                              const uint32_t* sorted_values, const kernels::RoofgsProjected& projected,
                              const kernels::FrameParams& frame, const kernels::RoofgsFrame& roofgs,
                              const kernels::RasterOptions& raster, const kernels::ImageView& image,
                              cudaStream_t stream) {
  using kernels::Cull;
  if (!kernels::is_lab_variant(raster)) {
    return kernels::render_roofgs(ranges, chunks, sorted_values, projected, frame, roofgs, raster, image, stream);
  }
  if (chunks.chunk_pairs != 0) return cudaErrorInvalidValue;  // chunk records are binary16: never a lab variant
  const kernels::RenderInputs in{reinterpret_cast<const float2*>(projected.means2d),
                                 reinterpret_cast<const float4*>(projected.conic_opacity), nullptr,
                                 reinterpret_cast<const float4*>(projected.colour_log_opacity), projected.depths};
  const float sigma = roofgs.fast_exp_sigma;
  const kernels::FoldedLists lists{ranges, chunks, sorted_values};
  if (raster.folded && raster.fast_exp) {  // FP32 blending with sub-tile culling
    kernels::launch_folded<true, Cull::kBlock, false>(lists, in, frame, sigma, image, stream);
  } else if (raster.folded) {
    if (raster.subtile_culling) {
      kernels::launch_folded<false, Cull::kBlock, false>(lists, in, frame, sigma, image, stream);
    } else {
      kernels::launch_folded<false, Cull::kNone, false>(lists, in, frame, sigma, image, stream);
    }
  } else if (raster.fast_exp) {
    kernels::launch_pixel<true, true>(ranges, sorted_values, in, frame, sigma, image, stream);
  } else {
    kernels::launch_pixel<true, false>(ranges, sorted_values, in, frame, sigma, image, stream);
  }
  return kernels::detail::launch_result();
}

kernels::RoofgsStages roofgs_stages() {
  kernels::RoofgsStages stages;
  stages.preprocess = preprocess_roofgs;
  stages.duplicate = duplicate_roofgs;
  stages.render = render_roofgs_all;
  return stages;
}

}  // namespace rgs::lab
