#pragma once
/// \file
/// Execution times for the simulator (and fake backends in tests), with common random
/// numbers (§10): the time of a unit instance is a pure function of (seed, what runs, on
/// which frame or job), so every policy sees the same time for the same instance.

#include <cstdint>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"

namespace red {

class CostSampler {
 public:
  /// `slowdown` multiplies every sampled time (models background interference).
  CostSampler(const Scenario& s, const Profile& p, std::uint64_t seed, double slowdown = 1.0);

  /// Time the dispatched unit (merged or batched) takes.
  [[nodiscard]] Duration sample(const Dispatch& d) const;

  /// One encoder run on (sensor, frame) at batch size `batch` (u of that frame).
  [[nodiscard]] Duration encoder(int sensor, std::uint64_t frame, int batch = 1) const;
  /// One head of (operation, job seq, node).
  [[nodiscard]] Duration head(int head, int op, std::uint64_t seq, int node, int batch = 1) const;
  /// A plain node of (operation, job seq, node).
  [[nodiscard]] Duration plain(const PlainCost& c, int op, std::uint64_t seq, int node) const;

 private:
  [[nodiscard]] Duration scaled(Duration d) const;

  const Scenario& scenario_;
  std::uint64_t seed_;
  double slowdown_;
  const UnitProfile* encoder_ = nullptr;
  std::vector<const UnitProfile*> heads_;
};

/// The distribution assumed for a plain cost {mean, p99}: p50 = mean,
/// p95 = mean + 0.6 (p99 − mean), min = max(0, mean − (p99 − mean) / 2),
/// max = p99 + 0.15 (p99 − mean). Deterministic when p99 == mean.
LatencyStats plain_stats(const PlainCost& c);

}  // namespace red
