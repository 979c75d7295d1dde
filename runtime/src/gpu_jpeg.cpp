// GpuJpegEncoder: nvJPEG loaded with dlopen. The few declarations below are nvJPEG's public C API as its
// nvjpeg.h declares them: opaque handles, the image struct, and the enumerators this file uses.
#include "rgs/runtime/gpu_jpeg.h"

#include <dlfcn.h>

#include <mutex>
#include <type_traits>
#include <string>
#include <utility>

#include "rgs/kernels/output_convert.h"

namespace rgs::runtime {
namespace {

using nvjpegStatus = int;  // nvjpegStatus_t: 0 is NVJPEG_STATUS_SUCCESS
using nvjpegHandle = struct NvjpegHandleOpaque*;
using nvjpegEncoderState = struct NvjpegEncoderStateOpaque*;
using nvjpegEncoderParams = struct NvjpegEncoderParamsOpaque*;
struct nvjpegImage {
  unsigned char* channel[4];
  size_t pitch[4];
};
constexpr int kInputRgbInterleaved = 5;  // NVJPEG_INPUT_RGBI
constexpr int kChroma444 = 0;            // NVJPEG_CSS_444
constexpr int kChroma420 = 2;            // NVJPEG_CSS_420

/// The entry points, resolved once per process.
struct NvjpegLibrary {
  std::string name;   // "nvJPEG 13.0.1 (libnvjpeg.so.13)"; empty when not loaded
  std::string error;  // why not
  nvjpegStatus (*create_simple)(nvjpegHandle*) = nullptr;
  nvjpegStatus (*destroy)(nvjpegHandle) = nullptr;
  nvjpegStatus (*get_property)(int, int*) = nullptr;
  nvjpegStatus (*state_create)(nvjpegHandle, nvjpegEncoderState*, cudaStream_t) = nullptr;
  nvjpegStatus (*state_destroy)(nvjpegEncoderState) = nullptr;
  nvjpegStatus (*params_create)(nvjpegHandle, nvjpegEncoderParams*, cudaStream_t) = nullptr;
  nvjpegStatus (*params_destroy)(nvjpegEncoderParams) = nullptr;
  nvjpegStatus (*set_quality)(nvjpegEncoderParams, int, cudaStream_t) = nullptr;
  nvjpegStatus (*set_sampling)(nvjpegEncoderParams, int, cudaStream_t) = nullptr;
  nvjpegStatus (*encode_image)(nvjpegHandle, nvjpegEncoderState, nvjpegEncoderParams, const nvjpegImage*, int, int,
                               int, cudaStream_t) = nullptr;
  nvjpegStatus (*retrieve)(nvjpegHandle, nvjpegEncoderState, unsigned char*, size_t*, cudaStream_t) = nullptr;
};

const NvjpegLibrary& library() {
  static NvjpegLibrary lib;
  static std::once_flag once;
  std::call_once(once, [] {
    // The CUDA 13 and 12 sonames (from the toolkit's lib64 on the loader's path, or a redistributable package),
    // then the toolkit's default location.
    const char* const candidates[] = {"libnvjpeg.so.13", "libnvjpeg.so.12", "/usr/local/cuda/lib64/libnvjpeg.so.13",
                                      "/usr/local/cuda/lib64/libnvjpeg.so.12"};
    void* handle = nullptr;
    const char* found = nullptr;
    std::string tried;
    for (const char* candidate : candidates) {
      handle = dlopen(candidate, RTLD_NOW | RTLD_LOCAL);
      if (handle != nullptr) {
        found = candidate;
        break;
      }
      tried += (tried.empty() ? "" : ", ") + std::string(candidate);
    }
    if (handle == nullptr) {
      lib.error = "nvJPEG not found (tried " + tried + ")";
      return;
    }
    bool complete = true;
    const auto bind = [&](auto* slot, const char* symbol) {
      *slot = reinterpret_cast<std::remove_pointer_t<decltype(slot)>>(dlsym(handle, symbol));
      complete = complete && *slot != nullptr;
    };
    bind(&lib.create_simple, "nvjpegCreateSimple");
    bind(&lib.destroy, "nvjpegDestroy");
    bind(&lib.get_property, "nvjpegGetProperty");
    bind(&lib.state_create, "nvjpegEncoderStateCreate");
    bind(&lib.state_destroy, "nvjpegEncoderStateDestroy");
    bind(&lib.params_create, "nvjpegEncoderParamsCreate");
    bind(&lib.params_destroy, "nvjpegEncoderParamsDestroy");
    bind(&lib.set_quality, "nvjpegEncoderParamsSetQuality");
    bind(&lib.set_sampling, "nvjpegEncoderParamsSetSamplingFactors");
    bind(&lib.encode_image, "nvjpegEncodeImage");
    bind(&lib.retrieve, "nvjpegEncodeRetrieveBitstream");
    if (!complete) {
      lib.error = std::string(found) + " lacks an nvJPEG encoder entry point";
      return;
    }
    int version[3] = {0, 0, 0};  // MAJOR_VERSION, MINOR_VERSION, PATCH_LEVEL
    for (int i = 0; i < 3; ++i) lib.get_property(i, &version[i]);
    lib.name = "nvJPEG " + std::to_string(version[0]) + "." + std::to_string(version[1]) + "." +
               std::to_string(version[2]) + " (" + found + ")";
  });
  return lib;
}

Status nvjpeg_status(nvjpegStatus status, const char* call) {
  if (status == 0) return Status();
  return Status(StatusCode::kCudaError, std::string(call) + " failed (nvJPEG status " + std::to_string(status) + ")");
}

}  // namespace

struct GpuJpegEncoder::State {
  const NvjpegLibrary* lib = nullptr;
  nvjpegHandle handle = nullptr;
  nvjpegEncoderState encoder = nullptr;
  nvjpegEncoderParams params = nullptr;
  DeviceBuffer<uint8_t> rgb;  // [H, W, 3], the encoder's input

  ~State() {
    if (params != nullptr) lib->params_destroy(params);
    if (encoder != nullptr) lib->state_destroy(encoder);
    if (handle != nullptr) lib->destroy(handle);
  }
};

Result<GpuJpegEncoder> GpuJpegEncoder::create() {
  const NvjpegLibrary& lib = library();
  RGS_RETURN_ERROR_IF(lib.name.empty(), StatusCode::kUnsupportedFeature, lib.error);
  auto state = std::make_unique<State>();
  state->lib = &lib;
  RGS_RETURN_IF_ERROR(nvjpeg_status(lib.create_simple(&state->handle), "nvjpegCreateSimple"));
  RGS_RETURN_IF_ERROR(
      nvjpeg_status(lib.state_create(state->handle, &state->encoder, nullptr), "nvjpegEncoderStateCreate"));
  RGS_RETURN_IF_ERROR(
      nvjpeg_status(lib.params_create(state->handle, &state->params, nullptr), "nvjpegEncoderParamsCreate"));
  return GpuJpegEncoder(std::move(state));
}

GpuJpegEncoder::GpuJpegEncoder(std::unique_ptr<State> state) : state_(std::move(state)) {}
GpuJpegEncoder::GpuJpegEncoder(GpuJpegEncoder&&) noexcept = default;
GpuJpegEncoder& GpuJpegEncoder::operator=(GpuJpegEncoder&&) noexcept = default;
GpuJpegEncoder::~GpuJpegEncoder() = default;

const std::string& GpuJpegEncoder::name() const { return state_->lib->name; }

Status GpuJpegEncoder::encode(const uint8_t* rgba, size_t pitch, uint32_t width, uint32_t height, int quality,
                              bool subsample_chroma, cudaStream_t stream, std::vector<uint8_t>* jpeg) {
  RGS_RETURN_ERROR_IF(rgba == nullptr || jpeg == nullptr, StatusCode::kInvalidArgument, "GpuJpegEncoder: null pointer");
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || width > 65535 || height > 65535, StatusCode::kInvalidArgument,
                      "GpuJpegEncoder: size " + std::to_string(width) + "x" + std::to_string(height) +
                          " outside 1..65535 (JPEG's limit)");
  RGS_RETURN_ERROR_IF(pitch < size_t(width) * 4, StatusCode::kInvalidArgument, "GpuJpegEncoder: pitch below 4·width");
  RGS_RETURN_ERROR_IF(quality < 1 || quality > 100, StatusCode::kInvalidArgument,
                      "GpuJpegEncoder: quality " + std::to_string(quality) + " outside 1..100");
  State& s = *state_;
  const NvjpegLibrary& lib = *s.lib;
  RGS_RETURN_IF_ERROR(s.rgb.reserve(size_t(width) * height * 3, "GpuJpegEncoder: RGB image"));
  const cudaError_t packed = kernels::launch_pack_rgb8(rgba, pitch, width, height, s.rgb.data(), stream);
  if (packed != cudaSuccess) return cuda_status(packed, "GpuJpegEncoder: packing RGB");
  RGS_RETURN_IF_ERROR(nvjpeg_status(lib.set_quality(s.params, quality, stream), "nvjpegEncoderParamsSetQuality"));
  RGS_RETURN_IF_ERROR(nvjpeg_status(lib.set_sampling(s.params, subsample_chroma ? kChroma420 : kChroma444, stream),
                                    "nvjpegEncoderParamsSetSamplingFactors"));
  nvjpegImage image{};
  image.channel[0] = s.rgb.data();
  image.pitch[0] = size_t(width) * 3;
  RGS_RETURN_IF_ERROR(nvjpeg_status(lib.encode_image(s.handle, s.encoder, s.params, &image, kInputRgbInterleaved,
                                                     int(width), int(height), stream),
                                    "nvjpegEncodeImage"));
  const cudaError_t done = cudaStreamSynchronize(stream);
  if (done != cudaSuccess) return cuda_status(done, "GpuJpegEncoder: encoding");
  size_t length = 0;
  RGS_RETURN_IF_ERROR(
      nvjpeg_status(lib.retrieve(s.handle, s.encoder, nullptr, &length, stream), "nvjpegEncodeRetrieveBitstream"));
  jpeg->resize(length);
  RGS_RETURN_IF_ERROR(nvjpeg_status(lib.retrieve(s.handle, s.encoder, jpeg->data(), &length, stream),
                                    "nvjpegEncodeRetrieveBitstream"));
  jpeg->resize(length);
  return Status();
}

}  // namespace rgs::runtime
