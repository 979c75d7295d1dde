// Camera paths through key views (camera.h fly_through_cameras): a uniform Catmull–Rom spline through the
// key centres, sampled evenly by arc length, with rotations slerped between the keys.
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

Vec3 centre_of(const Camera& c) {
  const std::array<float, 3> p = camera_centre(c);
  return {p[0], p[1], p[2]};
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

/// Point at u ∈ [0, 1] of segment i (keys i → i + 1) of the uniform Catmull–Rom spline through `p`; the
/// end segments reflect their missing neighbour.
Vec3 spline_point(const std::vector<Vec3>& p, size_t i, double u) {
  const size_t n = p.size();
  const Vec3& p1 = p[i];
  const Vec3& p2 = p[i + 1];
  Vec3 p0, p3;
  for (int a = 0; a < 3; ++a) {
    p0[a] = i > 0 ? p[i - 1][a] : 2 * p1[a] - p2[a];
    p3[a] = i + 2 < n ? p[i + 2][a] : 2 * p2[a] - p1[a];
  }
  const double u2 = u * u, u3 = u2 * u;
  Vec3 out;
  for (int a = 0; a < 3; ++a) {
    out[a] = 0.5 * (2 * p1[a] + (p2[a] - p0[a]) * u + (2 * p0[a] - 5 * p1[a] + 4 * p2[a] - p3[a]) * u2 +
                    (3 * p1[a] - p0[a] - 3 * p2[a] + p3[a]) * u3);
  }
  return out;
}

}  // namespace

Result<std::vector<Camera>> fly_through_cameras(const std::vector<Camera>& keys, uint32_t count) {
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kInvalidArgument, "fly-through: view count must be >= 1");
  RGS_RETURN_ERROR_IF(keys.size() < 2, StatusCode::kInvalidArgument,
                      "fly-through: needs at least 2 key cameras, got " + std::to_string(keys.size()));
  for (size_t k = 0; k < keys.size(); ++k) {
    Status valid = validate_camera(keys[k]);
    if (!valid.ok()) return valid.prepend("fly-through key " + std::to_string(k) + " (" + keys[k].name + ")");
    RGS_RETURN_ERROR_IF(keys[k].width != keys[0].width || keys[k].height != keys[0].height,
                        StatusCode::kInvalidArgument,
                        "fly-through: key " + std::to_string(k) + " (" + keys[k].name + ") is " +
                            std::to_string(keys[k].width) + "x" + std::to_string(keys[k].height) + ", key 0 is " +
                            std::to_string(keys[0].width) + "x" + std::to_string(keys[0].height));
  }
  std::vector<Vec3> centres;
  std::vector<Quat> rotations;
  for (const Camera& k : keys) {
    centres.push_back(centre_of(k));
    rotations.push_back(quaternion_of(k.rotation));
  }
  // Arc length at the samples of every segment: table[i · S + j] = length up to u = j / S of segment i.
  const size_t segments = keys.size() - 1;
  std::vector<double> table(segments * kArcSamples + 1, 0.0);
  Vec3 previous = centres[0];
  for (size_t i = 0; i < segments; ++i) {
    for (int j = 1; j <= kArcSamples; ++j) {
      const Vec3 q = spline_point(centres, i, double(j) / kArcSamples);
      const double step = std::sqrt((q[0] - previous[0]) * (q[0] - previous[0]) +
                                    (q[1] - previous[1]) * (q[1] - previous[1]) +
                                    (q[2] - previous[2]) * (q[2] - previous[2]));
      table[i * kArcSamples + j] = table[i * kArcSamples + j - 1] + step;
      previous = q;
    }
  }
  const double total = table.back();
  std::vector<Camera> out;
  out.reserve(count);
  for (uint32_t v = 0; v < count; ++v) {
    // Sample v at arc length total · v / (count − 1); all keys coincide (total 0): by key index instead.
    const double t = count == 1 ? 0.0 : double(v) / double(count - 1);
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
    const Vec3 c = spline_point(centres, segment, u);
    const std::array<double, 9> r = matrix_of(slerp(rotations[segment], rotations[segment + 1], u));
    Camera cam = keys[0];
    for (int i = 0; i < 9; ++i) cam.rotation[i] = float(r[i]);
    for (int i = 0; i < 3; ++i) cam.translation[i] = float(-(r[i * 3] * c[0] + r[i * 3 + 1] * c[1] + r[i * 3 + 2] * c[2]));
    char name[32];
    std::snprintf(name, sizeof name, "fly_%03u", v);
    cam.name = name;
    out.push_back(std::move(cam));
  }
  return out;
}

}  // namespace rgs::runtime
