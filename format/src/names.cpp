// Names of the .rgs enums for tools and messages (SPEC.md §3.1, §4).
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
  }
  return "unknown";
}

const char* codec_name(Codec codec) {
  switch (codec) {
    case Codec::kNone: return "none";
    case Codec::kZstd: return "zstd";
    case Codec::kDraco: return "draco";
    case Codec::kQuantized: return "quantized";
  }
  return "unknown";
}

const char* element_type_name(ElementType type) {
  switch (type) {
    case ElementType::kBytes: return "bytes";
    case ElementType::kInt8: return "i8";
    case ElementType::kFloat16: return "f16";
    case ElementType::kFloat32: return "f32";
  }
  return "unknown";
}

}  // namespace rgs::format
