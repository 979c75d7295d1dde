// The one conversion: any scene format in, .rgs / INRIA PLY / SPZ / glTF binary out, optionally fitted to a
// quality or size target (rate control of the archive profile, ConvertOptions::target). rgs-convert and Python's
// roofgs.convert call it and only parse options and print its report.
//
// Thread safety: convert() and convert_bytes() are reentrant (no shared state besides the files they name).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/api/scene.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/spz.h"
#include "rgs/format/archive.h"
#include "rgs/format/metadata.h"
#include "rgs/format/output_transaction.h"
#include "rgs/format/status.h"
#include "rgs/format/writer.h"

namespace rgs::api {

/// What convert() writes.
enum class OutputFormat {
  kRgs = 0,  ///< RoofGS .rgs (format/SPEC.md): quantized runtime profile, or the lossy archive profile
  kPly = 1,  ///< INRIA 3DGS PLY (float32, 62 properties at SH degree 3), readable by every 3DGS tool
  kSpz = 2,  ///< Niantic SPZ v4 (lossy: converter::serialize_spz documents the quantization)
  kGlb = 3,  ///< binary glTF with KHR_gaussian_splatting (float32)
  kSog = 4,  ///< PlayCanvas SOG v2: a bundled .sog, a folder when dst is named meta.json (converter::encode_sog), a
             ///< streamed SOG when named lod-meta.json (converter::write_sog_lod)
};

/// "rgs", "ply", "spz", "glb" or "sog": the spelling of rgs-convert's --to, Python's `to=` and the JSON report.
const char* output_format_name(OutputFormat format);

/// The output format of `dst`: `to` when given, else the extension (.rgs, .ply, .spz, .glb, .sog, any case;
/// without `to`, a name "meta.json" is a SOG folder and "lod-meta.json" a streamed SOG).
/// @return kInvalidArgument when neither decides, or when the extension names another of these four formats
///         than `to` (a GLB called scene.rgs would mislead every later reader of the name); an unrelated
///         extension is accepted with `to`.
Result<OutputFormat> output_format_for(const std::string& dst, std::optional<OutputFormat> to = std::nullopt);

/// Parses "rgs" / "ply" / "spz" / "glb" / "sog". @return kInvalidArgument otherwise.
Result<OutputFormat> parse_output_format(const std::string& name);

/// Every file a conversion to `dst` in `output` may write: `dst` itself, and for a SOG folder (`dst` named
/// meta.json) the images next to it (converter::sog_folder_files), so that an output transaction can declare
/// them all before any work.
std::vector<std::string> output_paths(const std::string& dst, OutputFormat output);

/// Where a running conversion is, for a progress display (ConvertOptions::progress).
struct ConvertProgress {
  /// The stage now running: "reading" (and decoding the input), "quantizing", "encoding the archive"
  /// (archive profile), "writing"; "done" once, with fraction 1, when the output is written. With a target
  /// (ConvertOptions::target), between reading and quantizing, rate control's steps in words: "rate control,
  /// step 3 of <= 22: refining: 40 archives encoded, 12 rendered; at 41.20 dB, 1,234,567 bytes". Valid only
  /// during the call.
  const char* stage = "";
  /// Fraction of the whole conversion done, in [0, 1]: each stage starts at its share of a typical
  /// conversion's time, so that elapsed * (1 - fraction) / fraction estimates the time left. Rate control
  /// spreads its steps over most of the range: step / steps of it once `step` steps are done.
  double fraction = 0;
  /// Rate control: steps done (a stage of a search or a check of an archive at the views' own size) and an
  /// upper bound on the steps of the whole fit (the bound shrinks as the search settles; step <= steps); 0 and
  /// 0 outside rate control.
  uint32_t step = 0, steps = 0;
};

/// A quality or a size the archive profile is fitted to (rate control, ConvertOptions::target): format::ArchiveOptions
/// (bits and code steps of rotations, scales and opacities, SH step multipliers per degree, position error, opacity
/// floor) chosen so that the archive's render meets a PSNR target against the source's render at the fewest bytes,
/// or fits a byte budget at the best PSNR. The search encodes each candidate in memory and measures it on the
/// views reduced in size (search_max_side, search_max_views); the choice is then checked at the views' own size.
/// How it searches and what it reaches: docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes.
struct ConvertTarget {
  ConvertTarget() {
    views.orbit_width = 960;
    views.orbit_height = 540;
  }
  /// The mean over the views of the per-view PSNR (dB, peak 1, clamped RGB, the whole frame: runtime::psnr_rgb)
  /// of the archive's render against the source's, at the views' own size: at least this, at the fewest bytes.
  /// Finite and positive.
  std::optional<double> psnr_db;
  /// The largest output file, bytes (sections, header, metadata and provenance): at most this, at the highest
  /// mean PSNR. Positive; excludes psnr_db.
  std::optional<uint64_t> bytes;
  /// The views the PSNR is measured on (make_cameras on the scene's bounds: a cameras file, an orbit or a path,
  /// with `every`, `limit`, `fly`, `width` and `height`; an orbit or path is 960x540 unless orbit_width and
  /// orbit_height say otherwise). Naming no cameras file, orbit or path: default_views (the scene's own
  /// cameras.json found beside it, else views guessed from its content), with `limit`, `width` and `height`.
  CameraChoice views;
  /// Renderer of the measurements: the CPU reference or CUDA (device cuda_device); CPU threads (0: all). The
  /// renders are the faithful preset on a black background; on the GPU the PSNR is computed on the device
  /// (runtime::GpuImageComparer: the same PSNR but for the order of its float64 sums).
  Device device = Device::kCpu;
  int cuda_device = 0;
  unsigned cpu_threads = 0;
  /// The search renders the views reduced (field of view kept) so that their longer side is at most this many
  /// pixels (at least 16); the final check renders them at their own size. 0: 320 on the CPU, 1920 with CUDA,
  /// where renders are cheap next to encoding and the reduced views of a dense scene read several dB above its
  /// full ones (docs/AUDITS.md, rate control).
  uint32_t search_max_side = 0;
  /// The search renders at most this many of the views, evenly spread; the final check renders them all.
  uint32_t search_max_views = 6;

  /// Whether a target is set (psnr_db or bytes).
  bool active() const { return psnr_db.has_value() || bytes.has_value(); }
};

/// What rate control chose and measured (ConvertReport::rate_control).
struct RateControlReport {
  /// The archive options of the written file.
  format::ArchiveOptions settings;
  /// The written archive's mean and lowest per-view PSNR (dB) on the views at their own size, and its mean on
  /// the search's reduced views.
  double psnr_mean_db = 0, psnr_min_db = 0, search_psnr_db = 0;
  uint32_t views = 0;                            ///< views measured
  uint32_t width = 0, height = 0;                ///< first view's own size (the final check)
  uint32_t search_width = 0, search_height = 0;  ///< first view's size in the search
  uint32_t encodings = 0;                        ///< archives encoded (each measured for bytes)
  uint32_t renders = 0;                          ///< archives rendered (each on every search view)
  Device device = Device::kCpu;
  std::string device_name;                       ///< "CPU reference renderer" or "CUDA device N"
  /// Wall time of the fit, and of it encoding the candidates and loading and rendering them with the PSNR
  /// against the source (the source's own renders not included).
  double seconds = 0, encode_seconds = 0, render_seconds = 0;
  /// Which views were measured when ConvertTarget::views named none (DefaultViews::note); empty otherwise.
  std::string views_note;
};

/// "rotation 10, scale 9, opacity 8 bits; SH step x1/3/5/6; position error 7.63e-06 of the extent": archive
/// options in words, SH multipliers up to `sh_degree`.
std::string describe_archive_options(const format::ArchiveOptions& options, uint32_t sh_degree);

/// The archive's quantized codes also try .xz streams from this zstd level on (format::kArchiveXzMinZstdLevel).
inline constexpr int kArchiveXzMinZstdLevel = format::kArchiveXzMinZstdLevel;

/// zstd level of ConvertOptions::zstd_sections when ConvertOptions::zstd_level is unset.
inline constexpr int kDefaultZstdLevel = 19;

/// zstd level of the archive profile when ConvertOptions::zstd_level is unset: quick, no .xz trials on scenes from
/// format::kArchiveDenseGaussians on. Level 19 with
/// the .xz trials (`--zstd-level 19`) codes the measured archives 2-7 % smaller in 5-21 times the time
/// (docs/lab/AUDIT_RUNS.md#entropy-coding-of-the-codes).
inline constexpr int kArchiveDefaultZstdLevel = 9;

/// Options of convert(); the defaults are rgs-convert's.
struct ConvertOptions {
  /// Output format; unset: the extension of `dst` decides (output_format_for).
  std::optional<OutputFormat> to;
  /// How the input is read: limits, the streamed-SOG level (`lod`), the SPZ axes (`spz_frame`, which also
  /// decides the axes of an SPZ output), checksums. invalid_policy and hash_file are set from `sanitize`.
  converter::SceneReadOptions read;
  /// Drop Gaussians with NaN/Inf values or zero-norm quaternions instead of failing (docs/INPUT_HYGIENE.md).
  bool sanitize = false;
  /// Write a scene without Gaussians instead of failing with kInvalidArgument.
  bool allow_empty = false;
  /// Drop the SH bands above this degree (0..3) before writing (converter::reduce_sh_degree), after the edits.
  std::optional<uint32_t> sh_degree;
  /// Edits applied to the scene as read, in this order, before anything else (rate control, the SH reduction,
  /// quantizing): translate (scene units), rotate (a unit quaternion w,x,y,z about the origin, SH bands rotated
  /// too), scale (uniform s > 0 about the origin), filter-nan, filter (a property compared with a value), crop-box
  /// and crop-sphere (keep inside, or outside); converter::EditAction documents units and encodings and
  /// converter::parse_edit_action makes one from rgs-convert's spelling ("rotate", "0,90,0"). A filter-nan reads
  /// the input under the sanitize policy (docs/INPUT_HYGIENE.md), so that the Gaussians with a non-finite value
  /// are dropped instead of refused. A scene built out of core gets the same edits batch by batch (the same
  /// bytes). Edits that remove every Gaussian leave an empty scene, refused unless allow_empty. Each edit is
  /// checked by check_convert_options (converter::check_edit_action). With several inputs they act on the merged
  /// scene, after each input's `input_edits`.
  std::vector<converter::EditAction> edits;
  /// A merge's edits of each input (convert() of several files): input_edits[i] act on srcs[i] as read, widened to
  /// the merge's SH degree, in order, before the merge and `edits`; fewer entries than inputs leave the rest as
  /// read (more are kInvalidArgument). A filter-nan of any input reads every input under the sanitize policy.
  /// Out of core, each batch gets the edits of the file it comes from. With one input they act as `edits` do,
  /// before them.
  std::vector<std::vector<converter::EditAction>> input_edits;

  // .rgs output only.
  /// FP16 scales stored linear (activated) or as the natural log.
  format::ScaleEncoding scale_encoding = format::ScaleEncoding::kLinear;
  /// SH scale: 100 = max |SH| / 127 (paper Eq. quant); lower clips the tail (converter::QuantizeOptions).
  float sh_clip_percentile = 100.0f;
  /// DC term precision, 8 or 16 bits (converter::QuantizeOptions::sh_dc_bits): 16 adds the DC residual section
  /// (SPEC §4.8, 3 bytes a Gaussian); 8 is the paper's INT8 alone. The archive profile always stores 8.
  uint32_t sh_dc_bits = 16;
  /// Sections compressed with zstd: "all" or names among metadata, provenance, means, rotations, scales,
  /// opacities, sh, sh_dc_residual. Empty: every section stored raw (the runtime copies it to the GPU as is).
  std::vector<std::string> zstd_sections;
  /// zstd level 1..22 of the zstd_sections and of the archive profile's coded sections; from
  /// kArchiveXzMinZstdLevel on (and at any level for scenes under format::kArchiveDenseGaussians), the archive's
  /// codes also try .xz streams (format::ArchiveOptions::xz). Unset:
  /// kArchiveDefaultZstdLevel for the archive profile, kDefaultZstdLevel otherwise (zstd_level_for).
  std::optional<int> zstd_level;
  /// kRuntime (lossless sections, mapped as is) or kArchive (Draco means and quantized attributes,
  /// SPEC §3.3), coded with `archive`.
  format::StorageProfile profile = format::StorageProfile::kRuntime;
  /// The archive profile's choices (format::ArchiveOptions): largest position error as a fraction of the
  /// scene's longest AABB side (position_error), bits of rotations, scales and opacities (0: by scene size),
  /// SH step multipliers per degree, SH codebook, Draco speed, threads; its sections are coded at zstd_level.
  /// With a `target`, rate control chooses the bits, steps, multipliers, position error and opacity floor and
  /// keeps the rest (sh_codebook_size, draco_speed, threads, xz).
  format::ArchiveOptions archive;
  /// Rate control: fit the archive profile to a PSNR or a byte target on `target.views` (ConvertTarget). A .rgs
  /// output only; the archive profile is written whatever `profile` says; no levels of detail.
  ConvertTarget target;
  /// An archive of this scene encoded before with these options' quantization (rate control's search): it
  /// lends the archive profile's encoding the sections coded with the same settings (format::encode_archive's
  /// `earlier`; the means when its Draco points are those of `archive`), so they are not coded again. The file's
  /// bytes do not depend on it.
  std::shared_ptr<const format::ArchiveScene> archive_earlier;
  /// Levels of detail (format/SPEC.md §4.9, converter::build_lod, docs/LOD.md): unset writes an ordinary file;
  /// 0 chooses the count (coarsest level about 1/64 of the full detail), 1..16 sets it. Needs the runtime profile
  /// with the per-Gaussian sections stored raw (kInvalidArgument otherwise).
  std::optional<uint32_t> lod_levels;
  /// Most full-detail Gaussians in one chunk of a level-of-detail file: the unit a renderer culls, selects and
  /// streams.
  uint32_t lod_chunk_gaussians = 65536;
  /// Most bytes of memory the conversion may use (the process's peak resident memory); 0: half the machine's
  /// physical memory (convert_memory_limit). When the estimated peak of reading the input whole
  /// (estimate_convert_memory) is above the limit, convert() builds a binary PLY into a level-of-detail .rgs out of
  /// core (lod_levels set, runtime profile, no target): the PLY read in batches, its levels built from partition
  /// files (unnamed, on the output's file system), the same bytes as in memory; any other input is refused with
  /// kLimitExceeded before it is read, naming the file, the estimate and the limit
  /// (docs/LOD.md#scenes-larger-than-memory). convert_bytes, convert_scene and convert_cloud take a scene already
  /// in memory and do not check it.
  uint64_t memory_limit = 0;
  /// Name recorded as the provenance's "converter" (with the library version).
  std::string converter_name = "roofgs api";
  /// The output transaction the output files go through; null: the conversion makes its own and commits it
  /// when it succeeds. Either way the files the scene reads are its inputs and every output file is declared
  /// to it before it is written, so that no output replaces an input; a tool passes its run's transaction,
  /// which it commits with the run's other files.
  format::OutputTransaction* files = nullptr;
  /// Called on the converting thread as each stage starts (with a target, also after each of rate control's
  /// steps), with non-decreasing fractions, and once with stage "done" and fraction 1 after a successful
  /// conversion (not after a failed one). Empty: not called.
  /// The library prints nothing itself; rgs-convert draws a progress line from these calls.
  std::function<void(const ConvertProgress&)> progress;
};

/// The zstd level convert() codes with: `options.zstd_level`, or when unset kArchiveDefaultZstdLevel for the
/// archive profile and kDefaultZstdLevel otherwise. Not checked against 1..22 (check_convert_options does that).
int zstd_level_for(const ConvertOptions& options);

/// The memory limit convert() applies, in bytes: `options.memory_limit`, or when it is 0 half of the machine's
/// physical memory (0 when the system does not say: no limit).
uint64_t convert_memory_limit(const ConvertOptions& options);

/// The peak memory in bytes that convert() is estimated to need for the scene at `src`, from the bytes of the
/// files it reads (converter::list_scene_files, those present) times a factor per input format, plus 64 MiB:
/// measured peak RSS over input bytes on real scenes converted with levels of detail, rounded up
/// (docs/LOD.md#scenes-larger-than-memory). Reads only the scene's start and its JSON files.
/// Errors: those of converter::detect_scene_format and converter::list_scene_files.
Result<uint64_t> estimate_convert_memory(const std::string& src);

/// The same for the inputs `srcs` read together (a merge): each input's share, and the 64 MiB once.
Result<uint64_t> estimate_convert_memory(const std::vector<std::string>& srcs);

/// The peak memory in bytes that convert() is estimated to need for a merged scene of `gaussians` at `sh_degree`
/// (every input widened to the highest degree): estimate_convert_memory's for a float PLY holding it.
uint64_t estimate_merged_memory(uint64_t gaussians, uint32_t sh_degree);

/// The most bytes of an input in the format `format_id` (converter::detect_scene_format's id: "ply", "rgs", ...)
/// that a conversion reading it whole may be given within convert_memory_limit(options): the largest input whose
/// estimated peak, by estimate_convert_memory's rule for that format, is within the limit; 0 when the limit is
/// below what every conversion holds (64 MiB); UINT64_MAX when there is no limit (0). For a stream that is held
/// whole before convert_bytes() converts it, as rgs-convert holds standard input: a stream cannot be read in
/// passes, so it is never built out of core.
uint64_t max_whole_input_bytes(const std::string& format_id, const ConvertOptions& options);

/// What the .rgs quantization cost (.rgs output only).
struct RgsOutputReport {
  /// Per-attribute errors of the written scene, as readers decode it, against the read one: for the
  /// runtime profile measured in the quantizing pass; for the archive profile measured on the archive's
  /// decoded scene (format::ArchiveScene::decoded, matched to the source through source_index), so they
  /// include Draco's position quantization and the archive's coarser rotations, scales, opacities and SH,
  /// over the Gaussians it keeps.
  converter::AttributeErrors errors;
  /// Archive profile: source Gaussians left out of the file because their opacity code is 0, so that they
  /// decode to opacity 0, which no renderer draws, or their opacity is below ArchiveOptions::opacity_floor
  /// (format::ArchiveScene::omitted, SPEC §3.3.2).
  uint64_t archive_omitted = 0;
  /// Clipped SH coefficients and FP16-flushed scales.
  converter::QuantizationReport quantization;
  /// The SH scale of each (degree, channel) stored in the metadata (SPEC §4.1.2).
  format::ShQuantization sh_quantization;
  /// Archive profile: the position step and bits chosen for `archive.position_error` (0 for the runtime profile);
  /// the largest position error relative to the extent is position_step / (2 * extent).
  double position_step = 0;
  uint32_t position_bits = 0;
  /// The scene extent (longest side of the source means' AABB, scene units), which `archive.position_error` and
  /// the relative position error are fractions of.
  double extent = 0;
  /// Levels of detail (ConvertOptions::lod_levels): levels and chunks of the index, and the Gaussians of every
  /// level together (ConvertReport::gaussians counts the full detail). 0 without levels of detail.
  uint32_t lod_levels = 0;
  uint32_t lod_chunks = 0;
  uint64_t lod_gaussians = 0;
  /// Partition files of a conversion built out of core (docs/LOD.md#scenes-larger-than-memory); 0 when the
  /// scene was converted in memory.
  uint32_t out_of_core_partitions = 0;
};

/// One input of a merge (convert() of several files), as the merge took it.
struct MergeInput {
  std::string path;
  uint64_t gaussians = 0;  ///< as read (after sanitizing)
  uint64_t kept = 0;       ///< after its edits (ConvertOptions::input_edits): what it gave the merged scene
  /// Its edits in order (converter::edit_action_text), a filtering one with " removed N Gaussians".
  std::vector<std::string> edits;
};

/// Seconds spent, wall clock.
struct ConvertTimes {
  /// quantize includes measuring the errors; total includes rate control (RateControlReport::seconds).
  double read = 0, quantize = 0, lod = 0, write = 0, total = 0;
};

/// What convert() read and wrote.
struct ConvertReport {
  /// The input: converter::InputScene's format_id ("ply", "sog", "spz", "rgs", ...), description in words,
  /// storage format, bytes of every file read, Gaussians declared, hygiene counts.
  std::string input_format;
  std::string input_description;
  std::string input_storage;
  uint64_t input_bytes = 0;
  uint64_t declared_gaussians = 0;
  /// The input is in a format made for distribution, which a runtime .rgs or a float32 output may well
  /// outgrow: SPZ, SOG (meta.json, bundled or streamed), PlayCanvas compressed PLY, glTF/GLB, or an
  /// archive-profile .rgs (input_storage "rgs archive").
  bool input_compact = false;
  converter::InputHygiene hygiene;
  /// What the reader noted (the SPZ axes assumed, ignored fields), the Gaussians each filtering edit removed
  /// (ConvertOptions::edits) and the SH bands dropped.
  std::vector<std::string> input_notes;

  OutputFormat output_format = OutputFormat::kRgs;
  /// The output in words: "RoofGS .rgs, runtime profile", "INRIA PLY, dequantized", "SPZ v4", ...
  std::string output_description;
  uint64_t output_bytes = 0;
  /// What the output format cannot carry or changed, one sentence each (SPZ precision and axes, PLY zero
  /// scales, GLB axes).
  std::vector<std::string> output_notes;

  uint64_t gaussians = 0;
  uint32_t sh_degree = 0;
  /// .rgs output: the quantization's cost.
  std::optional<RgsOutputReport> rgs;
  /// SPZ output: the writer's summary (version, position step, clamped values).
  std::optional<converter::SpzWriteSummary> spz;
  /// PLY output: zero scales written as converter::kZeroScaleLog instead of −inf.
  uint64_t zero_scales = 0;
  /// With ConvertOptions::target: what rate control chose and measured.
  std::optional<RateControlReport> rate_control;
  /// A merge's inputs in order (empty for one input); ConvertOptions::edits acted on the merged scene after them.
  std::vector<MergeInput> merge_inputs;
  ConvertTimes seconds;
};

/// The JSON text of a conversion's report: what rgs-convert --json writes and Python's convert() and save() return
/// (parsed), the one place its keys are chosen. `src`, `dst` and `options` are the conversion's (paths recorded as
/// given; the SPZ axes and rate control's target come from `options`). Keys: input {path, bytes, format, storage,
/// declared_vertices, compact, notes}, output {path, bytes, format, description, notes}, gaussians, sh_degree,
/// bytes_per_gaussian {input, output}, ratio, hygiene {the InputHygiene counts}; zero_scales (PLY output), spz (SPZ
/// output), rate_control (with a target), merge {inputs [{path, gaussians, kept, edits}], edits} (several inputs;
/// edits: those of the merged scene), scales_fp16, extent, lod, archive_omitted and errors (per attribute, SH per
/// degree; .rgs output); seconds {read, quantize, lod, write, total}. Two-space indents, no final newline; bytes that
/// are not UTF-8 (in a path) become U+FFFD. The same report gives the same text but for the timings.
std::string convert_report_json(const ConvertReport& report, const std::string& src, const std::string& dst,
                                const ConvertOptions& options);

/// Checks the options that need no input, as convert() does before reading anything: SH degree, clip percentile,
/// DC bits, zstd level and sections, the archive options (format::check_archive_options) with the archive
/// profile or a target, that levels of detail come with the runtime profile and raw per-Gaussian sections, each
/// edit (converter::check_edit_action), and
/// the target (ConvertTarget: one of psnr_db, finite and positive, or bytes, positive; no levels of detail; a
/// .rgs output when `to` is set; views named only with a target). Tools call it to refuse a command line before any work.
/// @return kInvalidArgument naming the option and the rule.
Status check_convert_options(const ConvertOptions& options);

/// check_convert_options, and the rules that need the output: a target writes a .rgs; levels of detail are
/// written into a .rgs or a streamed SOG (lod-meta.json) only. convert() checks them before reading anything.
/// @return kInvalidArgument naming `dst`, the option and the rule.
Status check_convert_output(const std::string& dst, OutputFormat output, const ConvertOptions& options);

/// Converts the scene at `src` (any format converter::read_scene detects, .rgs included) into `dst` in
/// options.to or the format its extension names: read (every file of the scene checked against `dst`), edit
/// (options.edits, in order), drop SH bands, then quantize into a .rgs (provenance records the source, its XXH64
/// and the options) or write PLY / SPZ / GLB from the float Gaussians (a .rgs input dequantized). `dst` is
/// replaced atomically and only on success: a failed conversion leaves an existing `dst` untouched.
/// With options.target, the archive options are first fitted to the target on the scene as edited (its SH bands
/// all rendered as the source; the fit's candidates drop those above sh_degree): psnr_db the fewest bytes whose
/// mean PSNR at the views' own size meets it; bytes the highest such PSNR whose file fits. Deterministic for a
/// given device; how it searches: docs/AUDITS.md#rate-control-of-the-archive-profile---target-psnr---target-bytes.
/// The archive is then written with the chosen options (ConvertReport::rate_control).
/// @return kInvalidArgument (bad options, an unknown zstd section, no output format, `dst` being one of the
///         scene's files, an empty scene without allow_empty; with a target: a non-.rgs output, no views, a PSNR
///         target above what the finest archive reaches (the message says what it reaches), a byte budget below
///         the coarsest archive (the message says its size), the views' errors prefixed with "<src>: rate
///         control's views"); kLimitExceeded (an input whose estimated memory is above options.memory_limit,
///         refused before it is read unless it is built out of core; a limit too small for the out-of-core build
///         of one chunk; a byte target no measured archive fits once coded at the file's
///         zstd level, or a written file over it: its provenance larger than the fit allowed for); the errors of
///         reading `src`, of rendering and of writing `dst` (kIoError naming it). On any error no output is
///         committed.
Result<ConvertReport> convert(const std::string& src, const std::string& dst, const ConvertOptions& options = {});

/// convert() of several scenes (`srcs`, one or more, any formats), each edited by its options.input_edits, merged
/// into one by converter::merge_scenes before options.edits, or out of core read file after file
/// (converter::PlyStream). The limits hold for the merged scene: options.read.max_gaussians for the inputs'
/// Gaussians together, the memory limit for the inputs read together and, once they are read, for the merged scene
/// (estimate_merged_memory: every input widened to the highest SH degree), unless a merge of binary PLYs is built
/// out of core. Messages, the report (ConvertReport::merge_inputs) and the provenance name them joined by " + ";
/// the output may replace none of their files. @return convert()'s errors, kLimitExceeded naming the inputs for a
/// merged scene over a limit, and kInvalidArgument for no input, more input_edits than inputs, or inputs whose
/// anti-aliasing flags differ (naming both files).
Result<ConvertReport> convert(const std::vector<std::string>& srcs, const std::string& dst,
                              const ConvertOptions& options = {});

/// How convert() reads its source: `options.read`, the invalid-value policy of `options.sanitize`, and the
/// file's XXH64 for the provenance.
converter::SceneReadOptions scene_read_options(const ConvertOptions& options);

/// convert() of a scene converter::read_scene has read from `src` with scene_read_options(options): for a caller
/// that works on the scene before writing it, without reading it twice. The files the scene read are the
/// transaction's inputs, as in convert(). The report counts no reading
/// time.
Result<ConvertReport> convert_scene(converter::InputScene input, const std::string& src, const std::string& dst,
                                    const ConvertOptions& options = {});

/// convert() of a scene held in memory (a PLY or .rgs read from standard input); `name` stands for the
/// source in messages and provenance.
Result<ConvertReport> convert_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const std::string& dst, const ConvertOptions& options = {});

/// convert() of float Gaussians held in memory (a training run's arrays, format::GaussianCloud's activated
/// layout) under converter::scene_from_cloud's value rules (ConvertOptions::sanitize drops the Gaussians
/// they reject); `name` stands for the source in messages and provenance.
Result<ConvertReport> convert_cloud(format::GaussianCloud cloud, const std::string& name, const std::string& dst,
                                    const ConvertOptions& options = {});

}  // namespace rgs::api
