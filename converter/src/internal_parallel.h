// Fork-join of the converter: the shared pool of rgs/parallel/fork_join.h (affinity-aware thread counts,
// kOutOfMemory for allocation failures in workers) under the names the converter's sources use, with the
// converter's cap on threads.
#pragma once

#include <cstdint>

#include "rgs/parallel/fork_join.h"

namespace rgs::converter::detail {

using parallel::available_cpus;
using parallel::parallel_items;
using parallel::parallel_slices;
using parallel::WorkerFailures;

/// Most workers worker_count() ever returns: beyond it the readers and quantize are bound by memory
/// bandwidth.
inline constexpr unsigned kMaxWorkers = 16;

/// Worker count for `items` units of similar cost: items / min_per_worker, at least 1 and at most
/// available_cpus() (capped at kMaxWorkers).
inline unsigned worker_count(uint64_t items, uint64_t min_per_worker) {
  return parallel::worker_count(items, min_per_worker, kMaxWorkers);
}

}  // namespace rgs::converter::detail
