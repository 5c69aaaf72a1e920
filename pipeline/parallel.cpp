#include "pipeline/parallel.hpp"

#include <tbb/blocked_range.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace hedgefit::pipeline {

int WorkerCount(int threads) {
  const int all = std::max(1, tbb::info::default_concurrency());
  return threads > 0 ? threads : all;
}

void ParallelFor(std::size_t n, int threads, std::size_t grain, const std::function<void(std::size_t, std::size_t)>& fn) {
  if (n == 0) return;
  grain = std::max<std::size_t>(1, grain);
  const std::size_t chunks = (n + grain - 1) / grain;
  const int workers = static_cast<int>(std::min<std::size_t>(std::size_t(WorkerCount(threads)), chunks));
  auto run_chunks = [&](std::size_t first, std::size_t last) {
    for (std::size_t k = first; k < last; ++k) fn(k * grain, std::min(n, (k + 1) * grain));
  };
  if (workers <= 1) {
    run_chunks(0, chunks);
    return;
  }
  auto loop = [&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1),
                      [&](const tbb::blocked_range<std::size_t>& r) { run_chunks(r.begin(), r.end()); },
                      tbb::simple_partitioner());
  };
  // All cores: the caller's own arena (the global pool's, or an enclosing ParallelFor's). Fewer:
  // an arena caps the workers at `threads` without touching the global pool's size.
  if (threads <= 0) {
    loop();
    return;
  }
  tbb::task_arena arena(workers);
  arena.execute(loop);
}

}  // namespace hedgefit::pipeline
