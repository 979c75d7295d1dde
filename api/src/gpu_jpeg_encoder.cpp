// GpuJpegEncoder: the front door's nvJPEG encoder over runtime::GpuJpegEncoder, on a stream of its own that
// waits on the GPU for the image's render.
#include <utility>

#include "internal_scene.h"
#include "rgs/api/renderer.h"

#if RGS_HAS_CUDA
#include "internal_gpu_scene_loading.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_jpeg.h"
#endif

namespace rgs::api {

struct GpuJpegEncoder::Impl {
#if RGS_HAS_CUDA
  int cuda_device = 0;
  runtime::GpuJpegEncoder encoder;
  cudaStream_t stream = nullptr;

  Impl(int device, runtime::GpuJpegEncoder e) : cuda_device(device), encoder(std::move(e)) {}
  ~Impl() {
    if (stream != nullptr) cudaStreamDestroy(stream);
  }
#endif
};

GpuJpegEncoder::GpuJpegEncoder(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GpuJpegEncoder::GpuJpegEncoder(GpuJpegEncoder&&) noexcept = default;
GpuJpegEncoder& GpuJpegEncoder::operator=(GpuJpegEncoder&&) noexcept = default;
GpuJpegEncoder::~GpuJpegEncoder() = default;

#if RGS_HAS_CUDA

Result<GpuJpegEncoder> GpuJpegEncoder::create(int cuda_device) {
  RGS_RETURN_IF_ERROR(require_cuda_device(cuda_device));
  RGS_RETURN_IF_ERROR(runtime::use_cuda_device(cuda_device));
  RGS_ASSIGN_OR_RETURN(runtime::GpuJpegEncoder encoder, runtime::GpuJpegEncoder::create());
  auto impl = std::make_unique<Impl>(cuda_device, std::move(encoder));
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamCreateWithFlags(&impl->stream, cudaStreamNonBlocking),
                           "GpuJpegEncoder: cudaStreamCreateWithFlags");
  return GpuJpegEncoder(std::move(impl));
}

const std::string& GpuJpegEncoder::name() const { return impl_->encoder.name(); }

Status GpuJpegEncoder::encode(const Image& image, int quality, bool subsample_chroma, std::vector<uint8_t>* jpeg) {
  RGS_RETURN_ERROR_IF(image.device() != Device::kCuda || image.cuda_device() != impl_->cuda_device ||
                          image.format() != PixelFormat::kRgba8,
                      StatusCode::kInvalidArgument,
                      "GpuJpegEncoder: the image must be an 8-bit RGBA image on CUDA device " +
                          std::to_string(impl_->cuda_device));
  RGS_RETURN_IF_ERROR(runtime::use_cuda_device(impl_->cuda_device));
  RGS_RETURN_IF_ERROR(image.make_stream_wait(impl_->stream));
  return impl_->encoder.encode(static_cast<const uint8_t*>(image.color()), image.color_pitch(), image.width(),
                               image.height(), quality, subsample_chroma, impl_->stream, jpeg);
}

#else

Result<GpuJpegEncoder> GpuJpegEncoder::create(int) {
  return Status(StatusCode::kUnsupportedFeature, "GpuJpegEncoder: this build has no CUDA support (RGS_WITH_CUDA=OFF)");
}

const std::string& GpuJpegEncoder::name() const {
  static const std::string none;
  return none;
}

Status GpuJpegEncoder::encode(const Image&, int, bool, std::vector<uint8_t>*) {
  return Status(StatusCode::kUnsupportedFeature, "GpuJpegEncoder: this build has no CUDA support");
}

#endif

}  // namespace rgs::api
