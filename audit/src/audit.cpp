#include "rgs/audit/audit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "rgs/api/renderer.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/quantize.h"
#include "rgs/runtime/image_metrics.h"
#include "rgs/config.h"
#include "rgs/format/spec.h"
#include "rgs/kernels/shared/blend_math.h"

#if RGS_HAS_CUDA
#include "rgs/runtime/gpu_image_metrics.h"
#include "rgs/runtime/cuda_device.h"
#endif

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

/// Calls visit(b, p) for every pixel p (index in the [height, width] image) of every f × f block b (index in the
/// [max(1, height / f), max(1, width / f)] blocks), block by block, each row by row; the last partial row/column
/// of blocks is dropped, a block wider than the image cut to it.
template <typename Visit>
void for_each_block_pixel(uint32_t width, uint32_t height, uint32_t f, Visit visit) {
  const uint32_t blocks_x = std::max(1u, width / f), blocks_y = std::max(1u, height / f);
  for (uint32_t y = 0; y < blocks_y; ++y) {
    for (uint32_t x = 0; x < blocks_x; ++x) {
      for (uint32_t dy = 0; dy < f && y * f + dy < height; ++dy) {
        for (uint32_t dx = 0; dx < f && x * f + dx < width; ++dx) {
          visit(size_t(y) * blocks_x + x, size_t(y * f + dy) * width + (x * f + dx));
        }
      }
    }
  }
}

/// Box mean of the clamped RGB values over f × f blocks (for_each_block_pixel's blocks).
Image8 reduce_colour(const runtime::ImageRef& img, uint32_t f) {
  Image8 out{std::max(1u, img.width / f), std::max(1u, img.height / f), 3, {}};
  std::vector<double> sums(size_t(out.width) * out.height * 4, 0.0);  // R, G, B and the pixel count of each block
  for_each_block_pixel(img.width, img.height, f, [&](size_t b, size_t p) {
    for (uint32_t c = 0; c < 3; ++c) sums[b * 4 + c] += clamp01(img.data[p * img.channels + c]);
    sums[b * 4 + 3] += 1;
  });
  out.pixels.resize(size_t(out.width) * out.height * 3);
  for (size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = to_byte(sums[i / 3 * 4 + i % 3] / sums[i / 3 * 4 + 3]);
  return out;
}

/// Per-pixel max over R, G, B of |Δ| of the clamped values, box maximum over f × f blocks: [H / f, W / f].
std::vector<float> reduce_difference(const runtime::ImageRef& a, const runtime::ImageRef& b, uint32_t f) {
  std::vector<float> out(size_t(std::max(1u, a.width / f)) * std::max(1u, a.height / f), 0.f);
  for_each_block_pixel(a.width, a.height, f, [&](size_t block, size_t p) {
    for (uint32_t c = 0; c < 3; ++c) {
      const float d = std::fabs(clamp01(a.data[p * a.channels + c]) - clamp01(b.data[p * b.channels + c]));
      out[block] = std::max(out[block], d);
    }
  });
  return out;
}

/// The grey heatmap of a [height, width] |Δ| map: `scale` is 255 (all 0 when scale is 0).
Image8 heatmap(const std::vector<float>& abs_difference, uint32_t width, uint32_t height, float scale) {
  Image8 out;
  out.width = width;
  out.height = height;
  out.channels = 1;
  out.pixels.assign(size_t(width) * height, 0);
  if (!(scale > 0.f)) return out;
  for (size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = to_byte(double(abs_difference[i]) / scale);
  return out;
}

/// Coefficients of the source Gaussians `paired` that the candidate's SH scales clip: |SH| ≥ 127.5·s
/// (round-half-away of SH/s would exceed 127), or s = 0 with SH ≠ 0.
void count_clipped(const format::GaussianCloud& source, const std::vector<uint64_t>& paired,
                   const format::ShQuantization& shq, uint64_t clipped[4][3]) {
  const uint32_t k_count = source.sh_coefficients();
  for (const uint64_t i : paired) {
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
  s.foreground_psnr_min_db = std::numeric_limits<double>::infinity();
  double psnr_sum = 0, ssim_sum = 0, foreground_sum = 0;
  size_t foreground_views = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    psnr_sum += views[v].psnr_db;
    ssim_sum += views[v].ssim;
    s.render_seconds += views[v].render_seconds;
    if (!std::isnan(views[v].foreground_psnr_db)) {
      foreground_sum += views[v].foreground_psnr_db;
      s.foreground_psnr_min_db = std::min(s.foreground_psnr_min_db, views[v].foreground_psnr_db);
      ++foreground_views;
    }
    s.psnr_min_db = std::min(s.psnr_min_db, views[v].psnr_db);
    if (v == 0 || verdict_view_psnr_db(views[v]) < verdict_view_psnr_db(views[s.worst_view])) s.worst_view = v;
    s.ssim_min = std::min(s.ssim_min, views[v].ssim);
    s.max_abs_diff = std::max(s.max_abs_diff, views[v].max_abs_diff);
  }
  if (!views.empty()) {
    s.psnr_mean_db = psnr_sum / double(views.size());
    s.ssim_mean = ssim_sum / double(views.size());
  }
  if (foreground_views > 0) {
    s.foreground_psnr_mean_db = foreground_sum / double(foreground_views);
  } else {
    s.foreground_psnr_mean_db = s.foreground_psnr_min_db = std::numeric_limits<double>::quiet_NaN();
  }
  return s;
}

/// Renders `scene` into `image`, reusing it when it has the camera's size.
Status render_into(api::Renderer& renderer, const api::Scene& scene, const runtime::Camera& camera,
                   const api::RenderSettings& settings, std::optional<api::Image>* image) {
  Status s;
  if (*image && (*image)->width() == camera.width && (*image)->height() == camera.height) {
    s = renderer.render(scene, camera, settings, (*image)->target()).status();
  } else {
    auto rendered = renderer.render_image(scene, camera, settings);
    if (rendered.ok()) image->emplace(std::move(rendered).value());
    s = rendered.status();
  }
  if (!s.ok()) return s.prepend(scene.info().path + ", view " + camera.name);
  return Status();
}

/// The image's RGBA32F pixels on the host: its own memory on the CPU, a copy (`host`, made once per render) of a
/// GPU image.
Result<runtime::ImageRef> host_pixels(const api::Image& image, std::vector<float>* host) {
  const float* pixels = static_cast<const float*>(image.color());
  if (image.device() != api::Device::kCpu) {
    if (host->empty()) {
      host->resize(size_t(image.width()) * image.height() * 4);
      RGS_RETURN_IF_ERROR(image.copy_to_host(host->data(), nullptr));
    }
    pixels = host->data();
  }
  return runtime::ImageRef{pixels, image.width(), image.height(), 4};
}

/// "CPU reference renderer (N threads)", or the CUDA device's name.
Result<std::string> device_description(const AuditOptions& options) {
  if (options.backend == Backend::kCpu) {
    const unsigned n = options.cpu_threads != 0 ? options.cpu_threads : std::thread::hardware_concurrency();
    return "CPU reference renderer (" + std::to_string(n) + " thread" + (n == 1 ? "" : "s") + ")";
  }
#if RGS_HAS_CUDA
  RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo info, runtime::cuda_device_info(options.cuda_device));
  return info.name;
#else
  return std::string();
#endif
}

/// A candidate's result before its views: its file, and its attribute errors where every candidate Gaussian is
/// paired with a source Gaussian (else a note saying why there are none).
Result<CandidateResult> candidate_with_attributes(const AuditScene& source, const AuditScene& cand) {
  CandidateResult c;
  c.scene = cand.info;
  if (cand.cloud.sh_degree != source.cloud.sh_degree) {
    c.attributes_note = "attribute errors not measured: the candidate's SH degree " +
                        std::to_string(cand.cloud.sh_degree) + " against the source's " +
                        std::to_string(source.cloud.sh_degree);
    return c;
  }
  RGS_ASSIGN_OR_RETURN(const converter::GaussianPairing pairing, pair_with_source(source, cand));
  if (!pairing.complete()) {
    c.attributes_note = "attribute errors not measured: " + unpaired_note(pairing, cand.cloud.size());
    return c;
  }
  auto errors = converter::measure_paired_attribute_errors(source.cloud, cand.cloud, pairing.reference_of_test);
  if (!errors.ok()) return Status(errors.status()).prepend(cand.info.path);
  AttributeReport report;
  report.errors = *errors;
  report.pairing = pairing.method;
  report.position_tolerance = pairing.position_tolerance;
  report.source_unpaired = pairing.unpaired_reference;
  if (cand.sh_quantization) {
    report.sh_quantization = cand.sh_quantization;
    count_clipped(source.cloud, pairing.reference_of_test, *cand.sh_quantization, report.clipped);
  }
  c.attributes = report;
  return c;
}

/// The source as the conversion that wrote `cand` edited it (AuditScene::conversion_options): its recorded edits
/// applied in order to a copy, --decimate left out (what decimation removed is part of what the conversion cost,
/// as a coarser level's is). Unset when the conversion edited nothing else; `reference` says what was done
/// (CandidateResult::reference), and `cameras` (the audit's, in the source's frame) are moved with the edits, so
/// that they see the edited source as they saw the source.
Result<std::optional<AuditScene>> edited_source(const AuditScene& source, const AuditScene& cand,
                                                std::string* reference, std::vector<runtime::Camera>* cameras) {
  auto recorded = converter::parse_recorded_edits(cand.conversion_options);
  if (!recorded.ok()) {
    *reference = "the whole source: its provenance's edits are not understood (" + recorded.status().message() + ")";
    return std::optional<AuditScene>();
  }
  std::vector<std::string> applied;
  AuditScene out;
  for (const converter::EditAction& edit : *recorded) {
    if (edit.kind == converter::EditKind::kDecimate) continue;
    if (applied.empty()) out = source;
    auto removed = converter::apply_edit(&out.cloud, edit);
    if (!removed.ok()) return Status(removed.status()).prepend("the source under the edits of " + cand.info.path);
    applied.push_back(converter::edit_action_text(edit));
  }
  if (applied.empty()) return std::optional<AuditScene>();
  const converter::EditMotion m = converter::edit_motion(*recorded);
  for (runtime::Camera& cam : *cameras) runtime::move_camera(&cam, m.rotation, m.scale, m.offset);
  out.bounds = converter::compute_bounds(out.cloud);
  out.info.gaussians = out.cloud.size();
  std::string chain;
  for (const std::string& text : applied) chain += (chain.empty() ? "" : "; ") + text;
  *reference = "the source under the edits its conversion recorded (" + chain + "), " +
               rgs::group_digits(out.info.gaussians) + " of its " + rgs::group_digits(source.info.gaussians) +
               " Gaussians: what they moved or removed is not counted as loss";
  return std::optional<AuditScene>(std::move(out));
}

/// Each candidate's result before the renders, its attribute errors measured against its reference: the source,
/// or the source edited as the candidate's conversion was (appended to `edited`, with `cameras` moved by its edits
/// to `moved`; reference[i] = k for edited[k − 1], 0 for the source).
Status compare_attributes(const AuditScene& source, const std::vector<AuditScene>& candidates,
                          const std::vector<runtime::Camera>& cameras, AuditResult* result,
                          std::vector<AuditScene>* edited, std::vector<std::vector<runtime::Camera>>* moved,
                          std::vector<size_t>* reference) {
  for (size_t i = 0; i < candidates.size(); ++i) {
    std::string described;
    std::vector<runtime::Camera> cams = cameras;
    RGS_ASSIGN_OR_RETURN(std::optional<AuditScene> ref, edited_source(source, candidates[i], &described, &cams));
    if (ref) {
      moved->push_back(std::move(cams));
      edited->push_back(std::move(*ref));
      (*reference)[i] = edited->size();
    }
    const AuditScene& compared = (*reference)[i] ? edited->back() : source;
    RGS_ASSIGN_OR_RETURN(CandidateResult c, candidate_with_attributes(compared, candidates[i]));
    c.reference = described;
    c.reference_gaussians = compared.info.gaussians;
    c.views.resize(cameras.size());
    result->candidates.push_back(std::move(c));
  }
  return Status();
}

/// The kHeatScalePercentile-th percentile (nearest rank) of the non-zero values of `maps`; 0 when there are none.
float percentile_of_nonzero(const std::vector<const std::vector<float>*>& maps) {
  std::vector<float> values;
  for (const std::vector<float>* m : maps) {
    for (float v : *m) {
      if (v > 0.f) values.push_back(v);
    }
  }
  if (values.empty()) return 0.f;
  const size_t rank = size_t(std::ceil(kHeatScalePercentile / 100.0 * double(values.size())));
  const auto at = values.begin() + std::ptrdiff_t(std::clamp<size_t>(rank, 1, values.size()) - 1);
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

/// Each candidate's summary, then its heatmaps on its own scale, known only now: a percentile of its kept |Δ|.
/// One scale per candidate, not one for the audit: a single bright pixel of one candidate would otherwise
/// leave the others' heatmaps black.
void summarize_and_scale(AuditResult* result, const std::vector<float>& worst_heatmap,
                         std::pair<uint32_t, uint32_t> worst_heatmap_size) {
  for (size_t i = 0; i < result->candidates.size(); ++i) {
    CandidateResult& c = result->candidates[i];
    c.summary = summarize(c.views);
    std::vector<const std::vector<float>*> maps;
    for (const ViewImages& w : c.worst) maps.push_back(&w.abs_difference);
    if (maps.empty() && i == 0 && !worst_heatmap.empty()) maps.push_back(&worst_heatmap);
    c.heat_scale = percentile_of_nonzero(maps);
    for (ViewImages& w : c.worst) {
      w.heat_scale = c.heat_scale;
      w.difference = heatmap(w.abs_difference, w.source.width, w.source.height, c.heat_scale);
    }
  }
  if (!worst_heatmap.empty()) {
    CandidateResult& c = result->candidates[0];
    c.worst_heatmap = heatmap(worst_heatmap, worst_heatmap_size.first, worst_heatmap_size.second, c.heat_scale);
  }
}

/// run_audit's arguments: a candidate, and views, each at least SSIM's window a side.
Status check_audit(const std::vector<AuditScene>& candidates, const std::vector<runtime::Camera>& cameras) {
  RGS_RETURN_ERROR_IF(cameras.empty(), StatusCode::kInvalidArgument, "audit: no views selected");
  RGS_RETURN_ERROR_IF(candidates.empty(), StatusCode::kInvalidArgument, "audit: no candidate scene to compare");
  for (const runtime::Camera& cam : cameras) {
    RGS_RETURN_ERROR_IF(cam.width < uint32_t(runtime::kSsimWindow) || cam.height < uint32_t(runtime::kSsimWindow),
                        StatusCode::kInvalidArgument,
                        "audit: view " + cam.name + " is " + std::to_string(cam.width) + "x" +
                            std::to_string(cam.height) + "; SSIM needs at least 11x11 pixels");
  }
  return Status();
}

}  // namespace

const char* backend_name(Backend backend) { return backend == Backend::kCuda ? "cuda" : "cpu"; }

Result<AuditResult> run_audit(const AuditScene& source, const std::vector<AuditScene>& candidates,
                              const std::vector<runtime::Camera>& cameras, const AuditOptions& options) {
  RGS_RETURN_IF_ERROR(check_audit(candidates, cameras));
  const auto t_start = Clock::now();
  AuditResult result;
  result.backend = options.backend;
  result.source = source.info;
  for (const runtime::Camera& cam : cameras) result.views.push_back(ViewInfo{cam.name, cam.width, cam.height});

  std::vector<AuditScene> edited;                       // the edited sources
  std::vector<std::vector<runtime::Camera>> moved;      // the cameras moved with each one's edits
  std::vector<size_t> reference(candidates.size(), 0);  // 0: the source; k: edited[k − 1]
  RGS_RETURN_IF_ERROR(compare_attributes(source, candidates, cameras, &result, &edited, &moved, &reference));

  // The renders go through the front door (api::Renderer, the faithful preset, black background); the images
  // are compared where they are (runtime::compare_images on the host, runtime::GpuImageComparer on the device).
  const api::Device device = options.backend == Backend::kCuda ? api::Device::kCuda : api::Device::kCpu;
  RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(device, options.cuda_device));
  api::RenderSettings settings;
  settings.preset = api::Preset::kFaithful;
  settings.cpu_threads = options.cpu_threads;
  api::LoadOptions load;
  load.device = device;
  load.cuda_device = options.cuda_device;
  // The source, the candidates, then the edited sources: scenes[candidates.size() + k] is edited[k − 1].
  std::vector<api::Scene> scenes;
  RGS_ASSIGN_OR_RETURN(api::Scene source_scene, api::load_cloud(source.cloud, source.bounds, source.info.path, load));
  scenes.push_back(std::move(source_scene));
  for (const std::vector<AuditScene>* group : {&candidates, &std::as_const(edited)}) {
    for (const AuditScene& scene : *group) {
      RGS_ASSIGN_OR_RETURN(api::Scene loaded, api::load_cloud(scene.cloud, scene.bounds, scene.info.path, load));
      scenes.push_back(std::move(loaded));
    }
  }
  std::vector<std::optional<api::Image>> edited_images(edited.size());
  std::vector<float> edited_host;
  RGS_ASSIGN_OR_RETURN(result.device, device_description(options));
#if RGS_HAS_CUDA
  runtime::GpuImageComparer comparer;
#endif
  std::optional<api::Image> source_image, candidate_image;
  std::vector<float> source_host, candidate_host;  // GPU images copied for the report
  std::vector<float> worst_heatmap;                // the first candidate's worst view, full size (|Δ|)
  std::pair<uint32_t, uint32_t> worst_heatmap_size{0, 0};

  for (size_t v = 0; v < cameras.size(); ++v) {
    const runtime::Camera& cam = cameras[v];
    const auto t_source = Clock::now();
    RGS_RETURN_IF_ERROR(render_into(renderer, scenes[0], cam, settings, &source_image));
    source_host.clear();
    if (options.on_render) {
      RGS_ASSIGN_OR_RETURN(const runtime::ImageRef pixels, host_pixels(*source_image, &source_host));
      RGS_RETURN_IF_ERROR(options.on_render(v, 0, pixels));
    }
    const double source_seconds = seconds_since(t_source) / double(candidates.size());
    AuditProgress progress;
    for (size_t i = 0; i < candidates.size(); ++i) {
      CandidateResult& c = result.candidates[i];
      const auto t_view = Clock::now();
      const size_t k = reference[i];  // each edited source serves one candidate, seen by the moved cameras
      const runtime::Camera& seen_by = k == 0 ? cam : moved[k - 1][v];
      if (k != 0) {
        RGS_RETURN_IF_ERROR(
            render_into(renderer, scenes[candidates.size() + k], seen_by, settings, &edited_images[k - 1]));
      }
      const api::Image& reference_image = k == 0 ? *source_image : *edited_images[k - 1];
      std::vector<float>& reference_host = k == 0 ? source_host : edited_host;
      edited_host.clear();
      RGS_RETURN_IF_ERROR(render_into(renderer, scenes[i + 1], seen_by, settings, &candidate_image));
#if RGS_HAS_CUDA
      // The GPU render is asynchronous: wait for it so that render_seconds is the render's (the comparison
      // below waits for it anyway).
      if (device == api::Device::kCuda) {
        const cudaError_t e = cudaStreamSynchronize(nullptr);
        RGS_RETURN_ERROR_IF(e != cudaSuccess, StatusCode::kCudaError,
                            "view " + cam.name + ": render of " + c.scene.path + ": " + cudaGetErrorString(e));
      }
#endif
      const double render_seconds = seconds_since(t_view);
      candidate_host.clear();
      if (options.on_render) {
        RGS_ASSIGN_OR_RETURN(const runtime::ImageRef pixels, host_pixels(*candidate_image, &candidate_host));
        RGS_RETURN_IF_ERROR(options.on_render(v, i + 1, pixels));
      }
      const float* a = static_cast<const float*>(reference_image.color());
      const float* b = static_cast<const float*>(candidate_image->color());
#if RGS_HAS_CUDA
      Result<runtime::ImageMetrics> metrics = device == api::Device::kCpu
                                         ? runtime::compare_images({a, cam.width, cam.height, 4}, {b, cam.width, cam.height, 4})
                                         : comparer.compare(a, b, cam.width, cam.height, 4);
#else
      Result<runtime::ImageMetrics> metrics = runtime::compare_images({a, cam.width, cam.height, 4}, {b, cam.width, cam.height, 4});
#endif
      if (!metrics.ok()) return Status(metrics.status()).prepend("view " + cam.name);
      const runtime::ImageMetrics& m = *metrics;
      ViewMetrics& vm = c.views[v];
      vm.psnr_db = m.psnr_db;
      vm.ssim = m.ssim;
      vm.max_abs_diff = m.max_abs_diff;
      vm.render_seconds = render_seconds;
      progress.psnr_db.push_back(m.psnr_db);
      vm.foreground_psnr_db = m.foreground.psnr_db;
      vm.foreground_fraction = double(m.foreground.pixels) / double(m.foreground.total_pixels);

      const double rank_db = verdict_view_psnr_db(vm);
      const bool new_worst = v == 0 || rank_db < verdict_view_psnr_db(c.views[c.summary.worst_view]);
      if (new_worst) c.summary.worst_view = v;
      const auto ranks_below = [&](double db, const ViewImages& w) { return db < verdict_view_psnr_db(c.views[w.view]); };
      const bool keep_images =
          options.worst_views > 0 && (c.worst.size() < options.worst_views || ranks_below(rank_db, c.worst.back()));
      const bool keep_heatmap = options.keep_worst_heatmap && i == 0 && new_worst;
      if (keep_images || keep_heatmap) {
        // GPU images are copied to the host only here (once per view and scene).
        RGS_ASSIGN_OR_RETURN(const runtime::ImageRef source_pixels, host_pixels(reference_image, &reference_host));
        RGS_ASSIGN_OR_RETURN(const runtime::ImageRef candidate_pixels, host_pixels(*candidate_image, &candidate_host));
        if (keep_images) {
          const uint32_t f = reduction_factor(cam.width, cam.height, options.image_max_side);
          ViewImages vi;
          vi.view = v;
          vi.psnr_db = m.psnr_db;
          vi.source = reduce_colour(source_pixels, f);
          vi.candidate = reduce_colour(candidate_pixels, f);
          vi.abs_difference = reduce_difference(source_pixels, candidate_pixels, f);
          auto at = std::upper_bound(c.worst.begin(), c.worst.end(), rank_db, ranks_below);
          c.worst.insert(at, std::move(vi));
          if (c.worst.size() > options.worst_views) c.worst.pop_back();
        }
        if (keep_heatmap) {
          worst_heatmap = reduce_difference(source_pixels, candidate_pixels, 1);
          worst_heatmap_size = {cam.width, cam.height};
        }
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
  summarize_and_scale(&result, worst_heatmap, worst_heatmap_size);
  result.render_seconds = seconds_since(t_start);
  return result;
}

Result<AuditResult> audit_files(const AuditFiles& files, AuditOptions options) {
  RGS_ASSIGN_OR_RETURN(const AuditScene source, load_audit_scene(files.source, "source", files.read));
  files.on_notes(source.info.notes);
  std::vector<AuditScene> candidates;
  for (size_t i = 0; i < files.candidates.size(); ++i) {
    const std::string label = i < files.labels.size() ? files.labels[i] : std::string();
    RGS_ASSIGN_OR_RETURN(AuditScene scene, load_audit_scene(files.candidates[i], label, files.read));
    files.on_notes(scene.info.notes);
    candidates.push_back(std::move(scene));
  }
  for (size_t i = 0, n = files.attribution ? candidates.size() : 0; i < n; ++i) {
    RGS_ASSIGN_OR_RETURN(std::vector<AuditScene> hybrids, attribution_scenes(source, candidates[i]));
    for (AuditScene& h : hybrids) candidates.push_back(std::move(h));
  }
  std::vector<runtime::Camera> cameras = files.cameras.value_or(std::vector<runtime::Camera>());
  std::string views_note;
  const api::CameraChoice& v = files.views;
  if (!files.cameras && v.cameras_path.empty() && v.orbit == 0 && v.path == 0) {
    RGS_ASSIGN_OR_RETURN(api::DefaultViews found, api::default_views(files.source, source.cloud, v));
    files.on_notes({found.note});
    cameras = std::move(found.cameras);
    views_note = std::move(found.note);
  } else if (!files.cameras) {
    RGS_ASSIGN_OR_RETURN(cameras, api::make_cameras(v, api::content_frame(source.cloud)));
  }
  if (files.before_render) RGS_RETURN_IF_ERROR(files.before_render(candidates, cameras, options));
  RGS_ASSIGN_OR_RETURN(AuditResult result, run_audit(source, candidates, cameras, options));
  result.views_note = std::move(views_note);
  return result;
}

}  // namespace rgs::audit
