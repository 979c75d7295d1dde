// Helpers of the audit suite: scenes converted in memory and written to a temporary .rgs file, so the tests go
// through load_audit_scene like the tool does; the views of the rate-control fit of the GPU suite and its PSNR by run_audit.
#pragma once

#include <doctest/doctest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/file_io.h"
#include "rgs/format/writer.h"
#include "test_data.h"

namespace rgs::test {

/// Converts `source` with the default options (what `rgs-convert in.ply out.rgs` writes) into a .rgs file in
/// the temporary folder named `name`, and loads it for the audit.
inline audit::AuditScene converted_scene(const audit::AuditScene& source, const std::string& name,
                                         const converter::QuantizeOptions& options = {}) {
  auto encoded = converter::quantize(source.cloud, options);
  REQUIRE_MESSAGE(encoded.ok(), encoded.status().to_string());
  auto bytes = format::serialize_scene(*encoded, format::WriteOptions{});
  REQUIRE_MESSAGE(bytes.ok(), bytes.status().to_string());
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  REQUIRE(format::write_file_atomic(path, bytes->data(), bytes->size()).ok());
  auto scene = audit::load_audit_scene(path, "converted");
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  return std::move(scene).value();
}

/// Loads a scene for the audit, failing the test on error.
inline audit::AuditScene audit_scene(const std::string& path) {
  auto scene = audit::load_audit_scene(path);
  REQUIRE_MESSAGE(scene.ok(), scene.status().to_string());
  return std::move(scene).value();
}

/// Two orbit views at 480x270: what the rate-control fits are measured on (as in tests/api).
inline api::CameraChoice small_orbit() {
  api::CameraChoice choice;
  choice.orbit = 2;
  choice.orbit_width = 480;
  choice.orbit_height = 270;
  return choice;
}

/// Mean PSNR of `candidate`'s render against `source`'s on `choice`'s cameras, by run_audit alone on `backend`.
inline double measured_psnr(const std::string& source, const std::string& candidate, const api::CameraChoice& choice,
                            audit::Backend backend = audit::Backend::kCpu) {
  const audit::AuditScene src = audit_scene(source);
  std::vector<audit::AuditScene> candidates = {audit_scene(candidate)};
  auto cameras = api::make_cameras(choice, api::content_frame(src.cloud));
  REQUIRE_MESSAGE(cameras.ok(), cameras.status().to_string());
  audit::AuditOptions options;
  options.worst_views = 0;
  options.backend = backend;
  auto result = audit::run_audit(src, candidates, *cameras, options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  return result->candidates[0].summary.psnr_mean_db;
}

}  // namespace rgs::test
