// Fuzz target: parse untrusted bytes as a GaussianSplats3D .ksplat (read_ksplat_bytes) under both invalid-value
// policies. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour, and no
// allocation beyond what the input's own bytes hold (the format has no codec). What kSanitize keeps must be
// renderable and convert as rgs-convert does (fuzz_sanitized_cloud.h). Dictionary: fuzz_ksplat_read.dict.
#include <cstddef>
#include <cstdint>

#include "fuzz_sanitized_cloud.h"
#include "rgs/converter/ksplat_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::InteropReadOptions options;
  options.convert_frame = (size & 2) != 0;
  rgs::fuzz::check_reader(&rgs::converter::read_ksplat_bytes, options, data, size);
  return 0;
}
