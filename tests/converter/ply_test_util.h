// Helpers of the converter tests: an independent minimal reader of INRIA float PLY files (to check the
// library against), a PLY builder for any storage/type/order, and the quantization bound checks.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/half.h"

namespace rgs::test {

inline std::vector<uint8_t> load_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in.good(), "cannot open " << path);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The raw float values of a binary-little-endian all-float PLY (the INRIA layout), by property name.
/// Deliberately simple and separate from the library's reader.
struct RawPly {
  std::vector<std::string> names;
  uint64_t count = 0;
  std::vector<float> values;  // [count, names.size()]
  std::string header;

  size_t column(const std::string& name) const {
    for (size_t j = 0; j < names.size(); ++j) {
      if (names[j] == name) return j;
    }
    FAIL("no property " << name);
    return 0;
  }
  float get(uint64_t i, const std::string& name) const { return values[i * names.size() + column(name)]; }
  bool has(const std::string& name) const {
    for (const auto& n : names) {
      if (n == name) return true;
    }
    return false;
  }
};

inline RawPly parse_raw_ply(const std::vector<uint8_t>& bytes) {
  RawPly raw;
  const std::string text(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(bytes.size(), 65536)));
  const size_t end = text.find("end_header\n");
  REQUIRE(end != std::string::npos);
  raw.header = text.substr(0, end + 11);
  std::istringstream lines(raw.header);
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream t(line);
    std::string key, a, b;
    t >> key >> a >> b;
    if (key == "element") {
      REQUIRE(a == "vertex");
      raw.count = std::stoull(b);
    } else if (key == "property") {
      REQUIRE(a == "float");
      raw.names.push_back(b);
    }
  }
  const size_t n_values = raw.count * raw.names.size();
  REQUIRE(bytes.size() >= raw.header.size() + n_values * 4);
  raw.values.resize(n_values);
  std::memcpy(raw.values.data(), bytes.data() + raw.header.size(), n_values * 4);
  return raw;
}

/// One property of a PLY to build: name and PLY type name.
struct PropSpec {
  std::string name;
  std::string type;
};

/// Builds a PLY with `n` vertices. `value(i, name)` gives each value (converted to the property type).
/// `storage` is "ascii", "binary_little_endian" or "binary_big_endian"; `newline` "\n" or "\r\n"
/// (header and ascii lines); `trailer_header` and `trailer_data` append other elements after vertex.
inline std::vector<uint8_t> build_ply(const std::string& storage, const std::vector<PropSpec>& props, uint64_t n,
                                      const std::function<double(uint64_t, const std::string&)>& value,
                                      const std::string& newline = "\n", const std::string& trailer_header = "",
                                      const std::string& trailer_data = "") {
  std::string h = "ply" + newline + "format " + storage + " 1.0" + newline + "comment built by ply_test_util.h" +
                  newline + "element vertex " + std::to_string(n) + newline;
  for (const auto& p : props) h += "property " + p.type + " " + p.name + newline;
  h += trailer_header;
  h += "end_header" + newline;
  std::vector<uint8_t> out(h.begin(), h.end());
  const bool big = storage == "binary_big_endian";
  auto put = [&](const void* src, size_t size) {
    const auto* b = static_cast<const uint8_t*>(src);
    if (big) {
      for (size_t k = size; k-- > 0;) out.push_back(b[k]);
    } else {
      out.insert(out.end(), b, b + size);
    }
  };
  char buf[64];
  for (uint64_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < props.size(); ++j) {
      const PropSpec& p = props[j];
      const double v = value(i, p.name);
      if (storage == "ascii") {
        std::to_chars_result r{};
        if (p.type == "float") {
          r = std::to_chars(buf, buf + sizeof(buf), static_cast<float>(v));
        } else if (p.type == "double") {
          r = std::to_chars(buf, buf + sizeof(buf), v);
        } else {
          r = std::to_chars(buf, buf + sizeof(buf), static_cast<long long>(v));
        }
        out.insert(out.end(), buf, r.ptr);
        if (j + 1 < props.size()) out.push_back(' ');
        continue;
      }
      if (p.type == "float") {
        const float f = static_cast<float>(v);
        put(&f, 4);
      } else if (p.type == "double") {
        put(&v, 8);
      } else if (p.type == "uchar") {
        const auto u = static_cast<uint8_t>(v);
        put(&u, 1);
      } else if (p.type == "short") {
        const auto s = static_cast<int16_t>(v);
        put(&s, 2);
      } else if (p.type == "int") {
        const auto s = static_cast<int32_t>(v);
        put(&s, 4);
      } else {
        FAIL("unsupported test type " << p.type);
      }
    }
    if (storage == "ascii") out.insert(out.end(), newline.begin(), newline.end());
  }
  out.insert(out.end(), trailer_data.begin(), trailer_data.end());
  return out;
}

/// Property specs of the INRIA layout at `degree`, all float.
inline std::vector<PropSpec> inria_props(uint32_t degree, bool normals = true) {
  std::vector<PropSpec> p;
  for (const char* n : {"x", "y", "z"}) p.push_back({n, "float"});
  if (normals) {
    for (const char* n : {"nx", "ny", "nz"}) p.push_back({n, "float"});
  }
  for (int c = 0; c < 3; ++c) p.push_back({"f_dc_" + std::to_string(c), "float"});
  const uint32_t k = format::sh_coefficient_count(degree);
  for (uint32_t r = 0; r < 3 * (k - 1); ++r) p.push_back({"f_rest_" + std::to_string(r), "float"});
  p.push_back({"opacity", "float"});
  for (int a = 0; a < 3; ++a) p.push_back({"scale_" + std::to_string(a), "float"});
  for (int a = 0; a < 4; ++a) p.push_back({"rot_" + std::to_string(a), "float"});
  return p;
}

inline bool same_floats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

/// Bitwise equality of two clouds (NaN payloads included).
inline bool same_cloud(const format::GaussianCloud& a, const format::GaussianCloud& b) {
  return a.sh_degree == b.sh_degree && same_floats(a.means, b.means) && same_floats(a.rotations, b.rotations) &&
         same_floats(a.scales, b.scales) && same_floats(a.opacities, b.opacities) && same_floats(a.sh, b.sh);
}

inline bool same_encoded(const format::EncodedScene& a, const format::EncodedScene& b) {
  auto eq = [](const auto& x, const auto& y) {
    using T = typename std::decay_t<decltype(x)>::value_type;
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(T)) == 0);
  };
  const auto& ma = a.metadata;
  const auto& mb = b.metadata;
  return a.count == b.count && eq(a.means, b.means) && eq(a.rotations, b.rotations) && eq(a.scales, b.scales) &&
         eq(a.opacities, b.opacities) && eq(a.sh, b.sh) && eq(a.sh_dc_residual, b.sh_dc_residual) && ma.sh_degree == mb.sh_degree &&
         ma.scale_encoding == mb.scale_encoding &&
         std::memcmp(&ma.sh_quantization.scales, &mb.sh_quantization.scales, sizeof(ma.sh_quantization.scales)) == 0 &&
         ma.sh_quantization.clip_percentile == mb.sh_quantization.clip_percentile &&
         std::memcmp(&ma.bounds, &mb.bounds, sizeof(ma.bounds)) == 0;
}

/// |h − v| <= half an ulp of binary16 at v: 2^-11·|v| for normal halves (the half ulp in the binade
/// [2^e, 2^(e+1)) is 2^(e-11) <= 2^-11·|v|), 2^-25 absolute in the subnormal range (|v| < 2^-14).
/// Exact: v is the very float32 that was rounded, so no extra slack is needed.
inline bool within_half_ulp(float v, uint16_t h) {
  const double r = format::half_bits_to_float(h);
  const double x = v;
  const double err = std::fabs(r - x);
  const double bound = std::fabs(x) < 6.103515625e-05 ? std::ldexp(1.0, -25) : std::ldexp(std::fabs(x), -11);
  return err <= bound;
}

/// Checks every bound of quantize() on `enc` against its source `cloud`; returns the number of
/// violations (0 when all hold) and reports the first few.
inline uint64_t check_quantization_bounds(const format::GaussianCloud& cloud, const format::EncodedScene& enc) {
  uint64_t violations = 0;
  auto report = [&violations](const std::string& what) {
    if (++violations <= 5) MESSAGE(what);
  };
  REQUIRE(enc.count == cloud.size());
  REQUIRE(enc.is_consistent());
  // Means bit-exact.
  CHECK(same_floats(enc.means, cloud.means));
  const uint64_t n = cloud.size();
  const uint32_t k_count = cloud.sh_coefficients();
  const auto& s = enc.metadata.sh_quantization.scales;
  const bool log_scale = enc.metadata.scale_encoding == format::ScaleEncoding::kLog;
  for (uint64_t i = 0; i < n; ++i) {
    // Rotation: the normalized quaternion (double normalize, float round), each component within half an ulp.
    double q[4], n2 = 0;
    for (int a = 0; a < 4; ++a) {
      q[a] = cloud.rotations[i * 4 + a];
      n2 += q[a] * q[a];
    }
    for (int a = 0; a < 4; ++a) {
      const float r = static_cast<float>(q[a] / std::sqrt(n2));
      if (!within_half_ulp(r, enc.rotations[i * 4 + a])) report("rotation " + std::to_string(i));
    }
    for (int a = 0; a < 3; ++a) {
      const float sc = cloud.scales[i * 3 + a];
      const float v = log_scale ? (sc > 0 ? static_cast<float>(std::log(static_cast<double>(sc))) : -65504.0f) : sc;
      if (!within_half_ulp(v, enc.scales[i * 3 + a])) report("scale " + std::to_string(i));
    }
    if (!within_half_ulp(cloud.opacities[i], enc.opacities[i])) report("opacity " + std::to_string(i));
    for (uint32_t k = 0; k < k_count; ++k) {
      const uint32_t d = format::sh_degree_of_coefficient(k);
      for (uint32_t c = 0; c < 3; ++c) {
        const double v = cloud.sh[(i * k_count + k) * 3 + c];
        const int8_t code = enc.sh[(i * k_count + k) * 3 + c];
        // In exact arithmetic |s·q − v| <= s/2. s·q is exact in double (float × int8); the only other
        // rounding is quantize()'s double division v/s (relative 2^-53, i.e. <= 127·2^-53·s), so a slack
        // of 1e-12·s is generous. (dequantize() forms s·q in float32, adding up to 127·2^-24·s.)
        double deq = static_cast<double>(s[d][c]) * code;
        double bound = 0.5 * s[d][c] * (1.0 + 1e-12);
        if (k == 0 && !enc.sh_dc_residual.empty()) {
          // The DC residual r (|r| <= 127) leaves at most 1/256 of the step: 1/512 from rounding 256·(v/s − q),
          // up to 1/256 where |v/s − q| is within 1/512 of 0.5 and r is clamped to ±127.
          const int8_t r = enc.sh_dc_residual[i * 3 + c];
          deq = static_cast<double>(s[d][c]) * (code + r / 256.0);
          bound = s[d][c] / 256.0 * (1.0 + 1e-9);
          if (r < -127) report("DC residual -128 at " + std::to_string(i));
        }
        if (code < -127 || std::fabs(deq - v) > bound) {
          report("SH " + std::to_string(i) + " k " + std::to_string(k) + " c " + std::to_string(c) + ": " +
                 std::to_string(v) + " -> " + std::to_string(deq) + " (s " + std::to_string(s[d][c]) + ")");
        }
      }
    }
  }
  return violations;
}

}  // namespace rgs::test
