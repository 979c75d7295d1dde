// The benchmark tools' options: rgs-bench's --resolution parser.
#include <doctest/doctest.h>

#include <string>

#include "rgs/lab/bench_options.h"

namespace rgs::test {

TEST_CASE("parse_resolution: WIDTHxHEIGHT and names") {
  auto r = lab::parse_resolution("1920x1080");
  REQUIRE(r.ok());
  CHECK(r->width == 1920);
  CHECK(r->height == 1080);
  r = lab::parse_resolution("640X480");
  REQUIRE(r.ok());
  CHECK(r->width == 640);
  r = lab::parse_resolution("4K");
  REQUIRE(r.ok());
  CHECK((r->width == 3840 && r->height == 2160));
  r = lab::parse_resolution("1080p");
  REQUIRE(r.ok());
  CHECK((r->width == 1920 && r->height == 1080));
  CHECK(lab::resolution_string({1256, 832}) == "1256x832");
  for (const char* bad : {"", "x", "1920", "1920x", "x1080", "0x10", "10x0", "32769x10", "-5x10", "1920x1080x3",
                          "1920by1080", "19 20x1080", "+5x5", "8k"}) {
    INFO(bad);
    auto e = lab::parse_resolution(bad);
    REQUIRE_FALSE(e.ok());
    CHECK(e.status().code() == StatusCode::kInvalidArgument);
    CHECK(e.status().message().find(std::string("'") + bad + "'") != std::string::npos);
  }
  CHECK(lab::parse_resolution("32768x1").ok());
}

}  // namespace rgs::test
