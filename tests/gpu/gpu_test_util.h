// Helpers of the GPU suite: device detection with a visible skip, scenes on both sides (host cloud for the
// CPU reference, GpuScene for the GPU), NaN-poisoned GPU renders, and image comparisons.
#pragma once

#include <cuda_runtime_api.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "render_test_util.h"  // tests/runtime: identity_camera, add_gaussian, read_ply access
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/runtime/gpu_renderer.h"
#include "rgs/runtime/gpu_scene.h"
#include "rgs/runtime/preset_techniques.h"
#include "test_data.h"
#if RGS_TEST_WITH_LAB
#include "rgs/lab/roofgs_stages.h"
#endif

namespace rgs::test {

/// True when a CUDA device is usable; otherwise prints the visible "skipped: no CUDA device" line.
inline bool have_gpu() {
  std::string why;
  if (runtime::cuda_device_count(&why) > 0) return true;
  MESSAGE("skipped: no CUDA device (" << why << ")");
  return false;
}

/// A scene as the CPU reference sees it (FP32 cloud) and as the GPU holds it.
struct GpuScenePair {
  bool available = false;
  format::GaussianCloud cloud;
  format::SceneBounds bounds;
  std::string cameras_path;  // flowers and taebak
  std::unique_ptr<runtime::GpuScene> gpu;
};

/// A cloud quantized in memory into a .rgs: the file (bytes owned here) and its dequantized values.
struct CompactScene {
  std::vector<uint8_t> bytes;
  std::unique_ptr<format::RgsFile> file;
  format::GaussianCloud dequantized;
  format::SceneBounds bounds;
};

inline CompactScene make_compact(const format::GaussianCloud& cloud, bool zstd) {
  CompactScene s;
  auto encoded = converter::quantize(cloud, converter::QuantizeOptions{});
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  format::WriteOptions options;
  if (zstd) {
    for (format::SectionId id : {format::SectionId::kMeans, format::SectionId::kRotations, format::SectionId::kScales,
                                 format::SectionId::kOpacities, format::SectionId::kSh}) {
      options.codecs[id] = format::Codec::kZstd;
    }
    options.zstd_level = 3;
  }
  auto bytes = format::serialize_scene(*encoded, options);
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  s.bytes = std::move(bytes).value();
  auto file = format::RgsFile::from_bytes(s.bytes.data(), s.bytes.size(), {}, "in-memory.rgs");
  REQUIRE_MESSAGE(file.ok(), file.status().to_string());
  s.file = std::make_unique<format::RgsFile>(std::move(file).value());
  auto dequantized = format::dequantize(*encoded);
  REQUIRE_MESSAGE(dequantized.ok(), dequantized.status().to_string());
  s.dequantized = std::move(dequantized).value();
  s.bounds = encoded->metadata.bounds;
  return s;
}

/// The pair of a .rgs file: the GPU uploads its compact sections and dequantizes them on the device
/// (GpuScene::from_rgs); the CPU reference renders format::dequantize(file.read_scene()), the same values
/// bit for bit. The file (and the bytes behind it) may go away afterwards.
inline GpuScenePair pair_from_rgs(const format::RgsFile& file) {
  GpuScenePair s;
  auto encoded = file.read_scene();
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  auto cloud = format::dequantize(*encoded);
  REQUIRE_MESSAGE(cloud.ok(), cloud.status().to_string());
  s.cloud = std::move(cloud).value();
  s.bounds = file.metadata().bounds;
  auto gpu = runtime::GpuScene::from_rgs(file);
  REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
  s.gpu = std::make_unique<runtime::GpuScene>(std::move(gpu).value());
  s.available = true;
  return s;
}

/// Loads a PLY (FP32 on both sides) or a .rgs (pair_from_rgs).
inline GpuScenePair load_pair(const std::string& path) {
  if (std::filesystem::path(path).extension() == ".rgs") {
    auto file = format::RgsFile::open(path);
    REQUIRE_MESSAGE(file.ok(), file.status().to_string());
    return pair_from_rgs(*file);
  }
  GpuScenePair s;
  auto ply = converter::read_ply(path);
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  s.cloud = std::move(ply->cloud);
  s.bounds = converter::compute_bounds(s.cloud);
  auto gpu = runtime::GpuScene::from_cloud(s.cloud, s.bounds);
  REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
  s.gpu = std::make_unique<runtime::GpuScene>(std::move(gpu).value());
  s.available = true;
  return s;
}

/// A shared scene by stem: `<stem>.ply`, else `<stem>.rgs` (the GPU host gets big scenes as .rgs).
inline std::string shared_scene_any(const std::string& stem) {
  for (const char* ext : {".ply", ".rgs"}) {
    const auto path = shared_data_dir() / (stem + ext);
    if (std::filesystem::exists(path)) return path.string();
  }
  MESSAGE("skipped: " << stem << ".ply/.rgs not found in " << shared_data_dir().string());
  return {};
}

/// tests/data/guitar_sh3.ply (shipped: 8,000 real Gaussians of the guitar with SH bands 1-3 synthetic,
/// tests/data/make_guitar_sh3.py) with its SH reduced to `degree` (converter::reduce_sh_degree, as
/// rgs-convert --sh-degree does), FP32 on both sides.
inline GpuScenePair guitar_sh3(uint32_t degree) {
  GpuScenePair s;
  auto ply = converter::read_ply(repo_path(kGuitarSh3));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  s.cloud = std::move(ply->cloud);
  REQUIRE(s.cloud.sh_degree == 3);
  const Status reduced = converter::reduce_sh_degree(&s.cloud, degree);
  REQUIRE_MESSAGE(reduced.ok(), reduced.to_string());
  s.bounds = converter::compute_bounds(s.cloud);
  auto gpu = runtime::GpuScene::from_cloud(s.cloud, s.bounds);
  REQUIRE_MESSAGE(gpu.ok(), gpu.status().to_string());
  s.gpu = std::make_unique<runtime::GpuScene>(std::move(gpu).value());
  s.available = true;
  return s;
}

inline const GpuScenePair& guitar() {
  static const GpuScenePair s = load_pair(repo_path("samples/guitar.ply"));
  return s;
}

inline const GpuScenePair& flowers_fp32() {
  static const GpuScenePair s = [] {
    const std::string ply = shared_scene("mipnerf360_flowers_c3dgs.ply");
    const std::string cams = shared_scene("mipnerf360_flowers_cameras.json");
    if (ply.empty() || cams.empty()) return GpuScenePair{};
    GpuScenePair p = load_pair(ply);
    p.cameras_path = cams;
    return p;
  }();
  return s;
}

/// Flowers as a .rgs for the baseline's device-dequantization path: the staged
/// `mipnerf360_flowers_c3dgs.rgs` when RGS_DATA_DIR has one (the GPU host does), else the PLY quantized in
/// memory with zstd sections (which also exercises from_rgs's pinned zstd upload).
inline const GpuScenePair& flowers_rgs() {
  static const GpuScenePair s = [] {
    const std::string cams = shared_scene("mipnerf360_flowers_cameras.json");
    if (cams.empty()) return GpuScenePair{};
    const auto staged = shared_data_dir() / "mipnerf360_flowers_c3dgs.rgs";
    GpuScenePair p;
    if (std::filesystem::exists(staged)) {
      p = load_pair(staged.string());
    } else {
      const GpuScenePair& fp32 = flowers_fp32();
      if (!fp32.available) return GpuScenePair{};
      const CompactScene compact = make_compact(fp32.cloud, true);
      p = pair_from_rgs(*compact.file);
    }
    p.cameras_path = cams;
    return p;
  }();
  return s;
}

inline const GpuScenePair& daffodils() {
  static const GpuScenePair s = [] {
    const std::string path = shared_scene_any("playcanvas_flowers_lod0");
    return path.empty() ? GpuScenePair{} : load_pair(path);
  }();
  return s;
}

/// taebak (4,249,286 Gaussians, a real aerial capture) and its 8 cameras (taebak_cameras.json in RGS_DATA_DIR).
/// The .rgs is named by RGS_TAEBAK_RGS: it is too large to stage with the other scenes, so the GPU host converts
/// it from the SOG (scripts/gpu_prepare_taebak.sh) and scripts/gpu_check.sh passes its path. Without the variable
/// or the cameras every call prints why it skips; the scene itself is loaded once.
inline const GpuScenePair& taebak() {
  static const GpuScenePair none;
  const char* rgs = std::getenv("RGS_TAEBAK_RGS");
  if (rgs == nullptr || *rgs == '\0') {
    MESSAGE("skipped: RGS_TAEBAK_RGS is not set (the path of taebak.rgs; scripts/gpu_check.sh sets it on the GPU "
            "host after scripts/gpu_prepare_taebak.sh)");
    return none;
  }
  const std::string cams = shared_scene("taebak_cameras.json");
  if (cams.empty()) return none;
  static const GpuScenePair s = [&] {
    GpuScenePair p = load_pair(rgs);
    p.cameras_path = cams;
    return p;
  }();
  return s;
}

/// Cameras of an INRIA cameras.json (every `every`-th, from the first), scaled to width × height.
inline std::vector<runtime::Camera> flowers_cameras(const std::string& path, uint32_t every, uint32_t width,
                                                    uint32_t height) {
  runtime::InriaCameraOptions options;
  options.every_kth = every;
  options.width = width;
  options.height = height;
  auto cams = runtime::load_inria_cameras(path, options);
  REQUIRE_MESSAGE(cams.ok(), cams.status().to_string());
  return std::move(cams).value();
}

/// Ping-pong key and value buffers of `capacity` pairs and the scratch of a 32-bit pair sort of that many
/// (kernels::sort_pairs_ping_pong's size query).
struct SortBuffers {
  runtime::DeviceBuffer<uint32_t> keys[2], values[2];
  runtime::DeviceBuffer<uint8_t> temp;
  size_t temp_bytes = 0;
  uint32_t* key_buffers[2] = {nullptr, nullptr};
  uint32_t* value_buffers[2] = {nullptr, nullptr};

  explicit SortBuffers(uint64_t capacity) {
    for (int i = 0; i < 2; ++i) {
      REQUIRE(keys[i].reserve_exact(capacity, "keys").ok());
      REQUIRE(values[i].reserve_exact(capacity, "values").ok());
      key_buffers[i] = keys[i].data();
      value_buffers[i] = values[i].data();
    }
    int sorted = 0;
    REQUIRE(kernels::sort_pairs_ping_pong(nullptr, &temp_bytes, key_buffers, value_buffers, capacity, capacity, 0, 32,
                                          false, &sorted, nullptr) == cudaSuccess);
    REQUIRE(temp.reserve_exact(temp_bytes, "sort scratch").ok());
  }
};

struct GpuFrame {
  std::vector<float> rgba;   // [H, W, 4]
  std::vector<float> depth;  // [H, W] when asked for
  runtime::GpuRenderStats stats;
};

/// True when two planes have the same size and the same bits.
inline bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

/// Renders on the GPU into planes poisoned with NaN (0xFF bytes), so unwritten pixels fail comparisons.
inline GpuFrame render_gpu(runtime::GpuRenderer& renderer, const runtime::GpuScene& scene,
                           const runtime::Camera& camera, const runtime::GpuRenderOptions& options,
                           bool with_depth) {
  runtime::DeviceImage image;
  REQUIRE(image.resize(camera.width, camera.height, with_depth).ok());
  const size_t pixels = size_t(camera.width) * camera.height;
  REQUIRE(cudaMemset(image.rgba(), 0xff, pixels * 4 * sizeof(float)) == cudaSuccess);
  if (with_depth) REQUIRE(cudaMemset(image.depth(), 0xff, pixels * sizeof(float)) == cudaSuccess);
  auto stats = renderer.render(scene, camera, options, &image);
  REQUIRE_MESSAGE(stats.ok(), stats.status().to_string());
  auto host = runtime::download(image);
  REQUIRE_MESSAGE(host.ok(), host.status().to_string());
  return GpuFrame{std::move(host->rgba), std::move(host->depth), *stats};
}

/// samples/guitar.ply, quantized as rgs-convert does, with levels of detail in chunks of 4096: the file's bytes.
inline const std::vector<uint8_t>& guitar_lod_bytes() {
  static const std::vector<uint8_t> bytes = [] {
    auto input = converter::read_scene(repo_path("samples/guitar.ply"));
    REQUIRE(input.ok());
    auto encoded = converter::quantize(input->cloud, converter::QuantizeOptions{});
    REQUIRE(encoded.ok());
    converter::LodBuildOptions build;
    build.max_chunk_gaussians = 4096;
    auto lod = converter::build_lod(*encoded, build);
    REQUIRE(lod.ok());
    format::WriteOptions write;
    write.lod = &lod->index;
    auto serialized = format::serialize_scene(lod->scene, write);
    REQUIRE(serialized.ok());
    return std::move(serialized).value();
  }();
  return bytes;
}

/// PSNR (values clamped to [0, 1], peak 1) and max |Δ| of the RGB channels of a GPU RGBA image against an
/// RGB image; a NaN anywhere in the GPU image (RGB or alpha: the poison of an unwritten pixel) is reported.
struct Diff {
  double psnr = std::numeric_limits<double>::infinity();
  double max_abs = 0;
  bool any_nan = false;
};

inline Diff compare_rgb(const std::vector<float>& rgba, const std::vector<float>& rgb) {
  REQUIRE(rgba.size() / 4 == rgb.size() / 3);
  Diff d;
  double se = 0;
  const size_t pixels = rgb.size() / 3;
  for (size_t p = 0; p < pixels; ++p) {
    if (std::isnan(rgba[p * 4 + 3])) d.any_nan = true;  // an unwritten alpha (poison) counts too
    for (int c = 0; c < 3; ++c) {
      const float g = rgba[p * 4 + c], r = rgb[p * 3 + c];
      if (std::isnan(g)) d.any_nan = true;  // std::max below would drop a NaN silently
      d.max_abs = std::max(d.max_abs, std::fabs(double(g) - double(r)));
      const double e = double(std::clamp(g, 0.f, 1.f)) - double(std::clamp(r, 0.f, 1.f));
      se += e * e;
    }
  }
  if (se > 0) d.psnr = 10.0 * std::log10(double(pixels * 3) / se);
  if (d.any_nan) d.psnr = -std::numeric_limits<double>::infinity();
  return d;
}

inline std::vector<float> rgb_of(const std::vector<float>& rgba) {
  std::vector<float> rgb(rgba.size() / 4 * 3);
  for (size_t p = 0; p < rgba.size() / 4; ++p) {
    for (int c = 0; c < 3; ++c) rgb[p * 3 + c] = rgba[p * 4 + c];
  }
  return rgb;
}

/// True when every pixel is exactly (bg, alpha 0).
inline bool all_background(const std::vector<float>& rgba, const std::array<float, 3>& bg) {
  for (size_t p = 0; p < rgba.size() / 4; ++p) {
    if (rgba[p * 4] != bg[0] || rgba[p * 4 + 1] != bg[1] || rgba[p * 4 + 2] != bg[2] || rgba[p * 4 + 3] != 0.f) {
      return false;
    }
  }
  return true;
}

/// Copies `count` floats from device memory.
inline std::vector<float> download_floats(const float* device, size_t count) {
  std::vector<float> host(count);
  if (count > 0) {
    REQUIRE(cudaMemcpy(host.data(), device, count * sizeof(float), cudaMemcpyDeviceToHost) == cudaSuccess);
  }
  return host;
}

/// GpuRenderOptions of `preset`, as the product renders it.
inline runtime::GpuRenderOptions preset_options(runtime::Preset preset) {
  runtime::GpuRenderOptions options;
  options.preset = preset;
  return options;
}

/// GpuRenderOptions with `preset`'s techniques set out for a test to change (GpuRenderOptions::lab_techniques).
inline runtime::GpuRenderOptions preset_techniques_options(runtime::Preset preset, bool scene_has_compact) {
  runtime::GpuRenderOptions options = preset_options(preset);
  options.lab_techniques = runtime::gpu_techniques(preset, scene_has_compact);
  return options;
}

/// Gives `options` the lab's RoofGS stages (lab::roofgs_stages()) for a configuration no preset uses (the
/// separate preprocess and duplication, a lab variant of the render kernel), when this build has the lab
/// (RGS_BUILD_LAB). @return false without the lab: the caller skips the configuration, saying so.
inline bool use_lab_stages(runtime::GpuRenderOptions* options) {
#if RGS_TEST_WITH_LAB
  options->stages = lab::roofgs_stages();
  return true;
#else
  (void)options;
  MESSAGE("skipped: a configuration no preset uses needs the lab's stages (RGS_BUILD_LAB=ON)");
  return false;
#endif
}

}  // namespace rgs::test
