// Fuzz target: parse untrusted PLY bytes (header, binary and ascii bodies) under both invalid-value
// policies. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
// What the reader accepts is then converted as rgs-convert does (quantize, write, validate): a file the
// converter writes must always pass validate(). Dictionary of PLY keywords: fuzz_ply_read.dict.
#include <cstddef>
#include <cstdint>

#include "fuzz_check.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::PlyReadOptions options;
  options.max_gaussians = 1u << 20;
  const auto rejected = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  options.hash_file = true;
  const auto sanitized = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  if (rejected.ok()) RGS_FUZZ_CHECK(sanitized.ok(), sanitized.status().to_string());
  if (!sanitized.ok()) return 0;

  rgs::converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding = (size & 1) ? rgs::format::ScaleEncoding::kLog
                                               : rgs::format::ScaleEncoding::kLinear;
  const auto scene = rgs::converter::quantize(sanitized->cloud, quantize_options);
  if (!scene.ok()) return 0;
  const auto bytes = rgs::format::serialize_scene(*scene);
  if (!bytes.ok()) return 0;
  const rgs::Status valid = rgs::format::validate(bytes->data(), bytes->size());
  RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
  return 0;
}
