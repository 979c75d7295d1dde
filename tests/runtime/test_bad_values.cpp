// The .rgs loading path of the CPU renderer (RgsFile::read_scene) refuses values the renderers must never see.
#include <doctest/doctest.h>

#include "bad_value_files.h"
#include "rgs/format/reader.h"
#include "test_data.h"

namespace rgs::test {

TEST_CASE("CPU render path: .rgs files with NaN means, zero quaternions, negative scales or opacity 2 fail") {
  // tools::load_scene (rgs-render --backend cpu, rgs-audit) reads through RgsFile::read_scene.
  check_read_scene_refuses_bad_values();
}

}  // namespace rgs::test
