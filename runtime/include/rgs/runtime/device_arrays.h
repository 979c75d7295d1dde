// Arrays in a caller's device memory (a training framework's tensors): the options of building a GpuScene
// from device Gaussians (GpuScene::from_device), and gsplat's planar outputs written from a rendered frame.
// Available only with RGS_WITH_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <string>

#include "rgs/format/status.h"
#include "rgs/kernels/array_io.h"

namespace rgs::runtime {

/// Options of GpuScene::from_device().
struct DeviceImportOptions {
  /// Drop the Gaussians with a non-finite value or a zero quaternion (InvalidPolicy::kSanitize of a file)
  /// instead of failing with kCorruptData.
  bool drop_invalid = false;
  /// The arrays are a scene trained with the 2D Mip filter (GpuScene::antialiased).
  bool antialiased = false;
  /// Names the arrays in messages.
  std::string name = "arrays";
};

/// Writes one rendered frame (`params.rgba`, [H, W, 4] float32, 16-byte aligned, and `params.depth` when a
/// depth plane is asked for) into gsplat's planar colours and alphas (kernels::PlanarOutputParams) on
/// `stream`; nothing waits. @return kInvalidArgument (a null or misaligned pointer, a zero size),
/// kCudaError (the launch).
Status write_planar_output(const kernels::PlanarOutputParams& params, cudaStream_t stream = nullptr);

}  // namespace rgs::runtime
