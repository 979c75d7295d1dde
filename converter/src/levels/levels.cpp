// Levels in memory: the store an in-memory build fills (held_store) and the view the sinks read (held_levels);
// and the section table both level stores share.
#include <algorithm>
#include <cstring>
#include <memory>
#include <string>

#include "internal_levels.h"
#include "rgs/converter/lod_builder.h"

namespace rgs::converter {

namespace detail {

int level_section(format::SectionId id) {
  const auto* at = std::find(kLevelSectionIds, kLevelSectionIds + kLevelSections, id);
  return at == kLevelSectionIds + kLevelSections ? -1 : static_cast<int>(at - kLevelSectionIds);
}

namespace {

class HeldStore final : public LevelStore {
 public:
  HeldStore(LodScene* out, const Layout& layout) : out_(*out), layout_(layout) {}
  Status reserve(const format::LodIndex& index, uint64_t total) override {
    out_.index = index;
    size_sections(&out_.scene, total, layout_.sh_values, layout_.dc_residual);
    return Status();
  }
  Status put(uint32_t c, uint32_t l, int k, const uint8_t* bytes, uint64_t size) override {
    RGS_RETURN_ERROR_IF(c >= out_.index.chunk_count || l >= out_.index.level_count, StatusCode::kInvalidArgument,
                        "build_lod: internal error: chunk " + std::to_string(c) + " outside the layout");
    std::memcpy(section_bytes(&out_.scene, k) + out_.index.at(l, c).first * section_width(k, layout_.sh_values),
                bytes, size);
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

format::EncodedScene head_of(const format::EncodedScene& scene) {
  format::EncodedScene head;
  head.count = scene.count;
  head.metadata = scene.metadata;
  head.provenance = scene.provenance;
  return head;
}

SectionLevels::SectionLevels(format::EncodedScene head, format::LodIndex index, bool residual)
    : head_(std::move(head)), index_(std::move(index)), residual_(residual),
      sh_values_(uint64_t{3} * format::sh_coefficient_count(head_.metadata.sh_degree)) {}

Status SectionLevels::read(uint64_t first, uint64_t count, format::EncodedScene* out) const {
  RGS_RETURN_ERROR_IF(first > head_.count || count > head_.count - first, StatusCode::kInvalidArgument,
                      "levels: Gaussians [" + std::to_string(first) + ", +" + std::to_string(count) +
                          ") outside the " + std::to_string(head_.count) + " built");
  out->metadata = head_.metadata;
  size_sections(out, count, sh_values_, residual_);
  for (int k = 0; k < section_count(residual_); ++k) {
    RGS_RETURN_IF_ERROR(read_section(k, first, count, section_bytes(out, k)));
  }
  return Status();
}

Status SectionLevels::stream_section(format::SectionId id, const format::ChunkSink& sink) const {
  const int k = level_section(id);
  if (k < 0 || k >= section_count(residual_)) return Status();
  const uint64_t width = section_width(k, sh_values_);
  const uint64_t step = std::max<uint64_t>(1, (uint64_t{4} << 20) / std::max<uint64_t>(width, 1));
  std::vector<uint8_t> piece(step * width);
  for (uint64_t at = 0; at < head_.count; at += step) {
    const uint64_t n = std::min(step, head_.count - at);
    RGS_RETURN_IF_ERROR(read_section(k, at, n, piece.data()));
    RGS_RETURN_IF_ERROR(sink(piece.data(), static_cast<size_t>(n * width)));
  }
  return Status();
}

}  // namespace detail

namespace {

using namespace detail;

/// Levels in the arrays of a LodScene (which outlives them).
class HeldLevels final : public SectionLevels {
 public:
  explicit HeldLevels(const LodScene& lod)
      : SectionLevels(head_of(lod.scene), lod.index, !lod.scene.sh_dc_residual.empty()), lod_(lod) {}

 private:
  Status read_section(int k, uint64_t first, uint64_t count, uint8_t* out) const override {
    const uint64_t width = section_width(k, sh_values_);
    std::memcpy(out, section_bytes(lod_.scene, k) + first * width, count * width);
    return Status();
  }
  const LodScene& lod_;
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
