#pragma once
/// The one parallel-for of hedgefit, on oneTBB's work-stealing pool. Every loop that used a
/// hand-written thread pool calls this instead.

#include <cstddef>
#include <functional>

namespace hedgefit::pipeline {

/// Workers ParallelFor uses for a `threads` setting: `threads`, or all cores when it is 0.
int WorkerCount(int threads);

/// Calls fn(begin, end) on the chunks [k * grain, (k + 1) * grain) of [0, n), with at most
/// WorkerCount(threads) workers. The chunks depend only on n and grain, never on timing, so
/// a reduction that keeps one partial result per chunk and adds them in chunk order is
/// deterministic. Exceptions thrown by fn reach the caller.
void ParallelFor(std::size_t n, int threads, std::size_t grain, const std::function<void(std::size_t, std::size_t)>& fn);

}  // namespace hedgefit::pipeline
