// Sample: open a .rgs file with the public API, map its runtime sections without decoding, and
// dequantize a few Gaussians to float32.
//
//   rgs_sample_read_scene scene.rgs

#include <cstdio>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s scene.rgs\n", argv[0]);
    return 2;
  }
  // open() maps the file and checks the header, section table and metadata; payloads stay untouched.
  auto file = rgs::format::RgsFile::open(argv[1]);
  if (!file.ok()) {
    std::fprintf(stderr, "error: %s\n", file.status().to_string().c_str());
    return 1;
  }
  std::printf("%llu Gaussians, SH degree %u\n", static_cast<unsigned long long>(file->gaussian_count()),
              file->metadata().sh_degree);

  // A section stored without a codec is a zero-copy view, ready for one cudaMemcpy to the GPU.
  auto means = file->stored_bytes(rgs::format::SectionId::kMeans);
  if (!means.ok()) {
    std::fprintf(stderr, "error: %s\n", means.status().to_string().c_str());
    return 1;
  }
  std::printf("means section: %zu bytes at file offset %llu\n", means->size,
              static_cast<unsigned long long>(file->find(rgs::format::SectionId::kMeans)->offset));

  // The CPU path: decode every section, then dequantize to float32 (paper Eq. quant).
  auto scene = file->read_scene();
  if (!scene.ok()) {
    std::fprintf(stderr, "error: %s\n", scene.status().to_string().c_str());
    return 1;
  }
  rgs::format::GaussianCloud first;
  rgs::Status s = rgs::format::dequantize_range(*scene, 0, scene->count < 3 ? scene->count : 3, &first);
  if (!s.ok()) {
    std::fprintf(stderr, "error: %s\n", s.to_string().c_str());
    return 1;
  }
  for (size_t i = 0; i < first.size(); ++i) {
    std::printf("Gaussian %zu: mean (%.4f, %.4f, %.4f) opacity %.4f scale (%.4g, %.4g, %.4g) DC (%.4f, %.4f, %.4f)\n",
                i, first.means[i * 3], first.means[i * 3 + 1], first.means[i * 3 + 2], first.opacities[i],
                first.scales[i * 3], first.scales[i * 3 + 1], first.scales[i * 3 + 2], first.sh[i * first.sh_coefficients() * 3],
                first.sh[i * first.sh_coefficients() * 3 + 1], first.sh[i * first.sh_coefficients() * 3 + 2]);
  }
  return 0;
}
