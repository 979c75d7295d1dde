// launch_convert_output: float RGBA frame → caller image (RGBA32F / RGBA16F / RGBA8, any pitch, depth);
// launch_pack_rgb8: RGBA8 → packed RGB8.
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

__global__ void pack_rgb8_kernel(const uint8_t* rgba, size_t rgba_pitch, uint32_t width, uint32_t height,
                                 uint8_t* rgb) {
  const uint32_t x = blockIdx.x * blockDim.x + threadIdx.x;
  const uint32_t y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= width || y >= height) return;
  const uint8_t* in = rgba + size_t(y) * rgba_pitch + size_t(x) * 4;
  uint8_t* out = rgb + (size_t(y) * width + x) * 3;
  out[0] = in[0];
  out[1] = in[1];
  out[2] = in[2];
}

}  // namespace

cudaError_t launch_convert_output(const OutputConvertParams& params, cudaStream_t stream) {
  if (params.width == 0 || params.height == 0) return cudaSuccess;
  const dim3 block(32, 8);
  const dim3 grid((params.width + block.x - 1) / block.x, (params.height + block.y - 1) / block.y);
  convert_output_kernel<<<grid, block, 0, stream>>>(params);
  return cudaGetLastError();
}

cudaError_t launch_pack_rgb8(const uint8_t* rgba, size_t rgba_pitch, uint32_t width, uint32_t height, uint8_t* rgb,
                             cudaStream_t stream) {
  if (width == 0 || height == 0) return cudaSuccess;
  const dim3 block(32, 8);
  const dim3 grid((width + block.x - 1) / block.x, (height + block.y - 1) / block.y);
  pack_rgb8_kernel<<<grid, block, 0, stream>>>(rgba, rgba_pitch, width, height, rgb);
  return cudaGetLastError();
}

}  // namespace rgs::kernels
