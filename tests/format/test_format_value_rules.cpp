// The value rules of the runtime sections (SPEC.md §4.3–§4.7, format/src/validate.cpp): the binary16 rules on
// the bits equal the rules on the values, on every binary16 value; records_pass, the pass check_records runs
// first (the level-of-detail reader checks every range it streams), accepts exactly what the per-record checks
// accept, on every SH byte and on means around every limit of the bounds; check_records names the first
// failing Gaussian. A white-box suite: it includes the format library's internal header.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <doctest/doctest.h>

#include "internal_sections.h"
#include "rgs/format/half.h"

namespace rgs::test {
namespace {

namespace d = rgs::format::detail;
using format::ScaleEncoding;
using format::SceneMetadata;
using format::SectionId;

std::vector<uint8_t> half_records(const std::vector<uint16_t>& values) {
  std::vector<uint8_t> bytes(2 * values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    bytes[2 * i] = static_cast<uint8_t>(values[i]);
    bytes[2 * i + 1] = static_cast<uint8_t>(values[i] >> 8);
  }
  return bytes;
}

/// Bounds centred near the origin: an AABB of half sizes 4, 3, 2 and a sphere of radius `radius` about
/// (0.5, −0.25, 0), so that either the box or the sphere is the limit a mean meets first.
SceneMetadata metadata_with_bounds(float box_scale, float radius) {
  SceneMetadata m;
  const float half[3] = {4.f, 3.f, 2.f};
  for (int a = 0; a < 3; ++a) {
    m.bounds.aabb_min[a] = -half[a] * box_scale;
    m.bounds.aabb_max[a] = half[a] * box_scale;
  }
  m.bounds.sphere_center[0] = 0.5f, m.bounds.sphere_center[1] = -0.25f, m.bounds.sphere_center[2] = 0.f;
  m.bounds.sphere_radius = radius;
  return m;
}

TEST_CASE("value rules: the binary16 rules on bits equal the rules on values, and the checks apply them") {
  int rotation = 0, scale_log = 0, scale_linear = 0, opacity = 0;
  for (uint32_t bits = 0; bits <= 0xffffu; ++bits) {
    const uint16_t b = static_cast<uint16_t>(bits);
    CAPTURE(b);
    // SPEC §4.4–§4.6 on the value: finite rotation components; finite scales, a log scale whose exp stays finite
    // in float32 (below 88.75, the first binary16 past ln FLT_MAX), a linear scale ≥ 0; opacities in [0, 1].
    const float v = format::half_bits_to_float(b);
    const bool finite = std::isfinite(v);
    CHECK(d::half_bits_finite(b) == finite);
    CHECK(d::scale_component_passes(b, ScaleEncoding::kLog) == (finite && v < 88.75f));
    CHECK(d::scale_component_passes(b, ScaleEncoding::kLinear) == (finite && v >= 0.0f));
    CHECK(d::opacity_passes(b) == (v >= 0.0f && v <= 1.0f));
    const uint16_t q[4] = {b, 0x3c00u, 0, 0};  // a non-zero quaternion whatever b is
    CHECK(d::check_rotation(q, 0).ok() == finite);
    const uint16_t s[3] = {b, 0, 0};
    CHECK(d::check_scale(s, 0, ScaleEncoding::kLog).ok() == d::scale_component_passes(b, ScaleEncoding::kLog));
    CHECK(d::check_scale(s, 0, ScaleEncoding::kLinear).ok() == d::scale_component_passes(b, ScaleEncoding::kLinear));
    CHECK(d::check_opacity(b, 0).ok() == d::opacity_passes(b));
    rotation += d::half_bits_finite(b);
    scale_log += d::scale_component_passes(b, ScaleEncoding::kLog);
    scale_linear += d::scale_component_passes(b, ScaleEncoding::kLinear);
    opacity += d::opacity_passes(b);
  }
  // Counts from the rules: 2·31·1024 finite values; log scales below 88.75 (0x558c positive patterns and every
  // finite negative one); linear scales ≥ 0 (the finite positive ones and −0); opacities 0..1 (0x3c01 and −0).
  CHECK(rotation == 63488);
  CHECK(scale_log == 0x558c + 31744);
  CHECK(scale_linear == 31744 + 1);
  CHECK(opacity == 0x3c01 + 1);
}

TEST_CASE("value rules: records_pass and check_records agree on whole sections, and name the first failure") {
  const SceneMetadata m = metadata_with_bounds(1.f, 100.f);
  // Every SH byte alone in a record of 48 (SH 3): only −128 fails.
  for (int v = -128; v <= 127; ++v) {
    std::vector<uint8_t> sh(48 * 3, 7);
    sh[48 + 17] = static_cast<uint8_t>(v);
    const Status s = d::check_records(SectionId::kSh, m, sh.data(), 3, 48, 100);
    CHECK(d::records_pass(SectionId::kSh, m, sh.data(), 3, 48) == (v != -128));
    CHECK(s.ok() == (v != -128));
    if (!s.ok()) CHECK(s.message().find("Gaussian 101") != std::string::npos);
  }
  // The zero quaternion, with either sign of zero, fails; one non-zero component passes.
  for (const uint16_t zero : {uint16_t(0), uint16_t(0x8000u)}) {
    const std::vector<uint8_t> q = half_records({0x3c00u, 0, 0, 0, zero, 0x8000u, 0, 0});
    CHECK_FALSE(d::records_pass(SectionId::kRotations, m, q.data(), 2, 8));
    const Status s = d::check_records(SectionId::kRotations, m, q.data(), 2, 8, 0);
    CHECK_FALSE(s.ok());
    CHECK(s.message().find("Gaussian 1: rotation quaternion is zero") != std::string::npos);
  }
  // Sections of 1,000 good rotations and scales (read as one stream of binary16 values, whatever the record)
  // with one bad component at record 617, component 2 or 3: records_pass fails and check_records names record 617.
  auto check_section = [](SectionId id, const SceneMetadata& with, size_t components, uint16_t good, size_t component,
                          uint16_t bad, const std::string& named) {
    std::vector<uint16_t> values(components * 1000, good);
    const size_t record = 2 * components;
    CHECK(d::records_pass(id, with, half_records(values).data(), 1000, record));
    values[components * 617 + component] = bad;
    CHECK_FALSE(d::records_pass(id, with, half_records(values).data(), 1000, record));
    CHECK(d::check_records(id, with, half_records(values).data(), 1000, record, 0).message().find(named) !=
          std::string::npos);
  };
  for (const uint16_t bad : {uint16_t(0x7c00u), uint16_t(0xfe00u)}) {  // +inf, a NaN
    check_section(SectionId::kRotations, m, 4, 0x3800u, 3, bad, "Gaussian 617: rotation component 3");
    for (const ScaleEncoding encoding : {ScaleEncoding::kLog, ScaleEncoding::kLinear}) {
      SceneMetadata with = m;
      with.scale_encoding = encoding;
      check_section(SectionId::kScales, with, 3, 0x3400u, 2, bad, "Gaussian 617: scale component 2");
    }
  }
  // A section of good opacities with one bad one: check_records names that one.
  std::vector<uint16_t> opacities(1000, 0x3800u);
  CHECK(d::check_records(SectionId::kOpacities, m, half_records(opacities).data(), 1000, 2, 0).ok());
  opacities[617] = 0x3c01u;  // the binary16 after 1
  const Status s = d::check_records(SectionId::kOpacities, m, half_records(opacities).data(), 1000, 2, 0);
  CHECK(s.message().find("Gaussian 617: opacity") != std::string::npos);
}

TEST_CASE("value rules: records_pass accepts the means check_mean accepts, around every limit") {
  // The box is the limit in `boxed` (sphere far outside it), the sphere in `round` (box far outside it).
  const SceneMetadata boxed = metadata_with_bounds(1.f, 100.f), round = metadata_with_bounds(100.f, 4.5f);
  std::vector<float> means;
  std::vector<const SceneMetadata*> bounds_of;
  auto add = [&](const SceneMetadata& m, float x, float y, float z) {
    means.insert(means.end(), {x, y, z});
    bounds_of.push_back(&m);
  };
  // On and just beyond each face of the box, and non-finite coordinates.
  for (int a = 0; a < 3; ++a) {
    for (const float edge : {boxed.bounds.aabb_min[a], boxed.bounds.aabb_max[a]}) {
      for (const float v : {edge, std::nextafter(edge, -INFINITY), std::nextafter(edge, INFINITY)}) {
        float p[3] = {0.f, 0.f, 0.f};
        p[a] = v;
        add(boxed, p[0], p[1], p[2]);
      }
    }
    for (const float v : {std::numeric_limits<float>::quiet_NaN(), INFINITY, -INFINITY}) {
      float p[3] = {0.f, 0.f, 0.f};
      p[a] = v;
      add(boxed, p[0], p[1], p[2]);
      add(round, p[0], p[1], p[2]);
    }
  }
  // Points on rays from the sphere's centre at distances stepping by single float ulps across its radius and
  // check_mean's slack.
  const format::SceneBounds& b = round.bounds;
  std::mt19937 rng(7);
  std::normal_distribution<float> normal;
  for (int ray = 0; ray < 200; ++ray) {
    const float dir[3] = {normal(rng), normal(rng), normal(rng)};
    const float len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    float t = b.sphere_radius * 0.999999f;
    for (int step = 0; step < 64; ++step, t = std::nextafter(t, INFINITY)) {
      add(round, b.sphere_center[0] + t * dir[0] / len, b.sphere_center[1] + t * dir[1] / len,
          b.sphere_center[2] + t * dir[2] / len);
    }
  }
  std::vector<uint8_t> bytes(4 * means.size());
  std::memcpy(bytes.data(), means.data(), bytes.size());  // the little-endian layout on every tested host
  size_t refused = 0, passed_fast = 0;
  for (size_t i = 0; i < means.size() / 3; ++i) {
    const SceneMetadata& m = *bounds_of[i];
    const bool fast = d::records_pass(SectionId::kMeans, m, bytes.data() + 12 * i, 1, 12);
    const bool exact = d::check_mean(&means[3 * i], i, m.bounds).ok();
    CAPTURE(i);
    CHECK(fast == exact);
    refused += !exact;
    passed_fast += fast;
  }
  const size_t count = means.size() / 3;
  MESSAGE(count << " means: " << refused << " refused by check_mean, " << passed_fast
                            << " passed by records_pass");
  CHECK(refused > 100);
  CHECK(passed_fast > 100);
  // A whole section with one mean outside: records_pass fails and check_records names it.
  std::vector<float> section(3 * 500, 0.25f);
  section[3 * 321 + 1] = 3.5f;  // beyond aabb_max.y = 3
  std::vector<uint8_t> raw(4 * section.size());
  std::memcpy(raw.data(), section.data(), raw.size());
  CHECK(d::records_pass(SectionId::kMeans, boxed, raw.data(), 320, 12));
  CHECK_FALSE(d::records_pass(SectionId::kMeans, boxed, raw.data(), 500, 12));
  CHECK(d::check_records(SectionId::kMeans, boxed, raw.data(), 500, 12, 0).message().find("Gaussian 321: mean") !=
        std::string::npos);
}

}  // namespace
}  // namespace rgs::test
