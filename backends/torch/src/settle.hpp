#pragma once
/// \file
/// Warming a unit up until its time settles (the backend's warm-up before a run): a
/// TorchScript model's profiling executor runs its first calls unoptimized and optimizes on
/// a later one, and a GPU chooses and loads its kernels on the first calls of a shape. One
/// call per shape left that to the run's first units, which paid it and could trip the
/// watchdog. Not installed; tests/torch/lane_device_test.cpp tests the rule.

#include <algorithm>
#include <functional>
#include <vector>

#include "red/core/time.hpp"

namespace red::torchb {

/// When warm-up calls of one unit have settled.
struct SettleRule {
  /// Calls at least (TorchScript's profiling executor optimizes on its second call, so the
  /// third is the first optimized one).
  int min_calls = 3;
  /// Calls at most, settled or not.
  int max_calls = 20;
  /// The last two calls are each within this fraction of the fastest so far.
  double tolerance = 0.10;
};

/// Whether calls that took `times` (in order) have settled under `rule`: at least
/// min_calls, and the last two no slower than (1 + tolerance) × the fastest. Always true
/// at max_calls.
[[nodiscard]] inline bool settled(const std::vector<Duration>& times, const SettleRule& rule) {
  const auto n = static_cast<int>(times.size());
  if (n >= rule.max_calls) return true;
  if (n < std::max(2, rule.min_calls)) return false;
  const Duration fastest = *std::min_element(times.begin(), times.end());
  const double bound = static_cast<double>(fastest.count()) * (1.0 + rule.tolerance);
  return static_cast<double>(times[times.size() - 1].count()) <= bound &&
         static_cast<double>(times[times.size() - 2].count()) <= bound;
}

/// Calls `call` (which runs the unit once and returns how long it took) until settled();
/// returns the times.
inline std::vector<Duration> warm_until_settled(const std::function<Duration()>& call,
                                                const SettleRule& rule) {
  std::vector<Duration> times;
  do {
    times.push_back(call());
  } while (!settled(times, rule));
  return times;
}

}  // namespace red::torchb
