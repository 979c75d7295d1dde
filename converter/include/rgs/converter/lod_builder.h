// Level-of-detail builder: spatial chunks of a scene, each at several levels of detail, for the lod index of
// a .rgs file (format/SPEC.md §4.9).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/lod.h"
#include "rgs/format/status.h"
#include "rgs/format/writer.h"

namespace rgs::converter {

struct LodBuildOptions {
  /// Levels per chunk including the full detail: 0 = auto (levels until the coarsest level holds at most
  /// 1/64 of the full detail, usually 4, or until every chunk is down to one Gaussian; at most 8), else 1..16.
  uint32_t levels = 0;
  /// Largest number of full-detail Gaussians in one chunk (spatial split until each chunk holds at most this
  /// many).
  uint32_t max_chunk_gaussians = 65536;
  /// Worker threads (0 = every CPU this process may run on). The result does not depend on it.
  uint32_t threads = 0;
  /// Called with the fraction done in [0, 1], non-decreasing, from the calling thread only, at most every
  /// few ms, and with 1 at the end (may be empty).
  std::function<void(double)> progress;
};

/// A scene with its level-of-detail index: `scene` holds N = Σ counts Gaussians, level-major as `index` says.
struct LodScene {
  format::EncodedScene scene;
  format::LodIndex index;
};

/// Builds the levels of detail of `scene` (runtime profile: FP32 means, FP16 rotations, scales and
/// opacities, INT8 SH with optional DC residual).
///
/// Output: C chunks × L levels. Level 0 of chunk c holds the input Gaussians of the chunk bit for bit (only
/// reordered); the level-0 ranges of all chunks are the prefix [0, N0) of every section, so the output's
/// first N0 Gaussians are a permutation of the input. Records are level-major (record l·C + c), their
/// ranges tile [0, N) in record order; count(l + 1, c) ≤ count(l, c), count ≥ 1; `checksum` fields are 0
/// (the writer computes them).
///
/// Chunks: octree over the cube of the means' AABB (Morton order of 21 bits per axis), nodes split until
/// they hold at most max_chunk_gaussians Gaussians; a finest cell still larger is split by index. Non-empty
/// leaves, in Morton order, are the chunks.
///
/// Levels: a regular grid over the cube of the chunk's AABB, 2^21 cells per axis at the finest, whose cells
/// double in edge (eight cells nest into one). Level l ≥ 1 groups level l − 1's Gaussians by cell at the
/// finest grid coarser than level l − 1's that leaves at most a quarter of its count (or one cell), and
/// merges each cell's Gaussians into one parent; a parent belongs to the cell it was merged in, so the
/// levels nest. A cell holding one Gaussian keeps it bit for bit; a chunk down to one Gaussian repeats it.
/// Cell diagonal g(l, c) = √3 · cell edge of level l (how far any full-detail mean is from its parent's).
/// error(l, c), measured once the level is built: over the chunk's full-detail Gaussians j, weighted by their
/// coverage α_j · r_j², the root mean square of e_j = √(|μ_j − μ_p|² + (r_p − r_j)²) + |c_j − c_p| · r_p, p the
/// level-l Gaussian j was merged into, r the RMS radius √(s1² + s2² + s3²) and c the RGB colour the DC term
/// draws (0.5 + 0.28209479 · dc), all as stored; raised to the level before's (non-decreasing), 0 at level 0,
/// float32 rounded up. Weights summing to 0 count every Gaussian alike.
///
/// Merge rule (moment matching as Hierarchical 3D Gaussian Splatting, Kerbl et al., SIGGRAPH 2024, merges
/// children into a parent), in double from the decoded children (linear scales s, activated opacities α,
/// normalized quaternions w, x, y, z as 3DGS build_rotation). Areas are taken as the renderer draws the
/// Gaussians where level l is first used, at the distance where g(l, c) is one pixel: the renderer's
/// low-pass adds 0.3 px² to every projected covariance, so each scale s counts as sqrt(s² + δ²) with
/// δ² = 0.3 · g(l, c)² (world units²), and S = s1 s2 + s1 s3 + s2 s3 of those (proportional to the
/// ellipsoid's area as drawn). Weights w_i = α_i · S_i, equal weights if they sum to 0; mean μ = Σ w_i μ_i /
/// W; covariance Σ = Σ w_i (R_i diag(s_i²) R_iᵀ + (μ_i − μ)(μ_i − μ)ᵀ) / W (δ² I would be added on both sides
/// and cancels); every SH coefficient and channel Σ w_i SH_i / W. Scales and rotation are the parent's
/// eigen-decomposition of Σ (Jacobi; scales sqrt(max(λ, 1e-36)), rotation the right-handed eigenvector
/// matrix, w ≥ 0). Opacity (our rule, not the paper's): α_p = 1 − exp(Σ_i (S_i / S_p) · ln(1 − min(α_i,
/// 0.999))), clamped to [0, 1], with S_p the parent's area as drawn: it preserves coverage (two coincident
/// copies give 1 − (1 − α)², pieces tiling the parent's area keep about α), and children far smaller than a
/// pixel, which the low-pass draws as overlapping blobs, give a parent as opaque as their overlap.
/// Parents are encoded with the input's metadata (same SH scales, same scale encoding, linear scales clamped
/// to the largest FP16, log scales to 88.6875): SH codes round-half-away(v / s) clamped to ±127, the DC
/// residual when the input has one as converter::quantize() computes it; means FP32 clamped into the chunk's
/// AABB.
///
/// Chunk spheres: centre the midpoint of the chunk's AABB; radius the largest |mean − centre| + 3 · (largest
/// linear scale) over every level of the chunk, computed in double, enlarged by 1e-6 relative and rounded up
/// to float32. Metadata bounds are those compute_bounds() gives for every output mean (parents stay in
/// their chunk's AABB, so the AABB is the input's; the sphere may grow); metadata is otherwise the input's. Provenance: the input's, then ("lod_levels", L) and ("lod_chunks", C).
///
/// Deterministic: the same bytes whatever options.threads. Memory: the input and the output (sized once),
/// 12 bytes a full-detail Gaussian of sort keys (24 during the first sort), and per worker the levels of two
/// chunks being built (handed to the output in chunk order) and one chunk's sort buffers; nothing is decoded
/// beyond the cell being merged. The builder is build_lod_out_of_core's, with the scene as its one partition.
/// Errors: kInvalidArgument (inconsistent or empty scene, levels > 16, max_chunk_gaussians 0, a Gaussian
/// whose 3σ extent overflows float32), kLimitExceeded (more than 2^31 − 1 Gaussians out), kOutOfMemory.
Result<LodScene> build_lod(const format::EncodedScene& scene, const LodBuildOptions& options = {});

/// A scene's quantized Gaussians read in batches, pass after pass (a scene larger than memory): every pass
/// yields the same Gaussians in the same order. A source that can change between passes (a file) checks that it
/// did not, at the latest when a pass ends (PlyStream does); build_lod_out_of_core refuses what it can see of a
/// change (counts, means outside the box or in other cells) as it reads it.
class EncodedBatches {
 public:
  virtual ~EncodedBatches() = default;
  /// Starts a new pass at the first Gaussian.
  virtual Status rewind() = 0;
  /// The next batch of this pass in `*batch` (replaced: arrays of batch->count Gaussians, metadata unused);
  /// false at the end of the pass.
  virtual Result<bool> next(format::EncodedScene* batch) = 0;
  /// The means ([n, 3] float32, as next() would give them) of the next batch of this pass in `*means`, for the
  /// pass that needs nothing else; false at the end of the pass. By default next()'s; a source that quantizes
  /// its batches can skip that here.
  virtual Result<bool> next_means(std::vector<float>* means);
};

/// Levels of detail as built, level-major as LodScene (and a .rgs file) lays them out: held in arrays (an
/// in-memory build, held_levels) or in unnamed spill files beside the output (build_lod_out_of_core). What the
/// sinks of a conversion read, so that every output of levels (the .rgs, the streamed SOG) is written once for
/// both memory modes.
class Levels {
 public:
  virtual ~Levels() = default;
  /// The scene without its arrays: count (every level's Gaussians), metadata (bounds over every level) and
  /// provenance (with the lod entries), as LodScene::scene has them.
  virtual const format::EncodedScene& head() const = 0;
  /// The index over the Gaussians (SPEC §4.9): range checksums set out of core, 0 in held levels (whose
  /// LodScene format::write_scene_file writes, computing them).
  virtual const format::LodIndex& index() const = 0;
  /// Whether the Gaussians have the DC residual (sh_dc_residual arrays).
  virtual bool sh_dc_residual() const = 0;
  /// Gaussians [first, first + count) in `*out`: arrays replaced, metadata the head's, count set.
  /// kInvalidArgument outside [0, head().count); kIoError naming a spill file.
  virtual Status read(uint64_t first, uint64_t count, format::EncodedScene* out) const = 0;
  /// Section `id`'s bytes (means, rotations, scales, opacities, sh, sh_dc_residual) of every Gaussian in order,
  /// in pieces of whole elements: format::StreamedScene::produce.
  virtual Status stream_section(format::SectionId id, const format::ChunkSink& sink) const = 0;
  /// The levels as format::write_streamed_scene_file takes them (these levels must outlive it); pass index() as
  /// WriteOptions::lod.
  format::StreamedScene streamed() const;
};

/// `lod` seen as Levels (it must outlive them).
std::unique_ptr<Levels> held_levels(const LodScene& lod);

struct OutOfCoreLodOptions {
  /// As build_lod's (progress aside: see below).
  LodBuildOptions lod;
  /// Bytes the build may hold at once (the batches of `EncodedBatches` apart): the partitions are sized to it.
  uint64_t memory_limit = uint64_t{4} << 30;
  /// Whether the Gaussians carry the DC residual (sh_dc_residual arrays in the batches).
  bool sh_dc_residual = true;
  /// Where the unnamed partition and spill files go: the output's folder, so that they share its file system.
  std::string spill_folder = ".";
  /// Called with the stage ("counting", "partitioning", "building levels of detail") and the fraction of the
  /// build done, non-decreasing, from the calling thread (may be empty).
  std::function<void(const char* stage, double fraction)> progress;
};

/// What an out-of-core build did: its levels, held in spill files until `levels` is destroyed.
struct OutOfCoreLevels {
  std::unique_ptr<Levels> levels;
  /// Partition files the scene was cut into, and the most Gaussians one held at once.
  uint32_t partitions = 0;
  uint64_t partition_capacity = 0;
};

/// Builds the levels of detail of a scene larger than memory: the same levels, index and head as build_lod()
/// of the whole scene, held in unnamed files in options.spill_folder for a sink to read (a .rgs written from
/// them is byte for byte build_lod's written by format::write_scene_file()).
/// `head`: the scene without its arrays: count N (the Gaussians every pass yields), metadata (SH degree and
/// quantization, scale encoding, flags; bounds.aabb the box of every mean) and provenance as the output gets
/// them (the build adds its bounds sphere and the lod entries).
///
/// Two passes over `batches`: counts of the means on a grid of up to 256 cells per axis over the scene's cube,
/// from which build_lod's octree chunks follow, then each Gaussian appended to a partition file (consecutive
/// octree nodes, as many Gaussians as memory_limit holds). Each partition is then read, sorted and cut into
/// chunks, their levels built in parallel and appended to spill files per (level, section), which the levels
/// read back. These are unnamed files (O_TMPFILE): nothing is left behind however the build or the process ends.
/// Disk: the spill files hold the whole output, so about its size beside it while it is written.
/// Errors: build_lod's; kLimitExceeded when memory_limit cannot hold a chunk's worth of the build, when more
/// than one cell of the count grid's Gaussians would have to be held at once, or beyond 512 partitions;
/// kCorruptData when the passes disagree (the input changed: another count, a mean outside head's box or NaN,
/// a mean in an octree node that the counting pass found with fewer Gaussians), refused before the Gaussian
/// indexes a count, node or partition; kIoError naming the temporary files; the errors of `batches`.
Result<OutOfCoreLevels> build_lod_out_of_core(EncodedBatches& batches, const format::EncodedScene& head,
                                              const OutOfCoreLodOptions& options);

}  // namespace rgs::converter
