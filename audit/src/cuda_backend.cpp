#include "internal_backend.h"
#include "rgs/config.h"

#if RGS_HAS_CUDA
#include "rgs/audit/gpu_image_metrics.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_renderer.h"
#include "rgs/runtime/gpu_scene.h"
#endif

namespace rgs::audit::detail {

#if RGS_HAS_CUDA

namespace {

class CudaBackend final : public ViewBackend {
 public:
  static Result<std::unique_ptr<ViewBackend>> create(const AuditScene& source,
                                                     const std::vector<AuditScene>& candidates, int device) {
    std::string why;
    const int count = runtime::cuda_device_count(&why);
    RGS_RETURN_ERROR_IF(count == 0, StatusCode::kUnsupportedFeature, "no usable CUDA device: " + why);
    RGS_RETURN_ERROR_IF(device < 0 || device >= count, StatusCode::kUnsupportedFeature,
                        "CUDA device " + std::to_string(device) + " does not exist (" + std::to_string(count) +
                            " found)");
    RGS_RETURN_IF_ERROR(runtime::use_cuda_device(device));
    std::unique_ptr<CudaBackend> b(new CudaBackend());
    RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo info, runtime::cuda_device_info(device));
    b->device_ = info.name;
    RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer renderer, runtime::GpuRenderer::create());
    b->renderer_ = std::make_unique<runtime::GpuRenderer>(std::move(renderer));
    auto upload = [](const AuditScene& scene) -> Result<runtime::GpuScene> {
      auto gpu = runtime::GpuScene::from_cloud(scene.cloud, scene.bounds);
      if (!gpu.ok()) return Status(gpu.status()).prepend(scene.info.path);
      return gpu;
    };
    RGS_ASSIGN_OR_RETURN(runtime::GpuScene s, upload(source));
    b->source_ = std::make_unique<runtime::GpuScene>(std::move(s));
    for (const AuditScene& c : candidates) {
      RGS_ASSIGN_OR_RETURN(runtime::GpuScene g, upload(c));
      b->candidates_.push_back(std::make_unique<runtime::GpuScene>(std::move(g)));
    }
    b->source_path_ = source.info.path;
    for (const AuditScene& c : candidates) b->candidate_paths_.push_back(c.info.path);
    return std::unique_ptr<ViewBackend>(std::move(b));
  }

  std::string device() const override { return device_; }

  Status render_source(const runtime::Camera& camera) override {
    auto stats = renderer_->render(*source_, camera, options_, &source_image_);
    if (!stats.ok()) return Status(stats.status()).prepend(source_path_ + ", view " + camera.name);
    source_host_valid_ = false;
    return Status();
  }

  Result<ImageMetrics> render_candidate(size_t index, const runtime::Camera& camera) override {
    auto stats = renderer_->render(*candidates_[index], camera, options_, &candidate_image_);
    if (!stats.ok()) return Status(stats.status()).prepend(candidate_paths_[index] + ", view " + camera.name);
    auto metrics = comparer_.compare(source_image_.rgba(), candidate_image_.rgba(), camera.width, camera.height, 4);
    if (!metrics.ok()) return Status(metrics.status()).prepend("view " + camera.name);
    candidate_host_valid_ = false;
    return metrics;
  }

  Result<std::pair<ImageRef, ImageRef>> last_images() override {
    if (!source_host_valid_) {
      RGS_ASSIGN_OR_RETURN(source_host_, runtime::download(source_image_));
      source_host_valid_ = true;
    }
    if (!candidate_host_valid_) {
      RGS_ASSIGN_OR_RETURN(candidate_host_, runtime::download(candidate_image_));
      candidate_host_valid_ = true;
    }
    return std::make_pair(ImageRef{source_host_.rgba.data(), source_host_.width, source_host_.height, 4},
                          ImageRef{candidate_host_.rgba.data(), candidate_host_.width, candidate_host_.height, 4});
  }

 private:
  CudaBackend() = default;

  std::string device_;
  std::unique_ptr<runtime::GpuRenderer> renderer_;
  std::unique_ptr<runtime::GpuScene> source_;
  std::vector<std::unique_ptr<runtime::GpuScene>> candidates_;
  std::string source_path_;
  std::vector<std::string> candidate_paths_;
  runtime::GpuRenderOptions options_;  // baseline pipeline, black background
  runtime::DeviceImage source_image_, candidate_image_;
  GpuImageComparer comparer_;
  runtime::HostImage source_host_, candidate_host_;
  bool source_host_valid_ = false, candidate_host_valid_ = false;
};

}  // namespace

Result<std::unique_ptr<ViewBackend>> make_cuda_backend(const AuditScene& source,
                                                       const std::vector<AuditScene>& candidates, int device) {
  return CudaBackend::create(source, candidates, device);
}

bool cuda_available(std::string* why) { return runtime::cuda_device_count(why) > 0; }

#else

Result<std::unique_ptr<ViewBackend>> make_cuda_backend(const AuditScene&, const std::vector<AuditScene>&, int) {
  return Status(StatusCode::kUnsupportedFeature,
                "the CUDA backend needs a build with CUDA (RGS_WITH_CUDA=ON); this one has none");
}

bool cuda_available(std::string* why) {
  if (why != nullptr) *why = "built without CUDA";
  return false;
}

#endif

}  // namespace rgs::audit::detail
