// Rate control's measurements: archives encoded (in batches, lending one another their sections) and rendered
// against the source's renders (measurer.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <new>

#include "measurer.h"
#include "rgs/format/writer.h"
#include "rgs/runtime/image_metrics.h"

namespace rgs::api::detail {

Status Measurer::start(std::vector<runtime::Camera> search_cameras, std::vector<runtime::Camera> cameras) {
  device_ = options_.target.device;
  const unsigned workers = device_ == api::Device::kCpu ? parallel::thread_count(options_.target.cpu_threads) : 1;
  for (unsigned w = 0; w < workers; ++w) {
    RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(device_, options_.target.cuda_device));
    renderers_.push_back(std::move(renderer));
  }
  settings_.preset = api::Preset::kFaithful;
  settings_.cpu_threads = workers > 1 ? 1 : options_.target.cpu_threads;
  search_.cameras = std::move(search_cameras);
  final_.cameras = std::move(cameras);
  RGS_ASSIGN_OR_RETURN(api::Scene scene, load(source_, bounds_, "source"));
  uint64_t source_bytes = 0;
  for (const ViewSet* set : {&search_, &final_}) {
    for (const runtime::Camera& cam : set->cameras) source_bytes += uint64_t{cam.width} * cam.height * 16;
  }
  for (ViewSet* set : {&search_, &final_}) {
    // The GPU comparer measures SSIM beside PSNR, so its views need sides of at least SSIM's window; a set with a
    // smaller view is compared on the host, as on the CPU.
    const bool comparable = std::all_of(set->cameras.begin(), set->cameras.end(), [](const runtime::Camera& cam) {
      return cam.width >= uint32_t(runtime::kSsimWindow) && cam.height >= uint32_t(runtime::kSsimWindow);
    });
    const bool on_device = device_ == api::Device::kCuda && source_bytes <= kDeviceSourceBytes && comparable;
    set->source.resize(set->cameras.size());
    if (on_device) set->source_images.resize(set->cameras.size());
    RGS_RETURN_IF_ERROR(for_views(set->cameras, [&](api::Renderer& renderer, size_t v) -> Status {
      const runtime::Camera& cam = set->cameras[v];
      api::Image* kept = on_device ? &set->source_images[v] : nullptr;
      RGS_ASSIGN_OR_RETURN(std::vector<float> rgb, render_rgb(renderer, scene, cam, kept));
      // Both renders of a view that sees nothing are black: it reads +inf dB whatever the archive.
      RGS_RETURN_ERROR_IF(std::none_of(rgb.begin(), rgb.end(), [](float c) { return c > 0; }),
                          StatusCode::kInvalidArgument,
                          "view " + cam.name + " sees nothing of the scene (its render of the source is black), so no "
                          "PSNR can be measured there: choose views that look at the scene");
      if (!on_device) set->source[v] = std::move(rgb);
      return Status();
    }));
    if (on_device) set->source.clear();
  }
  return Status();
}

Status Measurer::measure_overhead() {
  format::WriteOptions write;
  write.profile = format::StorageProfile::kArchive;
  write.archive = options_.start;
  RGS_ASSIGN_OR_RETURN(const Entry* e, encode(write.archive));
  write.archive_earlier = e->archive.get();
  RGS_ASSIGN_OR_RETURN(const std::vector<uint8_t> bytes, format::serialize_scene(quantized_, write));
  overhead_ = bytes.size() - e->sections + options_.provenance_bytes;
  return Status();
}

Result<std::vector<FitPoint>> Measurer::bytes(const std::vector<format::ArchiveOptions>& list) {
  std::vector<FitPoint> out;
  for (size_t i = 0; i < list.size(); ++i) {
    if (i % batch_ == 0) RGS_RETURN_IF_ERROR(encode_batch(list, i, std::min(list.size(), i + batch_)));
    RGS_ASSIGN_OR_RETURN(const Entry* e, encode(list[i]));
    out.push_back(e->point);
    out.back().bytes += overhead_;
  }
  return out;
}

Result<std::vector<FitPoint>> Measurer::measure(const std::vector<format::ArchiveOptions>& list, bool final) {
  std::vector<FitPoint> out;
  for (size_t i = 0; i < list.size(); ++i) {
    if (i % batch_ == 0) RGS_RETURN_IF_ERROR(encode_batch(list, i, std::min(list.size(), i + batch_)));
    const format::ArchiveOptions& o = list[i];
    RGS_ASSIGN_OR_RETURN(Entry * e, encode(o));
    if (final ? std::isnan(e->checked_db) : std::isnan(e->point.psnr_mean_db)) {
      RGS_ASSIGN_OR_RETURN(const auto psnr, render(e, final ? final_ : search_));
      (final ? e->checked_db : e->point.psnr_mean_db) = psnr.first;
      (final ? e->checked_min_db : e->point.psnr_min_db) = psnr.second;
    }
    FitPoint p = e->point;
    if (final) {
      p.psnr_mean_db = e->checked_db;
      p.psnr_min_db = e->checked_min_db;
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

void Measurer::watch_budget(uint64_t bytes) {
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

Result<uint64_t> Measurer::file_bytes(format::ArchiveOptions o, int zstd_level, bool xz) {
  o.zstd_level = zstd_level;
  o.xz = xz;
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(const format::ArchiveScene archive, format::encode_archive(quantized_, o, lender(o)));
  encode_seconds_ += seconds_since(start);
  uint64_t sections = 0;
  for (const std::vector<uint8_t>& s : archive.stored) sections += s.size();
  return sections + overhead_;
}

std::vector<FitPoint> Measurer::best_within(uint64_t bytes, size_t count) const {
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

std::shared_ptr<const format::ArchiveScene> Measurer::archive_with_points(const format::ArchiveOptions& o) const {
  for (const auto& a : points_) {
    if (same_points(a, o)) return a;
  }
  return nullptr;
}

std::string Measurer::device_name() const {
  if (device_ == api::Device::kCpu) return "CPU reference renderer";
  return "CUDA device " + std::to_string(options_.target.cuda_device);
}

Result<std::shared_ptr<const format::ArchiveScene>> Measurer::encode_archive(const format::ArchiveOptions& o) {
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(format::ArchiveScene archive, format::encode_archive(quantized_, o, lender(o)));
  encode_seconds_ += seconds_since(start);
  return keep_last(std::make_shared<const format::ArchiveScene>(std::move(archive)));
}

bool Measurer::same_points(const std::shared_ptr<const format::ArchiveScene>& a,
                           const format::ArchiveOptions& o) const {
  const format::ArchiveOptions want = format::resolve_archive_options(o, quantized_);
  return a && a->options.position_error == want.position_error && a->options.draco_speed == want.draco_speed &&
         a->options.opacity_bits == want.opacity_bits && a->options.opacity_step == want.opacity_step &&
         a->options.opacity_floor == want.opacity_floor;
}

const format::ArchiveScene* Measurer::lender(const format::ArchiveOptions& o) const {
  if (const auto a = archive_with_points(o)) return a.get();
  return points_.empty() ? nullptr : points_.front().get();
}

std::shared_ptr<const format::ArchiveScene> Measurer::keep_last(std::shared_ptr<const format::ArchiveScene> a) {
  const auto same =
      std::find_if(points_.begin(), points_.end(), [&](const auto& p) { return same_points(p, a->options); });
  if (same != points_.end()) points_.erase(same);
  points_.insert(points_.begin(), a);
  if (points_.size() > points_kept_) points_.pop_back();
  return a;
}

Status Measurer::encode_batch(const std::vector<format::ArchiveOptions>& list, size_t begin, size_t end) {
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

Result<Measurer::Entry*> Measurer::encode(const format::ArchiveOptions& o) {
  auto it = cache_.find(key_of(o));
  if (it != cache_.end()) return &it->second;
  RGS_ASSIGN_OR_RETURN(std::shared_ptr<const format::ArchiveScene> archive, encode_archive(o));
  return add_entry(o, std::move(archive));
}

Measurer::Entry* Measurer::add_entry(const format::ArchiveOptions& o,
                                     std::shared_ptr<const format::ArchiveScene> archive) {
  Entry e;
  e.archive = std::move(archive);
  e.point.options = o;
  for (const std::vector<uint8_t>& s : e.archive->stored) e.sections += s.size();
  e.point.bytes = e.sections;
  e.point.psnr_mean_db = e.point.psnr_min_db = kNaN;
  return &cache_.emplace(key_of(o), std::move(e)).first->second;
}

Result<api::Scene> Measurer::load(format::GaussianCloud cloud, const format::SceneBounds& bounds,
                                  const std::string& name) {
  api::LoadOptions load;
  load.device = device_;
  load.cuda_device = options_.target.cuda_device;
  return api::load_cloud(std::move(cloud), bounds, name, load);
}

Result<double> Measurer::view_psnr(api::Renderer& renderer, const api::Scene& scene, const ViewSet& set, size_t v) {
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
  return runtime::psnr_rgb(set.source[v], rgb, cam.width, cam.height);
}

Result<std::vector<float>> Measurer::render_rgb(api::Renderer& renderer, const api::Scene& scene,
                                                const runtime::Camera& cam, api::Image* kept) {
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
  if (kept) *kept = std::move(image).value();
  return rgb;
}

Result<std::pair<double, double>> Measurer::render(Entry* e, const ViewSet& set) {
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

}  // namespace rgs::api::detail
