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
  options.hash_file = true;
  rgs::fuzz::check_reader(&rgs::converter::read_ply_bytes, options, data, size);
  return 0;
}
