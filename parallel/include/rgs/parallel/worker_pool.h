// WorkerPool: threads kept between calls, for fork-join work repeated many times a second (the level-of-detail
// reader runs once a frame), where fork_join.h would start and join every thread on every call
// (docs/LOD.md#a-frame-under-a-budget measures what that cost the reader).
//
// run() has parallel_items' contract (items claimed in increasing order, allocation failures as kOutOfMemory,
// other exceptions rethrown on the caller, no item started after a failure); the caller is worker 0 and the
// pool's threads the others. One run() at a time: a pool belongs to one owner, which calls it from one thread
// at a time (not necessarily the same one). Between calls the threads sleep on a condition variable.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <new>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "rgs/parallel/fork_join.h"

namespace rgs::parallel {

class WorkerPool {
 public:
  /// A pool of `workers` workers, at least 1: the caller of run() and workers − 1 threads started now. A thread
  /// that cannot be started leaves fewer workers (workers() says how many), never an error.
  explicit WorkerPool(unsigned workers) {
    try {
      threads_.reserve(std::max(1u, workers) - 1);
      for (unsigned t = 1; t < workers; ++t) threads_.emplace_back(&WorkerPool::serve, &shared_, t);
    } catch (const std::system_error&) {
    } catch (const std::bad_alloc&) {
    }
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  /// Stops the threads and joins them (no run() may be in progress).
  ~WorkerPool() {
    {
      const std::lock_guard<std::mutex> lock(shared_.mutex);
      shared_.stop = true;
    }
    shared_.wake.notify_all();
    for (std::thread& t : threads_) t.join();
  }

  /// Workers a run() can use: the caller and the threads started.
  unsigned workers() const { return static_cast<unsigned>(threads_.size()) + 1; }

  /// fn(worker, item) once for every item of [0, items), on at most `max_workers` workers (the caller among
  /// them; never more than items or workers()), as parallel_items. Returns when every item is done.
  template <typename Fn>
  [[nodiscard]] Status run(uint64_t items, unsigned max_workers, Fn&& fn) {
    const unsigned used =
        static_cast<unsigned>(std::max<uint64_t>(1, std::min<uint64_t>({max_workers, workers(), items})));
    WorkerFailures failures;
    std::atomic<uint64_t> next{0};
    auto body = [&](unsigned t) { failures.run([&] { claim_items(next, items, t, fn); }); };
    if (used > 1) {
      Shared& s = shared_;
      {
        const std::lock_guard<std::mutex> lock(s.mutex);
        s.job = [](void* job, unsigned t) { (*static_cast<decltype(body)*>(job))(t); };
        s.job_state = &body;
        s.participants = used;
        s.busy = used - 1;
        ++s.generation;
      }
      s.wake.notify_all();
      body(0);
      std::unique_lock<std::mutex> lock(s.mutex);
      s.done.wait(lock, [&] { return s.busy == 0; });
    } else {
      body(0);
    }
    return failures.result(std::to_string(items) + " items");
  }

 private:
  // What the caller and the threads share, guarded by `mutex` (the state the job points to is the caller's).
  struct Shared {
    std::mutex mutex;
    std::condition_variable wake, done;
    uint64_t generation = 0;  ///< run() calls so far: a thread works once per generation it is part of
    unsigned participants = 0;
    unsigned busy = 0;  ///< threads of the current generation still working
    bool stop = false;
    void (*job)(void*, unsigned) = nullptr;
    void* job_state = nullptr;
  };

  static void serve(Shared* s, unsigned t) {
    uint64_t seen = 0;
    std::unique_lock<std::mutex> lock(s->mutex);
    for (;;) {
      s->wake.wait(lock, [&] { return s->stop || s->generation != seen; });
      if (s->stop) return;
      seen = s->generation;
      if (t >= s->participants) continue;  // not needed in this generation
      lock.unlock();
      s->job(s->job_state, t);  // never throws: the body records what fn throws
      lock.lock();
      if (--s->busy == 0) s->done.notify_one();
    }
  }

  Shared shared_;
  std::vector<std::thread> threads_;
};

}  // namespace rgs::parallel
