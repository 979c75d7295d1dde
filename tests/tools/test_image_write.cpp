// Library-free image output of rgs-render/rgs-audit (PPM/PGM, PFM, the dispatch by extension and the
// OpenImageIO-less errors).
#include <doctest/doctest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include "cli_common.h"
#include "image_write.h"
#include "rgs/audit/audit_report.h"

namespace {

namespace fs = std::filesystem;
using rgs::StatusCode;

fs::path scratch_dir() {
  const fs::path dir = fs::temp_directory_path() / ("rgs_test_image_write_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("audit::write_netpbm, the tools' Netpbm writer: P6 and P5 bytes") {
  using rgs::audit::write_netpbm;
  const fs::path dir = scratch_dir();
  const std::vector<uint8_t> rgb = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};  // 2x2 RGB
  REQUIRE(write_netpbm((dir / "a.ppm").string(), {2, 2, 3, rgb}).ok());
  CHECK(read_bytes(dir / "a.ppm") == std::string("P6\n2 2\n255\n") + std::string(rgb.begin(), rgb.end()));
  const std::vector<uint8_t> grey = {0, 128, 255};  // 3x1 grey
  REQUIRE(write_netpbm((dir / "g.pgm").string(), {3, 1, 1, grey}).ok());
  CHECK(read_bytes(dir / "g.pgm") == std::string("P5\n3 1\n255\n") + std::string(grey.begin(), grey.end()));
  CHECK(write_netpbm((dir / "b.ppm").string(), {2, 3, 3, rgb}).code() == StatusCode::kInvalidArgument);
  CHECK(write_netpbm((dir / "no_dir" / "c.ppm").string(), {2, 2, 3, rgb}).code() == StatusCode::kIoError);
  fs::remove_all(dir);
}

TEST_CASE("write_pfm_rgb: header, bottom row first, little-endian float32") {
  const fs::path dir = scratch_dir();
  // 1 wide, 2 high: top pixel (1, 2, 3), bottom pixel (−0.5, 1e30, 0).
  const std::vector<float> rgb = {1.f, 2.f, 3.f, -0.5f, 1e30f, 0.f};
  REQUIRE(rgs::tools::write_pfm_rgb(rgs::format::atomic_files(), (dir / "a.pfm").string(), 1, 2, rgb).ok());
  const std::string bytes = read_bytes(dir / "a.pfm");
  const std::string header = "PF\n1 2\n-1.0\n";
  REQUIRE(bytes.size() == header.size() + 6 * 4);
  CHECK(bytes.substr(0, header.size()) == header);
  const float expected[6] = {-0.5f, 1e30f, 0.f, 1.f, 2.f, 3.f};
  for (int i = 0; i < 6; ++i) {
    uint32_t u = 0;
    for (int b = 0; b < 4; ++b) u |= uint32_t(uint8_t(bytes[header.size() + i * 4 + b])) << (8 * b);
    float f;
    std::memcpy(&f, &u, 4);
    CHECK(f == expected[i]);
  }
  CHECK(rgs::tools::write_pfm_rgb(rgs::format::atomic_files(), (dir / "b.pfm").string(), 2, 2, rgb).code() == StatusCode::kInvalidArgument);
  fs::remove_all(dir);
}

TEST_CASE("write_image8: dispatch by extension, PNG only with OpenImageIO") {
  const fs::path dir = scratch_dir();
  const std::vector<uint8_t> grey = {10, 20};
  REQUIRE(rgs::tools::write_image8(rgs::format::atomic_files(), (dir / "g.ppm").string(), 2, 1, 1, grey).ok());  // grey repeated into RGB
  CHECK(read_bytes(dir / "g.ppm") == std::string("P6\n2 1\n255\n") + std::string("\x0a\x0a\x0a\x14\x14\x14", 6));
  REQUIRE(rgs::tools::write_image8(rgs::format::atomic_files(), (dir / "G.PGM").string(), 2, 1, 1, grey).ok());
  CHECK(rgs::tools::check_image8_path("x.pgm", 3).code() == StatusCode::kInvalidArgument);
  const rgs::Status unknown = rgs::tools::write_image8(rgs::format::atomic_files(), (dir / "g.bmp").string(), 2, 1, 1, grey);
  CHECK(unknown.code() == StatusCode::kInvalidArgument);
  CHECK(unknown.message().find("unknown image extension '.bmp'") != std::string::npos);
  const rgs::Status png = rgs::tools::write_image8(rgs::format::atomic_files(), (dir / "g.png").string(), 2, 1, 1, grey);
  if (rgs::tools::have_openimageio()) {
    CHECK(png.ok());
    CHECK(rgs::tools::check_image8_path("x.png", 3).ok());
  } else {
    CHECK(png.code() == StatusCode::kUnsupportedFeature);
    CHECK(png.message().find("needs OpenImageIO") != std::string::npos);
    const rgs::Status exr = rgs::tools::write_exr_rgba(rgs::format::atomic_files(), (dir / "g.exr").string(), 1, 1,
                                                       {0, 0, 0, 1});
    CHECK(exr.code() == StatusCode::kUnsupportedFeature);
    CHECK_FALSE(fs::exists(dir / "g.png"));
  }
  fs::remove_all(dir);
}
