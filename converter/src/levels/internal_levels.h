// The one level-of-detail builder's parts (lod_builder.cpp): where it takes the scene's partitions from (the
// scene itself in memory, buckets of partition files out of core: lod_out_of_core.cpp), where it puts the levels
// (arrays in memory: levels.cpp; spill files out of core), and the per-Gaussian sections both stores move.
#pragma once

#include <cstdint>
#include <memory>

#include "../internal_huge_pages.h"
#include "internal_lod_chunks.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/spec.h"

namespace rgs::converter::detail {

/// The per-Gaussian sections in file order (SPEC §4.3–§4.8).
inline constexpr int kLevelSections = 6;
inline constexpr format::SectionId kLevelSectionIds[kLevelSections] = {
    format::SectionId::kMeans,     format::SectionId::kRotations, format::SectionId::kScales,
    format::SectionId::kOpacities, format::SectionId::kSh,        format::SectionId::kShDcResidual};

/// The sections a scene holds: all of them with the DC residual, the last one (sh_dc_residual) left out without.
inline int section_count(bool residual) { return residual ? kLevelSections : kLevelSections - 1; }

/// Section `id`'s index in kLevelSectionIds, -1 for another section.
int level_section(format::SectionId id);

/// Bytes one Gaussian takes in section s (an index into kLevelSectionIds) with `sh_values` SH values a Gaussian.
inline uint64_t section_width(int s, uint64_t sh_values) {
  static constexpr uint64_t kWidths[kLevelSections] = {12, 8, 6, 2, 0, 3};
  return s == 4 ? sh_values : kWidths[s];
}

/// Where `scene` keeps section s: its first byte (the section's array of `scene`, sized by the caller).
inline const uint8_t* section_bytes(const format::EncodedScene& scene, int s) {
  switch (s) {
    case 0: return reinterpret_cast<const uint8_t*>(scene.means.data());
    case 1: return reinterpret_cast<const uint8_t*>(scene.rotations.data());
    case 2: return reinterpret_cast<const uint8_t*>(scene.scales.data());
    case 3: return reinterpret_cast<const uint8_t*>(scene.opacities.data());
    case 4: return reinterpret_cast<const uint8_t*>(scene.sh.data());
    default: return reinterpret_cast<const uint8_t*>(scene.sh_dc_residual.data());
  }
}
inline uint8_t* section_bytes(format::EncodedScene* scene, int s) {
  return const_cast<uint8_t*>(section_bytes(*scene, s));
}

/// Chunks built at once per worker before they are handed to the store in chunk order.
inline constexpr uint32_t kChunksPerWorker = 2;

/// A partition of the scene: its Gaussians, and their Morton order cut into the octree chunks (MortonOrder::leaves).
struct Partition {
  const format::EncodedScene* scene = nullptr;
  MortonOrder order;
};

/// Where the builder takes the scene's partitions from, in Morton order.
class PartitionSource {
 public:
  virtual ~PartitionSource() = default;
  virtual uint32_t count() const = 0;
  /// Partition b into `*out`, valid until the next load.
  virtual Status load(uint32_t b, Partition* out) = 0;
};

/// Where the builder puts each chunk's levels, chunk after chunk.
class LevelStore {
 public:
  virtual ~LevelStore() = default;
  /// The index laid out (checksums 0) and the Gaussians of every level, given before the first chunk when the
  /// builder knows them then (a scene of one partition, whose levels are chosen before they are built).
  virtual Status reserve(const format::LodIndex& layout, uint64_t total) = 0;
  /// Section k (an index into kLevelSectionIds) of chunk c's level l: `size` bytes, the chunks' in order.
  virtual Status put(uint32_t c, uint32_t l, int k, const uint8_t* bytes, uint64_t size) = 0;
  /// Whether the index is to carry each range's checksum (SPEC §4.9) from the builder.
  virtual bool needs_checksums() const = 0;
};

/// `scene` without its arrays: count, metadata and provenance.
format::EncodedScene head_of(const format::EncodedScene& scene);

/// Levels laid out level-major whose sections are read in pieces: read() and stream_section() over
/// read_section() of the store that holds them (arrays, spill files).
class SectionLevels : public Levels {
 public:
  SectionLevels(format::EncodedScene head, format::LodIndex index, bool residual);
  const format::EncodedScene& head() const final { return head_; }
  const format::LodIndex& index() const final { return index_; }
  bool sh_dc_residual() const final { return residual_; }
  Status read(uint64_t first, uint64_t count, format::EncodedScene* out) const final;
  Status stream_section(format::SectionId id, const format::ChunkSink& sink) const final;

 protected:
  /// Section k's bytes of Gaussians [first, first + count) of the output order into `out`.
  virtual Status read_section(int k, uint64_t first, uint64_t count, uint8_t* out) const = 0;
  format::EncodedScene head_;
  format::LodIndex index_;
  bool residual_;
  uint64_t sh_values_;
};

/// The index and the output's head (count, metadata with the bounds sphere, provenance with the lod entries).
struct BuiltIndex {
  format::LodIndex index;
  format::EncodedScene head;
};

/// The builder: every partition of `source` planned into chunks, their levels built in parallel and handed to
/// `store` in chunk order, then the level count chosen (before building with one partition), the index laid out
/// with the chunks' centres, radii and (store.needs_checksums()) checksums. `head`: the scene without its arrays
/// (count, metadata with bounds.aabb the box of every mean, provenance). `progress` counts 5/2 per Gaussian.
/// Errors: choose_levels', set_chunk_radii's, the source's and the store's.
Result<BuiltIndex> build_levels(PartitionSource& source, LevelStore& store, const format::EncodedScene& head,
                                const LodBuildOptions& options, Progress* progress);

/// The store of an in-memory build: the levels in `*out`'s arrays, each chunk's at its place in the index.
std::unique_ptr<LevelStore> held_store(LodScene* out, const Layout& layout);

}  // namespace rgs::converter::detail
