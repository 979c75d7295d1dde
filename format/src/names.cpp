// Names of the .rgs enums for tools and messages (SPEC.md §3.1, §4).
#include <iterator>

#include "rgs/format/spec.h"

namespace rgs::format {

const char* section_name(SectionId id) {
  switch (id) {
    case SectionId::kMetadata: return "metadata";
    case SectionId::kProvenance: return "provenance";
    case SectionId::kMeans: return "means";
    case SectionId::kRotations: return "rotations";
    case SectionId::kScales: return "scales";
    case SectionId::kOpacities: return "opacities";
    case SectionId::kSh: return "sh";
    case SectionId::kShDcResidual: return "sh_dc_residual";
    case SectionId::kLod: return "lod";
  }
  return "unknown";
}

const char* codec_name(Codec codec) {
  static const char* const kNames[] = {"none", "zstd", "draco", "quantized"};
  const auto index = static_cast<size_t>(codec);
  return index < std::size(kNames) ? kNames[index] : "unknown";
}

const char* element_type_name(ElementType type) {
  static const char* const kNames[] = {"bytes", "i8", "f16", "f32"};
  const auto index = static_cast<size_t>(type);
  return index < std::size(kNames) ? kNames[index] : "unknown";
}

}  // namespace rgs::format
