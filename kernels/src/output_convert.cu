// launch_convert_output: float RGBA frame → caller image (RGBA32F / RGBA16F / RGBA8, any pitch, depth).
#include <cuda_fp16.h>

#include "rgs/kernels/output_convert.h"
#include "rgs/kernels/shared/blend_math.h"

namespace rgs::kernels {
namespace {

__global__ void convert_output_kernel(OutputConvertParams p) {
  const uint32_t x = blockIdx.x * blockDim.x + threadIdx.x;
  const uint32_t y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= p.width || y >= p.height) return;
  const size_t pixel = size_t(y) * p.width + x;
  const float4 v = reinterpret_cast<const float4*>(p.rgba)[pixel];
  const float a = p.write_alpha ? v.w : 1.f;
  char* row = static_cast<char*>(p.color) + size_t(y) * p.color_pitch;
  switch (p.format) {
    case OutputPixelFormat::kRgba32f: {
      float* out = reinterpret_cast<float*>(row) + size_t(x) * 4;
      out[0] = v.x;
      out[1] = v.y;
      out[2] = v.z;
      out[3] = a;
      break;
    }
    case OutputPixelFormat::kRgba16f: {
      __half* out = reinterpret_cast<__half*>(row) + size_t(x) * 4;
      out[0] = __float2half_rn(v.x);
      out[1] = __float2half_rn(v.y);
      out[2] = __float2half_rn(v.z);
      out[3] = __float2half_rn(a);
      break;
    }
    case OutputPixelFormat::kRgba8: {
      uchar4 c;
      c.x = unorm8(v.x);
      c.y = unorm8(v.y);
      c.z = unorm8(v.z);
      c.w = unorm8(a);
      unsigned char* out = reinterpret_cast<unsigned char*>(row) + size_t(x) * 4;
      out[0] = c.x;  // byte stores: the caller's pitch need not keep uchar4 alignment
      out[1] = c.y;
      out[2] = c.z;
      out[3] = c.w;
      break;
    }
  }
  if (p.depth != nullptr && p.depth_out != nullptr) {
    float* drow = reinterpret_cast<float*>(reinterpret_cast<char*>(p.depth_out) + size_t(y) * p.depth_pitch);
    drow[x] = p.depth[pixel];
  }
}

}  // namespace

cudaError_t launch_convert_output(const OutputConvertParams& params, cudaStream_t stream) {
  if (params.width == 0 || params.height == 0) return cudaSuccess;
  const dim3 block(32, 8);
  const dim3 grid((params.width + block.x - 1) / block.x, (params.height + block.y - 1) / block.y);
  convert_output_kernel<<<grid, block, 0, stream>>>(params);
  return cudaGetLastError();
}

}  // namespace rgs::kernels
