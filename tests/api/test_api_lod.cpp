// Level-of-detail scenes through the front door on the CPU (LoadOptions::lod, docs/LOD.md): settings checked,
// settings a scene cannot use noted, the full detail on request; a frame draws exactly the levels
// runtime::select_lod chooses (with no budget and no error allowed: the ordinary render bit for bit; under a splat
// budget: the selection's ranges as the file stores them, and no more Gaussians than the budget).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <xxhash.h>

#include "rgs/api/convert.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/preset_techniques.h"
#include "rgs/runtime/lod_selection.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

/// samples/guitar.ply converted with levels of detail in chunks of 4096 (rgs-convert --lod-levels auto
/// --lod-chunk 4096); the writer is deterministic and writes atomically, so processes may share the name.
const std::string& guitar_lod_rgs() {
  static const std::string path = [] {
    const auto p = std::filesystem::temp_directory_path() / "rgs_test_api_guitar_lod.rgs";
    api::ConvertOptions options;
    options.lod_levels = 0;
    options.lod_chunk_gaussians = 4096;
    auto report = api::convert(test::repo_path("samples/guitar.ply"), p.string(), options);
    REQUIRE_MESSAGE(report.ok(), report.status().to_string());
    REQUIRE(report->rgs);
    REQUIRE(report->rgs->lod_chunks > 4);
    return p.string();
  }();
  return path;
}

api::LoadOptions cpu_options(uint64_t splat_budget, float pixel_error, bool enabled = true) {
  api::LoadOptions o;
  o.device = api::Device::kCpu;
  o.lod.enabled = enabled;
  o.lod.splat_budget = splat_budget;
  o.lod.pixel_error = pixel_error;
  return o;
}

struct Frame {
  std::vector<float> rgba, depth;
  api::FrameStats stats;
};

Frame render(api::Renderer& renderer, const api::Scene& scene, const api::Camera& camera) {
  Frame f;
  f.rgba.resize(size_t(camera.width) * camera.height * 4);
  f.depth.resize(size_t(camera.width) * camera.height);
  const api::ImageTarget target{camera.width, camera.height, f.rgba.data(), size_t(camera.width) * 16,
                                api::PixelFormat::kRgba32f, true, f.depth.data(), size_t(camera.width) * 4};
  auto stats = renderer.render(scene, camera, {}, target);
  REQUIRE_MESSAGE(stats.ok(), stats.status().to_string());
  f.stats = *stats;
  return f;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

bool has_note(const api::SceneInfo& info, const std::string& text) {
  return std::any_of(info.notes.begin(), info.notes.end(),
                     [&](const std::string& n) { return n.find(text) != std::string::npos; });
}

/// The Gaussians of `selection` read independently of the scene: each chosen range's bytes as the file stores
/// them (RgsFile::lod_range), dequantized, concatenated in chunk order.
format::GaussianCloud selected_cloud(const format::RgsFile& file, const runtime::LodSelection& selection) {
  format::GaussianCloud out;
  out.sh_degree = file.metadata().sh_degree;
  const uint64_t k3 = 3 * format::sh_coefficient_count(out.sh_degree);
  for (const runtime::LodChoice& choice : selection.choices) {
    auto r = file.lod_range(choice.level, choice.chunk);
    REQUIRE_MESSAGE(r.ok(), r.status().to_string());
    format::EncodedScene e;
    e.metadata = file.metadata();
    e.count = r->count;
    const auto take = [](auto& v, const format::ByteView& b, size_t n) {
      v.resize(n);
      REQUIRE(b.size == n * sizeof(v[0]));
      if (n > 0) std::memcpy(v.data(), b.data, b.size);
    };
    take(e.means, r->means, r->count * 3);
    take(e.rotations, r->rotations, r->count * 4);
    take(e.scales, r->scales, r->count * 3);
    take(e.opacities, r->opacities, r->count);
    take(e.sh, r->sh, r->count * k3);
    if (r->sh_dc_residual.size > 0) take(e.sh_dc_residual, r->sh_dc_residual, r->count * 3);
    auto part = format::dequantize(e);
    REQUIRE_MESSAGE(part.ok(), part.status().to_string());
    const auto append = [](std::vector<float>& to, const std::vector<float>& from) {
      to.insert(to.end(), from.begin(), from.end());
    };
    append(out.means, part->means);
    append(out.rotations, part->rotations);
    append(out.scales, part->scales);
    append(out.opacities, part->opacities);
    append(out.sh, part->sh);
  }
  REQUIRE(out.is_consistent());
  return out;
}

}  // namespace

TEST_CASE("LOD settings: out-of-range values refused, settings a scene cannot use noted, full detail on request") {
  const std::string lod_path = guitar_lod_rgs();
  const std::string plain = test::repo_path("samples/guitar.ply");
  for (const std::string& path : {lod_path, plain}) {
    CAPTURE(path);
    for (float bad : {-1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
      const Status s = api::load(path, cpu_options(1000, bad)).status();
      CHECK(s.code() == StatusCode::kInvalidArgument);
      CHECK(s.message().find("pixel error") != std::string::npos);
    }
    api::LoadOptions no_stream = cpu_options(1000, 1.0f);
    no_stream.lod.stream_bytes_per_frame = 0;
    CHECK(api::load(path, no_stream).status().code() == StatusCode::kInvalidArgument);
    // Disabled settings are not used, hence not checked.
    CHECK(api::load(path, cpu_options(1000, -1.0f, false)).ok());
  }

  // A file without levels: defaults pass silently, a budget of the caller's is noted as unused.
  auto quiet = api::load(plain, cpu_options(api::LodSettings{}.splat_budget, api::LodSettings{}.pixel_error));
  REQUIRE(quiet.ok());
  CHECK_FALSE(quiet->info().lod.active);
  CHECK_FALSE(has_note(quiet->info(), "level-of-detail"));
  auto noted = api::load(plain, cpu_options(1000, 1.0f));
  REQUIRE(noted.ok());
  CHECK_FALSE(noted->info().lod.active);
  CHECK(noted->info().lod.levels == 0);
  CHECK(has_note(noted->info(), "level-of-detail budgets not used"));

  // The level-of-detail file: streamed by default, its full detail with lod.enabled = false.
  auto file = format::RgsFile::open(lod_path);
  REQUIRE(file.ok());
  const format::LodIndex& index = *file->lod();
  api::LoadOptions defaults;
  defaults.device = api::Device::kCpu;
  auto active = api::load(lod_path, defaults);
  REQUIRE(active.ok());
  const api::SceneInfo& a = active->info();
  CHECK(a.lod.active);
  CHECK(a.lod.chunks == index.chunk_count);
  CHECK(a.lod.levels == index.level_count);
  CHECK(a.lod.stored_gaussians == file->gaussian_count());
  CHECK(a.lod.settings.splat_budget == 3'000'000);
  CHECK(a.lod.pool_bytes == 0);
  CHECK(a.gaussians == index.full_detail_count());
  CHECK(active->size() == index.full_detail_count());
  CHECK(a.memory_bytes > active->cloud()->size() * 4 * (3 + 4 + 3 + 1 + 3));  // the coarser levels too
  CHECK(a.description.find("levels of detail") != std::string::npos);
  CHECK_FALSE(has_note(a, "level-of-detail"));
  auto full = api::load(lod_path, cpu_options(0, 0.0f, false));
  REQUIRE(full.ok());
  CHECK_FALSE(full->info().lod.active);
  CHECK(full->info().lod.levels == index.level_count);
  CHECK(full->info().gaussians == index.full_detail_count());
  // cloud() is the full detail in both.
  CHECK(active->cloud()->means == full->cloud()->means);
  CHECK(active->cloud()->sh == full->cloud()->sh);

  // The CPU holds every level: a memory budget means nothing to it, and says so.
  api::LoadOptions budgeted = defaults;
  budgeted.lod.memory_budget = 1 << 20;
  auto with_budget = api::load(lod_path, budgeted);
  REQUIRE(with_budget.ok());
  CHECK(has_note(with_budget->info(), "memory budget not used on the CPU"));

  // Ordinary scenes report no level-of-detail counts.
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  auto cams = runtime::orbit_cameras(full->info().bounds, 1, 48, 27);
  REQUIRE(cams.ok());
  const Frame f = render(*renderer, *full, (*cams)[0]);
  CHECK(f.stats.lod.splats == 0);
  CHECK(f.stats.lod.chunks_drawn == 0);
  CHECK(f.stats.gaussians == index.full_detail_count());
}

TEST_CASE("LOD CPU frames: no budget and no error is the full render bit for bit, a budget draws the selection") {
  const std::string path = guitar_lod_rgs();
  auto file = format::RgsFile::open(path);
  REQUIRE(file.ok());
  const format::LodIndex& index = *file->lod();
  const uint64_t n0 = index.full_detail_count();
  auto full = api::load(path, cpu_options(0, 0.0f, false));
  REQUIRE(full.ok());
  auto exact = api::load(path, cpu_options(0, 0.0f));
  REQUIRE(exact.ok());
  const uint64_t budget = n0 / 4;
  auto budgeted = api::load(path, cpu_options(budget, 0.0f));  // the budget alone chooses
  REQUIRE(budgeted.ok());
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  auto cams = runtime::orbit_cameras(file->metadata().bounds, 3, 160, 90);
  REQUIRE(cams.ok());
  const uint64_t bpg = 12 + 8 + 6 + 2 + 3 * format::sh_coefficient_count(file->metadata().sh_degree) +
                       (file->find(format::SectionId::kShDcResidual) ? 3 : 0);
  for (const api::Camera& camera : *cams) {
    CAPTURE(camera.name);
    const Frame reference = render(*renderer, *full, camera);

    // Level 0 of every chunk, in chunk order: the file's full detail in its own order.
    const Frame whole = render(*renderer, *exact, camera);
    CHECK(whole.stats.lod.chunks_culled == 0);  // the orbit frames the whole scene
    CHECK(whole.stats.lod.chunks_drawn == index.chunk_count);
    CHECK(whole.stats.lod.chunks_coarsened == 0);
    CHECK(whole.stats.lod.splats == n0);
    CHECK(whole.stats.gaussians == n0);
    CHECK(whole.stats.pairs == reference.stats.pairs);
    CHECK(same_bits(whole.rgba, reference.rgba));
    CHECK(same_bits(whole.depth, reference.depth));

    // Under a quarter of the Gaussians: the selection's ranges, nothing else, and a different image.
    const Frame small = render(*renderer, *budgeted, camera);
    const runtime::LodSelection selection = runtime::select_lod(index, camera, {budget, 0.0f});
    CHECK(small.stats.lod.splats == selection.splats);
    CHECK(small.stats.lod.splats <= budget);
    CHECK(small.stats.gaussians == small.stats.lod.splats);
    CHECK(small.stats.lod.chunks_coarsened == selection.coarsened);
    CHECK(small.stats.lod.chunks_coarsened > 0);
    CHECK(small.stats.lod.chunks_drawn == selection.choices.size());
    CHECK(small.stats.lod.chunks_culled == selection.culled);
    CHECK(small.stats.lod.chunks_not_resident == 0);
    CHECK(small.stats.lod.bytes_streamed == 0);
    CHECK(small.stats.lod.bytes_resident == file->gaussian_count() * bpg);
    CHECK_FALSE(same_bits(small.rgba, reference.rgba));
    const format::GaussianCloud expected_cloud = selected_cloud(*file, selection);
    CHECK(expected_cloud.size() == selection.splats);
    auto expected = runtime::render_cpu(expected_cloud, camera,
                                        runtime::cpu_backend_options(api::Preset::kFastest, file->metadata().bounds));
    REQUIRE(expected.ok());
    CHECK(small.stats.pairs == expected->stats.pairs);
    bool same = true;
    for (size_t p = 0; p < size_t(camera.width) * camera.height; ++p) {
      for (int c = 0; c < 3; ++c) same &= small.rgba[p * 4 + c] == expected->rgb[p * 3 + c];
      same &= small.rgba[p * 4 + 3] == expected->alpha[p];
      same &= small.depth[p] == expected->depth[p];
    }
    CHECK(same);
    // The CPU keeps no frame state: the same camera gives the same frame.
    CHECK(same_bits(render(*renderer, *budgeted, camera).rgba, small.rgba));
  }
}

TEST_CASE("LOD CPU frames of the golden v1.3 file: chunks, levels and a budget of its coarsest levels") {
  const std::string path = test::repo_path("tests/data/v1.3/small_sh1_lod.rgs");
  auto scene = api::load(path, cpu_options(3, 1.0f));
  REQUIRE(scene.ok());
  const api::SceneInfo& info = scene->info();
  CHECK(info.lod.active);
  CHECK(info.lod.chunks == 2);
  CHECK(info.lod.levels == 3);
  CHECK(info.lod.stored_gaussians == 24);
  CHECK(info.gaussians == 14);
  CHECK(info.sh_degree == 1);
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  auto cams = runtime::orbit_cameras(info.bounds, 2, 64, 36);
  REQUIRE(cams.ok());
  for (const api::Camera& camera : *cams) {
    const Frame f = render(*renderer, *scene, camera);
    CHECK(f.stats.lod.chunks_drawn + f.stats.lod.chunks_culled == 2);
    CHECK(f.stats.lod.splats <= 3);  // the coarsest levels hold 3 Gaussians in all
    CHECK(f.stats.gaussians == f.stats.lod.splats);
  }

  // A damaged coarse level (the last Gaussian's mean, in level 2) is refused at load, naming the file.
  std::string bytes = test::slurp(path);
  auto file = format::RgsFile::from_bytes(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  REQUIRE(file.ok());
  const format::SectionEntry* means = file->find(format::SectionId::kMeans);
  REQUIRE(means != nullptr);
  bytes[means->offset + 23 * 12 + 1] ^= 0x40;
  test::TempDir dir;
  const std::string damaged = dir.file("damaged_lod.rgs");
  std::ofstream(damaged, std::ios::binary) << bytes;
  const Status refused = api::load(damaged, cpu_options(3, 1.0f)).status();
  CHECK(refused.code() == StatusCode::kChecksumMismatch);
  CHECK(refused.message().find(damaged) != std::string::npos);
}

TEST_CASE("LOD CPU load checks every level-0 range: Gaussians swapped in a range with its checksum stale are refused") {
  // Sections and header consistent (their checksums recomputed), only the range's XXH64 (SPEC 4.9) stale:
  // the CPU load must check the ranges of the full detail as the GPU's streamer checks every range it reads.
  const std::string path = test::repo_path("tests/data/v1.3/small_sh1_lod.rgs");
  std::string bytes = test::slurp(path);
  auto file = format::RgsFile::from_bytes(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  REQUIRE(file.ok());
  const format::LodLevel& range = file->lod()->at(0, 1);
  REQUIRE(range.count >= 2);
  const uint64_t a = range.first, b = range.first + range.count - 1;
  const auto u64_at = [&](size_t at) {
    uint64_t v = 0;
    for (int k = 7; k >= 0; --k) v = (v << 8) | static_cast<uint8_t>(bytes[at + static_cast<size_t>(k)]);
    return v;
  };
  const auto put_u64 = [&](size_t at, uint64_t v) {
    for (int k = 0; k < 8; ++k) bytes[at + static_cast<size_t>(k)] = static_cast<char>(v >> (8 * k));
  };
  const uint32_t sections = static_cast<uint32_t>(file->sections().size());
  bool differ = false;
  for (uint32_t i = 0; i < sections; ++i) {
    const format::SectionEntry& e = file->sections()[i];
    if (e.element_type == format::ElementType::kBytes || e.element_count != file->gaussian_count()) continue;
    const size_t record = static_cast<size_t>(e.raw_size / e.element_count);
    std::string& d = bytes;
    const size_t pa = static_cast<size_t>(e.offset + a * record), pb = static_cast<size_t>(e.offset + b * record);
    differ = differ || d.compare(pa, record, d, pb, record) != 0;
    for (size_t k = 0; k < record; ++k) std::swap(d[pa + k], d[pb + k]);
    const size_t entry = format::kHeaderSize + format::kSectionEntrySize * i;
    put_u64(entry + 48, XXH64(bytes.data() + e.offset, static_cast<size_t>(u64_at(entry + 32)), 0));
  }
  REQUIRE(differ);
  std::string covered = bytes.substr(0, 56) + bytes.substr(format::kHeaderSize, format::kSectionEntrySize * sections);
  put_u64(56, XXH64(covered.data(), covered.size(), 0));
  test::TempDir dir;
  const std::string stale = dir.file("stale_level0_range.rgs");
  std::ofstream(stale, std::ios::binary) << bytes;
  // The sections alone are valid: only the range's checksum tells.
  auto reopened = format::RgsFile::from_bytes(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  REQUIRE_MESSAGE(reopened.ok(), reopened.status().to_string());
  for (uint32_t i = 0; i < sections; ++i) {
    CHECK_MESSAGE(reopened->verify_section(reopened->sections()[i].id).ok(), "section " << i);
  }
  CHECK(reopened->lod_range(0, 1).status().code() == StatusCode::kChecksumMismatch);

  const Status refused = api::load(stale, cpu_options(0, 1.0f)).status();
  CHECK(refused.code() == StatusCode::kChecksumMismatch);
  CHECK(refused.message().find(stale) != std::string::npos);
  CHECK(refused.message().find("chunk 1") != std::string::npos);
  // The full detail alone (levels of detail not used) reads the same ranges.
  const Status full = api::load(stale, cpu_options(0, 1.0f, false)).status();
  CHECK(full.code() == StatusCode::kChecksumMismatch);
  CHECK(full.message().find(stale) != std::string::npos);
}
