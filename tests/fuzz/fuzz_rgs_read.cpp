// Fuzz target: untrusted .rgs bytes through every reading entry point. Any input must give ok or an error
// Status: never a crash, hang, leak or undefined behaviour. For inputs that validate() accepts it also
// checks the promises the API makes about valid files:
//   - from_bytes(), every section accessor, read_scene() and dequantize() succeed;
//   - the writer takes the decoded scene back (it refuses only what validate() rejects, SPEC §5.4), with
//     codec none or (by the last input byte) zstd, and writes a file that validates and is byte-identical
//     when written twice;
//   - the PLY export reads back with the same number of Gaussians (some may be dropped as invalid, never
//     lost silently);
//   - the scene archives (fuzz_archive.h: a constant scale axis decodes to its value).
// The libFuzzer build adds a container-aware mutator (rgs_mutator.cpp) that recomputes the checksums.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_archive.h"
#include "fuzz_check.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

void check_round_trips(const rgs::format::EncodedScene& scene, const rgs::format::GaussianCloud& cloud,
                       const rgs::format::ReadLimits& limits, bool zstd) {
  rgs::format::WriteOptions write_options;
  if (zstd) {  // every section compressed, at a fast level
    write_options.zstd_level = 1;
    for (rgs::format::SectionId id :
         {rgs::format::SectionId::kMetadata, rgs::format::SectionId::kProvenance, rgs::format::SectionId::kMeans,
          rgs::format::SectionId::kRotations, rgs::format::SectionId::kScales,
          rgs::format::SectionId::kOpacities, rgs::format::SectionId::kSh}) {
      write_options.codecs[id] = rgs::format::Codec::kZstd;
    }
  }
  auto written = rgs::format::serialize_scene(scene, write_options);
  RGS_FUZZ_CHECK(written.ok(), written.status().to_string());
  const rgs::Status rewritten_valid = rgs::format::validate(written->data(), written->size(), limits);
  RGS_FUZZ_CHECK(rewritten_valid.ok(), rewritten_valid.to_string());
  auto reread = rgs::format::RgsFile::from_bytes(written->data(), written->size());
  RGS_FUZZ_CHECK(reread.ok(), reread.status().to_string());
  auto scene2 = reread->read_scene();
  RGS_FUZZ_CHECK(scene2.ok(), scene2.status().to_string());
  auto written2 = rgs::format::serialize_scene(*scene2, write_options);
  RGS_FUZZ_CHECK(written2.ok() && *written2 == *written, "writing the re-read scene gave other bytes");

  auto ply = rgs::converter::serialize_ply(cloud);
  RGS_FUZZ_CHECK(ply.ok(), ply.status().to_string());
  rgs::converter::PlyReadOptions ply_options;
  ply_options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  auto back = rgs::converter::read_ply_bytes(ply->data(), ply->size(), "<round trip>", ply_options);
  RGS_FUZZ_CHECK(back.ok(), back.status().to_string());
  RGS_FUZZ_CHECK(back->cloud.size() + back->hygiene.dropped_gaussians == cloud.size(),
                 "PLY round trip changed the Gaussian count");
  RGS_FUZZ_CHECK(back->cloud.sh_degree == cloud.sh_degree, "PLY round trip changed the SH degree");
  rgs::fuzz::check_archive(scene);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::format::ReadOptions options;
  options.limits.max_gaussians = 1u << 20;  // keep allocations small under the fuzzer
  options.limits.max_section_raw_bytes = 64u << 20;
  const rgs::Status valid = rgs::format::validate(data, size, options.limits);

  auto file = rgs::format::RgsFile::from_bytes(data, size, options);
  if (valid.ok()) RGS_FUZZ_CHECK(file.ok(), file.status().to_string());
  if (!file.ok()) return 0;
  for (const rgs::format::SectionEntry& entry : file->sections()) {
    auto view = file->stored_bytes(entry.id);
    if (valid.ok()) RGS_FUZZ_CHECK(view.ok(), view.status().to_string());
    if (entry.raw_size <= (1u << 20) && entry.codec == rgs::format::Codec::kNone) {
      std::vector<uint8_t> raw(entry.raw_size);
      const rgs::Status decoded = file->decode_section(entry.id, raw.data(), raw.size());
      if (valid.ok()) RGS_FUZZ_CHECK(decoded.ok(), decoded.to_string());
    }
  }
  auto scene = file->read_scene();
  if (valid.ok()) RGS_FUZZ_CHECK(scene.ok(), scene.status().to_string());
  if (!scene.ok()) return 0;
  auto cloud = rgs::format::dequantize(*scene);
  if (valid.ok()) RGS_FUZZ_CHECK(cloud.ok(), cloud.status().to_string());
  if (valid.ok()) check_round_trips(*scene, *cloud, options.limits, (data[size - 1] & 1) != 0);
  return 0;
}
