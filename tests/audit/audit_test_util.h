// Helpers of the audit suite: scenes converted in memory and written to a temporary .rgs file, so the tests go
// through load_audit_scene like the tool does.
#pragma once

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

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

}  // namespace rgs::test
