// A minimal parallel loop (the synthetic generator, the database readers,
// the builtin verifier).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace hisfm {

/// Number of worker threads for `requested` (<= 0: every core).
inline int NumWorkerThreads(int requested) {
  if (requested > 0) return requested;
  return std::max(1u, std::thread::hardware_concurrency());
}

/// Calls fn(i) for i in [0, n) on up to num_threads threads (dynamic
/// scheduling in blocks of `grain`). fn must only write to data owned by
/// index i. The first exception thrown by fn is rethrown here.
template <typename Fn>
void ParallelFor(size_t n, int num_threads, Fn&& fn, size_t grain = 1) {
  const size_t threads =
      std::min<size_t>(NumWorkerThreads(num_threads), (n + grain - 1) / grain);
  if (threads <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<size_t> next(0);
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&]() {
    try {
      for (;;) {
        const size_t begin = next.fetch_add(grain);
        if (begin >= n) return;
        const size_t end = std::min(n, begin + grain);
        for (size_t i = begin; i < end; ++i) fn(i);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next.store(n);
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 0; t < threads; ++t) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace hisfm
