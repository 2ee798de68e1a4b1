#pragma once
/// \file
/// Execution times for the simulator (and fake backends in tests), with common random
/// numbers (docs/DESIGN.md, "Metrics"): the time of a unit instance is a pure function of (seed,
/// what runs, on which frame or job), so every policy sees the same time for the same instance.

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

  /// Time the dispatched unit (merged or batched) takes when it starts at `start` beside
  /// `busy_others` busy lanes. Both matter only with a calibrated profile (its time and lane
  /// factors); otherwise the time depends on the unit instance alone.
  [[nodiscard]] Duration sample(const Dispatch& d, TimePoint start = TimePoint{0},
                                int busy_others = 0) const;

  /// One encoder run on (sensor, frame) at batch size `batch` (u of that frame).
  [[nodiscard]] Duration encoder(int sensor, std::uint64_t frame, int batch = 1) const;
  /// One head of (operation, job seq, node).
  [[nodiscard]] Duration head(int head, int op, std::uint64_t seq, int node, int batch = 1) const;
  /// A plain node of (operation, job seq, node).
  [[nodiscard]] Duration plain(const PlainCost& c, int op, std::uint64_t seq, int node) const;

 private:
  [[nodiscard]] Duration scaled(Duration d) const;
  [[nodiscard]] Duration uncalibrated(const Dispatch& d) const;
  /// Residual tables of one unit by batch size (Calibration::residual's values).
  using Tables = std::vector<std::vector<Duration>>;
  /// The calibration's residual tables of a unit, or nullptr.
  [[nodiscard]] const Tables* tables(const std::string& unit) const;
  /// The table of batch b in `t`, or nullptr.
  [[nodiscard]] static const std::vector<Duration>* table_at(const Tables* t, int batch);
  /// A draw at u of (unit, batch): its residual table when it has one, else its statistics.
  [[nodiscard]] static Duration draw(const UnitProfile& u, const Tables* t, int batch, double u01);
  [[nodiscard]] double encoder_u(int sensor, std::uint64_t frame) const;
  [[nodiscard]] double head_u(int op, std::uint64_t seq, int node) const;

  const Scenario& scenario_;
  std::uint64_t seed_;
  double slowdown_;
  const Calibration* cal_ = nullptr;  ///< the profile's calibration, if any
  double cal_slowdown_ = 1.0;  ///< background load beyond the calibration's (calibrated only)
  const UnitProfile* encoder_ = nullptr;
  std::vector<const UnitProfile*> heads_;
  // Residual tables looked up once (calibrated profiles): encoder, head/<h>, coarse/<h>.
  const Tables* cal_encoder_ = nullptr;
  std::vector<const Tables*> cal_heads_;
  std::vector<const Tables*> cal_coarse_;
};

/// The profile's statistic `stat` (e.g. &LatencyStats::p99) of what `d` runs, not sampled:
/// a merged or batched unit at its batch size (sizes past the largest measured scale
/// linearly), a coarse or mono unit as the sum of its parts. `heads` by head index. For
/// plans and limits: the watchdog's, and when a lane's handler queues its next unit.
Duration profiled_cost(const Dispatch& d, const UnitProfile* encoder,
                       const std::vector<const UnitProfile*>& heads, Duration LatencyStats::*stat);

/// The distribution assumed for a plain cost {mean, p99}: p50 = mean,
/// p95 = mean + 0.6 (p99 − mean), min = max(0, mean − (p99 − mean) / 2),
/// max = p99 + 0.15 (p99 − mean). Deterministic when p99 == mean.
LatencyStats plain_stats(const PlainCost& c);

}  // namespace red
