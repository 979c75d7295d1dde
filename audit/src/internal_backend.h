// The renders behind run_audit(): one interface over the front door's renderer, on the CPU or the GPU.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rgs/audit/audit.h"
#include "rgs/audit/image_metrics.h"

namespace rgs::audit::detail {

/// Renders the source and the candidates of an audit view by view and compares them.
class ViewBackend {
 public:
  virtual ~ViewBackend() = default;
  /// "CPU reference (2 threads)", or the CUDA device's name.
  virtual std::string device() const = 0;
  /// Renders the source from `camera`; later candidate renders of the same camera are compared with it.
  virtual Status render_source(const runtime::Camera& camera) = 0;
  /// Renders candidate `index` from the camera of the last render_source and compares it with the source.
  virtual Result<ImageMetrics> render_candidate(size_t index, const runtime::Camera& camera) = 0;
  /// Host images of the last source and candidate renders (valid until the next render call).
  virtual Result<std::pair<ImageRef, ImageRef>> last_images() = 0;
};

/// The renders of `backend` through the front door (api::Renderer, faithful preset): the CPU reference with
/// `threads` threads, or CUDA device `cuda_device`. kUnsupportedFeature in a build without CUDA or without a
/// device; the errors of uploading the scenes.
Result<std::unique_ptr<ViewBackend>> make_view_backend(const AuditScene& source,
                                                       const std::vector<AuditScene>& candidates, Backend backend,
                                                       int cuda_device, unsigned threads);

bool cuda_available(std::string* why);

}  // namespace rgs::audit::detail
