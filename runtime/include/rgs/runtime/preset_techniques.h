// The technique switches behind each preset on the CPU reference (for testing the GPU against it, and for the
// lab's ablations, which start from them). The GPU's are in frame_plan.h (gpu_techniques).
#pragma once

#include "rgs/format/metadata.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/preset.h"
#include "rgs/runtime/roofgs_options.h"

namespace rgs::runtime {

/// The shared technique switches of `preset` (all off for kFaithful).
RoofgsOptions preset_techniques(Preset preset);

/// CPU reference options for `preset`'s techniques, term by term as the GPU applies them: preset_techniques(preset),
/// `bounds` (required by the 32-bit key of kFastest and kPaper), background black, all hardware threads.
RenderOptions cpu_render_options(Preset preset, const format::SceneBounds& bounds);

/// What the CPU backend renders `preset` with: each preset is the fastest of its kind on the backend that runs
/// it, so kFastest is there kFaithful's options (Preset::kFastest says why). The other presets: cpu_render_options.
RenderOptions cpu_backend_options(Preset preset, const format::SceneBounds& bounds);

}  // namespace rgs::runtime
