// Levels in memory: the store an in-memory build fills (held_store) and the view the sinks read (held_levels);
// and the section table both level stores share.
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include "../internal_huge_pages.h"
#include "internal_levels.h"
#include "rgs/converter/lod_builder.h"

namespace rgs::converter {

namespace detail {

int level_section(format::SectionId id) {
  const auto* at = std::find(kLevelSectionIds, kLevelSectionIds + kLevelSections, id);
  return at == kLevelSectionIds + kLevelSections ? -1 : static_cast<int>(at - kLevelSectionIds);
}

uint64_t section_width(int s, uint64_t sh_values) {
  static constexpr uint64_t kWidths[kLevelSections] = {12, 8, 6, 2, 0, 3};
  return s == 4 ? sh_values : kWidths[s];
}

const uint8_t* section_bytes(const format::EncodedScene& scene, int s) {
  switch (s) {
    case 0: return reinterpret_cast<const uint8_t*>(scene.means.data());
    case 1: return reinterpret_cast<const uint8_t*>(scene.rotations.data());
    case 2: return reinterpret_cast<const uint8_t*>(scene.scales.data());
    case 3: return reinterpret_cast<const uint8_t*>(scene.opacities.data());
    case 4: return reinterpret_cast<const uint8_t*>(scene.sh.data());
    default: return reinterpret_cast<const uint8_t*>(scene.sh_dc_residual.data());
  }
}

void size_sections(format::EncodedScene* scene, uint64_t n, uint64_t sh_values, bool residual) {
  scene->count = n;
  scene->means.resize(n * 3);
  scene->rotations.resize(n * 4);
  scene->scales.resize(n * 3);
  scene->opacities.resize(n);
  scene->sh.resize(n * sh_values);
  scene->sh_dc_residual.resize(residual ? n * 3 : 0);
}

namespace {

class HeldStore final : public LevelStore {
 public:
  HeldStore(LodScene* out, const Layout& layout) : out_(*out), layout_(layout) {}
  Status reserve(const format::LodIndex& index, uint64_t total) override {
    out_.index = index;
    format::EncodedScene& s = out_.scene;
    s.count = total;
    resize_huge(s.means, total * 3);
    resize_huge(s.rotations, total * 4);
    resize_huge(s.scales, total * 3);
    resize_huge(s.opacities, total);
    resize_huge(s.sh, total * layout_.sh_values);
    if (layout_.dc_residual) resize_huge(s.sh_dc_residual, total * 3);
    return Status();
  }
  Status add(uint32_t c, const format::EncodedScene& chunk, const ChunkPlan& plan, uint32_t levels) override {
    RGS_RETURN_ERROR_IF(c >= out_.index.chunk_count || levels != out_.index.level_count, StatusCode::kInvalidArgument,
                        "build_lod: internal error: chunk " + std::to_string(c) + " outside the layout");
    uint64_t from = 0;
    for (uint32_t l = 0; l < levels; ++l) {
      const uint64_t to = out_.index.at(l, c).first;
      for (int k = 0; k < section_count(layout_.dc_residual); ++k) {
        const uint64_t width = section_width(k, layout_.sh_values);
        std::memcpy(section_bytes(&out_.scene, k) + to * width, section_bytes(chunk, k) + from * width,
                    plan.count[l] * width);
      }
      from += plan.count[l];
    }
    return Status();
  }
  bool needs_checksums() const override { return false; }  // format::write_scene_file computes them

 private:
  LodScene& out_;
  Layout layout_;
};

}  // namespace

std::unique_ptr<LevelStore> held_store(LodScene* out, const Layout& layout) {
  return std::make_unique<HeldStore>(out, layout);
}

}  // namespace detail

namespace {

using namespace detail;

/// Pieces a section is streamed in.
constexpr uint64_t kPieceBytes = uint64_t{4} << 20;

class HeldLevels final : public Levels {
 public:
  explicit HeldLevels(const LodScene& lod) : lod_(lod) {
    head_.count = lod.scene.count;
    head_.metadata = lod.scene.metadata;
    head_.provenance = lod.scene.provenance;
  }
  const format::EncodedScene& head() const override { return head_; }
  const format::LodIndex& index() const override { return lod_.index; }
  bool sh_dc_residual() const override { return !lod_.scene.sh_dc_residual.empty(); }

  Status read(uint64_t first, uint64_t count, format::EncodedScene* out) const override {
    RGS_RETURN_ERROR_IF(first > head_.count || count > head_.count - first, StatusCode::kInvalidArgument,
                        "levels: Gaussians [" + std::to_string(first) + ", +" + std::to_string(count) +
                            ") outside the " + std::to_string(head_.count) + " built");
    const uint64_t sh_values = sh_values_of();
    out->metadata = head_.metadata;
    size_sections(out, count, sh_values, sh_dc_residual());
    for (int s = 0; s < section_count(sh_dc_residual()); ++s) {
      const uint64_t width = section_width(s, sh_values);
      std::memcpy(section_bytes(out, s), section_bytes(lod_.scene, s) + first * width, count * width);
    }
    return Status();
  }

  Status stream_section(format::SectionId id, const format::ChunkSink& sink) const override {
    const int s = level_section(id);
    if (s < 0 || s >= section_count(sh_dc_residual())) return Status();
    const uint64_t width = section_width(s, sh_values_of());
    const uint8_t* bytes = section_bytes(lod_.scene, s);
    const uint64_t piece = std::max<uint64_t>(1, kPieceBytes / std::max<uint64_t>(width, 1)) * width;
    for (uint64_t at = 0, size = head_.count * width; at < size; at += piece) {
      RGS_RETURN_IF_ERROR(sink(bytes + at, static_cast<size_t>(std::min(piece, size - at))));
    }
    return Status();
  }

 private:
  uint64_t sh_values_of() const { return uint64_t{3} * format::sh_coefficient_count(head_.metadata.sh_degree); }
  const LodScene& lod_;
  format::EncodedScene head_;
};

}  // namespace

format::StreamedScene Levels::streamed() const {
  format::StreamedScene scene;
  scene.metadata = head().metadata;
  scene.provenance = head().provenance;
  scene.count = head().count;
  scene.sh_dc_residual = sh_dc_residual();
  scene.produce = [this](format::SectionId id, const format::ChunkSink& sink) { return stream_section(id, sink); };
  return scene;
}

std::unique_ptr<Levels> held_levels(const LodScene& lod) { return std::make_unique<HeldLevels>(lod); }

}  // namespace rgs::converter
