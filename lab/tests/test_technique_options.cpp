// Rendering chosen RoofGS techniques (rgs/lab/technique_options.h): half-precision blending on the CPU
// reference (the GPU's binary16 arithmetic, emulated) with every other technique, and its prerequisites; the GPU
// options carry the lab's stages.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "rgs/config.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/lab/technique_options.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"
#include "test_data.h"

namespace {

using namespace rgs;

TEST_CASE("technique options: half blend with every technique renders on the CPU, alone it is refused") {
  runtime::RoofgsOptions t;
  t.key32 = true;
  t.snugbox_accutile = true;
  t.folded_coefficients = true;
  t.fast_exp = true;
  t.half_blend = true;
  CHECK(t.fast_exp_sigma == doctest::Approx(0.045677).epsilon(1e-6));  // the paper's sigma by default
  REQUIRE(lab::check_techniques(t).ok());
  auto ply = converter::read_ply(test::repo_path("samples/guitar.ply"));
  REQUIRE_MESSAGE(ply.ok(), ply.status().to_string());
  const format::SceneBounds bounds = converter::compute_bounds(ply->cloud);
  auto cams = runtime::orbit_cameras(bounds, 1, 64, 36);
  REQUIRE(cams.ok());
  const runtime::RenderOptions options = lab::cpu_technique_options(t, bounds);
  CHECK(options.roofgs.half_blend);
  CHECK(options.roofgs.key32);
  auto image = runtime::render_cpu(ply->cloud, (*cams)[0], options);
  REQUIRE_MESSAGE(image.ok(), image.status().to_string());
  CHECK(image->stats.pairs > 0);

  runtime::RoofgsOptions alone;
  alone.half_blend = true;
  const Status refused = lab::check_techniques(alone);
  CHECK(refused.code() == StatusCode::kInvalidArgument);
  CHECK(refused.message().find("half_blend needs folded_coefficients and fast_exp") != std::string::npos);
#if RGS_HAS_CUDA
  const runtime::GpuRenderOptions gpu = lab::gpu_technique_options(t, true);
  REQUIRE(gpu.lab_techniques.has_value());
  CHECK(gpu.lab_techniques->pipeline == runtime::GpuPipeline::kRoofgs);
  CHECK(gpu.lab_techniques->roofgs.compact_attributes);
  CHECK(gpu.lab_techniques->roofgs.fused_preprocess);
  CHECK(gpu.lab_techniques->roofgs.techniques.half_blend);
  CHECK(lab::planned_techniques(gpu, true).roofgs.techniques.half_blend);
  CHECK((gpu.stages.preprocess != nullptr));
  CHECK((gpu.stages.render != kernels::render_roofgs));
#endif
}

}  // namespace
