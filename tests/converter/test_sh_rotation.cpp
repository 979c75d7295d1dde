// SH rotation (converter::sh_rotation) and the edits of the edit chain (converter::parse_edit_action,
// apply_edit): the D-matrices against the renderers' own SH basis, the documented Euler convention, and each
// edit's effect and refusals on the shipped SH-3 scene.
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/converter/cloud_edits.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/sh_rotation.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "test_data.h"

namespace rgs::test {
namespace {

using Matrix3 = std::array<double, 9>;

Matrix3 multiply(const Matrix3& a, const Matrix3& b) {
  Matrix3 c{};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) {
      for (int col = 0; col < 3; ++col) c[r * 3 + col] += a[r * 3 + k] * b[k * 3 + col];
    }
  }
  return c;
}

Matrix3 axis_rotation(int axis, double degrees) {
  const double a = degrees * 3.14159265358979323846 / 180, c = std::cos(a), s = std::sin(a);
  if (axis == 0) return {1, 0, 0, 0, c, -s, 0, s, c};
  if (axis == 1) return {c, 0, s, 0, 1, 0, -s, 0, c};
  return {c, -s, 0, s, c, 0, 0, 0, 1};
}

/// A rotation from three seeded random angles (not aligned with any axis).
Matrix3 random_rotation(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(-180, 180);
  return multiply(axis_rotation(2, angle(rng)), multiply(axis_rotation(1, angle(rng)), axis_rotation(0, angle(rng))));
}

std::array<double, 3> random_direction(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  std::array<double, 3> d{n(rng), n(rng), n(rng)};
  const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  for (double& v : d) v /= len;
  return d;
}

/// The renderers' basis (kernels/shared/spherical_harmonics.h, float32) at `d`.
std::array<float, 16> basis(const std::array<double, 3>& d) {
  std::array<float, 16> y{};
  kernels::sh_basis(float(d[0]), float(d[1]), float(d[2]), 3, y.data());
  return y;
}

double max_abs_difference(const converter::ShRotation& a, const converter::ShRotation& b) {
  double worst = 0;
  for (int l = 0; l < 4; ++l) {
    for (int i = 0; i < 49; ++i) worst = std::max(worst, std::fabs(a.band[l][i] - b.band[l][i]));
  }
  return worst;
}

format::GaussianCloud guitar_sh3() {
  auto read = converter::read_ply(repo_path(kGuitarSh3));
  REQUIRE_MESSAGE(read.ok(), read.status().to_string());
  return std::move(read->cloud);
}

converter::EditAction parsed(const std::string& name, const std::string& value) {
  auto edit = converter::parse_edit_action(name, value);
  REQUIRE_MESSAGE(edit.ok(), edit.status().to_string());
  return std::move(edit).value();
}

uint64_t applied(format::GaussianCloud* cloud, const std::string& name, const std::string& value) {
  auto removed = converter::apply_edit(cloud, parsed(name, value));
  REQUIRE_MESSAGE(removed.ok(), removed.status().to_string());
  return *removed;
}

}  // namespace

TEST_CASE("SH rotation: the D-matrices are orthogonal, the identity for no rotation, and compose as the rotations") {
  std::mt19937 rng(7);
  const converter::ShRotation identity = converter::sh_rotation({1, 0, 0, 0, 1, 0, 0, 0, 1});
  for (int l = 0; l < 4; ++l) {
    const int n = 2 * l + 1;
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) CHECK(identity.band[l][r * n + c] == doctest::Approx(r == c ? 1.0 : 0.0).epsilon(1e-12));
    }
  }
  for (int trial = 0; trial < 8; ++trial) {
    const Matrix3 r1 = random_rotation(rng), r2 = random_rotation(rng);
    const converter::ShRotation d1 = converter::sh_rotation(r1), d2 = converter::sh_rotation(r2);
    const converter::ShRotation d12 = converter::sh_rotation(multiply(r1, r2));
    converter::ShRotation product;
    double orthogonality = 0;
    for (int l = 0; l < 4; ++l) {
      const int n = 2 * l + 1;
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) {
          double dd = 0, ddt = 0;
          for (int k = 0; k < n; ++k) {
            dd += d1.band[l][r * n + k] * d2.band[l][k * n + c];
            ddt += d1.band[l][r * n + k] * d1.band[l][c * n + k];
          }
          product.band[l][r * n + c] = dd;
          orthogonality = std::max(orthogonality, std::fabs(ddt - (r == c ? 1.0 : 0.0)));
        }
      }
    }
    CHECK(orthogonality < 1e-12);
    CHECK(max_abs_difference(product, d12) < 1e-12);
  }
}

TEST_CASE("SH rotation: the rotated coefficients give the renderers' basis the same colour towards the rotated direction") {
  // Y(R·d)·D(R)·c == Y(d)·c, with the float32 basis the CPU reference and the CUDA kernels evaluate: a D built
  // for another sign convention or coefficient order fails this for most rotations.
  std::mt19937 rng(11);
  std::normal_distribution<double> coefficient(0, 0.3);
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const Matrix3 r = trial == 0 ? axis_rotation(1, 90) : random_rotation(rng);
    std::vector<float> sh(16 * 3);
    for (float& v : sh) v = float(coefficient(rng));
    std::vector<float> rotated = sh;
    converter::rotate_sh(converter::sh_rotation(r), 3, 1, rotated.data());
    CHECK(rotated[0] == sh[0]);  // DC unchanged
    for (int k = 0; k < 5; ++k) {
      const std::array<double, 3> d = random_direction(rng);
      std::array<double, 3> rd{};
      for (int a = 0; a < 3; ++a) rd[a] = r[a * 3] * d[0] + r[a * 3 + 1] * d[1] + r[a * 3 + 2] * d[2];
      const std::array<float, 16> y = basis(d), ry = basis(rd);
      for (int c = 0; c < 3; ++c) {
        double before = 0, after = 0;
        for (int i = 0; i < 16; ++i) {
          before += double(y[i]) * sh[i * 3 + c];
          after += double(ry[i]) * rotated[i * 3 + c];
        }
        worst = std::max(worst, std::fabs(after - before));
      }
    }
  }
  MESSAGE("largest colour difference over 100 directions: " << worst);
  CHECK(worst < 2e-6);
}

TEST_CASE("edits: Euler angles are extrinsic x, then y, then z (R = Rz Ry Rx), and a quaternion w,x,y,z is a rotation too") {
  format::GaussianCloud cloud;
  cloud.resize(1);
  cloud.means = {1.0f, 2.0f, 3.0f};
  cloud.rotations = {1, 0, 0, 0};
  cloud.scales = {0.1f, 0.2f, 0.3f};
  cloud.opacities = {0.5f};
  format::GaussianCloud by_quaternion = cloud;
  const Matrix3 r = multiply(axis_rotation(2, 50), multiply(axis_rotation(1, 40), axis_rotation(0, 30)));
  CHECK(applied(&cloud, "rotate", "30,40,50") == 0);
  for (int a = 0; a < 3; ++a) CHECK(cloud.means[a] == doctest::Approx(r[a * 3] * 1 + r[a * 3 + 1] * 2 + r[a * 3 + 2] * 3).epsilon(1e-6));
  // The Gaussian's own rotation becomes R: its quaternion, as 3DGS turns it into a matrix, gives R.
  const float* q = cloud.rotations.data();
  CHECK(1 - 2 * (q[2] * q[2] + q[3] * q[3]) == doctest::Approx(r[0]).epsilon(1e-6));
  CHECK(2 * (q[1] * q[2] - q[0] * q[3]) == doctest::Approx(r[1]).epsilon(1e-6));
  CHECK(2 * (q[1] * q[3] + q[0] * q[2]) == doctest::Approx(r[2]).epsilon(1e-6));
  // 90 degrees about y as a quaternion (cos 45, 0, sin 45, 0), 4 decimals: within the unit tolerance.
  CHECK(applied(&by_quaternion, "rotate", "0.7071, 0, 0.7071, 0") == 0);
  CHECK(by_quaternion.means[0] == doctest::Approx(3.0).epsilon(1e-6));
  CHECK(by_quaternion.means[1] == doctest::Approx(2.0).epsilon(1e-6));
  CHECK(by_quaternion.means[2] == doctest::Approx(-1.0).epsilon(1e-6));
}

TEST_CASE("edits: translate and scale move means and scales, filters and crops keep what they say") {
  const format::GaussianCloud source = guitar_sh3();
  format::GaussianCloud cloud = source;
  CHECK(applied(&cloud, "translate", "1,-2,0.5") == 0);
  CHECK(applied(&cloud, "scale", "2") == 0);
  // Each edit in double, rounded to float32.
  CHECK(cloud.means[0] == float(double(float(double(source.means[0]) + 1)) * 2));
  CHECK(cloud.means[1] == float(double(float(double(source.means[1]) - 2)) * 2));
  CHECK(cloud.scales[2] == float(double(source.scales[2]) * 2));
  CHECK(cloud.sh == source.sh);

  const auto count_if = [](const format::GaussianCloud& c, auto keep) {
    uint64_t n = 0;
    for (size_t i = 0; i < c.size(); ++i) n += keep(c, i) ? 1 : 0;
    return n;
  };
  struct Case {
    const char* name;
    const char* value;
    bool (*keep)(const format::GaussianCloud&, size_t);
  };
  const Case cases[] = {
      {"filter", "opacity gt 0.5", [](const format::GaussianCloud& c, size_t i) { return c.opacities[i] > 0.5; }},
      {"filter", "scale_1 <= 0.001", [](const format::GaussianCloud& c, size_t i) { return c.scales[i * 3 + 1] <= 0.001; }},
      {"filter", "rot_0 ge 0.9", [](const format::GaussianCloud& c, size_t i) { return c.rotations[i * 4] >= 0.9; }},
      {"filter", "f_dc_2 lt 0", [](const format::GaussianCloud& c, size_t i) { return c.sh[i * 16 * 3 + 2] < 0; }},
      // The colour splat-transform's -V f_dc_0 compares: 0.5 + C0 · f_dc.
      {"filter", "red gt 0.6",
       [](const format::GaussianCloud& c, size_t i) { return 0.5 + 0.28209479177387814 * c.sh[i * 16 * 3] > 0.6; }},
      {"filter", "blue le 0.3",
       [](const format::GaussianCloud& c, size_t i) { return 0.5 + 0.28209479177387814 * c.sh[i * 16 * 3 + 2] <= 0.3; }},
      // f_rest_20: channel 20 / 15 = 1 (green), coefficient 20 % 15 + 1 = 6.
      {"filter", "f_rest_20 > 0.01", [](const format::GaussianCloud& c, size_t i) { return c.sh[(i * 16 + 6) * 3 + 1] > 0.01; }},
      {"filter", "y ge -4", [](const format::GaussianCloud& c, size_t i) { return c.means[i * 3 + 1] >= -4; }},
      {"crop-box", "-0.5,-9,-9,0.5,9,9",
       [](const format::GaussianCloud& c, size_t i) { return c.means[i * 3] >= -0.5 && c.means[i * 3] <= 0.5; }},
      {"crop-box-outside", "-0.5,-9,-9,0.5,9,9",
       [](const format::GaussianCloud& c, size_t i) { return !(c.means[i * 3] >= -0.5 && c.means[i * 3] <= 0.5); }},
      {"crop-sphere", "-0.3,-3.9,0.1,0.2", [](const format::GaussianCloud& c, size_t i) {
         const double x = c.means[i * 3] + 0.3, y = c.means[i * 3 + 1] + 3.9, z = c.means[i * 3 + 2] - 0.1;
         return x * x + y * y + z * z <= 0.2 * 0.2;
       }},
      {"crop-sphere-outside", "-0.3,-3.9,0.1,0.2", [](const format::GaussianCloud& c, size_t i) {
         const double x = c.means[i * 3] + 0.3, y = c.means[i * 3 + 1] + 3.9, z = c.means[i * 3 + 2] - 0.1;
         return x * x + y * y + z * z > 0.2 * 0.2;
       }},
  };
  for (const Case& c : cases) {
    const std::string value = c.value;
    CAPTURE(value);
    format::GaussianCloud edited = source;
    const uint64_t kept = count_if(source, c.keep);
    CHECK(kept > 0);
    CHECK(kept < source.size());
    CHECK(applied(&edited, c.name, c.value) == source.size() - kept);
    CHECK(edited.size() == kept);
    CHECK(edited.is_consistent());
    CHECK(count_if(edited, c.keep) == kept);
  }
  // eq and ne split the scene at one Gaussian's value, VALUE rounded to float32 as the property is held.
  char x0[64];
  std::snprintf(x0, sizeof(x0), "%.9g", double(source.means[0]));
  format::GaussianCloud equal = source, not_equal = source;
  const uint64_t dropped = applied(&equal, "filter", std::string("x eq ") + x0);
  CHECK(equal.size() >= 1);
  CHECK(applied(&not_equal, "filter", std::string("x != ") + x0) == equal.size());
  CHECK(dropped == not_equal.size());
  // filter-nan drops a Gaussian with one non-finite SH coefficient, and only it.
  format::GaussianCloud with_nan = source;
  with_nan.sh[(5 * 16 + 9) * 3 + 1] = std::nanf("");
  CHECK(applied(&with_nan, "filter-nan", "") == 1);
  CHECK(with_nan.size() == source.size() - 1);
  CHECK(with_nan.means[5 * 3] == source.means[6 * 3]);
}

TEST_CASE("edits: malformed actions are refused naming the action and the rule") {
  const auto refused = [](const std::string& name, const std::string& value, const std::string& why) {
    CAPTURE(name);
    CAPTURE(value);
    auto edit = converter::parse_edit_action(name, value);
    REQUIRE_FALSE(edit.ok());
    CHECK(edit.status().code() == StatusCode::kInvalidArgument);
    CHECK_MESSAGE(edit.status().message().find(why) != std::string::npos, edit.status().message());
  };
  refused("spin", "1,2,3", "unknown edit 'spin'");
  refused("translate", "1,2", "takes 3 numbers, not 2");
  refused("translate", "1,inf,2", "'inf' is not a finite number");
  refused("translate", "1,,2", "'' is not a number");
  refused("translate", "1,2,3,", "a number is missing");
  refused("rotate", "nan,0,0", "'nan' is not a finite number");
  refused("rotate", "1,2,3,4,5", "takes 3 numbers (Euler angles x,y,z in degrees) or 4");
  refused("rotate", "1,0,0,0.1", "a rotation that is not one");
  refused("scale", "-1", "the scale must be positive");
  refused("scale", "0", "the scale must be positive");
  refused("crop-box", "0,0,1,1,1,0", "min z 1 > max z 0");
  refused("crop-sphere", "0,0,0,0", "the radius must be positive");
  refused("filter", "colour gt 1", "unknown property 'colour'");
  refused("filter", "f_rest_45 gt 1", "unknown property 'f_rest_45'");
  refused("filter", "opacity about 1", "unknown comparison 'about'");
  refused("filter", "opacity gt", "NAME OP VALUE");
  refused("filter", "opacity gt nan", "not a finite number");
  refused("filter-nan", "1", "takes no value");
  // A property the scene does not hold fails when applied, naming the degree.
  format::GaussianCloud sh1 = guitar_sh3();
  REQUIRE(converter::reduce_sh_degree(&sh1, 1).ok());
  auto beyond = converter::apply_edit(&sh1, parsed("filter", "f_rest_9 gt 0"));
  REQUIRE_FALSE(beyond.ok());
  CHECK(beyond.status().message().find("SH degree 1, whose f_rest runs 0..8") != std::string::npos);
  // Built in code, checked the same way.
  converter::EditAction code;
  code.kind = converter::EditKind::kScale;
  code.values = {std::nan("")};
  CHECK(converter::check_edit_action(code).message() == "scale 'nan': number 1 is not finite");
}

}  // namespace rgs::test
