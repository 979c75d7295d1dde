// Fuzz target: parse untrusted PLY bytes (header, binary and ascii bodies) under both invalid-value
// policies. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
// What kSanitize keeps must be renderable and convert as rgs-convert does (fuzz_sanitized_cloud.h).
// Dictionary of PLY keywords: fuzz_ply_read.dict.
#include <cstddef>
#include <cstdint>

#include "fuzz_sanitized_cloud.h"
#include "rgs/converter/ply_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::PlyReadOptions options;
  options.max_gaussians = 1u << 20;
  const auto rejected = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  options.hash_file = true;
  const auto sanitized = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  const uint64_t declared = sanitized.ok() ? sanitized->declared_vertices : 0;
  if (const auto* cloud = rgs::fuzz::sanitized_cloud(rejected, sanitized, declared)) {
    rgs::fuzz::check_converts(*cloud, (size & 1) != 0);
  }
  return 0;
}
