// The edits of a conversion's edit chain: parsing rgs-convert's spelling, checking, applying to a float cloud.
#include "rgs/converter/cloud_edits.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <tuple>
#include <utility>

#include "../internal_interop.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/sh_rotation.h"

namespace rgs::converter {

namespace {

/// How far a quaternion's norm may be from 1 and still be taken as a rotation (normalized before use).
constexpr double kUnitTolerance = 1e-3;
/// f_rest_K of an SH-3 scene: K < 45.
constexpr uint32_t kMaxRestIndex = 45;

struct NameKind {
  const char* name;
  EditKind kind;
  bool outside;
};
constexpr NameKind kNames[] = {
    {"translate", EditKind::kTranslate, false}, {"rotate", EditKind::kRotate, false},
    {"scale", EditKind::kScale, false},         {"filter-nan", EditKind::kFilterNan, false},
    {"filter", EditKind::kFilter, false},       {"crop-box", EditKind::kCropBox, false},
    {"crop-box-outside", EditKind::kCropBox, true}, {"crop-sphere", EditKind::kCropSphere, false},
    {"crop-sphere-outside", EditKind::kCropSphere, true}, {"decimate", EditKind::kDecimate, false},
};

/// EditCompare's spellings, in its order: the word and the symbol.
constexpr const char* kCompareNames[][2] = {{"lt", "<"},  {"le", "<="}, {"gt", ">"},
                                            {"ge", ">="}, {"eq", "=="}, {"ne", "!="}};

const char* kind_name(EditKind kind) {
  for (const NameKind& n : kNames) {
    if (n.kind == kind) return n.name;
  }
  return "edit";
}

Status invalid(const EditAction& action, const std::string& why) {
  return Status(StatusCode::kInvalidArgument, edit_action_text(action) + ": " + why);
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

/// A finite decimal number filling the whole of `token` (spaces around it allowed).
Result<double> parse_number(const std::string& token) {
  const std::string t = trim(token);
  char* end = nullptr;
  const double v = t.empty() ? 0 : std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size()) {
    return Status(StatusCode::kInvalidArgument, "'" + t + "' is not a number");
  }
  if (!std::isfinite(v)) return Status(StatusCode::kInvalidArgument, "'" + t + "' is not a finite number");
  return v;
}

Result<std::vector<double>> parse_numbers(const std::string& value) {
  std::vector<double> out;
  std::stringstream in(value);
  std::string token;
  while (std::getline(in, token, ',')) {
    RGS_ASSIGN_OR_RETURN(const double v, parse_number(token));
    out.push_back(v);
  }
  if (!value.empty() && value.back() == ',') {
    return Status(StatusCode::kInvalidArgument, "a number is missing after the last comma");
  }
  return out;
}

/// The quaternion w, x, y, z of R = Rz(z)·Ry(y)·Rx(x), angles in degrees: q = qz·qy·qx.
std::vector<double> euler_quaternion(double x_deg, double y_deg, double z_deg) {
  const double h = 3.14159265358979323846 / 360.0;  // half an angle, in radians per degree
  const double cx = std::cos(x_deg * h), sx = std::sin(x_deg * h), cy = std::cos(y_deg * h), sy = std::sin(y_deg * h);
  const double cz = std::cos(z_deg * h), sz = std::sin(z_deg * h);
  return {cz * cy * cx + sz * sy * sx, cz * cy * sx - sz * sy * cx, cz * sy * cx + sz * cy * sx,
          sz * cy * cx - cz * sy * sx};
}

/// Where a filter's property lives in the cloud: an array, the component per Gaussian, and for SH the index.
struct PropertyRef {
  enum Array { kMeans, kOpacity, kScales, kRotations, kDc, kColour, kRest } array = kMeans;
  uint32_t index = 0;
};

Result<PropertyRef> find_property(const std::string& name) {
  const auto indexed = [&](const char* prefix, uint32_t count) -> int {
    const std::string p = prefix;
    if (name.compare(0, p.size(), p) != 0 || name.size() == p.size() || name.size() > p.size() + 2) return -1;
    uint32_t v = 0;
    for (size_t i = p.size(); i < name.size(); ++i) {
      if (name[i] < '0' || name[i] > '9') return -1;
      v = v * 10 + uint32_t(name[i] - '0');
    }
    if (name.size() > p.size() + 1 && name[p.size()] == '0') return -1;  // no leading zeros
    return v < count ? int(v) : -1;
  };
  if (name == "x" || name == "y" || name == "z") return PropertyRef{PropertyRef::kMeans, uint32_t(name[0] - 'x')};
  if (name == "opacity") return PropertyRef{PropertyRef::kOpacity, 0};
  if (int i = indexed("scale_", 3); i >= 0) return PropertyRef{PropertyRef::kScales, uint32_t(i)};
  if (int i = indexed("rot_", 4); i >= 0) return PropertyRef{PropertyRef::kRotations, uint32_t(i)};
  if (int i = indexed("f_dc_", 3); i >= 0) return PropertyRef{PropertyRef::kDc, uint32_t(i)};
  for (uint32_t c = 0; c < 3; ++c) {
    if (name == std::array{"red", "green", "blue"}[c]) return PropertyRef{PropertyRef::kColour, c};
  }
  if (int i = indexed("f_rest_", kMaxRestIndex); i >= 0) return PropertyRef{PropertyRef::kRest, uint32_t(i)};
  return Status(StatusCode::kInvalidArgument,
                "unknown property '" + name +
                    "' (x, y, z, opacity, scale_0..2, rot_0..3, f_dc_0..2, red, green, blue, f_rest_0..44)");
}

bool compare(float v, EditCompare op, float value) {
  switch (op) {
    case EditCompare::kLt: return v < value;
    case EditCompare::kLe: return v <= value;
    case EditCompare::kGt: return v > value;
    case EditCompare::kGe: return v >= value;
    case EditCompare::kEq: return v == value;
    case EditCompare::kNe: return v != value;
  }
  return false;
}

/// "NAME OP VALUE" into `action`.
Status parse_filter(const std::string& value, EditAction* action) {
  std::istringstream in(value);
  std::string name, op, number, extra;
  in >> name >> op >> number;
  if (number.empty() || (in >> extra)) {
    return invalid(*action, "give three words, NAME OP VALUE (e.g. 'opacity gt 0.1')");
  }
  action->property = name;
  bool known = false;
  for (size_t i = 0; i < 6; ++i) {
    if (op == kCompareNames[i][0] || op == kCompareNames[i][1]) {
      action->compare = EditCompare(i);
      known = true;
    }
  }
  if (!known) return invalid(*action, "unknown comparison '" + op + "' (lt le gt ge eq ne, or < <= > >= == !=)");
  auto v = parse_number(number);
  if (!v.ok()) return invalid(*action, v.status().message());
  action->values = {*v};
  return Status();
}

/// Removes the Gaussians for which keep(i) is false. @return how many.
template <typename Keep>
uint64_t remove_unless(format::GaussianCloud* cloud, Keep keep) {
  std::vector<uint64_t> drop;
  for (uint64_t i = 0; i < cloud->size(); ++i) {
    if (!keep(i)) drop.push_back(i);
  }
  cloud->remove_gaussians(drop);
  return drop.size();
}

bool all_finite(const float* v, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

/// A rotate edit's quaternion, normalized.
std::array<double, 4> unit_quaternion(const std::vector<double>& q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

void rotate_cloud(format::GaussianCloud* cloud, const std::vector<double>& quaternion) {
  const std::array<double, 4> r = unit_quaternion(quaternion);
  const std::array<double, 9> m = detail::quaternion_matrix(r.data());
  for (size_t i = 0; i < cloud->size(); ++i) {
    float* p = &cloud->means[i * 3];
    const double x = p[0], y = p[1], z = p[2];
    for (int a = 0; a < 3; ++a) p[a] = float(m[a * 3] * x + m[a * 3 + 1] * y + m[a * 3 + 2] * z);
    float* q = &cloud->rotations[i * 4];
    const double w = q[0], qx = q[1], qy = q[2], qz = q[3];
    const double out[4] = {r[0] * w - r[1] * qx - r[2] * qy - r[3] * qz, r[0] * qx + r[1] * w + r[2] * qz - r[3] * qy,
                           r[0] * qy - r[1] * qz + r[2] * w + r[3] * qx, r[0] * qz + r[1] * qy - r[2] * qx + r[3] * w};
    const double len = std::sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3]);
    for (int a = 0; a < 4; ++a) q[a] = float(out[a] / len);
  }
  rotate_sh(sh_rotation(m), cloud->sh_degree, cloud->size(), cloud->sh.data());
}

Result<uint64_t> filter_cloud(format::GaussianCloud* cloud, const EditAction& action) {
  RGS_ASSIGN_OR_RETURN(const PropertyRef ref, find_property(action.property));
  const uint32_t k = cloud->sh_coefficients();
  const uint32_t rest = 3 * (k - 1);
  if (ref.array == PropertyRef::kRest && ref.index >= rest) {
    return invalid(action, "the scene has SH degree " + std::to_string(cloud->sh_degree) +
                               (rest == 0 ? ", without f_rest" : ", whose f_rest runs 0.." + std::to_string(rest - 1)));
  }
  const auto value_of = [&](uint64_t i) -> float {
    switch (ref.array) {
      case PropertyRef::kMeans: return cloud->means[i * 3 + ref.index];
      case PropertyRef::kOpacity: return cloud->opacities[i];
      case PropertyRef::kScales: return cloud->scales[i * 3 + ref.index];
      case PropertyRef::kRotations: return cloud->rotations[i * 4 + ref.index];
      case PropertyRef::kDc: return cloud->sh[(i * k) * 3 + ref.index];
      case PropertyRef::kColour: return float(0.5 + detail::kShC0 * cloud->sh[(i * k) * 3 + ref.index]);
      case PropertyRef::kRest: {
        const uint32_t channel = ref.index / (k - 1), coefficient = ref.index % (k - 1) + 1;
        return cloud->sh[(i * k + coefficient) * 3 + channel];
      }
    }
    return 0.0f;
  };
  const float value = float(action.values[0]);  // as the property is stored: "x eq 0.1" finds 0.1f
  return remove_unless(cloud, [&](uint64_t i) { return compare(value_of(i), action.compare, value); });
}

/// 0 when a translation or a scale left every mean and scale finite, else the error naming the first Gaussian it
/// took out of float32's range.
Result<uint64_t> in_float_range(const format::GaussianCloud& cloud, const EditAction& action) {
  for (size_t i = 0; i < cloud.size(); ++i) {
    if (!all_finite(&cloud.means[i * 3], 3) || !all_finite(&cloud.scales[i * 3], 3)) {
      return invalid(action, "takes Gaussian " + std::to_string(i) + " out of float32's range");
    }
  }
  return uint64_t{0};
}

/// The level of each chunk of `index` in the cut apply_edit's decimation takes (cloud_edits.h); empty when even
/// the coarsest levels hold more than `target`.
std::vector<uint32_t> decimation_cut(const format::LodIndex& index, uint64_t target) {
  std::vector<std::tuple<float, uint32_t, uint32_t>> steps;  // error, chunk, level
  for (uint32_t l = 1; l < index.level_count; ++l) {
    for (uint32_t c = 0; c < index.chunk_count; ++c) steps.emplace_back(index.at(l, c).error, c, l);
  }
  std::sort(steps.begin(), steps.end());  // a chunk's errors do not decrease with its level
  std::vector<uint32_t> level(index.chunk_count, 0);
  uint64_t total = index.full_detail_count();
  for (const auto& [error, c, l] : steps) {
    if (total <= target) break;
    total -= index.at(l - 1, c).count - index.at(l, c).count;
    level[c] = l;
  }
  if (total > target) level.clear();
  return level;
}

Result<uint64_t> decimate_cloud(format::GaussianCloud* cloud, double value) {
  const uint64_t n = cloud->size();
  const uint64_t target = value < 1 ? std::max<uint64_t>(1, uint64_t(std::llround(value * double(n)))) : uint64_t(value);
  if (n <= target) return uint64_t{0};
  RGS_ASSIGN_OR_RETURN(const format::EncodedScene encoded, quantize(*cloud, QuantizeOptions{}));
  for (uint64_t chunk = std::max<uint64_t>(target / 16, 64);; chunk *= 8) {
    LodBuildOptions options;
    options.levels = format::kMaxLodLevels;
    options.max_chunk_gaussians = uint32_t(std::min(chunk, n));
    RGS_ASSIGN_OR_RETURN(LodScene lod, build_lod(encoded, options));
    const std::vector<uint32_t> level = decimation_cut(lod.index, target);
    if (level.empty() && chunk < n) continue;
    if (level.empty()) return Status(StatusCode::kInvalidArgument, "cannot decimate to " + std::to_string(target));
    format::GaussianCloud out, part;
    out.sh_degree = cloud->sh_degree;
    out.antialiased = cloud->antialiased;
    for (uint32_t c = 0; c < lod.index.chunk_count; ++c) {
      const format::LodLevel& range = lod.index.at(level[c], c);
      RGS_RETURN_IF_ERROR(format::dequantize_range(lod.scene, range.first, range.count, &part));
      for (auto [to, from] : {std::pair(&out.means, &part.means), std::pair(&out.rotations, &part.rotations),
                              std::pair(&out.scales, &part.scales), std::pair(&out.opacities, &part.opacities),
                              std::pair(&out.sh, &part.sh)}) {
        to->insert(to->end(), from->begin(), from->end());
      }
    }
    *cloud = std::move(out);
    return n - cloud->size();
  }
}

}  // namespace

std::string edit_action_text(const EditAction& action) {
  if (!action.text.empty()) return action.text;
  std::ostringstream text;
  text.precision(17);
  text << kind_name(action.kind);
  const bool filter = action.kind == EditKind::kFilter;
  if (action.outside) text << "-outside";
  if (filter) text << " '" << action.property << " " << kCompareNames[int(action.compare)][0];
  for (size_t i = 0; i < action.values.size(); ++i) text << (i ? "," : filter ? " " : " '") << action.values[i];
  if (filter || !action.values.empty()) text << "'";
  return text.str();
}

Status check_edit_action(const EditAction& action) {
  static constexpr size_t kCounts[] = {3, 4, 1, 0, 1, 6, 4, 1};
  const size_t want = kCounts[size_t(action.kind)];
  const std::vector<double>& v = action.values;
  if (v.size() != want) {
    // A parsed rotation holds 4 numbers whatever was given: 3 come only from code.
    if (action.kind == EditKind::kRotate && v.size() == 3) {
      return invalid(action,
                     "holds a quaternion w,x,y,z (parse_edit_action turns Euler angles into one), not 3 numbers");
    }
    return invalid(action, action.kind == EditKind::kRotate
                               ? "takes 3 numbers (Euler angles x,y,z in degrees) or 4 (a quaternion w,x,y,z), not " +
                                     std::to_string(v.size())
                               : "takes " + std::to_string(want) + (want == 1 ? " number" : " numbers") + ", not " +
                                     std::to_string(v.size()));
  }
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) return invalid(action, "number " + std::to_string(i + 1) + " is not finite");
  }
  if (action.kind == EditKind::kRotate) {
    const double norm = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
    if (!(std::fabs(norm - 1) <= kUnitTolerance)) {
      std::ostringstream why;
      why << "the quaternion w,x,y,z has norm " << norm
          << ": a rotation that is not one (a unit quaternion, norm 1 within " << kUnitTolerance << ")";
      return invalid(action, why.str());
    }
  }
  if (action.kind == EditKind::kScale && !(v[0] > 0)) return invalid(action, "the scale must be positive");
  if (action.kind == EditKind::kCropSphere && !(v[3] > 0)) return invalid(action, "the radius must be positive");
  if (action.kind == EditKind::kDecimate) {
    const bool count = v[0] >= 1 && v[0] == std::floor(v[0]) && v[0] < 0x1p64;
    if (!count && !(v[0] > 0 && v[0] < 1)) {
      return invalid(action, "takes a count of Gaussians (an integer >= 1) or a fraction of them in (0, 1)");
    }
  }
  if (action.kind == EditKind::kCropBox) {
    for (int a = 0; a < 3; ++a) {
      if (v[a] > v[a + 3]) {
        std::ostringstream why;
        why << "min " << "xyz"[a] << " " << v[a] << " > max " << "xyz"[a] << " " << v[a + 3];
        return invalid(action, why.str());
      }
    }
  }
  if (action.kind == EditKind::kFilter) {
    if (auto p = find_property(action.property); !p.ok()) return invalid(action, p.status().message());
  }
  return Status();
}

Result<EditAction> parse_edit_action(const std::string& name, const std::string& value) {
  EditAction action;
  action.text = value.empty() ? name : name + " '" + value + "'";
  const NameKind* found = nullptr;
  for (const NameKind& n : kNames) {
    if (name == n.name) found = &n;
  }
  if (found == nullptr) {
    return Status(StatusCode::kInvalidArgument,
                  "unknown edit '" + name + "' (translate, rotate, scale, filter-nan, filter, crop-box, "
                  "crop-box-outside, crop-sphere, crop-sphere-outside, decimate)");
  }
  action.kind = found->kind;
  action.outside = found->outside;
  if (action.kind == EditKind::kFilterNan) {
    if (!trim(value).empty()) return invalid(action, "takes no value");
  } else if (action.kind == EditKind::kFilter) {
    RGS_RETURN_IF_ERROR(parse_filter(value, &action));
  } else {
    auto numbers = parse_numbers(value);
    if (!numbers.ok()) return invalid(action, numbers.status().message());
    action.values = std::move(numbers).value();
    if (action.kind == EditKind::kRotate && action.values.size() == 3) {
      action.values = euler_quaternion(action.values[0], action.values[1], action.values[2]);
    }
  }
  RGS_RETURN_IF_ERROR(check_edit_action(action));
  return action;
}

Result<std::vector<EditAction>> parse_recorded_edits(const std::string& options) {
  std::vector<EditAction> out;
  size_t at = options.find(" edits=");
  if (at == std::string::npos) return out;
  at += 7;
  for (;;) {  // NAME 'VALUE' or NAME, then "; " and the next, or a space and the next option
    const size_t name_end = std::min(options.find_first_of(" ;", at), options.size());
    const std::string name = options.substr(at, name_end - at);
    std::string value;
    at = name_end;
    if (options.compare(at, 2, " '") == 0) {
      const size_t close = options.find('\'', at + 2);
      RGS_RETURN_ERROR_IF(close == std::string::npos, StatusCode::kInvalidArgument,
                          "recorded edits: no closing quote after '" + name + "'");
      value = options.substr(at + 2, close - at - 2);
      at = close + 1;
    }
    RGS_ASSIGN_OR_RETURN(EditAction action, parse_edit_action(name, value));
    out.push_back(std::move(action));
    if (options.compare(at, 2, "; ") != 0) return out;
    at += 2;
  }
}

EditMotion edit_motion(const std::vector<EditAction>& edits) {
  EditMotion m;
  for (const EditAction& edit : edits) {
    const std::vector<double>& v = edit.values;
    if (edit.kind == EditKind::kTranslate) {
      for (int a = 0; a < 3; ++a) m.offset[a] += v[a];
    } else if (edit.kind == EditKind::kScale) {
      m.scale *= v[0];
      for (double& o : m.offset) o *= v[0];
    } else if (edit.kind == EditKind::kRotate) {
      const std::array<double, 9> r = detail::quaternion_matrix(unit_quaternion(v).data());
      const EditMotion before = m;
      for (int i = 0; i < 9; ++i) {
        m.rotation[i] = 0;
        for (int k = 0; k < 3; ++k) m.rotation[i] += r[i / 3 * 3 + k] * before.rotation[k * 3 + i % 3];
      }
      for (int i = 0; i < 3; ++i) {
        m.offset[i] = r[i * 3] * before.offset[0] + r[i * 3 + 1] * before.offset[1] + r[i * 3 + 2] * before.offset[2];
      }
    }
  }
  return m;
}

Result<uint64_t> apply_edit(format::GaussianCloud* cloud, const EditAction& action) {
  RGS_RETURN_IF_ERROR(check_edit_action(action));
  if (!cloud->is_consistent()) return invalid(action, "the cloud's arrays disagree with its size and SH degree");
  const std::vector<double>& v = action.values;
  const size_t n = cloud->size();
  switch (action.kind) {
    case EditKind::kTranslate:
      for (size_t i = 0; i < n * 3; ++i) cloud->means[i] = float(double(cloud->means[i]) + v[i % 3]);
      return in_float_range(*cloud, action);
    case EditKind::kRotate:
      rotate_cloud(cloud, v);
      return uint64_t{0};
    case EditKind::kScale:
      for (float& m : cloud->means) m = float(double(m) * v[0]);
      for (size_t i = 0; i < cloud->scales.size(); ++i) {
        const float before = cloud->scales[i];
        cloud->scales[i] = float(double(before) * v[0]);
        if (cloud->scales[i] == 0 && before != 0) {  // underflow: the scene would collapse to a point
          return invalid(action, "takes Gaussian " + std::to_string(i / 3) + "'s scale " + std::to_string(before) +
                                     " to 0, below float32's smallest positive value");
        }
      }
      return in_float_range(*cloud, action);
    case EditKind::kFilterNan: {
      const size_t sh = size_t{cloud->sh_coefficients()} * 3;
      return remove_unless(cloud, [&](uint64_t i) {
        return all_finite(&cloud->means[i * 3], 3) && all_finite(&cloud->rotations[i * 4], 4) &&
               all_finite(&cloud->scales[i * 3], 3) && all_finite(&cloud->opacities[i], 1) &&
               all_finite(&cloud->sh[i * sh], sh);
      });
    }
    case EditKind::kFilter:
      return filter_cloud(cloud, action);
    case EditKind::kCropBox:
      return remove_unless(cloud, [&](uint64_t i) {
        const float* p = &cloud->means[i * 3];
        bool inside = true;
        for (int a = 0; a < 3; ++a) inside = inside && v[a] <= p[a] && p[a] <= v[a + 3];
        return inside != action.outside;
      });
    case EditKind::kCropSphere:
      return remove_unless(cloud, [&](uint64_t i) {
        const float* p = &cloud->means[i * 3];
        const double dx = p[0] - v[0], dy = p[1] - v[1], dz = p[2] - v[2];
        return (dx * dx + dy * dy + dz * dz <= v[3] * v[3]) != action.outside;
      });
    case EditKind::kDecimate: {
      Result<uint64_t> removed = decimate_cloud(cloud, v[0]);
      if (!removed.ok()) return invalid(action, removed.status().message());
      return removed;
    }
  }
  return uint64_t{0};
}

}  // namespace rgs::converter
