// load() and convert(): every supported file into a Scene on the CPU or the GPU.
#include <filesystem>
#include <sstream>

#include "internal_scene.h"
#include "rgs/api/scene_loading.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

#if RGS_HAS_CUDA
#include "rgs/api/gpu_scene_loading.h"
#endif

namespace rgs::api {

const char* device_name(Device device) { return device == Device::kCuda ? "cuda" : "cpu"; }

Result<Device> parse_device(const std::string& name) {
  if (name == "cpu") return Device::kCpu;
  if (name == "cuda" || name == "gpu") return Device::kCuda;
  return Status(StatusCode::kInvalidArgument, "unknown device '" + name + "' (use cpu or cuda)");
}

const SceneInfo& Scene::info() const { return impl_->info; }

const format::GaussianCloud* Scene::cloud() const {
  return impl_->info.device == Device::kCpu ? &impl_->cloud : nullptr;
}

const runtime::GpuScene* Scene::gpu_scene() const {
#if RGS_HAS_CUDA
  return impl_->gpu ? &*impl_->gpu : nullptr;
#else
  return nullptr;
#endif
}

namespace {

uint64_t cloud_bytes(const format::GaussianCloud& c) {
  return (c.means.size() + c.rotations.size() + c.scales.size() + c.opacities.size() + c.sh.size()) * sizeof(float);
}

uint64_t runtime_bytes(uint64_t n, uint32_t degree) {
  return n * (12 + 8 + 6 + 2) + n * format::sh_coefficient_count(degree) * 3;
}

Result<Scene> load_cpu(const std::string& path, const LoadOptions& options) {
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, read_input_scene(path, options.read_options));
  info.source_is_rgs = input.format_id == "rgs";
  info.file_bytes = input.file_bytes;
  if (info.source_is_rgs || !options.quantize_other_formats) {
    impl->cloud = std::move(input.cloud);
    info.bounds = input.bounds;
  } else {
    auto encoded = converter::quantize(input.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    auto cloud = format::dequantize(*encoded);
    if (!cloud.ok()) return Status(cloud.status()).prepend(path);
    impl->cloud = std::move(cloud).value();
    info.bounds = encoded->metadata.bounds;
  }
  info.device = Device::kCpu;
  info.path = path;
  info.gaussians = impl->cloud.size();
  info.sh_degree = impl->cloud.sh_degree;
  info.memory_bytes = cloud_bytes(impl->cloud);
  info.runtime_section_bytes = (info.source_is_rgs || options.quantize_other_formats)
                                   ? runtime_bytes(info.gaussians, info.sh_degree)
                                   : 0;
  return Scene(std::move(impl));
}

#if RGS_HAS_CUDA
Result<Scene> load_cuda(const std::string& path, const LoadOptions& options) {
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  runtime::GpuSceneOptions gpu_options;
  gpu_options.fp32_attributes = false;
  for (Preset p : options.presets) gpu_options.fp32_attributes |= preset_reads_fp32(p);

  std::optional<LoadedGpuScene> loaded;
  if (is_rgs_path(path) || !options.quantize_other_formats) {
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, load_gpu_scene(path, gpu_options, nullptr, options.read_options));
    loaded.emplace(std::move(l));
  } else {
    RGS_ASSIGN_OR_RETURN(converter::InputScene ply, read_input_scene(path, options.read_options));
    auto encoded = converter::quantize(ply.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    ply.cloud = format::GaussianCloud{};
    auto bytes = format::serialize_scene(*encoded);
    if (!bytes.ok()) return Status(bytes.status()).prepend(path);
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, upload_rgs_bytes(*bytes, ply.file_bytes, path, gpu_options));
    l.is_rgs = false;
    loaded.emplace(std::move(l));
  }
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  info.device = Device::kCuda;
  info.path = path;
  info.bounds = loaded->bounds;
  info.source_is_rgs = loaded->is_rgs;
  info.file_bytes = loaded->file_bytes;
  impl->gpu.emplace(std::move(loaded->scene));
  const runtime::GpuScene& gpu = *impl->gpu;
  info.gaussians = gpu.size();
  info.sh_degree = gpu.sh_degree();
  info.has_compact = gpu.has_compact();
  info.has_fp32 = gpu.has_fp32();
  info.memory_bytes = gpu.device_bytes();
  info.runtime_section_bytes = gpu.runtime_section_bytes();
  return Scene(std::move(impl));
}
#endif

}  // namespace

Result<Scene> load(const std::string& path, const LoadOptions& options) {
  if (options.device == Device::kCpu) return load_cpu(path, options);
#if RGS_HAS_CUDA
  return load_cuda(path, options);
#else
  return Status(StatusCode::kUnsupportedFeature,
                path + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
#endif
}

namespace {

const std::vector<std::pair<std::string, format::SectionId>>& section_names() {
  static const std::vector<std::pair<std::string, format::SectionId>> names = {
      {"metadata", format::SectionId::kMetadata}, {"provenance", format::SectionId::kProvenance},
      {"means", format::SectionId::kMeans},       {"rotations", format::SectionId::kRotations},
      {"scales", format::SectionId::kScales},     {"opacities", format::SectionId::kOpacities},
      {"sh", format::SectionId::kSh}};
  return names;
}

Result<format::WriteOptions> write_options(const ConvertOptions& options) {
  RGS_RETURN_ERROR_IF(options.zstd_level < 1 || options.zstd_level > 22, StatusCode::kInvalidArgument,
                      "convert: zstd_level " + std::to_string(options.zstd_level) + " outside [1, 22]");
  format::WriteOptions write;
  write.zstd_level = options.zstd_level;
  for (const std::string& name : options.zstd_sections) {
    bool found = false;
    for (const auto& [n, id] : section_names()) {
      if (name == "all" || n == name) {
        write.codecs[id] = format::Codec::kZstd;
        found = true;
      }
    }
    RGS_RETURN_ERROR_IF(!found, StatusCode::kInvalidArgument,
                        "convert: unknown zstd section '" + name +
                            "' (use all, metadata, provenance, means, rotations, scales, opacities, sh)");
  }
  return write;
}

/// kInvalidArgument when `dst` is one of the files the conversion reads (through any spelling or link).
Status check_output_not_input(const std::string& dst, const std::vector<std::string>& inputs) {
  format::OutputSet identities;
  RGS_RETURN_IF_ERROR(identities.add_output(dst));
  for (const std::string& input : inputs) RGS_RETURN_IF_ERROR(identities.add_input(input));
  return Status();
}

}  // namespace

Result<ConvertReport> convert(const std::string& src, const std::string& dst, const ConvertOptions& options) {
  ConvertReport report;
  if (is_rgs_path(src)) {
    report.direction = "rgs->ply";
    RGS_RETURN_IF_ERROR(check_output_not_input(dst, {src}));
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(src));
    RGS_ASSIGN_OR_RETURN(format::EncodedScene encoded, file.read_scene());
    auto cloud = format::dequantize(encoded);
    if (!cloud.ok()) return Status(cloud.status()).prepend(src);
    RGS_ASSIGN_OR_RETURN(uint64_t written, converter::write_ply(dst, *cloud));
    report.gaussians = cloud->size();
    report.sh_degree = cloud->sh_degree;
    report.input_bytes = file.file_size();
    report.output_bytes = written;
    return report;
  }
  report.direction = "ply->rgs";
  RGS_ASSIGN_OR_RETURN(format::WriteOptions write, write_options(options));
  converter::SceneReadOptions read_options;
  read_options.invalid_policy =
      options.sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
  read_options.hash_file = true;
  RGS_ASSIGN_OR_RETURN(converter::InputScene ply, converter::read_scene(src, read_options));
  RGS_RETURN_IF_ERROR(check_output_not_input(dst, ply.files));
  converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding = options.scale_encoding;
  quantize_options.sh_clip_percentile = options.sh_clip_percentile;
  auto encoded = converter::quantize(ply.cloud, quantize_options, &report.quantization, &report.errors);
  if (!encoded.ok()) return Status(encoded.status()).prepend(src);
  std::ostringstream options_text;
  options_text << "scale_encoding=" << (options.scale_encoding == format::ScaleEncoding::kLog ? "log" : "linear")
               << " sh_clip_percentile=" << options.sh_clip_percentile << " sanitize=" << (options.sanitize ? 1 : 0)
               << " zstd_level=" << options.zstd_level << " zstd=";
  for (size_t i = 0; i < options.zstd_sections.size(); ++i) {
    options_text << (i ? "," : "") << options.zstd_sections[i];
  }
  char hash[17];
  std::snprintf(hash, sizeof(hash), "%016llx", static_cast<unsigned long long>(ply.file_xxh64.value_or(0)));
  encoded->provenance = {
      {"source_file", std::filesystem::path(src).filename().string()},
      {"source_bytes", std::to_string(ply.file_bytes)},
      {"source_xxh64", hash},
      {"source_storage", ply.storage_format},
      {"converter", std::string("roofgs api ") + RGS_VERSION_STRING},
      {"options", options_text.str()},
      {"dropped_gaussians", std::to_string(ply.hygiene.dropped_gaussians)},
  };
  RGS_ASSIGN_OR_RETURN(uint64_t written, format::write_scene_file(dst, *encoded, write));
  report.gaussians = encoded->count;
  report.sh_degree = encoded->metadata.sh_degree;
  report.input_bytes = ply.file_bytes;
  report.output_bytes = written;
  report.dropped_gaussians = ply.hygiene.dropped_gaussians;
  return report;
}

}  // namespace rgs::api
