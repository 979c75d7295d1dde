// The memory check convert() runs before it reads its input (convert_memory.cpp), and the conversion of an input
// over the memory limit (convert_out_of_core.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "rgs/api/convert.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/format/metadata.h"
#include "rgs/format/writer.h"

namespace rgs::api::detail {

/// kLimitExceeded naming `src`, the estimate and the limit when estimate_convert_memory(src) is above
/// convert_memory_limit(options); no check when the limit is 0 (unknown physical memory).
Status check_convert_memory(const std::string& src, const ConvertOptions& options);

/// The input of a conversion convert() builds out of core, opened: a binary PLY (by content) converted to a
/// level-of-detail .rgs (ConvertOptions::lod_levels, runtime profile, no target) whose estimated peak memory in
/// memory is above convert_memory_limit(options). Null for every other conversion (an ascii PLY included).
Result<std::unique_ptr<converter::PlyStream>> out_of_core_input(const std::string& src, OutputFormat output,
                                                                 const ConvertOptions& options);

/// convert() of such an input (docs/LOD.md#scenes-larger-than-memory): the PLY read in batches, once for the
/// statistics quantize() takes (bounds, SH scales, hygiene, the file's hash) and twice by
/// converter::build_lod_out_of_core; the same bytes as the conversion in memory. `options.files` is the
/// conversion's transaction (never null here), with `src` and `dst` declared.
Result<ConvertReport> convert_out_of_core(std::unique_ptr<converter::PlyStream> stream, const std::string& src,
                                          const std::string& dst, const ConvertOptions& options);

/// Adds a note to `report` when a written .rgs of `gaussians` (every level) is over the readers' default
/// max_gaussians (format::ReadLimits): what to pass to read it.
void note_read_limit(uint64_t gaussians, ConvertReport* report);

/// The write options of a .rgs conversion (profile, codecs, zstd level), checked.
Result<format::WriteOptions> rgs_write_options(const ConvertOptions& options);

/// The provenance a .rgs conversion writes (SPEC §4.2): the source file's name, bytes, XXH64 and storage, the
/// converter and the options that change the bytes, the Gaussians dropped by sanitizing.
format::Provenance rgs_provenance(const std::string& src_name, const ConvertOptions& options, uint64_t file_bytes,
                                  uint64_t file_xxh64, const std::string& storage, uint64_t dropped_gaussians);

}  // namespace rgs::api::detail
