// What a run measures besides the scheduler's statistics: uniform samples of timings
// (reservoir sampling), the periodic RuntimeSample, resident memory, and the ring of the
// newest decision times behind Runtime::decision_us_since.

#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <fstream>
#include <mutex>
#include <vector>

#include "red/core/newest.hpp"
#include "red/runtime/runtime.hpp"
#include "runtime_impl.hpp"

namespace red {

std::int64_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::int64_t size = 0, resident = 0;
  if (!(f >> size >> resident)) return 0;
  return resident * static_cast<std::int64_t>(sysconf(_SC_PAGESIZE));
}

// Keeps a uniform sample of at most max_timing_samples values (reservoir sampling,
// Algorithm R); `seen` counts every value offered. Caller holds report_mu.
void Runtime::Impl::record(std::vector<double>& v, std::uint64_t& seen, double x) noexcept {
  ++seen;
  if (v.size() < options.max_timing_samples) {
    v.push_back(x);  // within the reserved capacity
    return;
  }
  reservoir_rng ^= reservoir_rng << 13;
  reservoir_rng ^= reservoir_rng >> 7;
  reservoir_rng ^= reservoir_rng << 17;
  const std::uint64_t j = reservoir_rng % seen;
  if (j < v.size()) v[static_cast<std::size_t>(j)] = x;
}

// One RuntimeSample (the sampler thread).
void Runtime::Impl::take_sample() {
  RuntimeSample s;
  s.t = clock.now();
  s.rss_bytes = resident_bytes();
  {
    std::lock_guard lock(sched_mu);
    s.ready = sched.ready_tasks();
    s.in_flight = sched.jobs_in_flight();
  }
  std::lock_guard rl(report_mu);
  report.samples.push_back(s);
}

// Samples every sample_period until `sampling` is cleared.
void Runtime::Impl::sampler_main() {
  std::unique_lock lock(sample_mu);
  TimePoint next = options.sample_period;
  for (;;) {
    const auto wall = std::chrono::steady_clock::time_point(
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(clock.origin() + next));
    if (sample_cv.wait_until(lock, wall, [this] { return !sampling; })) return;
    lock.unlock();
    take_sample();
    lock.lock();
    next += options.sample_period;
  }
}

std::vector<double> Runtime::decision_us_since(std::uint64_t& cursor) const {
  // From the ring of the newest decisions: report.decision_us is a uniform sample once it
  // is full, so it has no "since". Decisions older than the ring are gone.
  std::lock_guard lock(impl_->report_mu);
  const Impl& m = *impl_;
  std::vector<double> out = newest_since(m.recent_decision_us, m.recent_total, cursor);
  cursor = m.recent_total;
  return out;
}

}  // namespace red
