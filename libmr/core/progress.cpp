#include "core/progress.h"

#include <unistd.h>

#include <cstdio>
#include <mutex>

namespace mr {

namespace {
std::mutex g_progress_mutex;
}

bool Progress::Enabled() { return isatty(STDERR_FILENO) != 0; }

Progress::Progress(std::string label, int64_t total)
    : label_(std::move(label)),
      total_(total),
      enabled_(Enabled()),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

Progress::~Progress() { Done(); }

void Progress::Update(int64_t done) {
  if (!enabled_) return;
  std::lock_guard lock(g_progress_mutex);
  auto now = std::chrono::steady_clock::now();
  if (now - last_ < std::chrono::milliseconds(200) && done < total_) return;
  last_ = now;
  double elapsed = std::chrono::duration<double>(now - start_).count();
  double frac = total_ > 0 ? static_cast<double>(done) / static_cast<double>(total_) : 1.0;
  double eta = frac > 0 ? elapsed * (1 - frac) / frac : 0;
  std::fprintf(stderr, "\r%s: %5.1f%% (%.1fs elapsed, %.1fs left)   ", label_.c_str(), 100.0 * frac, elapsed, eta);
  std::fflush(stderr);
}

void Progress::Done() {
  if (!enabled_ || finished_) return;
  finished_ = true;
  Update(total_);
  std::fprintf(stderr, "\n");
}

}  // namespace mr
