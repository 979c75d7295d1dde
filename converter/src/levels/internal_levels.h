// The per-Gaussian sections of a runtime-profile scene as bytes, for the level stores (levels.cpp holds the
// in-memory one, lod_out_of_core.cpp the spilled one): which sections, how wide, and where a scene keeps them.
#pragma once

#include <cstdint>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/spec.h"

namespace rgs::converter::detail {

/// The per-Gaussian sections in file order (SPEC §4.3–§4.8).
inline constexpr int kLevelSections = 6;
inline constexpr format::SectionId kLevelSectionIds[kLevelSections] = {
    format::SectionId::kMeans,     format::SectionId::kRotations, format::SectionId::kScales,
    format::SectionId::kOpacities, format::SectionId::kSh,        format::SectionId::kShDcResidual};

/// Section `id`'s index in kLevelSectionIds, -1 for another section.
int level_section(format::SectionId id);

/// Bytes one Gaussian takes in section s (an index into kLevelSectionIds) with `sh_values` SH values a Gaussian.
uint64_t section_width(int s, uint64_t sh_values);

/// Where `scene` keeps section s: its first byte (the section's array of `scene`, sized by the caller).
const uint8_t* section_bytes(const format::EncodedScene& scene, int s);
inline uint8_t* section_bytes(format::EncodedScene* scene, int s) {
  return const_cast<uint8_t*>(section_bytes(*scene, s));
}

/// `scene`'s arrays sized for n Gaussians with `sh_values` SH values each (and the DC residual when `residual`).
void size_sections(format::EncodedScene* scene, uint64_t n, uint64_t sh_values, bool residual);

}  // namespace rgs::converter::detail
