// The golden .rgs files whose values break SPEC §5.4, and the check that the loading path every renderer and
// converter shares refuses them. Link rgs_format.
#pragma once

#include <string>

#include <doctest/doctest.h>

#include "rgs/format/reader.h"
#include "test_data.h"

namespace rgs::test {

/// tests/data/bad/<name>.rgs files that open (structure and checksums are valid) but hold values the spec
/// rules out: a NaN mean, a zero quaternion, a negative linear scale, an opacity above one.
inline constexpr const char* kBadValueRgsFiles[] = {"nan_mean", "zero_rotation", "negative_linear_scale",
                                                    "opacity_above_one"};

/// Checks that each of kBadValueRgsFiles opens and that RgsFile::read_scene refuses it with kCorruptData,
/// the message naming the file and the Gaussian.
inline void check_read_scene_refuses_bad_values() {
  for (const char* name : kBadValueRgsFiles) {
    CAPTURE(name);
    auto file = format::RgsFile::open(repo_path(std::string("tests/data/bad/") + name + ".rgs"));
    REQUIRE(file.ok());
    auto scene = file->read_scene();
    REQUIRE_FALSE(scene.ok());
    CHECK(scene.status().code() == StatusCode::kCorruptData);
    CHECK(scene.status().message().find("Gaussian ") != std::string::npos);
    CHECK(scene.status().message().find(std::string(name) + ".rgs") != std::string::npos);
  }
}

}  // namespace rgs::test
