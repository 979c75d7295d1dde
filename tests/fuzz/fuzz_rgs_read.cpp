// Fuzz target: open untrusted .rgs bytes, validate them fully, and decode every section.
// Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
#include <cstddef>
#include <cstdint>

#include "rgs/format/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::format::ReadOptions options;
  options.limits.max_gaussians = 1u << 20;  // keep allocations small under the fuzzer
  options.limits.max_section_raw_bytes = 64u << 20;
  (void)rgs::format::validate(data, size, options.limits);
  auto file = rgs::format::RgsFile::from_bytes(data, size, options);
  if (file.ok()) (void)file->read_scene();
  return 0;
}
