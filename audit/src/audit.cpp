#include "rgs/audit/audit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "internal_backend.h"
#include "rgs/format/spec.h"
#include "rgs/kernels/shared/blend_math.h"

namespace rgs::audit {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

float clamp01(float v) { return std::isnan(v) ? 0.f : std::clamp(v, 0.f, 1.f); }
uint8_t to_byte(double v) { return kernels::unorm8(static_cast<float>(v)); }

/// Smallest integer factor that brings the larger side to at most `max_side`.
uint32_t reduction_factor(uint32_t width, uint32_t height, uint32_t max_side) {
  const uint32_t side = std::max(width, height);
  if (max_side == 0 || side <= max_side) return 1;
  return (side + max_side - 1) / max_side;
}

/// Box mean of the clamped RGB values over f × f blocks (the last partial row/column dropped).
Image8 reduce_colour(const ImageRef& img, uint32_t f) {
  Image8 out;
  out.width = std::max(1u, img.width / f);
  out.height = std::max(1u, img.height / f);
  out.channels = 3;
  out.pixels.resize(size_t(out.width) * out.height * 3);
  for (uint32_t y = 0; y < out.height; ++y) {
    for (uint32_t x = 0; x < out.width; ++x) {
      double sum[3] = {0, 0, 0};
      uint32_t n = 0;
      for (uint32_t dy = 0; dy < f && y * f + dy < img.height; ++dy) {
        for (uint32_t dx = 0; dx < f && x * f + dx < img.width; ++dx) {
          const size_t p = size_t(y * f + dy) * img.width + (x * f + dx);
          for (uint32_t c = 0; c < 3; ++c) sum[c] += clamp01(img.data[p * img.channels + c]);
          ++n;
        }
      }
      for (uint32_t c = 0; c < 3; ++c) out.pixels[(size_t(y) * out.width + x) * 3 + c] = to_byte(sum[c] / n);
    }
  }
  return out;
}

/// Per-pixel max over R, G, B of |Δ| of the clamped values, box maximum over f × f blocks, scaled by `scale`.
Image8 reduce_difference(const ImageRef& a, const ImageRef& b, uint32_t f, float scale) {
  Image8 out;
  out.width = std::max(1u, a.width / f);
  out.height = std::max(1u, a.height / f);
  out.channels = 1;
  out.pixels.assign(size_t(out.width) * out.height, 0);
  if (!(scale > 0.f)) return out;
  for (uint32_t y = 0; y < out.height; ++y) {
    for (uint32_t x = 0; x < out.width; ++x) {
      float m = 0.f;
      for (uint32_t dy = 0; dy < f && y * f + dy < a.height; ++dy) {
        for (uint32_t dx = 0; dx < f && x * f + dx < a.width; ++dx) {
          const size_t p = size_t(y * f + dy) * a.width + (x * f + dx);
          for (uint32_t c = 0; c < 3; ++c) {
            m = std::max(m, std::fabs(clamp01(a.data[p * a.channels + c]) - clamp01(b.data[p * b.channels + c])));
          }
        }
      }
      out.pixels[size_t(y) * out.width + x] = to_byte(double(m) / scale);
    }
  }
  return out;
}

/// Source coefficients that the candidate's SH scales clip: |SH| ≥ 127.5·s (round-half-away of SH/s would
/// exceed 127), or s = 0 with SH ≠ 0.
void count_clipped(const format::GaussianCloud& source, const format::ShQuantization& shq, uint64_t clipped[4][3]) {
  const uint32_t k_count = source.sh_coefficients();
  for (uint64_t i = 0; i < source.size(); ++i) {
    for (uint32_t k = 0; k < k_count; ++k) {
      const uint32_t d = format::sh_degree_of_coefficient(k);
      for (uint32_t c = 0; c < 3; ++c) {
        const double v = std::fabs(static_cast<double>(source.sh[(i * k_count + k) * 3 + c]));
        const double s = shq.scales[d][c];
        clipped[d][c] += (s > 0) ? (v >= 127.5 * s) : (v != 0.0);
      }
    }
  }
}

Summary summarize(const std::vector<ViewMetrics>& views) {
  Summary s;
  s.psnr_min_db = std::numeric_limits<double>::infinity();
  s.ssim_min = std::numeric_limits<double>::infinity();
  double psnr_sum = 0, ssim_sum = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    psnr_sum += views[v].psnr_db;
    ssim_sum += views[v].ssim;
    if (views[v].psnr_db < s.psnr_min_db || v == 0) {
      s.psnr_min_db = views[v].psnr_db;
      s.worst_view = v;
    }
    s.ssim_min = std::min(s.ssim_min, views[v].ssim);
    s.max_abs_diff = std::max(s.max_abs_diff, views[v].max_abs_diff);
  }
  if (!views.empty()) {
    s.psnr_mean_db = psnr_sum / double(views.size());
    s.ssim_mean = ssim_sum / double(views.size());
  }
  return s;
}

}  // namespace

const char* backend_name(Backend backend) { return backend == Backend::kCuda ? "cuda" : "cpu"; }

bool cuda_backend_available(std::string* why) { return detail::cuda_available(why); }

Result<AuditResult> run_audit(const AuditScene& source, const std::vector<AuditScene>& candidates,
                              const std::vector<runtime::Camera>& cameras, const AuditOptions& options) {
  RGS_RETURN_ERROR_IF(cameras.empty(), StatusCode::kInvalidArgument, "audit: no views selected");
  RGS_RETURN_ERROR_IF(candidates.empty(), StatusCode::kInvalidArgument, "audit: no candidate scene to compare");
  for (const runtime::Camera& cam : cameras) {
    RGS_RETURN_ERROR_IF(cam.width < uint32_t(kSsimWindow) || cam.height < uint32_t(kSsimWindow),
                        StatusCode::kInvalidArgument,
                        "audit: view " + cam.name + " is " + std::to_string(cam.width) + "x" +
                            std::to_string(cam.height) + "; SSIM needs at least 11x11 pixels");
  }
  const auto t_start = Clock::now();
  AuditResult result;
  result.backend = options.backend;
  result.source = source.info;
  for (const runtime::Camera& cam : cameras) result.views.push_back(ViewInfo{cam.name, cam.width, cam.height});

  // Attribute errors where the Gaussians correspond one to one.
  for (const AuditScene& cand : candidates) {
    CandidateResult c;
    c.scene = cand.info;
    if (cand.cloud.size() != source.cloud.size() || cand.cloud.sh_degree != source.cloud.sh_degree) {
      c.attributes_note = "no per-attribute errors: " + std::to_string(cand.cloud.size()) +
                          " Gaussians of SH degree " + std::to_string(cand.cloud.sh_degree) + " against the source's " +
                          std::to_string(source.cloud.size()) + " of degree " + std::to_string(source.cloud.sh_degree);
    } else {
      auto errors = converter::measure_attribute_errors(source.cloud, cand.cloud);
      if (!errors.ok()) return Status(errors.status()).prepend(cand.info.path);
      AttributeReport report;
      report.errors = *errors;
      if (cand.sh_quantization) {
        report.sh_quantization = cand.sh_quantization;
        count_clipped(source.cloud, *cand.sh_quantization, report.clipped);
      }
      c.attributes = report;
    }
    c.views.resize(cameras.size());
    result.candidates.push_back(std::move(c));
  }

  RGS_ASSIGN_OR_RETURN(std::unique_ptr<detail::ViewBackend> backend,
                       detail::make_view_backend(source, candidates, options.backend, options.cuda_device,
                                                 options.cpu_threads));
  result.device = backend->device();

  for (size_t v = 0; v < cameras.size(); ++v) {
    const runtime::Camera& cam = cameras[v];
    const auto t_source = Clock::now();
    RGS_RETURN_IF_ERROR(backend->render_source(cam));
    const double source_seconds = seconds_since(t_source) / double(candidates.size());
    AuditProgress progress;
    for (size_t i = 0; i < candidates.size(); ++i) {
      CandidateResult& c = result.candidates[i];
      const auto t_view = Clock::now();
      RGS_ASSIGN_OR_RETURN(ImageMetrics m, backend->render_candidate(i, cam));
      ViewMetrics& vm = c.views[v];
      vm.psnr_db = m.psnr_db;
      vm.ssim = m.ssim;
      vm.max_abs_diff = m.max_abs_diff;
      progress.psnr_db.push_back(m.psnr_db);

      const bool new_worst = v == 0 || m.psnr_db < c.views[c.summary.worst_view].psnr_db;
      if (new_worst) c.summary.worst_view = v;
      const bool keep_images =
          options.worst_views > 0 &&
          (c.worst.size() < options.worst_views || m.psnr_db < c.worst.back().psnr_db);
      const bool keep_heatmap = options.keep_worst_heatmap && i == 0 && new_worst;
      if (keep_images || keep_heatmap) {
        RGS_ASSIGN_OR_RETURN(auto images, backend->last_images());
        if (keep_images) {
          const uint32_t f = reduction_factor(cam.width, cam.height, options.image_max_side);
          ViewImages vi;
          vi.view = v;
          vi.psnr_db = m.psnr_db;
          vi.source = reduce_colour(images.first, f);
          vi.candidate = reduce_colour(images.second, f);
          vi.heat_scale = m.max_abs_diff;
          vi.difference = reduce_difference(images.first, images.second, f, m.max_abs_diff);
          auto at = std::upper_bound(c.worst.begin(), c.worst.end(), vi.psnr_db,
                                     [](double p, const ViewImages& w) { return p < w.psnr_db; });
          c.worst.insert(at, std::move(vi));
          if (c.worst.size() > options.worst_views) c.worst.pop_back();
        }
        if (keep_heatmap) c.worst_heatmap = reduce_difference(images.first, images.second, 1, m.max_abs_diff);
      }
      vm.seconds = seconds_since(t_view) + source_seconds;
    }
    if (options.progress) {
      progress.views_done = v + 1;
      progress.views_total = cameras.size();
      progress.view = cam.name;
      progress.elapsed_s = seconds_since(t_start);
      progress.remaining_s = progress.elapsed_s / double(v + 1) * double(cameras.size() - v - 1);
      options.progress(progress);
    }
  }
  for (CandidateResult& c : result.candidates) c.summary = summarize(c.views);
  result.render_seconds = seconds_since(t_start);
  return result;
}

}  // namespace rgs::audit
