// fit_archive(): the archive profile's settings for a PSNR target or a byte budget; convert_fitted(): the fit,
// then api::convert with its choice.
#include "rgs/audit/rate_control.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <tuple>
#include <utility>

#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/audit/image_metrics.h"
#include "rgs/audit/scene_views.h"
#include "rgs/config.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/file_io.h"
#include "rgs/format/writer.h"
#include "rgs/parallel/fork_join.h"

#if RGS_HAS_CUDA
#include "rgs/audit/gpu_image_metrics.h"
#endif

namespace rgs::audit {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The mean squared error (peak 1) of a PSNR in dB.
double mse_of(double psnr_db) { return std::pow(10.0, -psnr_db / 10); }

/// SH step multipliers the search moves between: steps of about 1.2x (1.6 dB of that band's error).
constexpr std::array<uint32_t, 24> kMultipliers = {1,  2,  3,  4,  5,  6,  7,  8,  10, 12, 14,  16,
                                                   20, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112, 127};
/// The code step knobs (ArchiveOptions::rotation_step, scale_step, opacity_step) move by quarter bits, up to 4
/// bits past the bits' own step: finer than a bit, and below the format's 4-bit minimum.
constexpr double kMaxCodeStep = 16;
/// The opacity floor (ArchiveOptions::opacity_floor) moves from 0 to 1/255, which leaves out only Gaussians that
/// never blend in the source (α ≤ opacity < 1/255), then by factors of √2 up to this: each step leaves out
/// Gaussians that can blend, the faintest first. Floors the opacity code 0 already covers are skipped.
constexpr double kMaxOpacityFloor = 32.0 / 255;
/// The fine scan of an SH multiplier tries at most this many integers above it.
constexpr uint32_t kFineMultipliers = 16;
/// Rounds of one-knob steps after the ladder, and of code steps at the end: bounds on the search's time.
constexpr int kMaxRounds = 10;
constexpr int kMaxFillRounds = 24;
constexpr uint32_t kMinBits = 4, kMaxBits = 16;
/// Archives encoded at the same time (Measurer::encode_batch): at most one per CPU, and as many as fit this much
/// memory when each is estimated at kBatchBytesPerGaussian bytes a Gaussian besides its SH codes (its decoded
/// arrays, stored sections, point order and the encoder's work arrays; an upper estimate, the peak RSS measured
/// with batches is in docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes).
constexpr uint64_t kBatchBytes = uint64_t{4} << 30;
constexpr uint64_t kBatchBytesPerGaussian = 100;
/// Archives kept for their Draco points (Measurer::encode_archive): as many as fit this much memory at the
/// estimate above, at least 2 and at most kMaxPointsKept.
constexpr uint64_t kPointsBytes = uint64_t{2} << 30;
constexpr uint64_t kMaxPointsKept = 8;
/// On the GPU the source's renders of both view sets stay on the device, where the candidates' renders are
/// compared with them, while they take at most this much (RGBA float32); beyond it they are kept on the host.
constexpr uint64_t kDeviceSourceBytes = uint64_t{4} << 30;
/// Position errors the search uses: 2^-kFinestPositionLog2 .. 2^-kCoarsestPositionLog2 of the extent.
constexpr int kFinestPositionLog2 = 25, kCoarsestPositionLog2 = 3;
/// The ladder's range: q = 0 is the defaults, each unit one bit (a factor 2) coarser on every knob.
constexpr double kLadderFinest = -8, kLadderCoarsest = 8;
/// How much above the target the final choice may be before the search is run again at an adjusted target.
constexpr double kMaxAboveDb = 0.5;
/// The scan of the SH multipliers and the code steps' stage spend only what the whole steps leave more than this
/// above the target.
constexpr double kMinSlackDb = 0.15;
/// Exchanges (Search::exchange_for_psnr): the pairs of steps measured in each, the most taken in one search, and
/// the share of the bytes an exchange must save for the search to look for another.
constexpr size_t kExchangePairs = 4;
constexpr int kMaxExchanges = 4;
constexpr double kExchangeMinSaving = 0.0025;
/// Searches (each checked at the cameras' own size) before the choice is settled.
constexpr int kMaxAttempts = 3;
/// kTargetBytes: the PSNR searches of its bisection over targets at most, and the width in dB at which it stops.
constexpr int kMaxBytesSearches = 10;
constexpr double kBytesTargetResolutionDb = 0.1;
/// kTargetBytes: the slope its search over targets assumes before it has measured one, dB per doubling of the bytes.
constexpr double kDbPerDoubling = 6;
/// kTargetBytes: the share of the budget a file may leave unused before the search runs again on a larger one.
constexpr double kBytesSlack = 0.005;
/// kTargetBytes: the archives of the highest search PSNR within the budget checked at the cameras' own size.
constexpr size_t kBytesFinalists = 3;
/// kTargetBytes's climb (fit_bytes): PSNR fits this far above its choice first, and at most this many.
constexpr double kBytesClimbDb = 0.25;
constexpr int kMaxBytesClimbs = 4;
/// The search target's margin over the measured difference between the search size and the cameras' size.
constexpr double kCalibrationMarginDb = 0.15;

/// The knobs the search moves, one at a time: kKnobs in the rounds, kCodeSteps in a kTargetPsnr search's last
/// stage (Search::fill_for_psnr).
enum class Knob {
  kRotation, kScale, kOpacity, kSh0, kSh1, kSh2, kSh3, kPosition, kOpacityFloor, kRotationStep, kScaleStep,
  kOpacityStep
};
constexpr std::array<Knob, 9> kKnobs = {Knob::kRotation, Knob::kScale, Knob::kOpacity,
                                        Knob::kSh0,      Knob::kSh1,   Knob::kSh2,
                                        Knob::kSh3,      Knob::kPosition, Knob::kOpacityFloor};
constexpr std::array<Knob, 3> kCodeSteps = {Knob::kRotationStep, Knob::kScaleStep, Knob::kOpacityStep};

uint32_t clamp_bits(double bits) { return uint32_t(std::clamp(std::lround(bits), long(kMinBits), long(kMaxBits))); }

double clamp_position(double error) {
  return std::clamp(error, std::ldexp(1.0, -kFinestPositionLog2), std::ldexp(1.0, -kCoarsestPositionLog2));
}

/// The ladder: every knob of `anchor` coarsened by `q` bits (q < 0: finer).
format::ArchiveOptions ladder(const format::ArchiveOptions& anchor, double q) {
  format::ArchiveOptions o = anchor;
  o.rotation_bits = clamp_bits(double(anchor.rotation_bits) - q);
  o.scale_bits = clamp_bits(double(anchor.scale_bits) - q);
  o.opacity_bits = clamp_bits(double(anchor.opacity_bits) - q);
  for (size_t d = 0; d < 4; ++d) {
    o.sh_step_multipliers[d] =
        uint32_t(std::clamp(std::lround(double(anchor.sh_step_multipliers[d]) * std::exp2(q)), 1L, 127L));
  }
  o.position_error = clamp_position(anchor.position_error * std::exp2(q));
  return o;
}

/// `o` with `knob` one step coarser (`coarser`) or finer; nullopt at the end of its range.
std::optional<format::ArchiveOptions> step(format::ArchiveOptions o, Knob knob, bool coarser) {
  auto move_bits = [&](uint32_t* bits) {
    const uint32_t next = coarser ? *bits - 1 : *bits + 1;
    if (next < kMinBits || next > kMaxBits) return false;
    *bits = next;
    return true;
  };
  auto move_step = [&](double* code_step) {  // quarter bits: 2^(k/4), k = 0 .. 4·log2(kMaxCodeStep)
    const long k = std::lround(4 * std::log2(*code_step)) + (coarser ? 1 : -1);
    if (k < 0 || k > std::lround(4 * std::log2(kMaxCodeStep))) return false;
    *code_step = std::exp2(double(k) / 4);
    return true;
  };
  auto move_multiplier = [&](uint32_t* m) {
    if (coarser) {
      auto it = std::upper_bound(kMultipliers.begin(), kMultipliers.end(), *m);
      if (it == kMultipliers.end()) return false;
      *m = *it;
    } else {
      auto it = std::lower_bound(kMultipliers.begin(), kMultipliers.end(), *m);
      if (it == kMultipliers.begin()) return false;
      *m = *(it - 1);
    }
    return true;
  };
  // The floor: 0, or 2^(k/2) / 255 for k = 0 .. 2·log2(255·kMaxOpacityFloor). A floor at or below the opacities
  // whose code is 0 (below half a code step) changes nothing, so a step skips those values, and one finer
  // than them goes to 0.
  auto move_floor = [&](double* floor) {
    const long last = std::lround(2 * std::log2(255 * kMaxOpacityFloor));
    const double code_zero = o.opacity_bits == 0 ? 0.0 : 0.5 * o.opacity_step / double((1u << o.opacity_bits) - 1);
    auto value = [](long k) { return std::exp2(double(k) / 2) / 255; };
    long k = *floor == 0 ? -1 : std::lround(2 * std::log2(255 * *floor));
    if (coarser) {
      do {
        ++k;
      } while (k <= last && value(k) <= code_zero);
      if (k > last) return false;
      *floor = value(k);
    } else {
      if (k < 0) return false;
      *floor = k == 0 || value(k - 1) <= code_zero ? 0.0 : value(k - 1);
    }
    return true;
  };
  bool moved = false;
  switch (knob) {
    case Knob::kRotation: moved = move_bits(&o.rotation_bits); break;
    case Knob::kScale: moved = move_bits(&o.scale_bits); break;
    case Knob::kScaleStep: moved = move_step(&o.scale_step); break;
    case Knob::kOpacity: moved = move_bits(&o.opacity_bits); break;
    case Knob::kRotationStep: moved = move_step(&o.rotation_step); break;
    case Knob::kOpacityStep: moved = move_step(&o.opacity_step); break;
    case Knob::kOpacityFloor: moved = move_floor(&o.opacity_floor); break;
    case Knob::kSh0: moved = move_multiplier(&o.sh_step_multipliers[0]); break;
    case Knob::kSh1: moved = move_multiplier(&o.sh_step_multipliers[1]); break;
    case Knob::kSh2: moved = move_multiplier(&o.sh_step_multipliers[2]); break;
    case Knob::kSh3: moved = move_multiplier(&o.sh_step_multipliers[3]); break;
    case Knob::kPosition: {
      const double next = clamp_position(coarser ? o.position_error * 2 : o.position_error / 2);
      moved = next != o.position_error;
      o.position_error = next;
      break;
    }
  }
  if (!moved) return std::nullopt;
  return o;
}

using Key =
    std::tuple<uint32_t, double, uint32_t, double, uint32_t, double, double, std::array<uint32_t, 4>, double>;
Key key_of(const format::ArchiveOptions& o) {
  return {o.rotation_bits, o.rotation_step, o.scale_bits,    o.scale_step,          o.opacity_bits,
          o.opacity_step,  o.opacity_floor, o.sh_step_multipliers, o.position_error};
}

/// One set of views with the source's renders, rendered once: [H, W, 3] float RGB on the host, or on the GPU
/// (kDeviceSourceBytes) the RGBA32F images where it rendered them.
struct ViewSet {
  std::vector<runtime::Camera> cameras;
  std::vector<std::vector<float>> source;
  std::vector<api::Image> source_images;
};

/// Measures archives of one quantized scene: bytes by encoding, PSNR by rendering against the source's renders
/// (run_audit's renderer settings and PSNR: the faithful preset, black background, the whole frame's PSNR, on
/// the device with the GPU). Every archive is encoded once and rendered at most once on the search views (cached
/// by its options).
class Measurer {
 public:
  Measurer(const AuditScene& source, format::EncodedScene quantized, const FitOptions& options)
      : source_(source), quantized_(std::move(quantized)), options_(options) {
    const uint64_t sh_per_gaussian = quantized_.count != 0 ? quantized_.sh.size() / quantized_.count : 0;
    const uint64_t per_archive = std::max<uint64_t>(1, quantized_.count * (kBatchBytesPerGaussian + sh_per_gaussian));
    batch_ = size_t(std::clamp<uint64_t>(kBatchBytes / per_archive, 1, parallel::available_cpus()));
    points_kept_ = size_t(std::clamp<uint64_t>(kPointsBytes / per_archive, 2, kMaxPointsKept));
  }

  /// Creates the renderers and renders the source on both view sets. On the CPU with several threads, each
  /// worker renders whole views on one thread: a lone frame does not keep several CPUs busy (its sort and
  /// allocations are serial; docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes),
  /// and the images do not depend on the thread count.
  Status start(std::vector<runtime::Camera> search_cameras, std::vector<runtime::Camera> cameras) {
    device_ = options_.audit.backend == Backend::kCuda ? api::Device::kCuda : api::Device::kCpu;
    const unsigned workers = device_ == api::Device::kCpu ? parallel::thread_count(options_.audit.cpu_threads) : 1;
    for (unsigned w = 0; w < workers; ++w) {
      RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(device_, options_.audit.cuda_device));
      renderers_.push_back(std::move(renderer));
    }
    settings_.preset = api::Preset::kFaithful;
    settings_.cpu_threads = workers > 1 ? 1 : options_.audit.cpu_threads;
    search_.cameras = std::move(search_cameras);
    final_.cameras = std::move(cameras);
    RGS_ASSIGN_OR_RETURN(api::Scene scene, load(source_.cloud, source_.bounds, "source"));
    uint64_t source_bytes = 0;
    for (const ViewSet* set : {&search_, &final_}) {
      for (const runtime::Camera& cam : set->cameras) source_bytes += uint64_t{cam.width} * cam.height * 16;
    }
    for (ViewSet* set : {&search_, &final_}) {
      if (device_ == api::Device::kCuda && source_bytes <= kDeviceSourceBytes) {
        for (const runtime::Camera& cam : set->cameras) {
          auto image = renderers_[0].render_image(scene, cam, settings_);
          if (!image.ok()) return Status(image.status()).prepend("source, view " + cam.name);
          set->source_images.push_back(std::move(image).value());
        }
        continue;
      }
      set->source.resize(set->cameras.size());
      RGS_RETURN_IF_ERROR(for_views(set->cameras, [&](api::Renderer& renderer, size_t v) -> Status {
        RGS_ASSIGN_OR_RETURN(set->source[v], render_rgb(renderer, scene, set->cameras[v]));
        return Status();
      }));
    }
    return Status();
  }

  /// File bytes besides the per-Gaussian sections: measured once by serializing the start's archive (its
  /// sections lent by its encoding).
  Status measure_overhead() {
    format::WriteOptions write;
    write.profile = format::StorageProfile::kArchive;
    write.archive = options_.start;
    RGS_ASSIGN_OR_RETURN(const Entry* e, encode(write.archive));
    write.archive_earlier = e->archive.get();
    RGS_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, format::serialize_scene(quantized_, write));
    overhead_ = bytes.size() - e->sections + options_.provenance_bytes;
    return Status();
  }

  /// Bytes of each archive (encoded when new).
  Result<std::vector<FitPoint>> bytes(const std::vector<format::ArchiveOptions>& list) {
    std::vector<FitPoint> out;
    for (size_t i = 0; i < list.size(); ++i) {
      if (i % batch_ == 0) RGS_RETURN_IF_ERROR(encode_batch(list, i, std::min(list.size(), i + batch_)));
      RGS_ASSIGN_OR_RETURN(const Entry* e, encode(list[i]));
      out.push_back(e->point);
      out.back().bytes += overhead_;
    }
    return out;
  }

  /// Bytes and PSNR on the search views (final: on the cameras at their own size, never cached). An archive
  /// checked at the cameras' size before reads at most that check plus search_offset() on the search views: the
  /// two sizes differ by more for some knobs than for others, and a choice the check found below the target
  /// must not meet the search's target again.
  Result<std::vector<FitPoint>> measure(const std::vector<format::ArchiveOptions>& list, bool final = false) {
    std::vector<FitPoint> out;
    for (size_t i = 0; i < list.size(); ++i) {
      if (i % batch_ == 0) RGS_RETURN_IF_ERROR(encode_batch(list, i, std::min(list.size(), i + batch_)));
      const format::ArchiveOptions& o = list[i];
      RGS_ASSIGN_OR_RETURN(Entry * e, encode(o));
      FitPoint p = e->point;
      if (final || std::isnan(p.psnr_mean_db)) {
        RGS_ASSIGN_OR_RETURN(const auto psnr, render(e, final ? final_ : search_));
        p.psnr_mean_db = psnr.first;
        p.psnr_min_db = psnr.second;
        if (!final) e->point = p;
      }
      if (final) {
        e->checked_db = p.psnr_mean_db;
      } else if (!std::isnan(e->checked_db)) {
        p.psnr_mean_db = std::min(p.psnr_mean_db, e->checked_db + search_offset_);
      }
      p.bytes += overhead_;
      if (!final && budget_ && p.bytes <= *budget_ && (!best_within_ || p.psnr_mean_db > best_within_->psnr_mean_db)) {
        best_within_ = p;
      }
      out.push_back(p);
    }
    return out;
  }

  /// From now on, measure() keeps the archive of the highest mean PSNR on the search views among those of at most
  /// `bytes` (best_within).
  void watch_budget(uint64_t bytes) {
    budget_ = bytes;
    best_within_.reset();
    for (const auto& [key, e] : cache_) {
      FitPoint p = e.point;
      p.bytes += overhead_;
      if (p.bytes <= bytes && std::isfinite(p.psnr_mean_db) &&
          (!best_within_ || p.psnr_mean_db > best_within_->psnr_mean_db)) {
        best_within_ = p;
      }
    }
  }

  /// The bytes of the file that codes `o` at zstd level `zstd_level` (with `xz`: each code stream as the smaller of
  /// zstd and .xz), as FitPoint::bytes counts them; not cached.
  Result<uint64_t> file_bytes(format::ArchiveOptions o, int zstd_level, bool xz) {
    o.zstd_level = zstd_level;
    o.xz = xz;
    const auto start = Clock::now();
    RGS_ASSIGN_OR_RETURN(const format::ArchiveScene archive, format::encode_archive(quantized_, o, lender(o)));
    encode_seconds_ += seconds_since(start);
    uint64_t sections = 0;
    for (const std::vector<uint8_t>& s : archive.stored) sections += s.size();
    return sections + overhead_;
  }
  const std::optional<FitPoint>& best_within() const { return best_within_; }

  /// The `count` archives of the highest mean PSNR on the search views among those measured of at most `bytes`,
  /// highest first.
  std::vector<FitPoint> best_within(uint64_t bytes, size_t count) const {
    std::vector<FitPoint> out;
    for (const auto& [key, e] : cache_) {
      FitPoint p = e.point;
      p.bytes += overhead_;
      if (p.bytes <= bytes && std::isfinite(p.psnr_mean_db)) out.push_back(p);
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const FitPoint& a, const FitPoint& b) { return a.psnr_mean_db > b.psnr_mean_db; });
    if (out.size() > count) out.resize(count);
    return out;
  }

  /// An archive encoded with the points `o` codes for Draco (same_points), or null: what lends the file that
  /// writes `o` its means.
  std::shared_ptr<const format::ArchiveScene> archive_with_points(const format::ArchiveOptions& o) const {
    for (const auto& a : points_) {
      if (same_points(a, o)) return a;
    }
    return nullptr;
  }

  std::string device_name() const {
    if (device_ == api::Device::kCpu) return "CPU reference renderer";
    return "CUDA device " + std::to_string(options_.audit.cuda_device);
  }

  /// How far the search's target lies above the target at the cameras' size (see measure).
  void set_search_offset(double db) { search_offset_ = db; }

  uint32_t encodings() const { return uint32_t(cache_.size()); }
  uint32_t renders() const { return renders_; }
  double encode_seconds() const { return encode_seconds_; }
  double render_seconds() const { return render_seconds_; }

 private:
  struct Entry {
    FitPoint point;  ///< bytes: the sections only
    double checked_db = kNaN;  ///< mean PSNR at the cameras' own size, once checked
    uint64_t sections = 0;
    std::shared_ptr<const format::ArchiveScene> archive;  ///< kept until it is rendered
  };

  /// Encodes `o`, taking the sections whose settings it shares with an archive encoded before (the search moves
  /// one knob at a time, so most candidates encode one section). That archive is the last one, unless it
  /// codes other points for Draco than `o` will (other position bits, or other opacity settings, which change
  /// the Gaussians left out) and one of the last archives with other points (points_) does not: then Draco, the
  /// slowest section, need not run again when the search comes back to points it coded before (each round
  /// steps the opacity and the position error from a point that differs from the last round's in another knob).
  Result<std::shared_ptr<const format::ArchiveScene>> encode_archive(const format::ArchiveOptions& o) {
    const auto start = Clock::now();
    RGS_ASSIGN_OR_RETURN(format::ArchiveScene archive, format::encode_archive(quantized_, o, lender(o)));
    encode_seconds_ += seconds_since(start);
    return keep_last(std::make_shared<const format::ArchiveScene>(std::move(archive)));
  }

  /// Whether `a` codes the same points for Draco as options `o` will (the same position error and the same
  /// opacity settings, which decide the Gaussians left out).
  bool same_points(const std::shared_ptr<const format::ArchiveScene>& a, const format::ArchiveOptions& o) const {
    const format::ArchiveOptions want = format::resolve_archive_options(o, quantized_.count);
    return a && a->options.position_error == want.position_error && a->options.draco_speed == want.draco_speed &&
           a->options.opacity_bits == want.opacity_bits && a->options.opacity_step == want.opacity_step &&
           a->options.opacity_floor == want.opacity_floor;
  }

  /// The archive encode_archive lends its sections to `o` (see encode_archive): the last one encoded (the first
  /// of points_), unless another of points_ has the points `o` will code and it does not.
  const format::ArchiveScene* lender(const format::ArchiveOptions& o) const {
    if (const auto a = archive_with_points(o)) return a.get();
    return points_.empty() ? nullptr : points_.front().get();
  }

  /// Makes `a` the last archive encoded: the first of points_, replacing the one with its points.
  std::shared_ptr<const format::ArchiveScene> keep_last(std::shared_ptr<const format::ArchiveScene> a) {
    const auto same =
        std::find_if(points_.begin(), points_.end(), [&](const auto& p) { return same_points(p, a->options); });
    if (same != points_.end()) points_.erase(same);
    points_.insert(points_.begin(), a);
    if (points_.size() > points_kept_) points_.pop_back();
    return a;
  }

  /// Encodes the archives of list[begin, end) not encoded before at the same time, one worker each, each free to
  /// code its sections on every CPU (a candidate whose points are new runs Draco on one thread first and codes
  /// its sections when the others are done), each lent sections by the archive encode_archive would lend it
  /// before the batch: the candidates of one step of the search differ from one another, not from the archive they
  /// step from. The bytes and decoded values do not depend on the workers or the lender (format::encode_archive).
  Status encode_batch(const std::vector<format::ArchiveOptions>& list, size_t begin, size_t end) {
    std::vector<format::ArchiveOptions> todo;
    std::vector<Key> keys;
    for (size_t i = begin; i < end; ++i) {
      const Key k = key_of(list[i]);
      if (cache_.count(k) != 0 || std::find(keys.begin(), keys.end(), k) != keys.end()) continue;
      keys.push_back(k);
      todo.push_back(list[i]);
    }
    if (todo.size() < 2) return Status();  // encode() codes a lone archive with all its threads
    const unsigned cpus = parallel::available_cpus();
    std::vector<const format::ArchiveScene*> lenders;
    for (format::ArchiveOptions& o : todo) {
      lenders.push_back(lender(o));
      o.threads = cpus;
    }
    std::vector<std::optional<format::ArchiveScene>> archives(todo.size());
    std::vector<Status> results(todo.size());
    const auto start = Clock::now();
    RGS_RETURN_IF_ERROR(parallel::parallel_items(todo.size(), cpus, [&](unsigned, uint64_t i) {
      auto a = format::encode_archive(quantized_, todo[i], lenders[i]);
      if (a.ok()) {
        archives[i] = std::move(a).value();
      } else {
        results[i] = a.status();
      }
    }));
    encode_seconds_ += seconds_since(start);
    for (size_t i = 0; i < todo.size(); ++i) {
      RGS_RETURN_IF_ERROR(results[i]);
      todo[i].threads = options_.start.threads;
      add_entry(todo[i], keep_last(std::make_shared<const format::ArchiveScene>(std::move(*archives[i]))));
    }
    return Status();
  }

  Result<Entry*> encode(const format::ArchiveOptions& o) {
    auto it = cache_.find(key_of(o));
    if (it != cache_.end()) return &it->second;
    RGS_ASSIGN_OR_RETURN(std::shared_ptr<const format::ArchiveScene> archive, encode_archive(o));
    return add_entry(o, std::move(archive));
  }

  Entry* add_entry(const format::ArchiveOptions& o, std::shared_ptr<const format::ArchiveScene> archive) {
    Entry e;
    e.archive = std::move(archive);
    e.point.options = o;
    for (const std::vector<uint8_t>& s : e.archive->stored) e.sections += s.size();
    e.point.bytes = e.sections;
    e.point.psnr_mean_db = e.point.psnr_min_db = kNaN;
    return &cache_.emplace(key_of(o), std::move(e)).first->second;
  }

  Result<api::Scene> load(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name) {
    api::LoadOptions load;
    load.device = device_;
    load.cuda_device = options_.audit.cuda_device;
    return api::load_cloud(std::move(cloud), bounds, name, load);
  }

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

  /// PSNR of `scene`'s render of view v of `set` against the source's: psnr_rgb on the host, the audit's
  /// GpuImageComparer on the device (the same PSNR but for the order of its float64 sums).
  Result<double> view_psnr(api::Renderer& renderer, const api::Scene& scene, const ViewSet& set, size_t v) {
    const runtime::Camera& cam = set.cameras[v];
#if RGS_HAS_CUDA
    if (!set.source_images.empty()) {
      auto image = renderer.render_image(scene, cam, settings_);
      if (!image.ok()) return Status(image.status()).prepend(scene.info().path + ", view " + cam.name);
      auto metrics = comparer_.compare(static_cast<const float*>(set.source_images[v].color()),
                                       static_cast<const float*>(image->color()), cam.width, cam.height, 4);
      if (!metrics.ok()) return Status(metrics.status()).prepend(scene.info().path + ", view " + cam.name);
      return metrics->psnr_db;
    }
#endif
    RGS_ASSIGN_OR_RETURN(const std::vector<float> rgb, render_rgb(renderer, scene, cam));
    return psnr_rgb(set.source[v], rgb, cam.width, cam.height);
  }

  /// A render's clamped-later RGB as [H, W, 3] floats on the host.
  Result<std::vector<float>> render_rgb(api::Renderer& renderer, const api::Scene& scene, const runtime::Camera& cam) {
    auto image = renderer.render_image(scene, cam, settings_);
    if (!image.ok()) return Status(image.status()).prepend(scene.info().path + ", view " + cam.name);
    const size_t pixels = size_t(cam.width) * cam.height;
    const float* rgba = static_cast<const float*>(image->color());
    std::vector<float> host;
    if (image->device() != api::Device::kCpu) {
      host.resize(pixels * 4);
      RGS_RETURN_IF_ERROR(image->copy_to_host(host.data(), nullptr));
      rgba = host.data();
    }
    std::vector<float> rgb(pixels * 3);
    for (size_t i = 0; i < pixels; ++i) std::copy_n(rgba + 4 * i, 3, rgb.data() + 3 * i);
    return rgb;
  }

  /// Mean and lowest PSNR of the archive's renders against the source's on `set`; its decoded scene is
  /// freed (encoded again if it is rendered again).
  Result<std::pair<double, double>> render(Entry* e, const ViewSet& set) {
    if (!e->archive) {
      RGS_ASSIGN_OR_RETURN(e->archive, encode_archive(e->point.options));
    }
    const auto start = Clock::now();
    const format::EncodedScene& decoded = e->archive->decoded;
    RGS_ASSIGN_OR_RETURN(format::GaussianCloud cloud, format::dequantize(decoded));
    const std::string name = "archive (" + describe_archive_options(e->point.options, decoded.metadata.sh_degree) + ")";
    const format::SceneBounds bounds = decoded.metadata.bounds;
    e->archive.reset();
    RGS_ASSIGN_OR_RETURN(api::Scene scene, load(std::move(cloud), bounds, name));
    std::vector<double> psnr(set.cameras.size());
    RGS_RETURN_IF_ERROR(for_views(set.cameras, [&](api::Renderer& renderer, size_t v) -> Status {
      RGS_ASSIGN_OR_RETURN(psnr[v], view_psnr(renderer, scene, set, v));
      return Status();
    }));
    double sum = 0, lowest = std::numeric_limits<double>::infinity();
    for (double p : psnr) {
      sum += p;
      lowest = std::min(lowest, p);
    }
    ++renders_;
    render_seconds_ += seconds_since(start);
    return std::pair{sum / double(set.cameras.size()), lowest};
  }

  const AuditScene& source_;
  format::EncodedScene quantized_;
  const FitOptions& options_;
  api::Device device_ = api::Device::kCpu;
  std::vector<api::Renderer> renderers_;  ///< one per worker (CPU), else one
  api::RenderSettings settings_;
#if RGS_HAS_CUDA
  GpuImageComparer comparer_;  ///< for the one GPU worker
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

std::string group_digits(uint64_t n) {
  std::string s = std::to_string(n);
  for (int i = int(s.size()) - 3; i > 0; i -= 3) s.insert(size_t(i), ",");
  return s;
}

std::string db_text(double db) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f dB", db);
  return text;
}

/// The knobs the rounds move for a scene of SH degree `sh_degree`.
std::vector<Knob> knobs_for(uint32_t sh_degree) {
  std::vector<Knob> out;
  for (Knob k : kKnobs) {
    const int band = int(k) - int(Knob::kSh0);
    if (band >= 0 && band <= 3 && uint32_t(band) > sh_degree) continue;
    out.push_back(k);
  }
  return out;
}

class Search {
 public:
  Search(Measurer& m, const FitOptions& options, uint32_t sh_degree, format::ArchiveOptions anchor)
      : m_(m),
        options_(options),
        knobs_(knobs_for(sh_degree)),
        anchor_(std::move(anchor)),
        sh_degree_(sh_degree) {}

  void report(const std::string& what) {
    if (options_.progress) options_.progress(what);
  }

  /// kTargetPsnr at the search size: the path of accepted archives, finest first, each meeting `target`. It
  /// starts from the last step of `previous` (an earlier search's path) that meets `target`, else from the
  /// ladder.
  Result<std::vector<FitPoint>> for_psnr(double target, const std::vector<FitPoint>& previous = {}) {
    std::vector<FitPoint> path;
    // Measured again (cached): a step checked at the cameras' size since reads as measure() says.
    std::vector<format::ArchiveOptions> steps;
    for (const FitPoint& p : previous) steps.push_back(p.options);
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> now, m_.measure(steps));
    for (const FitPoint& p : now) {
      if (p.psnr_mean_db >= target) path = {p};
    }
    if (path.empty()) {
      RGS_ASSIGN_OR_RETURN(FitPoint pass, ladder_for_psnr(target));
      path = {pass};
    }
    RGS_RETURN_IF_ERROR(refine_for_psnr(target, &path));
    RGS_RETURN_IF_ERROR(scan_multipliers_for_psnr(target, &path));
    for (int exchange = 0; exchange < kMaxExchanges; ++exchange) {
      const uint64_t before = path.back().bytes;
      RGS_ASSIGN_OR_RETURN(const bool exchanged, exchange_for_psnr(target, &path));
      if (!exchanged) break;
      RGS_RETURN_IF_ERROR(refine_for_psnr(target, &path));
      if (double(path.back().bytes) > double(before) * (1 - kExchangeMinSaving)) break;
    }
    RGS_RETURN_IF_ERROR(fill_for_psnr(target, &path));
    return path;
  }

  /// kTargetPsnr's ladder: the coarsest point of the ladder that meets `target`, bracketed to a quarter bit.
  Result<FitPoint> ladder_for_psnr(double target) {
    // The ladder: bracket the largest q that meets the target, halving the bracket with three points a batch.
    std::vector<double> qs = {-4, -2, 0, 2, 4};
    double q_pass = std::numeric_limits<double>::quiet_NaN(), q_fail = kLadderCoarsest + 1;
    std::optional<FitPoint> pass;
    for (int round = 0; round < 6; ++round) {
      std::vector<format::ArchiveOptions> list;
      for (double q : qs) list.push_back(ladder(anchor_, q));
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
      for (size_t i = 0; i < qs.size(); ++i) {
        note_finest(points[i]);
        if (points[i].psnr_mean_db >= target) {
          if (std::isnan(q_pass) || qs[i] > q_pass) {
            q_pass = qs[i];
            pass = points[i];
          }
        } else {
          q_fail = std::min(q_fail, qs[i]);
        }
      }
      report_progress("ladder", pass);
      if (std::isnan(q_pass)) {
        if (round > 0) break;
        qs = {kLadderFinest};  // nothing met the target: the finest archive decides whether any can
        continue;
      }
      if (q_fail > kLadderCoarsest) {  // nothing measured failed: coarser steps, up to the coarsest
        if (q_pass >= kLadderCoarsest) break;
        qs = {std::min(q_pass + 1, kLadderCoarsest), std::min(q_pass + 2, kLadderCoarsest), kLadderCoarsest};
        qs.erase(std::unique(qs.begin(), qs.end()), qs.end());
        continue;
      }
      const double width = q_fail - q_pass;
      if (width <= 0.25) break;
      qs = {q_pass + width / 4, q_pass + width / 2, q_pass + 3 * width / 4};
    }
    if (!pass) {
      return Status(StatusCode::kInvalidArgument,
                    "target " + db_text(target) + " is above what the archive profile reaches on these views: " +
                        db_text(finest_->psnr_mean_db) + " at the finest settings (" +
                        describe_archive_options(finest_->options, sh_degree_) + ")");
    }
    return *pass;
  }

  /// kTargetPsnr's refinement from path->back(): each round moves every knob one step coarser on its own; the
  /// steps that still meet `target` are taken together, best bytes saved per unit of squared error first,
  /// while the sum of their error increments (errors of different knobs add, roughly) stays within what the
  /// target allows; the combination is measured and kept when it meets the target, else the best single step.
  Status refine_for_psnr(double target, std::vector<FitPoint>* path) {
    const double allowed_mse = mse_of(target);
    std::vector<bool> frozen(knobs_.size(), false);
    for (int round = 0; round < kMaxRounds; ++round) {
      const FitPoint at = path->back();
      std::vector<format::ArchiveOptions> list;
      std::vector<size_t> knob_of;
      next_steps(knobs_, at.options, true, &frozen, &list, &knob_of);
      if (list.empty()) break;
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
      const std::vector<Move> moves = passing_moves(at, points, knob_of, target, &frozen);
      if (moves.empty()) break;
      FitPoint next = points[moves[0].index];
      format::ArchiveOptions together = at.options;
      double predicted = mse_of(at.psnr_mean_db);
      size_t taken = 0;
      for (const Move& mv : moves) {
        if (predicted + mv.added_mse > allowed_mse) continue;
        together = *step(together, knobs_[knob_of[mv.index]], true);
        predicted += mv.added_mse;
        ++taken;
      }
      if (taken > 1) {
        RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> combined, m_.measure({together}));
        if (combined[0].psnr_mean_db >= target && combined[0].bytes < next.bytes) next = combined[0];
      }
      path->push_back(next);
      report_progress("refining", path->back());
    }
    return Status();
  }

  /// kTargetPsnr's scan of each SH step multiplier's integers, while path->back() is more than
  /// kMinSlackDb above `target`: the integers between the multiplier and the second ladder value above it
  /// (at most kFineMultipliers). Where the source's colours already lie on a grid of their own (a scene that was
  /// 8-bit before it was a PLY), the error of a step depends on how it lines up with that grid, not only on its
  /// size, so a multiplier between two ladder values can be both smaller and closer to the target than either.
  /// The smallest archive that meets `target` is kept when it is smaller than path->back().
  Status scan_multipliers_for_psnr(double target, std::vector<FitPoint>* path) {
    for (Knob knob : knobs_) {
      if (knob < Knob::kSh0 || knob > Knob::kSh3) continue;
      const FitPoint at = path->back();
      if (!(at.psnr_mean_db > target + kMinSlackDb)) break;
      const size_t degree = size_t(int(knob) - int(Knob::kSh0));
      const uint32_t m = at.options.sh_step_multipliers[degree];
      auto next = std::upper_bound(kMultipliers.begin(), kMultipliers.end(), m);
      const uint32_t end = next == kMultipliers.end() || next + 1 == kMultipliers.end() ? 128 : *(next + 1);
      std::vector<format::ArchiveOptions> list;
      for (uint32_t v = m + 1; v < end && list.size() < kFineMultipliers; ++v) {
        format::ArchiveOptions o = at.options;
        o.sh_step_multipliers[degree] = v;
        list.push_back(o);
      }
      // Bytes first: only the archives smaller than `at` are rendered.
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> sizes, m_.bytes(list));
      std::vector<format::ArchiveOptions> smaller;
      for (size_t i = 0; i < sizes.size(); ++i) {
        if (sizes[i].bytes < at.bytes) smaller.push_back(list[i]);
      }
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(smaller));
      std::optional<FitPoint> best;
      for (const FitPoint& p : points) {
        if (p.psnr_mean_db >= target && (!best || p.bytes < best->bytes)) best = p;
      }
      if (best) {
        path->push_back(*best);
        report_progress("scanning", path->back());
      }
    }
    return Status();
  }

  /// kTargetPsnr's exchange between knobs, after the rounds, where no knob can go one step coarser on its own: the
  /// knobs differ in bytes per squared error, so one step coarser with another step finer can meet `target` in
  /// fewer bytes (a greedy path through the knobs ends off the rate-distortion curve otherwise). Every knob one step
  /// coarser and one step finer, and every SH multiplier one step finer together, are measured at path->back() (the
  /// coarser steps are the last round's, measured before); squared errors and bytes of two steps roughly add, so
  /// the kExchangePairs pairs of a coarser and a finer step of two knobs predicted smallest among those predicted to
  /// meet `target` are measured together. The smallest that meets it, if smaller than path->back(), is taken
  /// (returns true).
  Result<bool> exchange_for_psnr(double target, std::vector<FitPoint>* path) {
    const FitPoint at = path->back();
    struct Single {
      format::ArchiveOptions options;
      size_t knob;  ///< index in knobs_; knobs_.size() for every SH multiplier together
    };
    std::vector<Single> coarser, finer;
    for (size_t k = 0; k < knobs_.size(); ++k) {
      if (auto o = step(at.options, knobs_[k], true)) coarser.push_back({*o, k});
      if (auto o = step(at.options, knobs_[k], false)) finer.push_back({*o, k});
    }
    if (sh_degree_ > 0) {
      format::ArchiveOptions o = at.options;
      bool moved = false;
      for (Knob knob : knobs_) {
        if (knob < Knob::kSh0 || knob > Knob::kSh3) continue;
        if (auto next = step(o, knob, false)) o = *next, moved = true;
      }
      if (moved) finer.push_back({o, knobs_.size()});
    }
    std::vector<format::ArchiveOptions> list;
    for (const auto* singles : {&coarser, &finer}) {
      for (const Single& one : *singles) list.push_back(one.options);
    }
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
    const double mse_at = mse_of(at.psnr_mean_db), allowed_mse = mse_of(target);
    struct Pair {
      double bytes;
      format::ArchiveOptions options;
    };
    std::vector<Pair> pairs;
    for (size_t c = 0; c < coarser.size(); ++c) {
      const FitPoint& pc = points[c];
      const bool sh_knob = knobs_[coarser[c].knob] >= Knob::kSh0 && knobs_[coarser[c].knob] <= Knob::kSh3;
      for (size_t f = 0; f < finer.size(); ++f) {
        const FitPoint& pf = points[coarser.size() + f];
        const size_t fk = finer[f].knob;
        if (fk == coarser[c].knob || (fk == knobs_.size() && sh_knob)) continue;
        const double mse = mse_of(pc.psnr_mean_db) + mse_of(pf.psnr_mean_db) - mse_at;
        const double bytes = double(pc.bytes) + double(pf.bytes) - double(at.bytes);
        if (!(mse <= allowed_mse) || !(bytes < double(at.bytes))) continue;
        std::optional<format::ArchiveOptions> o = pc.options;
        if (fk == knobs_.size()) {
          o->sh_step_multipliers = pf.options.sh_step_multipliers;
        } else {
          o = step(*o, knobs_[fk], false);
        }
        if (o) pairs.push_back({bytes, *o});
      }
    }
    std::stable_sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.bytes < b.bytes; });
    list.clear();
    for (const Pair& pair : pairs) {
      if (list.size() == kExchangePairs) break;
      if (std::none_of(list.begin(), list.end(), [&](const auto& o) { return key_of(o) == key_of(pair.options); })) {
        list.push_back(pair.options);
      }
    }
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> measured, m_.measure(list));
    std::optional<FitPoint> best;
    for (const FitPoint& p : measured) {
      if (p.psnr_mean_db >= target && p.bytes < at.bytes && (!best || p.bytes < best->bytes)) best = p;
    }
    if (!best) return false;
    path->push_back(*best);
    report_progress("exchanging", path->back());
    return true;
  }

  /// kTargetPsnr's last stage, while path->back() is more than kMinSlackDb above `target`: the code steps of
  /// rotations, scales and opacities, a quarter bit coarser at a time (finer than the bits, and below their
  /// 4-bit minimum), the step with the most bytes saved per squared error added that still meets `target` each
  /// round. It only spends what the knobs of whole steps leave above the target, so it never ends larger.
  Status fill_for_psnr(double target, std::vector<FitPoint>* path) {
    const std::vector<Knob> steps(kCodeSteps.begin(), kCodeSteps.end());
    std::vector<bool> frozen(steps.size(), false);
    for (int round = 0; round < kMaxFillRounds; ++round) {
      const FitPoint at = path->back();
      if (!(at.psnr_mean_db > target + kMinSlackDb)) break;
      std::vector<format::ArchiveOptions> list;
      std::vector<size_t> knob_of;
      next_steps(steps, at.options, true, &frozen, &list, &knob_of);
      if (list.empty()) break;
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(list));
      const std::vector<Move> moves = passing_moves(at, points, knob_of, target, &frozen);
      if (moves.empty()) break;
      path->push_back(points[moves[0].index]);
      report_progress("filling", path->back());
    }
    return Status();
  }

  /// kTargetBytes at the search size: the archive of the highest mean PSNR within `budget` among every archive
  /// the search measured (Measurer::watch_budget). The searches are kTargetPsnr's (for_psnr), over the same
  /// knobs and with the same rounds, scans, exchanges and code steps, so that no PSNR search finds a file of at
  /// most these bytes that reads higher on these views: from the ladder's point that fits the budget, a search
  /// over PSNR targets (secant steps in log bytes, bracketed) for the highest target whose search ends within it
  /// (at most kMaxBytesSearches searches, to kBytesTargetResolutionDb; the searches of earlier budgets count). Then the finer steps of one knob at a time that still fit spend
  /// what the budget leaves, the step with the most dB gained per byte added each round.
  Result<FitPoint> for_bytes(uint64_t budget) {
    m_.watch_budget(budget);
    // The ladder by bytes alone (no renders): bisect the finest q whose file fits.
    double lo = kLadderFinest, hi = kLadderCoarsest;  // invariant: hi fits (checked), lo does not (or untested)
    // The smallest archive the searches make: the ladder's coarsest with the coarsest opacity floor and code steps
    // (knobs the ladder leaves alone, which the PSNR searches move).
    format::ArchiveOptions smallest_options = ladder(anchor_, hi);
    smallest_options.opacity_floor = kMaxOpacityFloor;
    smallest_options.rotation_step = smallest_options.scale_step = smallest_options.opacity_step = kMaxCodeStep;
    RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> coarsest, m_.bytes({ladder(anchor_, hi), smallest_options}));
    if (coarsest[1].bytes > budget) {
      return Status(StatusCode::kInvalidArgument,
                    group_digits(budget) + " bytes is below the smallest archive the search makes: " +
                        group_digits(coarsest[1].bytes) + " bytes at the coarsest settings (" +
                        describe_archive_options(coarsest[1].options, sh_degree_) + ")");
    }
    FitPoint fit = coarsest[0].bytes <= budget ? coarsest[0] : coarsest[1];
    RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> finest, m_.bytes({ladder(anchor_, lo)}));
    if (finest[0].bytes <= budget) {
      fit = finest[0];
      hi = lo;
    }
    while (coarsest[0].bytes <= budget && hi - lo > 0.125) {
      const double mid = (lo + hi) / 2;
      RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> p, m_.bytes({ladder(anchor_, mid)}));
      if (p[0].bytes <= budget) {
        hi = mid;
        fit = p[0];
      } else {
        lo = mid;
      }
    }
    RGS_ASSIGN_OR_RETURN(std::vector<FitPoint> start, m_.measure({fit.options}));
    report_progress("ladder", start[0]);
    // The search over targets, in log2 of the bytes, from every PSNR search run so far (probes_, kept across
    // budgets): `below` is the highest target whose search ended within the budget, `above` the lowest above it
    // whose search ended over it or failed (bytes +inf). Between the two, the next target is interpolated where
    // the bytes would meet the budget (kept off either end by a tenth of the bracket); above every search that
    // fits, extrapolated along the slope of the two highest (kDbPerDoubling until there are two), by at least a
    // step that doubles from 1 dB (on a flat stretch of the curve, a few per cent of bytes are several dB).
    const double log_budget = std::log2(double(budget));
    std::optional<Probe> below, above, below_before;
    for (const Probe& p : probes_) {
      if (p.bytes <= double(budget)) {
        if (!below || p.target > below->target) below_before = below, below = p;
      }
    }
    for (const Probe& p : probes_) {
      if (p.bytes > double(budget) && (!below || p.target > below->target) && (!above || p.target < above->target)) {
        above = p;
      }
    }
    if (!below) below = Probe{start[0].psnr_mean_db, double(start[0].bytes), start[0].psnr_mean_db};
    std::vector<FitPoint> previous;
    double min_step = 1;
    for (int search = 0; search < kMaxBytesSearches; ++search) {
      double target = 0;
      if (above) {
        const double width = above->target - below->target;
        if (width < kBytesTargetResolutionDb) break;
        target = below->target + width / 2;
        if (std::isfinite(above->bytes) && above->bytes > below->bytes) {
          target = below->target + width * (log_budget - std::log2(below->bytes)) /
                                       (std::log2(above->bytes) - std::log2(below->bytes));
        }
        target = std::clamp(target, below->target + width / 10, above->target - width / 10);
      } else {
        double slope = kDbPerDoubling;
        if (below_before && below->bytes > below_before->bytes && below->psnr > below_before->psnr) {
          slope = (below->psnr - below_before->psnr) / std::log2(below->bytes / below_before->bytes);
        }
        target = std::max(below->psnr, below->target) +
                 std::max(slope * (log_budget - std::log2(below->bytes)), min_step);
        min_step *= 2;
      }
      Result<std::vector<FitPoint>> searched = for_psnr(target, previous);
      Probe probe{target, std::numeric_limits<double>::infinity(), kNaN};  // failed: above what the finest reaches
      if (!searched.ok()) {
        if (searched.status().code() != StatusCode::kInvalidArgument) return std::move(searched).status();
      } else {
        previous = std::move(searched).value();
        probe.bytes = double(previous.back().bytes);
        probe.psnr = previous.back().psnr_mean_db;
      }
      probes_.push_back(probe);
      if (probe.bytes <= double(budget)) {
        below_before = below;
        below = probe;
      } else {
        above = probe;
      }
      report_progress("searching", m_.best_within());
    }
    RGS_RETURN_IF_ERROR(fill_for_bytes(budget));
    return *m_.best_within();
  }

  const std::optional<FitPoint>& finest() const { return finest_; }
  uint32_t sh_degree() const { return sh_degree_; }

 private:
  /// kTargetBytes's last stage, from the best archive within `budget` measured so far: each round, of the finer
  /// steps of one knob that still fit, the one with the most dB gained per byte added (at most kMaxRounds).
  Status fill_for_bytes(uint64_t budget) {
    std::vector<bool> frozen(knobs_.size(), false);
    for (int round = 0; round < kMaxRounds; ++round) {
      const FitPoint at = *m_.best_within();
      std::vector<format::ArchiveOptions> list;
      std::vector<size_t> knob_of;
      next_steps(knobs_, at.options, false, &frozen, &list, &knob_of);
      if (list.empty()) break;
      // Bytes first: only the steps that fit are rendered.
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> sizes, m_.bytes(list));
      std::vector<format::ArchiveOptions> fitting;
      std::vector<size_t> fitting_knob;
      for (size_t i = 0; i < sizes.size(); ++i) {
        if (sizes[i].bytes <= budget) {
          fitting.push_back(list[i]);
          fitting_knob.push_back(knob_of[i]);
        } else {
          frozen[knob_of[i]] = true;
        }
      }
      if (fitting.empty()) break;
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> points, m_.measure(fitting));
      for (size_t i = 0; i < points.size(); ++i) {
        if (!(points[i].psnr_mean_db > at.psnr_mean_db)) frozen[fitting_knob[i]] = true;  // no better for its bytes
      }
      if (!(m_.best_within()->psnr_mean_db > at.psnr_mean_db)) break;
      report_progress("refining", m_.best_within());
    }
    return Status();
  }

  /// One step of every knob of `knobs` not yet frozen, coarser or finer, into `list` with its index in `knobs`
  /// in `knob_of`; a knob that has no such step left is frozen.
  static void next_steps(const std::vector<Knob>& knobs, const format::ArchiveOptions& at, bool coarser,
                         std::vector<bool>* frozen, std::vector<format::ArchiveOptions>* list,
                         std::vector<size_t>* knob_of) {
    for (size_t k = 0; k < knobs.size(); ++k) {
      if ((*frozen)[k]) continue;
      if (auto o = step(at, knobs[k], coarser)) {
        list->push_back(*o);
        knob_of->push_back(k);
      } else {
        (*frozen)[k] = true;
      }
    }
  }

  /// A coarser step measured at `points[index]`: the squared error it adds and its bytes saved per unit of it.
  struct Move {
    size_t index;
    double added_mse, ratio;
  };
  /// The coarser steps `points` (of the knobs `knob_of`, from `at`) that still meet `target` in fewer bytes, by
  /// bytes saved per squared error added, best first (a step that adds none first; ties in knob order); the knob
  /// of every other step is frozen: coarser still, with the others coarser too, will not meet the target.
  static std::vector<Move> passing_moves(const FitPoint& at, const std::vector<FitPoint>& points,
                                         const std::vector<size_t>& knob_of, double target, std::vector<bool>* frozen) {
    std::vector<Move> moves;
    for (size_t i = 0; i < points.size(); ++i) {
      const FitPoint& p = points[i];
      if (!(p.psnr_mean_db >= target) || p.bytes >= at.bytes) {
        (*frozen)[knob_of[i]] = true;
        continue;
      }
      const double added = std::max(mse_of(p.psnr_mean_db) - mse_of(at.psnr_mean_db), 0.0);
      moves.push_back({i, added, double(at.bytes - p.bytes) / std::max(added, 1e-30)});
    }
    std::stable_sort(moves.begin(), moves.end(), [](const Move& a, const Move& b) { return a.ratio > b.ratio; });
    return moves;
  }

  void note_finest(const FitPoint& p) {
    if (!finest_ || p.bytes > finest_->bytes) finest_ = p;
  }

  void report_progress(const char* stage, const std::optional<FitPoint>& best) {
    std::string line = std::string(stage) + ": " + std::to_string(m_.encodings()) + " archives encoded, " +
                       std::to_string(m_.renders()) + " rendered";
    if (best) line += "; at " + db_text(best->psnr_mean_db) + ", " + group_digits(best->bytes) + " bytes";
    report(line);
  }

  /// A PSNR search of the bytes search: its target, and its choice's bytes (+inf when the target is above the
  /// finest archive) and PSNR.
  struct Probe {
    double target, bytes, psnr;
  };

  Measurer& m_;
  const FitOptions& options_;
  std::vector<Probe> probes_;  ///< every PSNR search for_bytes ran, whatever its budget
  std::vector<Knob> knobs_;
  format::ArchiveOptions anchor_;
  uint32_t sh_degree_;
  std::optional<FitPoint> finest_;
};

uint32_t search_max_side(const FitOptions& options) {
  if (options.search_max_side != 0) return options.search_max_side;
  return options.audit.backend == Backend::kCuda ? kCudaSearchMaxSide : kCpuSearchMaxSide;
}

/// The search's views: at most `max_views` of `cameras`, evenly spread, reduced to `max_side`.
std::vector<runtime::Camera> reduced(const std::vector<runtime::Camera>& cameras, uint32_t max_side,
                                     uint32_t max_views) {
  std::vector<runtime::Camera> subset;
  const size_t n = cameras.size(), k = std::min<size_t>(n, std::max<uint32_t>(max_views, 1));
  for (size_t i = 0; i < k; ++i) subset.push_back(cameras[i * n / k]);
  std::vector<runtime::Camera> out;
  max_side = std::max<uint32_t>(max_side, 16);
  for (const runtime::Camera& c : subset) {
    const uint32_t side = std::max(c.width, c.height);
    if (side <= max_side) {
      out.push_back(c);
      continue;
    }
    const double f = double(max_side) / double(side);
    const auto w = uint32_t(std::max(16L, std::lround(c.width * f)));
    const auto h = uint32_t(std::max(16L, std::lround(c.height * f)));
    out.push_back(runtime::resize_camera(c, w, h));
  }
  return out;
}

/// kTargetPsnr: checks the ladder's point for the target on the cameras at their own size, searches at the
/// target moved by the difference measured between the two sizes, checks the search's last step, and searches
/// again at a target moved by the difference measured between the two sizes while the check
/// misses the target or lands more than kMaxAboveDb above it. On the last attempt, a miss is followed by
/// checks of the earlier steps of the path. A (moved) target above the finest archive on the search views
/// ends the search with a check of that finest archive: the search views may read below or above the
/// cameras' own size. Sets result->chosen and result->search_psnr_db.
Status fit_psnr(Measurer& measurer, Search& search, const runtime::Camera& first, double target, FitResult* result) {
  const std::string size = std::to_string(first.width) + "x" + std::to_string(first.height);
  std::optional<FitPoint> best;
  double best_search_psnr = kNaN;
  auto keep = [&](const FitPoint& checked, double search_psnr) {
    if (checked.psnr_mean_db >= target && (!best || checked.bytes < best->bytes)) {
      best = checked;
      best_search_psnr = search_psnr;
    }
  };
  // Whether `searched` failed because `search_target` is above the finest archive on the search views.
  auto above_finest = [&](const Status& searched, double search_target) {
    return searched.code() == StatusCode::kInvalidArgument && search.finest() &&
           !(search.finest()->psnr_mean_db >= search_target);
  };
  auto check_finest = [&]() -> Status {
    const FitPoint finest = *search.finest();
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({finest.options}, true));
    search.report("check of the finest archive at " + size + ": " + db_text(checked[0].psnr_mean_db) +
                  " (search views: " + db_text(finest.psnr_mean_db) + ")");
    keep(checked[0], finest.psnr_mean_db);
    if (best) return Status();
    return Status(StatusCode::kInvalidArgument,
                  "target " + db_text(target) + " is above what the archive profile reaches on these views: " +
                      db_text(checked[0].psnr_mean_db) + " at the finest settings (" +
                      describe_archive_options(finest.options, search.sh_degree()) + ")");
  };
  auto settle = [&]() {
    result->chosen = *best;
    result->search_psnr_db = best_search_psnr;
    return Status();
  };

  // A first estimate of the difference between the sizes, at the ladder's point for the target.
  Result<FitPoint> ladder_point = search.ladder_for_psnr(target);
  if (!ladder_point.ok()) {
    if (!above_finest(ladder_point.status(), target)) return std::move(ladder_point).status();
    RGS_RETURN_IF_ERROR(check_finest());
    return settle();
  }
  RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> calibration, measurer.measure({ladder_point->options}, true));
  search.report("check at " + size + ": " + db_text(calibration[0].psnr_mean_db) + " (search views: " +
                db_text(ladder_point->psnr_mean_db) + ")");
  double search_target =
      std::max(target, target + ladder_point->psnr_mean_db - calibration[0].psnr_mean_db + kCalibrationMarginDb);
  keep(calibration[0], ladder_point->psnr_mean_db);
  std::vector<FitPoint> path;
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    measurer.set_search_offset(search_target - target);
    Result<std::vector<FitPoint>> searched = search.for_psnr(search_target, path);
    if (!searched.ok()) {
      if (!above_finest(searched.status(), search_target)) return std::move(searched).status();
      if (!best) RGS_RETURN_IF_ERROR(check_finest());
      break;
    }
    path = std::move(searched).value();
    const bool last_attempt = attempt + 1 == kMaxAttempts;
    // From the search's last (cheapest) step back, on the last attempt: the first that meets the target.
    FitPoint last_checked;
    bool settled = false;  // this search's choice (or on the last attempt, a step before it) meets the target
    for (size_t back = 0; back < (last_attempt ? std::min<size_t>(path.size(), 3) : 1); ++back) {
      const FitPoint& at = path[path.size() - 1 - back];
      RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({at.options}, true));
      if (back == 0) last_checked = checked[0];
      search.report("check at " + size + ": " + db_text(checked[0].psnr_mean_db) + " (search views: " +
                    db_text(at.psnr_mean_db) + ")");
      keep(checked[0], at.psnr_mean_db);
      if (checked[0].psnr_mean_db >= target) {
        settled = checked[0].psnr_mean_db <= target + kMaxAboveDb;
        break;
      }
    }
    if (settled) break;
    // The difference between the search views and the final ones at the search's last step.
    const double offset = path.back().psnr_mean_db - last_checked.psnr_mean_db;
    double next = target + offset + kCalibrationMarginDb;
    if (last_checked.psnr_mean_db < target) next = std::max(next, search_target + kCalibrationMarginDb);
    if (std::abs(next - search_target) < 0.01) break;
    search_target = next;
  }
  if (!best) {
    return Status(StatusCode::kInvalidArgument,
                  "target " + db_text(target) + " is not met by any archive the search measured at " + size +
                      " (the finest reached " + db_text(search.finest() ? search.finest()->psnr_mean_db : kNaN) +
                      " at the search size)");
  }
  return settle();
}

/// kTargetBytes: Search::for_bytes on a budget of the search's bytes (zstd level kSearchZstdLevel, no .xz), then
/// the bytes of its choice as the file codes it (`file_zstd_level`, `file_xz`), which are fewer: on a flat stretch
/// of the rate-distortion curve a few per cent of bytes are several dB (guitar: 35 to 40 dB in 4 % more bytes), so
/// the search runs again on the budget that puts the choice's file at `target` (the ratio of the two byte counts
/// measured at the choice), at most kMaxAttempts searches, while the file is over the target or more than
/// kBytesSlack below it. Of the archives within the largest budget whose choice's file fit, the kBytesFinalists of
/// the highest search PSNR whose files fit are measured at the cameras' own size, where the search views rank
/// close archives differently, and the highest is chosen. Then the climb: kTargetPsnr fits (fit_psnr, checked at
/// the cameras' own size) at kBytesClimbDb above the choice, the step doubling after each that does not fit or
/// reads no higher, at most kMaxBytesClimbs; one whose file fits and reads higher is chosen. Sets result->chosen
/// and result->search_psnr_db.
Status fit_bytes(Measurer& measurer, Search& search, const runtime::Camera& first, uint64_t target,
                 int file_zstd_level, bool file_xz, FitResult* result) {
  uint64_t budget = target, fitting_budget = 0;
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    RGS_ASSIGN_OR_RETURN(const FitPoint best, search.for_bytes(budget));
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(best.options, file_zstd_level, file_xz));
    search.report("search's choice within " + group_digits(budget) + " bytes: " + group_digits(best.bytes) +
                  " bytes there, " + group_digits(file) + " in the file");
    if (file <= target) fitting_budget = std::max(fitting_budget, budget);
    if (file <= target && double(target - file) <= kBytesSlack * double(target)) break;
    const auto next = uint64_t(double(target) * double(best.bytes) / double(std::max<uint64_t>(file, 1)));
    if (next == budget) break;
    budget = next;
  }
  std::optional<FitPoint> chosen;
  double chosen_search_db = kNaN;
  for (const FitPoint& p : measurer.best_within(fitting_budget, kBytesFinalists)) {
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(p.options, file_zstd_level, file_xz));
    if (file > target) continue;
    RGS_ASSIGN_OR_RETURN(const std::vector<FitPoint> checked, measurer.measure({p.options}, true));
    search.report("check at the cameras' size: " + db_text(checked[0].psnr_mean_db) + " (search views: " +
                  db_text(p.psnr_mean_db) + "), " + group_digits(file) + " bytes in the file");
    if (!chosen || checked[0].psnr_mean_db > chosen->psnr_mean_db) {
      chosen = checked[0];
      chosen_search_db = p.psnr_mean_db;
    }
  }
  if (!chosen) {
    return Status(StatusCode::kLimitExceeded, "no archive the search measured codes into " + group_digits(target) +
                                                  " bytes at zstd level " + std::to_string(file_zstd_level));
  }
  // The climb: the searches' bytes are not monotonic in their target (guitar's 35 dB fit is smaller than its
  // 33.11 dB one), so PSNR fits a little above the choice, at the cameras' own size, may still fit.
  double step_db = kBytesClimbDb;
  for (int climb = 0; climb < kMaxBytesClimbs; ++climb) {
    FitResult fitted;
    const Status status = fit_psnr(measurer, search, first, chosen->psnr_mean_db + step_db, &fitted);
    if (!status.ok()) {
      if (status.code() != StatusCode::kInvalidArgument) return status;
      break;  // above what the finest archive reaches
    }
    RGS_ASSIGN_OR_RETURN(const uint64_t file, measurer.file_bytes(fitted.chosen.options, file_zstd_level, file_xz));
    search.report("fit for " + db_text(chosen->psnr_mean_db + step_db) + ": " +
                  db_text(fitted.chosen.psnr_mean_db) + ", " + group_digits(file) + " bytes in the file");
    if (file <= target && fitted.chosen.psnr_mean_db > chosen->psnr_mean_db) {
      chosen = fitted.chosen;
      chosen_search_db = fitted.search_psnr_db;
      step_db = kBytesClimbDb;
    } else {
      step_db *= 2;
    }
  }
  result->chosen = *chosen;
  result->search_psnr_db = chosen_search_db;
  return Status();
}

}  // namespace

std::string describe_archive_options(const format::ArchiveOptions& o, uint32_t sh_degree) {
  std::string text = "rotation " + std::to_string(o.rotation_bits) + ", scale " + std::to_string(o.scale_bits) +
                     ", opacity " + std::to_string(o.opacity_bits) + " bits; ";
  if (o.rotation_step != 1 || o.scale_step != 1 || o.opacity_step != 1) {
    char steps[96];
    std::snprintf(steps, sizeof(steps), "code steps x%.3g/%.3g/%.3g; ", o.rotation_step, o.scale_step, o.opacity_step);
    text += steps;
  }
  if (o.opacity_floor > 0) {
    char floor[64];
    std::snprintf(floor, sizeof(floor), "opacity floor %.3g/255; ", 255 * o.opacity_floor);
    text += floor;
  }
  text += "SH step x";
  for (uint32_t d = 0; d <= std::min<uint32_t>(sh_degree, 3); ++d) {
    text += (d ? "/" : "") + std::to_string(o.sh_step_multipliers[d]);
  }
  char position[64];
  std::snprintf(position, sizeof(position), "; position error %.3g of the extent", o.position_error);
  return text + position;
}

Result<FitResult> fit_archive(const format::GaussianCloud& source, const std::vector<runtime::Camera>& cameras,
                              const FitOptions& options) {
  const auto start = Clock::now();
  RGS_RETURN_ERROR_IF(cameras.empty(), StatusCode::kInvalidArgument, "rate control: no views selected");
  RGS_RETURN_ERROR_IF(source.size() == 0, StatusCode::kInvalidArgument, "rate control: the scene has no Gaussians");
  if (options.goal == FitGoal::kTargetPsnr) {
    RGS_RETURN_ERROR_IF(!std::isfinite(options.target_psnr_db) || options.target_psnr_db <= 0,
                        StatusCode::kInvalidArgument,
                        "rate control: target PSNR " + std::to_string(options.target_psnr_db) +
                            " dB is not a finite, positive number");
  } else {
    RGS_RETURN_ERROR_IF(options.target_bytes == 0, StatusCode::kInvalidArgument,
                        "rate control: a target of 0 bytes");
  }
  AuditScene reference;
  reference.cloud = source;
  reference.bounds = converter::compute_bounds(source);
  reference.info.path = "source";
  reference.info.label = "source";
  reference.info.gaussians = source.size();
  reference.info.sh_degree = source.sh_degree;

  format::GaussianCloud encoded_cloud;
  const format::GaussianCloud* to_encode = &source;
  if (options.sh_degree && *options.sh_degree < source.sh_degree) {
    encoded_cloud = source;
    RGS_RETURN_IF_ERROR(converter::reduce_sh_degree(&encoded_cloud, *options.sh_degree));
    to_encode = &encoded_cloud;
  }
  converter::QuantizeOptions quantize = options.quantize;
  quantize.sh_dc_bits = 8;  // the archive drops the DC residual (SPEC §4.8)
  RGS_ASSIGN_OR_RETURN(format::EncodedScene quantized, converter::quantize(*to_encode, quantize));
  const uint32_t sh_degree = quantized.metadata.sh_degree;
  format::ArchiveOptions anchor = format::resolve_archive_options(options.start, quantized.count);
  // The zstd level and the .xz trial change a file's bytes, not what it decodes to: the search codes with zstd at
  // a quick level, the file is written as asked (FitOptions::start).
  const int file_zstd_level = anchor.zstd_level;
  const bool file_xz = anchor.xz;
  anchor.zstd_level = std::min(file_zstd_level, kSearchZstdLevel);
  anchor.xz = false;

  FitOptions resolved = options;
  resolved.start = anchor;
  const std::vector<runtime::Camera> search_cameras =
      reduced(cameras, search_max_side(options), options.search_max_views);
  Measurer measurer(reference, std::move(quantized), resolved);
  RGS_RETURN_IF_ERROR(measurer.start(search_cameras, cameras));
  RGS_RETURN_IF_ERROR(measurer.measure_overhead());
  Search search(measurer, resolved, sh_degree, anchor);

  FitResult result;
  result.views = uint32_t(cameras.size());
  result.search_width = search_cameras[0].width;
  result.search_height = search_cameras[0].height;
  result.width = cameras[0].width;
  result.height = cameras[0].height;
  result.backend = options.audit.backend;

  if (options.goal == FitGoal::kTargetBytes) {
    RGS_RETURN_IF_ERROR(
        fit_bytes(measurer, search, cameras[0], options.target_bytes, file_zstd_level, file_xz, &result));
  } else {
    RGS_RETURN_IF_ERROR(fit_psnr(measurer, search, cameras[0], options.target_psnr_db, &result));
  }
  result.finest = search.finest();
  result.archive = measurer.archive_with_points(result.chosen.options);
  auto as_asked = [&](format::ArchiveOptions* o) {
    o->zstd_level = file_zstd_level;
    o->xz = file_xz;
  };
  as_asked(&result.chosen.options);
  if (result.finest) as_asked(&result.finest->options);
  result.encodings = measurer.encodings();
  result.renders = measurer.renders();
  result.encode_seconds = measurer.encode_seconds();
  result.render_seconds = measurer.render_seconds();
  result.device = measurer.device_name();
  result.seconds = seconds_since(start);
  return result;
}

Result<FittedConversion> convert_fitted(const std::string& src, const std::string& dst, api::ConvertOptions options,
                                        const api::CameraChoice& cameras, FitOptions fit) {
  {
    // The options the file is written with, refused before the search rather than after it.
    api::ConvertOptions written = options;
    written.profile = format::StorageProfile::kArchive;
    RGS_RETURN_IF_ERROR(api::check_convert_options(written));
  }
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(src, api::scene_read_options(options)));
  RGS_RETURN_IF_ERROR(format::check_output_file(dst, input.files));  // before the fit, not only at the write
  FittedConversion out;
  std::vector<runtime::Camera> views;
  if (cameras.cameras_path.empty() && cameras.orbit == 0 && cameras.path == 0) {
    RGS_ASSIGN_OR_RETURN(DefaultViews found, default_views(src, input.cloud, cameras));
    views = std::move(found.cameras);
    out.views_note = std::move(found.note);
  } else {
    auto made = api::make_cameras(cameras, input.bounds);
    if (!made.ok()) return Status(made.status()).prepend(src + ": rate control's views");
    views = std::move(made).value();
  }
  fit.quantize.scale_encoding = options.scale_encoding;
  fit.quantize.sh_clip_percentile = options.sh_clip_percentile;
  fit.sh_degree = options.sh_degree;
  fit.start = options.archive;
  options.profile = format::StorageProfile::kArchive;
  // As api::convert codes the archive: at its zstd level, with .xz streams only from kArchiveXzMinZstdLevel on.
  fit.start.zstd_level = api::zstd_level_for(options);
  fit.start.xz = options.archive.xz && fit.start.zstd_level >= api::kArchiveXzMinZstdLevel;
  // The provenance: the source's name and storage, the converter's name and the options' text.
  fit.provenance_bytes = 768 + std::filesystem::path(src).filename().string().size() + input.storage_format.size() +
                         options.converter_name.size();
  auto fitted = fit_archive(input.cloud, views, fit);
  if (!fitted.ok()) return Status(fitted.status()).prepend(src);
  out.fit = std::move(fitted).value();
  options.archive = out.fit.chosen.options;
  options.archive_earlier = std::move(out.fit.archive);
  RGS_ASSIGN_OR_RETURN(out.convert, api::convert_scene(std::move(input), src, dst, options));
  if (fit.goal == FitGoal::kTargetBytes && out.convert.output_bytes > fit.target_bytes) {
    return Status(StatusCode::kLimitExceeded,
                  dst + ": the archive has " + group_digits(out.convert.output_bytes) + " bytes, over the target of " +
                      group_digits(fit.target_bytes) + " (its provenance is larger than the fit allowed for)");
  }
  return out;
}

}  // namespace rgs::audit
