// Parallel loops that give bit-identical results for any thread count.
//
// ParallelFor: each index writes only its own outputs, so the schedule cannot
// change them.  DeterministicSum: fixed-size chunks are summed independently
// and the partial sums combined in index order, so the rounding is the same
// whether one thread or sixty run it.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/math.h"

namespace mr {

// Limits TBB to n threads for the rest of the process (n <= 0: all cores).
void SetThreadCount(int n);
int ThreadCount();

// Calls fn(i) for i in [begin, end) in parallel; `grain` indices per task.
void ParallelFor(int64_t begin, int64_t end, const std::function<void(int64_t)>& fn, int64_t grain = 1);

// Calls fn(i0, i1) on fixed, thread-independent chunks [i0, i1).
void ParallelForChunks(int64_t begin, int64_t end, int64_t chunk, const std::function<void(int64_t, int64_t)>& fn);

// Sum of fn(i) over [begin, end), compensated, in a thread-independent order.
double DeterministicSum(int64_t begin, int64_t end, const std::function<double(int64_t)>& fn, int64_t chunk = 4096);

}  // namespace mr
