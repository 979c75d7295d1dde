#include <thread>

#include "internal_backend.h"
#include "rgs/runtime/cpu_renderer.h"

namespace rgs::audit::detail {

namespace {

class CpuBackend final : public ViewBackend {
 public:
  CpuBackend(const AuditScene& source, const std::vector<AuditScene>& candidates, unsigned threads)
      : source_(source), candidates_(candidates) {
    options_.num_threads = threads;
  }

  std::string device() const override {
    const unsigned n = options_.num_threads != 0 ? options_.num_threads : std::thread::hardware_concurrency();
    return "CPU reference renderer (" + std::to_string(n) + " thread" + (n == 1 ? "" : "s") + ")";
  }

  Status render_source(const runtime::Camera& camera) override {
    auto image = runtime::render_cpu(source_.cloud, camera, options_);
    if (!image.ok()) return Status(image.status()).prepend(source_.info.path + ", view " + camera.name);
    source_image_ = std::move(image).value();
    return Status();
  }

  Result<ImageMetrics> render_candidate(size_t index, const runtime::Camera& camera) override {
    const AuditScene& scene = candidates_[index];
    auto image = runtime::render_cpu(scene.cloud, camera, options_);
    if (!image.ok()) return Status(image.status()).prepend(scene.info.path + ", view " + camera.name);
    candidate_image_ = std::move(image).value();
    auto metrics = compare_images(source_ref(), candidate_ref());
    if (!metrics.ok()) return Status(metrics.status()).prepend("view " + camera.name);
    return metrics;
  }

  Result<std::pair<ImageRef, ImageRef>> last_images() override {
    return std::make_pair(source_ref(), candidate_ref());
  }

 private:
  ImageRef source_ref() const {
    return ImageRef{source_image_.rgb.data(), source_image_.width, source_image_.height, 3};
  }
  ImageRef candidate_ref() const {
    return ImageRef{candidate_image_.rgb.data(), candidate_image_.width, candidate_image_.height, 3};
  }

  const AuditScene& source_;
  const std::vector<AuditScene>& candidates_;
  runtime::RenderOptions options_;  // baseline: every RoofGS technique off, black background
  runtime::RenderResult source_image_, candidate_image_;
};

}  // namespace

std::unique_ptr<ViewBackend> make_cpu_backend(const AuditScene& source, const std::vector<AuditScene>& candidates,
                                              unsigned threads) {
  return std::make_unique<CpuBackend>(source, candidates, threads);
}

}  // namespace rgs::audit::detail
