// Fuzz target: parse untrusted PLY bytes (header, binary and ascii bodies) under both invalid-value
// policies. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
#include <cstddef>
#include <cstdint>

#include "rgs/converter/ply_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::PlyReadOptions options;
  options.max_gaussians = 1u << 20;
  (void)rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  (void)rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  return 0;
}
