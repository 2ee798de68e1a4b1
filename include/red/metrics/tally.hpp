#pragma once
/// \file
/// What counts as a miss and how QoE is averaged (docs/DESIGN.md, "Metrics"), written once: the
/// tally of ended jobs by outcome that a run's summary (MetricsCollector), the phase table
/// (red/metrics/phases.hpp) and the ROS 2 node's diagnostics all count with.
///
///     OutcomeTally t;
///     t.add(JobOutcome::Met, 1.0);
///     t.add(JobOutcome::Dropped, 0.0);
///     // t.missed() == 1, t.miss_rate() == 0.5, t.qoe() == 0.5

#include <cstdint>

#include "red/sched/records.hpp"

namespace red {

/// Ended jobs by outcome, and the QoE of the completed ones. A job misses if it finishes late
/// or produces no result (dropped, skipped or failed); the miss rate, the drop rate and the QoE
/// are taken over the decided jobs (completed or without result), the unfinished ones aside, and
/// a job without result scores QoE 0.
struct OutcomeTally {
  std::int64_t jobs = 0;                 ///< added, whatever their outcome
  std::int64_t met = 0;                  ///< completed by the deadline
  std::int64_t late = 0;                 ///< completed after it (JobOutcome::Missed)
  std::int64_t dropped = 0;              ///< without result: dropped, skipped or failed
  std::int64_t skipped = 0, failed = 0;  ///< of those dropped
  std::int64_t unfinished = 0;           ///< still in flight when the run ended
  double qoe_sum = 0;                    ///< of the completed jobs, summed in the order added

  /// Adds an ended job; `qoe` (its qoe_score) counts only if it completed.
  void add(JobOutcome outcome, double qoe) noexcept {
    ++jobs;
    switch (outcome) {
      case JobOutcome::Met:
        ++met;
        qoe_sum += qoe;
        break;
      case JobOutcome::Missed:
        ++late;
        qoe_sum += qoe;
        break;
      case JobOutcome::Dropped:
        ++dropped;
        break;
      case JobOutcome::Skipped:
        ++dropped;
        ++skipped;
        break;
      case JobOutcome::Failed:
        ++dropped;
        ++failed;
        break;
      case JobOutcome::Unfinished:
        ++unfinished;
        break;
    }
  }

  [[nodiscard]] std::int64_t completed() const noexcept { return met + late; }
  /// Completed or without result: what the rates are taken over.
  [[nodiscard]] std::int64_t decided() const noexcept { return completed() + dropped; }
  /// Finished late or without result.
  [[nodiscard]] std::int64_t missed() const noexcept { return late + dropped; }

  /// missed() / decided(); 0 when none is decided. Not rounded.
  [[nodiscard]] double miss_rate() const noexcept { return over_decided(missed()); }
  /// dropped / decided(); 0 when none is decided. Not rounded.
  [[nodiscard]] double drop_rate() const noexcept { return over_decided(dropped); }
  /// qoe_sum / decided(); 0 when none is decided. Not rounded.
  [[nodiscard]] double qoe() const noexcept {
    return decided() > 0 ? qoe_sum / static_cast<double>(decided()) : 0.0;
  }

 private:
  [[nodiscard]] double over_decided(std::int64_t n) const noexcept {
    return decided() > 0 ? static_cast<double>(n) / static_cast<double>(decided()) : 0.0;
  }
};

}  // namespace red
