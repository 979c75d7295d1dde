// The lab's macro-tile binning: a kernels::PairBinning that builds the tiles' depth-ordered lists without the
// global pair sort (docs/lab/TRIED.md). Available only with RGS_WITH_CUDA.
#pragma once

#include "rgs/kernels/roofgs_pipeline.h"

namespace rgs::lab {

/// The process's macro-tile binning, for kernels::RoofgsStages::binning (rgs-bench's fastest-macro-bins mode).
/// Holds its device buffers until exit; one renderer at a time may use it (not thread-safe).
kernels::PairBinning* macro_tile_binning();

}  // namespace rgs::lab
