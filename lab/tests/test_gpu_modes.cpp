// rgs-bench's named GPU modes (rgs/lab/gpu_modes.h): every listed mode parses; a scene without compact
// attributes is refused by the modes that exist to read the compact ones; the presets are the first modes, and
// the modes that render with a lab variant of the render kernel are the non-product ones.
#include <doctest/doctest.h>

#include <string>

#include "rgs/api/preset.h"
#include "rgs/lab/gpu_modes.h"

namespace {

using namespace rgs;

TEST_CASE("gpu modes: names, compact attributes, the presets first, lab variants") {
  for (const lab::GpuMode& mode : lab::gpu_modes()) {
    CAPTURE(mode.name);
    CHECK(lab::gpu_mode_options(mode.name, true).ok());
    CHECK(lab::gpu_mode_options(mode.name, false).ok() == !mode.requires_compact);
    const bool product = mode.name == "faithful" || mode.name == "fastest" || mode.name == "paper" ||
                         mode.name == "fastest-whole-tiles" || mode.name == "roofgs-no-subtile";
    CHECK(mode.lab == !product);
  }
  // One registry: the presets are the first modes, under the names parse_preset() reads.
  const api::Preset presets[] = {api::Preset::kFaithful, api::Preset::kFastest, api::Preset::kPaper};
  for (size_t i = 0; i < 3; ++i) {
    REQUIRE(lab::gpu_modes().size() > i);
    CHECK(lab::gpu_modes()[i].name == api::preset_name(presets[i]));
    CHECK(api::parse_preset(lab::gpu_modes()[i].name).value() == presets[i]);
  }
  CHECK(lab::gpu_mode_options("nope", true).status().code() == StatusCode::kInvalidArgument);
}

}  // namespace
