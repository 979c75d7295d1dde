// The launches behind lab::roofgs_stages() (rgs/lab/roofgs_stages.h).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

#include "rgs/kernels/roofgs_pipeline.h"

namespace rgs::lab {

/// kernels::PreprocessRoofgsStage (preprocess_roofgs.cu).
cudaError_t preprocess_roofgs(const kernels::GaussianSource& source, const kernels::FrameParams& frame,
                              const kernels::RoofgsFrame& roofgs, const kernels::RoofgsProjected& out,
                              unsigned long long* large_pairs, cudaStream_t stream);

/// kernels::DuplicateRoofgsStage (preprocess_roofgs.cu).
cudaError_t duplicate_roofgs(const kernels::RoofgsProjected& projected, const uint64_t* offsets, uint32_t count,
                             const kernels::FrameParams& frame, const kernels::RoofgsFrame& roofgs,
                             const kernels::LargeGaussianList& large, uint64_t* keys64, uint32_t* keys32,
                             uint32_t* values, cudaStream_t stream);

/// kernels::RenderRoofgsStage with every variant (lab_render.cu): the lab variants here, the others through
/// kernels::render_roofgs.
cudaError_t render_roofgs_all(const uint64_t* ranges, const kernels::TileChunks& chunks,
                              const uint32_t* sorted_values, const kernels::RoofgsProjected& projected,
                              const kernels::FrameParams& frame, const kernels::RoofgsFrame& roofgs,
                              const kernels::RasterOptions& raster, const kernels::ImageView& image,
                              cudaStream_t stream);

}  // namespace rgs::lab
