// Rate control's knobs: the ladder that coarsens every knob together and the one-knob steps.
#include "knobs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rgs::api::detail {

namespace {

uint32_t clamp_bits(double bits) { return uint32_t(std::clamp(std::lround(bits), long(kMinBits), long(kMaxBits))); }

double clamp_position(double error) {
  return std::clamp(error, std::ldexp(1.0, -kFinestPositionLog2), std::ldexp(1.0, -kCoarsestPositionLog2));
}

}  // namespace

format::ArchiveOptions ladder(const format::ArchiveOptions& anchor, double q) {
  format::ArchiveOptions o = anchor;
  o.rotation_bits = clamp_bits(double(anchor.rotation_bits) - q);
  o.scale_bits = clamp_bits(double(anchor.scale_bits) - q);
  o.opacity_bits = clamp_bits(double(anchor.opacity_bits) - q);
  for (size_t d = 0; d < 4; ++d) {
    o.sh_step_multipliers[d] =
        uint32_t(std::clamp(std::lround(double(anchor.sh_step_multipliers[d]) * std::exp2(q)), 1L, 127L));
  }
  o.position_error = clamp_position(anchor.position_error * std::exp2(q));
  return o;
}

std::optional<format::ArchiveOptions> step(format::ArchiveOptions o, Knob knob, bool coarser) {
  auto move_bits = [&](uint32_t* bits) {
    const uint32_t next = coarser ? *bits - 1 : *bits + 1;
    if (next < kMinBits || next > kMaxBits) return false;
    *bits = next;
    return true;
  };
  auto move_step = [&](double* code_step) {  // quarter bits: 2^(k/4), k = 0 .. 4·log2(kMaxCodeStep)
    const long k = std::lround(4 * std::log2(*code_step)) + (coarser ? 1 : -1);
    if (k < 0 || k > std::lround(4 * std::log2(kMaxCodeStep))) return false;
    *code_step = std::exp2(double(k) / 4);
    return true;
  };
  auto move_multiplier = [&](uint32_t* m) {
    if (coarser) {
      auto it = std::upper_bound(kMultipliers.begin(), kMultipliers.end(), *m);
      if (it == kMultipliers.end()) return false;
      *m = *it;
    } else {
      auto it = std::lower_bound(kMultipliers.begin(), kMultipliers.end(), *m);
      if (it == kMultipliers.begin()) return false;
      *m = *(it - 1);
    }
    return true;
  };
  // The floor: 0, or 2^(k/2) / 255 for k = 0 .. 2·log2(255·kMaxOpacityFloor). A floor at or below the opacities
  // whose code is 0 (below half a code step) changes nothing, so a step skips those values, and one finer
  // than them goes to 0.
  auto move_floor = [&](double* floor) {
    const long last = std::lround(2 * std::log2(255 * kMaxOpacityFloor));
    const double code_zero = o.opacity_bits == 0 ? 0.0 : 0.5 * o.opacity_step / double((1u << o.opacity_bits) - 1);
    auto value = [](long k) { return std::exp2(double(k) / 2) / 255; };
    long k = *floor == 0 ? -1 : std::lround(2 * std::log2(255 * *floor));
    if (coarser) {
      do {
        ++k;
      } while (k <= last && value(k) <= code_zero);
      if (k > last) return false;
      *floor = value(k);
    } else {
      if (k < 0) return false;
      *floor = k == 0 || value(k - 1) <= code_zero ? 0.0 : value(k - 1);
    }
    return true;
  };
  bool moved = false;
  switch (knob) {
    case Knob::kRotation: moved = move_bits(&o.rotation_bits); break;
    case Knob::kScale: moved = move_bits(&o.scale_bits); break;
    case Knob::kScaleStep: moved = move_step(&o.scale_step); break;
    case Knob::kOpacity: moved = move_bits(&o.opacity_bits); break;
    case Knob::kRotationStep: moved = move_step(&o.rotation_step); break;
    case Knob::kOpacityStep: moved = move_step(&o.opacity_step); break;
    case Knob::kOpacityFloor: moved = move_floor(&o.opacity_floor); break;
    case Knob::kSh0: moved = move_multiplier(&o.sh_step_multipliers[0]); break;
    case Knob::kSh1: moved = move_multiplier(&o.sh_step_multipliers[1]); break;
    case Knob::kSh2: moved = move_multiplier(&o.sh_step_multipliers[2]); break;
    case Knob::kSh3: moved = move_multiplier(&o.sh_step_multipliers[3]); break;
    case Knob::kPosition: {
      const double next = clamp_position(coarser ? o.position_error * 2 : o.position_error / 2);
      moved = next != o.position_error;
      o.position_error = next;
      break;
    }
  }
  if (!moved) return std::nullopt;
  return o;
}

double knob_value(const format::ArchiveOptions& o, Knob knob) {
  switch (knob) {
    case Knob::kRotation: return o.rotation_bits;
    case Knob::kScale: return o.scale_bits;
    case Knob::kOpacity: return o.opacity_bits;
    case Knob::kSh0: case Knob::kSh1: case Knob::kSh2: case Knob::kSh3:
      return o.sh_step_multipliers[size_t(int(knob) - int(Knob::kSh0))];
    case Knob::kPosition: return o.position_error;
    case Knob::kOpacityFloor: return o.opacity_floor;
    case Knob::kRotationStep: return o.rotation_step;
    case Knob::kScaleStep: return o.scale_step;
    case Knob::kOpacityStep: return o.opacity_step;
  }
  return kNaN;
}

Key key_of(const format::ArchiveOptions& o) {
  return {o.rotation_bits, o.rotation_step, o.scale_bits,    o.scale_step,          o.opacity_bits,
          o.opacity_step,  o.opacity_floor, o.sh_step_multipliers, o.position_error};
}

double mse_of(double psnr_db) { return std::pow(10.0, -psnr_db / 10); }

std::string db_text(double db) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f dB", db);
  return text;
}

std::vector<Knob> knobs_for(uint32_t sh_degree) {
  std::vector<Knob> out;
  for (Knob k : kKnobs) {
    const int band = int(k) - int(Knob::kSh0);
    if (band >= 0 && band <= 3 && uint32_t(band) > sh_degree) continue;
    out.push_back(k);
  }
  return out;
}

}  // namespace rgs::api::detail
