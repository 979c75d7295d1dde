// Fuzz target: parse untrusted bytes as SPZ (versions 2–4), antimatter15 .splat, glTF/GLB
// (KHR_gaussian_splatting) and PlayCanvas compressed PLY, each under both invalid-value policies: every
// input goes through all four readers. Any input must give ok or an error Status: never a crash, hang,
// leak or undefined behaviour. What kSanitize keeps must be renderable and convert as rgs-convert does
// (fuzz_sanitized_cloud.h). Dictionary: fuzz_interop_read.dict.
#include <cstddef>
#include <cstdint>

#include "fuzz_sanitized_cloud.h"
#include "rgs/converter/gltf.h"
#include "rgs/converter/playcanvas_readers.h"
#include "rgs/converter/splat_reader.h"
#include "rgs/converter/spz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::InteropReadOptions interop;
  interop.convert_frame = (size & 2) != 0;
  rgs::fuzz::check_reader(&rgs::converter::read_spz_bytes, interop, data, size);
  rgs::fuzz::check_reader(&rgs::converter::read_splat_bytes, interop, data, size);
  rgs::fuzz::check_reader(&rgs::converter::read_gltf_bytes, interop, data, size);
  rgs::fuzz::check_reader(&rgs::converter::read_compressed_ply_bytes, rgs::converter::SceneReadOptions{}, data,
                          size);
  return 0;
}
