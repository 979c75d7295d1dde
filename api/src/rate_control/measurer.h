// Rate control's measurements (private to rgs_api): the bytes of archives by encoding them, their PSNR by
// rendering them against the source's renders, each archive encoded once and rendered at most once on the search
// views.
#pragma once

#include <algorithm>
#include <cstdio>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rate_control.h"
#include "knobs.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/parallel/fork_join.h"
#if RGS_HAS_CUDA
#include "rgs/runtime/gpu_image_metrics.h"
#endif

namespace rgs::api::detail {

/// One set of views with the source's renders, rendered once: [H, W, 3] float RGB on the host, or on the GPU
/// (kDeviceSourceBytes, every view at least SSIM's window on each side) the RGBA32F images where it rendered them.
struct ViewSet {
  std::vector<runtime::Camera> cameras;
  std::vector<std::vector<float>> source;
  std::vector<api::Image> source_images;
};

/// Measures archives of one quantized scene: bytes by encoding, PSNR by rendering against the source's renders
/// (the audit's renderer settings and PSNR: the faithful preset, black background, the whole frame's PSNR, on the
/// device with the GPU). Every archive is encoded once and rendered at most once on the search views (cached by its
/// options).
class Measurer {
 public:
  Measurer(const format::GaussianCloud& source, const format::SceneBounds& bounds, format::EncodedScene quantized,
           const FitOptions& options)
      : source_(source), bounds_(bounds), quantized_(std::move(quantized)), options_(options) {
    const uint64_t sh_per_gaussian = quantized_.count != 0 ? quantized_.sh.size() / quantized_.count : 0;
    const uint64_t per_archive = std::max<uint64_t>(1, quantized_.count * (kBatchBytesPerGaussian + sh_per_gaussian));
    batch_ = size_t(std::clamp<uint64_t>(kBatchBytes / per_archive, 1, parallel::available_cpus()));
    points_kept_ = size_t(std::clamp<uint64_t>(kPointsBytes / per_archive, 2, kMaxPointsKept));
  }

  /// Creates the renderers and renders the source on both view sets. On the CPU with several threads, each
  /// worker renders whole views on one thread: a lone frame does not keep several CPUs busy (its sort and
  /// allocations are serial; docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes),
  /// and the images do not depend on the thread count.
  Status start(std::vector<runtime::Camera> search_cameras, std::vector<runtime::Camera> cameras);

  /// File bytes besides the per-Gaussian sections: measured once by serializing the start's archive (its
  /// sections lent by its encoding).
  Status measure_overhead();

  /// Bytes of each archive (encoded when new).
  Result<std::vector<FitPoint>> bytes(const std::vector<format::ArchiveOptions>& list);

  /// Bytes and PSNR on the search views (final: on the cameras at their own size). An archive checked at the
  /// cameras' size before reads at most that check plus search_offset() on the search views: the
  /// two sizes differ by more for some knobs than for others, and a choice the check found below the target
  /// must not meet the search's target again.
  Result<std::vector<FitPoint>> measure(const std::vector<format::ArchiveOptions>& list, bool final = false);

  /// From now on, measure() keeps the archive of the highest mean PSNR on the search views among those of at most
  /// `bytes` (best_within).
  void watch_budget(uint64_t bytes);

  /// The bytes of the file that codes `o` at zstd level `zstd_level` (with `xz`: each code stream as the smaller of
  /// zstd and .xz), as FitPoint::bytes counts them; not cached.
  Result<uint64_t> file_bytes(format::ArchiveOptions o, int zstd_level, bool xz);
  const std::optional<FitPoint>& best_within() const { return best_within_; }

  /// The `count` archives of the highest mean PSNR on the search views among those measured of at most `bytes`,
  /// highest first.
  std::vector<FitPoint> best_within(uint64_t bytes, size_t count) const;

  /// An archive encoded with the points `o` codes for Draco (same_points), or null: what lends the file that
  /// writes `o` its means.
  std::shared_ptr<const format::ArchiveScene> archive_with_points(const format::ArchiveOptions& o) const;

  std::string device_name() const;

  /// How far the search's target lies above the target at the cameras' size (see measure).
  void set_search_offset(double db) { search_offset_ = db; }

  uint32_t encodings() const { return uint32_t(cache_.size()); }
  uint32_t renders() const { return renders_; }
  double encode_seconds() const { return encode_seconds_; }
  double render_seconds() const { return render_seconds_; }

 private:
  struct Entry {
    FitPoint point;  ///< bytes: the sections only
    double checked_db = kNaN, checked_min_db = kNaN;  ///< mean and lowest PSNR at the cameras' own size, once checked
    uint64_t sections = 0;
    std::shared_ptr<const format::ArchiveScene> archive;  ///< kept until it is rendered
  };

  /// Encodes `o`, taking the sections whose settings it shares with an archive encoded before (the search moves
  /// one knob at a time, so most candidates encode one section). That archive is the last one, unless it
  /// codes other points for Draco than `o` will (other position bits, or other opacity settings, which change
  /// the Gaussians left out) and one of the last archives with other points (points_) does not: then Draco, the
  /// slowest section, need not run again when the search comes back to points it coded before (each round
  /// steps the opacity and the position error from a point that differs from the last round's in another knob).
  Result<std::shared_ptr<const format::ArchiveScene>> encode_archive(const format::ArchiveOptions& o);

  /// Whether `a` codes the same points for Draco as options `o` will (the same position error and the same
  /// opacity settings, which decide the Gaussians left out).
  bool same_points(const std::shared_ptr<const format::ArchiveScene>& a, const format::ArchiveOptions& o) const;

  /// The archive encode_archive lends its sections to `o` (see encode_archive): the last one encoded (the first
  /// of points_), unless another of points_ has the points `o` will code and it does not.
  const format::ArchiveScene* lender(const format::ArchiveOptions& o) const;

  /// Makes `a` the last archive encoded: the first of points_, replacing the one with its points.
  std::shared_ptr<const format::ArchiveScene> keep_last(std::shared_ptr<const format::ArchiveScene> a);

  /// Encodes the archives of list[begin, end) not encoded before at the same time, one worker each, each free to
  /// code its sections on every CPU (a candidate whose points are new runs Draco on one thread first and codes
  /// its sections when the others are done), each lent sections by the archive encode_archive would lend it
  /// before the batch: the candidates of one step of the search differ from one another, not from the archive they
  /// step from. The bytes and decoded values do not depend on the workers or the lender (format::encode_archive).
  Status encode_batch(const std::vector<format::ArchiveOptions>& list, size_t begin, size_t end);

  Result<Entry*> encode(const format::ArchiveOptions& o);

  Entry* add_entry(const format::ArchiveOptions& o, std::shared_ptr<const format::ArchiveScene> archive);

  Result<api::Scene> load(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name);

  /// fn(renderer, v) for every view v of `cameras`, spread over the workers' renderers; the first error in view
  /// order. A failed allocation is kOutOfMemory naming the view and its size, not only the worker thread.
  template <typename Fn>
  Status for_views(const std::vector<runtime::Camera>& cameras, Fn&& fn) {
    std::vector<Status> results(cameras.size());
    RGS_RETURN_IF_ERROR(parallel::parallel_items(cameras.size(), unsigned(renderers_.size()), [&](unsigned w, uint64_t v) {
      try {
        results[v] = fn(renderers_[w], size_t(v));
      } catch (const std::bad_alloc&) {
        const runtime::Camera& cam = cameras[v];
        char image[32];
        std::snprintf(image, sizeof(image), "%.2f GB", double(cam.width) * cam.height * 3 * sizeof(float) / 1e9);
        results[v] = Status(StatusCode::kOutOfMemory, "out of memory rendering view " + cam.name + " at " +
                                                          std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                                          " (" + image + " for its RGB image alone)");
      }
    }));
    for (const Status& s : results) RGS_RETURN_IF_ERROR(s);
    return Status();
  }

  /// PSNR of `scene`'s render of view v of `set` against the source's: psnr_rgb on the host,
  /// runtime::GpuImageComparer on the device (the same PSNR but for the order of its float64 sums).
  Result<double> view_psnr(api::Renderer& renderer, const api::Scene& scene, const ViewSet& set, size_t v);

  /// A render's clamped-later RGB as [H, W, 3] floats on the host; the image itself into `kept` when not null.
  Result<std::vector<float>> render_rgb(api::Renderer& renderer, const api::Scene& scene, const runtime::Camera& cam,
                                        api::Image* kept = nullptr);

  /// Mean and lowest PSNR of the archive's renders against the source's on `set`; its decoded scene is
  /// freed (encoded again if it is rendered again).
  Result<std::pair<double, double>> render(Entry* e, const ViewSet& set);

  const format::GaussianCloud& source_;
  format::SceneBounds bounds_;
  format::EncodedScene quantized_;
  const FitOptions& options_;
  api::Device device_ = api::Device::kCpu;
  std::vector<api::Renderer> renderers_;  ///< one per worker (CPU), else one
  api::RenderSettings settings_;
#if RGS_HAS_CUDA
  runtime::GpuImageComparer comparer_;  ///< for the one GPU worker
#endif
  ViewSet search_, final_;
  std::map<Key, Entry> cache_;
  /// The last archives encoded with distinct Draco points, the last one encoded first (encode_archive), at most
  /// points_kept_ (set by the constructor).
  std::vector<std::shared_ptr<const format::ArchiveScene>> points_;
  size_t points_kept_ = 2;
  uint64_t overhead_ = 0;
  uint32_t renders_ = 0;
  size_t batch_ = 1;  ///< archives encoded at the same time (encode_batch)
  double encode_seconds_ = 0, render_seconds_ = 0;
  double search_offset_ = 0;
  std::optional<uint64_t> budget_;
  std::optional<FitPoint> best_within_;
};

}  // namespace rgs::api::detail
