// Fork-join of the CPU renderer: the shared pool of rgs/parallel/fork_join.h under the names the runtime's
// sources use. RenderOptions::num_threads = 0 means every CPU this process may run on (its affinity mask).
#pragma once

#include "rgs/parallel/fork_join.h"

namespace rgs::runtime::detail {

using parallel::parallel_chunks;
using parallel::parallel_for;
using parallel::parallel_items;

/// Thread count for a request: `requested`, or parallel::available_cpus() when 0; at least 1.
inline unsigned resolve_thread_count(unsigned requested) { return parallel::thread_count(requested); }

}  // namespace rgs::runtime::detail
