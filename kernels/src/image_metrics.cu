// Image comparison for the audit (kernels/include/rgs/kernels/image_metrics.h). Three kernels: per pixel
// (squared error, maximum difference, optional diff map), per SSIM tile (separable 11×11 filter in shared
// memory, float64, the CPU reference's operation order: rgs::audit's image_metrics.cpp), and a one-block
// reduction of the per-block partials in a fixed order, so the result does not depend on scheduling.
#include "launch_util.cuh"
#include "rgs/kernels/image_metrics.h"

namespace rgs::kernels {
namespace {

constexpr int kRadius = kMetricsSsimWindow / 2;
/// SSIM output tile: 32 × 16 valid windows per block of 32 × 8 threads (two rows each).
constexpr int kTileW = 32;
constexpr int kTileH = 16;
constexpr int kThreadsY = 8;
constexpr int kSsimThreads = kTileW * kThreadsY;
constexpr int kInW = kTileW + 2 * kRadius;
constexpr int kInH = kTileH + 2 * kRadius;
constexpr int kReduceThreads = 256;

/// The CPU reference's clamp: NaN → 0, then [0, 1].
__device__ inline float clamp01(float v) { return isnan(v) ? 0.f : fminf(fmaxf(v, 0.f), 1.f); }

/// Sum of a block's per-thread values in a fixed tree order; the result is valid in thread 0.
template <int kThreads>
__device__ inline double block_sum(double v, double* shared) {
  const int t = threadIdx.y * blockDim.x + threadIdx.x;
  shared[t] = v;
  __syncthreads();
  for (int stride = kThreads / 2; stride > 0; stride /= 2) {
    if (t < stride) shared[t] += shared[t + stride];
    __syncthreads();
  }
  const double total = shared[0];
  __syncthreads();
  return total;
}

/// Per-block partial sums of the pixel kernel: squared error (whole frame, foreground), foreground pixels.
struct PixelPartials {
  double* sse;
  double* foreground_sse;
  double* foreground_pixels;
  float* maxima;
};

__global__ void __launch_bounds__(detail::kBlockSize) pixel_metrics_kernel(ImageMetricsParams p, PixelPartials out) {
  __shared__ double sums[detail::kBlockSize];
  __shared__ float maxima[detail::kBlockSize];
  const uint64_t pixels = uint64_t(p.width) * p.height;
  const uint64_t pix = uint64_t(blockIdx.x) * detail::kBlockSize + threadIdx.x;
  double se = 0;
  float largest = 0.f;
  bool foreground = false;
  if (pix < pixels) {
    // NaN alpha is not covered, as on the CPU (rgs::audit::foreground_psnr).
    foreground = p.channels >= 4 && p.a[pix * p.channels + 3] > 0.f;
    for (uint32_t c = 0; c < 3; ++c) {
      // float64 difference of the clamped values, as the CPU reference (clamp01 in double is exact).
      const float a = clamp01(p.a[pix * p.channels + c]);
      const double d = double(a) - double(clamp01(p.b[pix * p.channels + c]));
      se += d * d;
      largest = fmaxf(largest, float(fabs(d)));
      foreground = foreground || a > 0.f;
    }
    if (p.diff != nullptr) p.diff[pix] = largest;
  }
  const double total = block_sum<detail::kBlockSize>(se, sums);
  const double foreground_total = block_sum<detail::kBlockSize>(foreground ? se : 0.0, sums);
  const double foreground_count = block_sum<detail::kBlockSize>(foreground ? 1.0 : 0.0, sums);
  maxima[threadIdx.x] = largest;
  __syncthreads();
  for (int stride = detail::kBlockSize / 2; stride > 0; stride /= 2) {
    if (threadIdx.x < stride) maxima[threadIdx.x] = fmaxf(maxima[threadIdx.x], maxima[threadIdx.x + stride]);
    __syncthreads();
  }
  if (threadIdx.x == 0) {
    out.sse[blockIdx.x] = total;
    out.foreground_sse[blockIdx.x] = foreground_total;
    out.foreground_pixels[blockIdx.x] = foreground_count;
    out.maxima[blockIdx.x] = maxima[0];
  }
}

/// One block per kTileW × kTileH valid SSIM windows (window top-left corners), all three channels.
__global__ void __launch_bounds__(kSsimThreads) ssim_kernel(ImageMetricsParams p, double* __restrict__ partials) {
  __shared__ float sx[kInH][kInW];
  __shared__ float sy[kInH][kInW];
  __shared__ double hz[5][kInH][kTileW];
  __shared__ double reduce[kSsimThreads];
  const int t = threadIdx.y * kTileW + threadIdx.x;
  const int ow = int(p.width) - 2 * kRadius, oh = int(p.height) - 2 * kRadius;
  const int x0 = blockIdx.x * kTileW, y0 = blockIdx.y * kTileH;
  double channel_sums[3] = {0, 0, 0};
  for (int c = 0; c < 3; ++c) {
    for (int i = t; i < kInH * kInW; i += kSsimThreads) {
      const int r = i / kInW, col = i % kInW;
      const int gx = x0 + col, gy = y0 + r;
      float xv = 0.f, yv = 0.f;
      if (gx < int(p.width) && gy < int(p.height)) {
        const uint64_t pix = uint64_t(gy) * p.width + gx;
        xv = clamp01(p.a[pix * p.channels + c]);
        yv = clamp01(p.b[pix * p.channels + c]);
      }
      sx[r][col] = xv;
      sy[r][col] = yv;
    }
    __syncthreads();
    for (int i = t; i < kInH * kTileW; i += kSsimThreads) {
      const int r = i / kTileW, o = i % kTileW;
      double s[5] = {0, 0, 0, 0, 0};
#pragma unroll
      for (int k = 0; k < kMetricsSsimWindow; ++k) {
        const double xv = sx[r][o + k], yv = sy[r][o + k], gk = p.window[k];
        s[0] += gk * xv;
        s[1] += gk * yv;
        s[2] += gk * xv * xv;
        s[3] += gk * yv * yv;
        s[4] += gk * xv * yv;
      }
#pragma unroll
      for (int m = 0; m < 5; ++m) hz[m][r][o] = s[m];
    }
    __syncthreads();
    for (int row = threadIdx.y; row < kTileH; row += kThreadsY) {
      const int o = threadIdx.x;
      if (x0 + o >= ow || y0 + row >= oh) continue;
      double s[5] = {0, 0, 0, 0, 0};
#pragma unroll
      for (int k = 0; k < kMetricsSsimWindow; ++k) {
#pragma unroll
        for (int m = 0; m < 5; ++m) s[m] += p.window[k] * hz[m][row + k][o];
      }
      const double mx = s[0], my = s[1];
      const double vx = s[2] - mx * mx, vy = s[3] - my * my, cxy = s[4] - mx * my;
      channel_sums[c] += ((2 * mx * my + p.c1) * (2 * cxy + p.c2)) / ((mx * mx + my * my + p.c1) * (vx + vy + p.c2));
    }
    __syncthreads();  // sx/sy/hz are refilled for the next channel
  }
  const uint32_t block = blockIdx.y * gridDim.x + blockIdx.x;
  for (int c = 0; c < 3; ++c) {
    const double total = block_sum<kSsimThreads>(channel_sums[c], reduce);
    if (t == 0) partials[uint64_t(block) * 3 + c] = total;
  }
}

__global__ void __launch_bounds__(kReduceThreads)
    reduce_metrics_kernel(PixelPartials partials, uint32_t pixel_blocks, const double* __restrict__ ssim_partials,
                          uint32_t ssim_blocks, ImageMetricsSums* __restrict__ sums) {
  __shared__ double shared[kReduceThreads];
  __shared__ float maxima[kReduceThreads];
  const int t = threadIdx.x;
  double se = 0, foreground_se = 0, foreground_pixels = 0;
  float largest = 0.f;
  for (uint32_t i = t; i < pixel_blocks; i += kReduceThreads) {
    se += partials.sse[i];
    foreground_se += partials.foreground_sse[i];
    foreground_pixels += partials.foreground_pixels[i];
    largest = fmaxf(largest, partials.maxima[i]);
  }
  const double se_total = block_sum<kReduceThreads>(se, shared);
  const double foreground_se_total = block_sum<kReduceThreads>(foreground_se, shared);
  const double foreground_pixels_total = block_sum<kReduceThreads>(foreground_pixels, shared);
  maxima[t] = largest;
  __syncthreads();
  for (int stride = kReduceThreads / 2; stride > 0; stride /= 2) {
    if (t < stride) maxima[t] = fmaxf(maxima[t], maxima[t + stride]);
    __syncthreads();
  }
  double ssim_total[3];
  for (int c = 0; c < 3; ++c) {
    double v = 0;
    for (uint32_t i = t; i < ssim_blocks; i += kReduceThreads) v += ssim_partials[uint64_t(i) * 3 + c];
    ssim_total[c] = block_sum<kReduceThreads>(v, shared);
  }
  if (t == 0) {
    sums->squared_error = se_total;
    sums->foreground_squared_error = foreground_se_total;
    sums->foreground_pixels = foreground_pixels_total;
    sums->max_abs_diff = maxima[0];
    for (int c = 0; c < 3; ++c) sums->ssim[c] = ssim_total[c];
  }
}

struct Layout {
  uint32_t pixel_blocks = 0;
  dim3 ssim_grid;
  uint32_t ssim_blocks = 0;
  size_t sse_offset = 0, foreground_offset = 0, ssim_offset = 0, max_offset = 0, bytes = 0;
};

size_t align16(size_t v) { return (v + 15) / 16 * 16; }

Layout layout_for(uint32_t width, uint32_t height) {
  Layout l;
  l.pixel_blocks = detail::blocks_for(uint64_t(width) * height);
  const uint32_t ow = width > 2 * kRadius ? width - 2 * kRadius : 1;
  const uint32_t oh = height > 2 * kRadius ? height - 2 * kRadius : 1;
  l.ssim_grid = dim3((ow + kTileW - 1) / kTileW, (oh + kTileH - 1) / kTileH);
  l.ssim_blocks = l.ssim_grid.x * l.ssim_grid.y;
  l.sse_offset = 0;
  l.foreground_offset = align16(l.sse_offset + size_t(l.pixel_blocks) * sizeof(double));  // sse, then pixels
  l.ssim_offset = align16(l.foreground_offset + size_t(l.pixel_blocks) * 2 * sizeof(double));
  l.max_offset = align16(l.ssim_offset + size_t(l.ssim_blocks) * 3 * sizeof(double));
  l.bytes = align16(l.max_offset + size_t(l.pixel_blocks) * sizeof(float));
  return l;
}

}  // namespace

size_t image_metrics_scratch_bytes(uint32_t width, uint32_t height) { return layout_for(width, height).bytes; }

cudaError_t launch_image_metrics(const ImageMetricsParams& params, cudaStream_t stream) {
  if (params.width == 0 || params.height == 0) return cudaSuccess;
  const Layout l = layout_for(params.width, params.height);
  char* scratch = static_cast<char*>(params.scratch);
  double* foreground = reinterpret_cast<double*>(scratch + l.foreground_offset);
  const PixelPartials partials{reinterpret_cast<double*>(scratch + l.sse_offset), foreground,
                               foreground + l.pixel_blocks, reinterpret_cast<float*>(scratch + l.max_offset)};
  double* ssim = reinterpret_cast<double*>(scratch + l.ssim_offset);
  pixel_metrics_kernel<<<l.pixel_blocks, detail::kBlockSize, 0, stream>>>(params, partials);
  cudaError_t result = detail::launch_result();
  if (result != cudaSuccess) return result;
  ssim_kernel<<<l.ssim_grid, dim3(kTileW, kThreadsY), 0, stream>>>(params, ssim);
  result = detail::launch_result();
  if (result != cudaSuccess) return result;
  reduce_metrics_kernel<<<1, kReduceThreads, 0, stream>>>(partials, l.pixel_blocks, ssim, l.ssim_blocks, params.sums);
  return detail::launch_result();
}

}  // namespace rgs::kernels
