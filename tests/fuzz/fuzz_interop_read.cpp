// Fuzz target: parse untrusted bytes as SPZ (versions 2–4), antimatter15 .splat and glTF/GLB
// (KHR_gaussian_splatting), each under both invalid-value policies: every input goes through all three
// readers. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
// What kSanitize keeps must be renderable and convert as rgs-convert does (fuzz_sanitized_cloud.h).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_sanitized_cloud.h"
#include "rgs/converter/gltf_reader.h"
#include "rgs/converter/splat_reader.h"
#include "rgs/converter/spz_reader.h"

namespace {

using Reader = rgs::Result<rgs::converter::InteropScene> (*)(const uint8_t*, size_t, const std::string&,
                                                            const rgs::converter::InteropReadOptions&);

void read_both_ways(Reader read, const uint8_t* data, size_t size) {
  rgs::converter::InteropReadOptions options;
  options.max_gaussians = 1u << 20;
  options.convert_frame = (size & 2) != 0;
  const auto rejected = read(data, size, "<fuzz>", options);
  options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  const auto sanitized = read(data, size, "<fuzz>", options);
  const uint64_t declared = sanitized.ok() ? sanitized->declared_gaussians : 0;
  if (const auto* cloud = rgs::fuzz::sanitized_cloud(rejected, sanitized, declared)) {
    rgs::fuzz::check_converts(*cloud, (size & 1) != 0);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  read_both_ways(&rgs::converter::read_spz_bytes, data, size);
  read_both_ways(&rgs::converter::read_splat_bytes, data, size);
  read_both_ways(&rgs::converter::read_gltf_bytes, data, size);
  return 0;
}
