#include "core/parallel.h"

#include <memory>
#include <mutex>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

namespace mr {

namespace {
std::mutex g_control_mutex;
std::unique_ptr<tbb::global_control> g_control;
}  // namespace

void SetThreadCount(int n) {
  std::lock_guard lock(g_control_mutex);
  g_control.reset();
  if (n > 0)
    g_control =
        std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(n));
}

int ThreadCount() {
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

void ParallelFor(int64_t begin, int64_t end, const std::function<void(int64_t)>& fn, int64_t grain) {
  if (end <= begin) return;
  tbb::parallel_for(tbb::blocked_range<int64_t>(begin, end, std::max<int64_t>(1, grain)),
                    [&](const tbb::blocked_range<int64_t>& r) {
                      for (int64_t i = r.begin(); i != r.end(); ++i) fn(i);
                    });
}

void ParallelForChunks(int64_t begin, int64_t end, int64_t chunk, const std::function<void(int64_t, int64_t)>& fn) {
  if (end <= begin) return;
  MR_CHECK_GT(chunk, 0);
  const int64_t n_chunks = (end - begin + chunk - 1) / chunk;
  tbb::parallel_for(int64_t{0}, n_chunks, [&](int64_t c) {
    const int64_t i0 = begin + c * chunk;
    fn(i0, std::min(end, i0 + chunk));
  });
}

double DeterministicSum(int64_t begin, int64_t end, const std::function<double(int64_t)>& fn, int64_t chunk) {
  if (end <= begin) return 0.0;
  MR_CHECK_GT(chunk, 0);
  const int64_t n_chunks = (end - begin + chunk - 1) / chunk;
  std::vector<CompensatedSum<double>> partial(static_cast<size_t>(n_chunks));
  ParallelForChunks(begin, end, chunk, [&](int64_t i0, int64_t i1) {
    CompensatedSum<double> s;
    for (int64_t i = i0; i < i1; ++i) s += fn(i);
    partial[static_cast<size_t>((i0 - begin) / chunk)] = s;
  });
  CompensatedSum<double> total;
  for (const auto& p : partial) total += p;
  return total.Value();
}

}  // namespace mr
