// Device peaks for the roofline: a large device-to-device copy and the FP32 FMA loop, each timed with CUDA
// events after a warm-up, medians over the repeats.
#include "rgs/lab/device_peaks.h"

#include <algorithm>
#include <string>
#include <utility>

#include "internal_peak_kernels.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::lab {
namespace {

constexpr uint64_t kMinCopyBytes = uint64_t{64} << 20;

/// A pair of CUDA events, destroyed with the object.
class EventPair {
 public:
  EventPair() = default;
  EventPair(const EventPair&) = delete;
  EventPair& operator=(const EventPair&) = delete;
  ~EventPair() {
    if (start_ != nullptr) cudaEventDestroy(start_);
    if (stop_ != nullptr) cudaEventDestroy(stop_);
  }
  Status create() {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreate(&start_), "device peaks: cudaEventCreate");
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreate(&stop_), "device peaks: cudaEventCreate");
    return Status();
  }
  cudaEvent_t start() const { return start_; }
  cudaEvent_t stop() const { return stop_; }

 private:
  cudaEvent_t start_ = nullptr, stop_ = nullptr;
};

double median(std::vector<float> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 == 1 ? double(v[n / 2]) : 0.5 * (double(v[n / 2 - 1]) + double(v[n / 2]));
}

/// Runs `enqueue` once untimed, then `repeats` times between the two events; returns each time in ms.
template <typename Enqueue>
Result<std::vector<float>> time_repeats(uint32_t repeats, const EventPair& ev, cudaStream_t stream,
                                        const std::string& what, Enqueue&& enqueue) {
  RGS_RETURN_IF_CUDA_ERROR(enqueue(), what + " (warm-up)");
  std::vector<float> ms;
  for (uint32_t r = 0; r < repeats; ++r) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev.start(), stream), what + ": cudaEventRecord");
    RGS_RETURN_IF_CUDA_ERROR(enqueue(), what);
    RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev.stop(), stream), what + ": cudaEventRecord");
    RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(ev.stop()), what + ": cudaEventSynchronize");
    float t = 0.f;
    RGS_RETURN_IF_CUDA_ERROR(cudaEventElapsedTime(&t, ev.start(), ev.stop()), what + ": cudaEventElapsedTime");
    ms.push_back(t);
  }
  return ms;
}

Status measure_copy(const DevicePeakOptions& options, const EventPair& ev, cudaStream_t stream, DevicePeaks* out) {
  runtime::DeviceBuffer<uint8_t> src, dst;
  uint64_t bytes = options.copy_bytes;
  for (;;) {
    Status a = src.allocate_exactly(bytes, "device peaks: copy source");
    Status b = a.ok() ? dst.allocate_exactly(bytes, "device peaks: copy destination") : a;
    if (b.ok()) break;
    src.release();
    dst.release();
    if (b.code() != StatusCode::kOutOfMemory || bytes / 2 < kMinCopyBytes) return b;
    bytes /= 2;
  }
  // A non-zero pattern (CONTRIBUTING.md#gpu-code-and-tests: never time all-zero data).
  RGS_RETURN_IF_CUDA_ERROR(cudaMemsetAsync(src.data(), 0xA5, bytes, stream), "device peaks: cudaMemsetAsync");
  RGS_ASSIGN_OR_RETURN(out->copy_ms, time_repeats(options.repeats, ev, stream, "device peaks: device-to-device copy",
                                                  [&] {
                                                    return cudaMemcpyAsync(dst.data(), src.data(), bytes,
                                                                           cudaMemcpyDeviceToDevice, stream);
                                                  }));
  out->copy_bytes = bytes;
  out->copy_median_ms = median(out->copy_ms);
  out->memory_gbps = out->copy_median_ms > 0 ? 2.0 * double(bytes) / (out->copy_median_ms * 1e-3) / 1e9 : 0.0;
  return Status();
}

Status measure_fma(const DevicePeakOptions& options, const EventPair& ev, cudaStream_t stream, DevicePeaks* out) {
  int device = 0, sms = 0, per_sm = 0;
  RGS_RETURN_IF_CUDA_ERROR(cudaGetDevice(&device), "device peaks: cudaGetDevice");
  RGS_RETURN_IF_CUDA_ERROR(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device),
                           "device peaks: cudaDeviceGetAttribute(multiprocessors)");
  RGS_RETURN_IF_CUDA_ERROR(fma_peak_blocks_per_sm(options.fma_threads_per_block, &per_sm),
                           "device peaks: occupancy of the FMA loop at " +
                               std::to_string(options.fma_threads_per_block) + " threads per block");
  RGS_RETURN_ERROR_IF(sms <= 0 || per_sm <= 0, StatusCode::kCudaError,
                      "device peaks: " + std::to_string(sms) + " SMs, " + std::to_string(per_sm) +
                          " resident FMA-loop blocks per SM");
  FmaPeakParams params;
  params.blocks = uint32_t(sms) * uint32_t(per_sm) * options.fma_waves;
  params.threads_per_block = options.fma_threads_per_block;
  params.iterations = options.fma_iterations;
  runtime::DeviceBuffer<float> sink;
  RGS_RETURN_IF_ERROR(
      sink.allocate_exactly(size_t(params.blocks) * params.threads_per_block, "device peaks: FMA sink"));
  params.out = sink.data();
  RGS_ASSIGN_OR_RETURN(out->fma_ms, time_repeats(options.repeats, ev, stream, "device peaks: FMA loop kernel",
                                                 [&] { return launch_fma_peak(params, stream); }));
  out->fma_blocks = params.blocks;
  out->fma_threads_per_block = params.threads_per_block;
  out->fma_iterations = params.iterations;
  out->fma_blocks_per_sm = uint32_t(per_sm);
  out->fma_chains_per_thread = kFmaPeakChains;
  out->fma_flops = fma_peak_flops(params);
  out->fma_median_ms = median(out->fma_ms);
  out->fp32_gflops = out->fma_median_ms > 0 ? out->fma_flops / (out->fma_median_ms * 1e-3) / 1e9 : 0.0;
  params.half2 = true;
  RGS_ASSIGN_OR_RETURN(out->hfma2_ms, time_repeats(options.repeats, ev, stream, "device peaks: half2 FMA loop kernel",
                                                   [&] { return launch_fma_peak(params, stream); }));
  out->hfma2_flops = fma_peak_flops(params);
  out->hfma2_median_ms = median(out->hfma2_ms);
  out->half_gflops = out->hfma2_median_ms > 0 ? out->hfma2_flops / (out->hfma2_median_ms * 1e-3) / 1e9 : 0.0;
  return Status();
}

}  // namespace

Result<DevicePeaks> measure_device_peaks(const DevicePeakOptions& options, cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(options.repeats == 0 || options.fma_iterations == 0 || options.fma_waves == 0,
                      StatusCode::kInvalidArgument, "device peaks: repeats, fma_iterations and fma_waves must be >= 1");
  RGS_RETURN_ERROR_IF(options.copy_bytes < kMinCopyBytes, StatusCode::kInvalidArgument,
                      "device peaks: copy_bytes " + std::to_string(options.copy_bytes) + " < 64 MiB");
  const uint32_t t = options.fma_threads_per_block;
  RGS_RETURN_ERROR_IF(t < 32 || t > 1024 || t % 32 != 0, StatusCode::kInvalidArgument,
                      "device peaks: fma_threads_per_block " + std::to_string(t) +
                          " is not a multiple of 32 in [32, 1024]");
  EventPair ev;
  RGS_RETURN_IF_ERROR(ev.create());
  DevicePeaks peaks;
  RGS_RETURN_IF_ERROR(measure_copy(options, ev, stream, &peaks));
  RGS_RETURN_IF_ERROR(measure_fma(options, ev, stream, &peaks));
  return peaks;
}

}  // namespace rgs::lab
