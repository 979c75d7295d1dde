// The audit's renders: the front door (api::Renderer, the faithful preset) on the CPU reference or the GPU, the
// images compared where they are (compare_images on the host, GpuImageComparer on the device).
#include <optional>
#include <thread>

#include "internal_backend.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"

#if RGS_HAS_CUDA
#include "rgs/audit/gpu_image_metrics.h"
#include "rgs/runtime/cuda_device.h"
#endif

namespace rgs::audit::detail {

namespace {

class FrontDoorBackend final : public ViewBackend {
 public:
  static Result<std::unique_ptr<ViewBackend>> create(const AuditScene& source,
                                                     const std::vector<AuditScene>& candidates, api::Device device,
                                                     int cuda_device, unsigned threads) {
    RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(device, cuda_device));
    std::unique_ptr<FrontDoorBackend> b(new FrontDoorBackend(std::move(renderer)));
    b->settings_.preset = api::Preset::kFaithful;
    b->settings_.cpu_threads = threads;
    api::LoadOptions load;
    load.device = device;
    load.cuda_device = cuda_device;
    RGS_ASSIGN_OR_RETURN(api::Scene s, api::load_cloud(source.cloud, source.bounds, source.info.path, load));
    b->scenes_.push_back(std::move(s));
    for (const AuditScene& c : candidates) {
      RGS_ASSIGN_OR_RETURN(api::Scene scene, api::load_cloud(c.cloud, c.bounds, c.info.path, load));
      b->scenes_.push_back(std::move(scene));
    }
    if (device == api::Device::kCpu) {
      const unsigned n = threads != 0 ? threads : std::thread::hardware_concurrency();
      b->device_ = "CPU reference renderer (" + std::to_string(n) + " thread" + (n == 1 ? "" : "s") + ")";
    } else {
#if RGS_HAS_CUDA
      RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo info, runtime::cuda_device_info(cuda_device));
      b->device_ = info.name;
#endif
    }
    return std::unique_ptr<ViewBackend>(std::move(b));
  }

  std::string device() const override { return device_; }

  Status render_source(const runtime::Camera& camera) override {
    Status s = render(0, camera, &source_);
    source_host_.clear();
    return s;
  }

  Result<ImageMetrics> render_candidate(size_t index, const runtime::Camera& camera) override {
    RGS_RETURN_IF_ERROR(render(index + 1, camera, &candidate_));
    candidate_host_.clear();
    const float* a = static_cast<const float*>(source_->color());
    const float* b = static_cast<const float*>(candidate_->color());
    Result<ImageMetrics> metrics = Status(StatusCode::kInvalidArgument, "no comparison");
    if (renderer_.device() == api::Device::kCpu) {
      metrics = compare_images(ImageRef{a, camera.width, camera.height, 4}, ImageRef{b, camera.width, camera.height, 4});
    } else {
#if RGS_HAS_CUDA
      metrics = comparer_.compare(a, b, camera.width, camera.height, 4);
#endif
    }
    if (!metrics.ok()) return Status(metrics.status()).prepend("view " + camera.name);
    return metrics;
  }

  Result<std::pair<ImageRef, ImageRef>> last_images() override {
    RGS_ASSIGN_OR_RETURN(const float* a, host_pixels(*source_, &source_host_));
    RGS_ASSIGN_OR_RETURN(const float* b, host_pixels(*candidate_, &candidate_host_));
    return std::make_pair(ImageRef{a, source_->width(), source_->height(), 4},
                          ImageRef{b, candidate_->width(), candidate_->height(), 4});
  }

 private:
  explicit FrontDoorBackend(api::Renderer renderer) : renderer_(std::move(renderer)) {}

  /// Renders scene `index` (0: the source) into `image`, reusing it when it has the camera's size.
  Status render(size_t index, const runtime::Camera& camera, std::optional<api::Image>* image) {
    const api::Scene& scene = scenes_[index];
    Status s;
    if (*image && (*image)->width() == camera.width && (*image)->height() == camera.height) {
      s = renderer_.render(scene, camera, settings_, (*image)->target()).status();
    } else {
      auto rendered = renderer_.render_image(scene, camera, settings_);
      if (rendered.ok()) image->emplace(std::move(rendered).value());
      s = rendered.status();
    }
    if (!s.ok()) return s.prepend(scene.info().path + ", view " + camera.name);
    return Status();
  }

  /// The image's RGBA32F pixels on the host: its own memory on the CPU, a copy (`host`) of a GPU image.
  Result<const float*> host_pixels(const api::Image& image, std::vector<float>* host) const {
    if (image.device() == api::Device::kCpu) return static_cast<const float*>(image.color());
    if (host->empty()) {
      host->resize(size_t(image.width()) * image.height() * 4);
      RGS_RETURN_IF_ERROR(image.copy_to_host(host->data(), nullptr));
    }
    return host->data();
  }

  api::Renderer renderer_;
  api::RenderSettings settings_;  // faithful, black background
  std::vector<api::Scene> scenes_;  // the source, then the candidates
  std::string device_;
  std::optional<api::Image> source_, candidate_;
  std::vector<float> source_host_, candidate_host_;  // GPU images copied for last_images()
#if RGS_HAS_CUDA
  GpuImageComparer comparer_;
#endif
};

}  // namespace

Result<std::unique_ptr<ViewBackend>> make_view_backend(const AuditScene& source,
                                                       const std::vector<AuditScene>& candidates, Backend backend,
                                                       int cuda_device, unsigned threads) {
  const api::Device device = backend == Backend::kCuda ? api::Device::kCuda : api::Device::kCpu;
  return FrontDoorBackend::create(source, candidates, device, cuda_device, threads);
}

bool cuda_available(std::string* why) {
#if RGS_HAS_CUDA
  return runtime::cuda_device_count(why) > 0;
#else
  if (why != nullptr) *why = "built without CUDA";
  return false;
#endif
}

}  // namespace rgs::audit::detail
