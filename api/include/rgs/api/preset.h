// Named render configurations: the three presets of the front door (runtime/preset.h states what each one
// renders with).
#pragma once

#include "rgs/runtime/preset.h"

namespace rgs::api {

using runtime::parse_preset;
using runtime::Preset;
using runtime::preset_name;
using runtime::preset_reads_fp32;

}  // namespace rgs::api
