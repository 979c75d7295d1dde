// Camera paths through key views (camera.h fly_through_cameras): a Catmull–Rom spline (centripetal by default)
// through the key centres, sampled evenly by arc length, with rotations slerped between the keys.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "rgs/runtime/camera.h"

namespace rgs::runtime {
namespace {

using Vec3 = std::array<double, 3>;
using Quat = std::array<double, 4>;  // w, x, y, z

/// Samples per key segment of the arc-length table.
constexpr int kArcSamples = 256;

/// Camera centre −Rᵀ·t in double (camera_centre() rounds it to float).
Vec3 centre_of(const Camera& c) {
  Vec3 p;
  for (int a = 0; a < 3; ++a) {
    p[a] = -(double(c.rotation[a]) * c.translation[0] + double(c.rotation[3 + a]) * c.translation[1] +
             double(c.rotation[6 + a]) * c.translation[2]);
  }
  return p;
}

/// Unit quaternion of a rotation matrix (row-major), w ≥ 0.
Quat quaternion_of(const std::array<float, 9>& m) {
  const double r[3][3] = {{m[0], m[1], m[2]}, {m[3], m[4], m[5]}, {m[6], m[7], m[8]}};
  Quat q;
  const double trace = r[0][0] + r[1][1] + r[2][2];
  if (trace > 0) {
    const double s = 2 * std::sqrt(1 + trace);
    q = {0.25 * s, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s};
  } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
    const double s = 2 * std::sqrt(1 + r[0][0] - r[1][1] - r[2][2]);
    q = {(r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s};
  } else if (r[1][1] > r[2][2]) {
    const double s = 2 * std::sqrt(1 + r[1][1] - r[0][0] - r[2][2]);
    q = {(r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s};
  } else {
    const double s = 2 * std::sqrt(1 + r[2][2] - r[0][0] - r[1][1]);
    q = {(r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s};
  }
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const double sign = q[0] < 0 ? -1.0 : 1.0;
  for (double& v : q) v *= sign / n;
  return q;
}

/// Shortest-arc spherical interpolation from a to b at u ∈ [0, 1].
Quat slerp(Quat a, Quat b, double u) {
  double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (dot < 0) {
    for (double& v : b) v = -v;
    dot = -dot;
  }
  double wa = 1 - u, wb = u;
  if (dot < 0.9995) {  // else nearly equal: linear, normalized below
    const double theta = std::acos(std::min(dot, 1.0));
    wa = std::sin((1 - u) * theta) / std::sin(theta);
    wb = std::sin(u * theta) / std::sin(theta);
  }
  Quat q;
  double n = 0;
  for (int i = 0; i < 4; ++i) {
    q[i] = wa * a[i] + wb * b[i];
    n += q[i] * q[i];
  }
  for (double& v : q) v /= std::sqrt(n);
  return q;
}

/// Row-major rotation matrix of a unit quaternion.
std::array<double, 9> matrix_of(const Quat& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

double length(const Vec3& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

/// The spline as cubic Hermite segments: segment i runs from centre i to centre i + 1 over knot interval
/// span[i] (0 for coincident centres), with tangent[i] the derivative at key i with respect to the knot
/// parameter.
struct Spline {
  std::vector<Vec3> centre;
  std::vector<double> span;
  std::vector<Vec3> tangent;
};

/// Knot intervals |cᵢ₊₁ − cᵢ|^α and the Catmull–Rom tangents at the keys. At an interior key with both
/// intervals d0, d1 > 0 the tangent is the derivative of the Barry–Goldman pyramid at the key,
/// (c − c₋)/d0 − (c₊ − c₋)/(d0 + d1) + (c₊ − c)/d1, the same from both segments that meet there (so C1);
/// with one interval missing or zero (an end key, or a neighbour at the same centre) it is the chord to the
/// other neighbour over its interval; with both zero it is 0.
Spline make_spline(std::vector<Vec3> centres, double alpha) {
  Spline s;
  const size_t n = centres.size();
  std::vector<double> chord(n - 1);
  double longest = 0;
  for (size_t i = 0; i + 1 < n; ++i) {
    chord[i] = length(sub(centres[i + 1], centres[i]));
    longest = std::max(longest, chord[i]);
  }
  s.span.resize(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) {
    // Centres that differ by float rounding only count as coincident: such a span would be noise.
    const bool zero = chord[i] <= 1e-12 * longest || longest == 0;
    s.span[i] = zero ? 0.0 : std::pow(chord[i], alpha);
  }
  s.tangent.assign(n, Vec3{0, 0, 0});
  for (size_t i = 0; i < n; ++i) {
    const double d0 = i > 0 ? s.span[i - 1] : 0.0;
    const double d1 = i + 1 < n ? s.span[i] : 0.0;
    Vec3& m = s.tangent[i];
    for (int a = 0; a < 3; ++a) {
      if (d0 > 0 && d1 > 0) {
        m[a] = (centres[i][a] - centres[i - 1][a]) / d0 - (centres[i + 1][a] - centres[i - 1][a]) / (d0 + d1) +
               (centres[i + 1][a] - centres[i][a]) / d1;
      } else if (d1 > 0) {
        m[a] = (centres[i + 1][a] - centres[i][a]) / d1;
      } else if (d0 > 0) {
        m[a] = (centres[i][a] - centres[i - 1][a]) / d0;
      }
    }
  }
  s.centre = std::move(centres);
  return s;
}

/// Point at u ∈ [0, 1] of segment i: the cubic Hermite between centres i and i + 1 with their tangents scaled
/// by the segment's knot interval (a segment of span 0 stays at its first centre).
Vec3 spline_point(const Spline& s, size_t i, double u) {
  const double d = s.span[i];
  if (d == 0) return s.centre[i];
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  Vec3 out;
  for (int a = 0; a < 3; ++a) {
    out[a] = h00 * s.centre[i][a] + h10 * d * s.tangent[i][a] + h01 * s.centre[i + 1][a] +
             h11 * d * s.tangent[i + 1][a];
  }
  return out;
}

}  // namespace

Result<std::vector<Camera>> fly_through_cameras(const std::vector<Camera>& keys, uint32_t count,
                                                const FlyThroughOptions& options) {
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kInvalidArgument, "fly-through: the view count is 0; ask for >= 1");
  RGS_RETURN_ERROR_IF(keys.size() < 2, StatusCode::kInvalidArgument,
                      "fly-through: needs at least 2 key cameras, got " + std::to_string(keys.size()));
  RGS_RETURN_ERROR_IF(!(options.spline_alpha >= 0.0 && options.spline_alpha <= 1.0), StatusCode::kInvalidArgument,
                      "fly-through: spline_alpha " + std::to_string(options.spline_alpha) + " is outside [0, 1]");
  for (size_t k = 0; k < keys.size(); ++k) {
    Status valid = validate_camera(keys[k]);
    if (!valid.ok()) return valid.prepend("fly-through key " + std::to_string(k) + " (" + keys[k].name + ")");
    RGS_RETURN_ERROR_IF(keys[k].width != keys[0].width || keys[k].height != keys[0].height,
                        StatusCode::kInvalidArgument,
                        "fly-through: key " + std::to_string(k) + " (" + keys[k].name + ") is " +
                            std::to_string(keys[k].width) + "x" + std::to_string(keys[k].height) + ", key 0 is " +
                            std::to_string(keys[0].width) + "x" + std::to_string(keys[0].height) +
                            "; resize the keys to one size first");
  }
  std::vector<Vec3> centres;
  std::vector<Quat> rotations;
  for (const Camera& k : keys) {
    centres.push_back(centre_of(k));
    rotations.push_back(quaternion_of(k.rotation));
  }
  const Spline spline = make_spline(std::move(centres), options.spline_alpha);
  // Arc length at the samples of every segment: table[i · S + j] = length up to u = j / S of segment i.
  const size_t segments = keys.size() - 1;
  std::vector<double> table(segments * kArcSamples + 1, 0.0);
  Vec3 previous = spline.centre[0];
  for (size_t i = 0; i < segments; ++i) {
    for (int j = 1; j <= kArcSamples; ++j) {
      const Vec3 q = spline_point(spline, i, double(j) / kArcSamples);
      table[i * kArcSamples + j] = table[i * kArcSamples + j - 1] + length(sub(q, previous));
      previous = q;
    }
  }
  const double total = table.back();
  std::vector<Camera> out;
  out.reserve(count);
  for (uint32_t v = 0; v < count; ++v) {
    Camera cam = keys[0];
    char name[32];
    std::snprintf(name, sizeof name, "fly_%03u", v);
    cam.name = name;
    if (v > 0 && v + 1 == count) {  // the last key's pose exactly (view 0 keeps the first key's)
      cam.rotation = keys.back().rotation;
      cam.translation = keys.back().translation;
    } else if (v > 0) {
      // View v at arc length total · v / (count − 1); all keys coincide (total 0): by key index instead.
      const double t = double(v) / double(count - 1);
      size_t sample = 0;
      double frac = 0;
      if (total > 0) {
        const double s = total * t;
        sample = size_t(std::upper_bound(table.begin(), table.end(), s) - table.begin());
        sample = std::clamp<size_t>(sample, 1, table.size() - 1) - 1;
        const double span = table[sample + 1] - table[sample];
        frac = span > 0 ? std::clamp((s - table[sample]) / span, 0.0, 1.0) : 0.0;
      } else {
        const double x = t * double(segments * kArcSamples);
        sample = std::min<size_t>(size_t(x), segments * kArcSamples - 1);
        frac = x - double(sample);
      }
      const size_t segment = sample / kArcSamples;
      const double u = (double(sample % kArcSamples) + frac) / kArcSamples;
      const Vec3 c = spline_point(spline, segment, u);
      set_pose(&cam, matrix_of(slerp(rotations[segment], rotations[segment + 1], u)), c);
    }
    out.push_back(std::move(cam));
  }
  return out;
}

}  // namespace rgs::runtime
