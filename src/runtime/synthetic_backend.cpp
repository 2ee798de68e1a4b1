#include "red/runtime/synthetic_backend.hpp"

#include <chrono>
#include <stdexcept>
#include <thread>

namespace red {

SyntheticBackend::SyntheticBackend(const Scenario& s, const Profile& p, std::uint64_t seed,
                                   Options o)
    : sampler_(s, p, seed), options_(std::move(o)) {}

void SyntheticBackend::run(int /*lane*/, const Dispatch& d) {
  runs_.fetch_add(1, std::memory_order_relaxed);
  if (options_.inject) {
    const int what = options_.inject(d);
    if (what == 1) throw std::runtime_error("injected failure");
    if (what == 2) throw OutOfMemoryError("injected out-of-memory");
    if (what == 3) {
      // A hang: the call does not return for `hang`, then returns as if it had worked.
      std::this_thread::sleep_for(options_.hang);
      return;
    }
  }
  const auto t = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      Duration{static_cast<std::int64_t>(static_cast<double>(sampler_.sample(d).count()) *
                                         options_.time_scale)});
  if (t <= std::chrono::steady_clock::duration::zero()) return;
  const auto until = std::chrono::steady_clock::now() + t;
  if (options_.spin) {
    while (std::chrono::steady_clock::now() < until) {
    }
  } else {
    std::this_thread::sleep_until(until);
  }
}

}  // namespace red
