#pragma once
/// \file
/// Figures per workload phase (docs/REPORTS.md, "Phases"): the measured window split at
/// each workload event (the scenario's `events:`), so a run whose workload changes
/// mid-way (the paper's case study 1: before, while and after detection joins) is read
/// phase by phase instead of averaged over the whole run. A job belongs to the phase in
/// which it was released.
///
///     for (const PhaseMetrics& ph : phase_metrics(s, run.jobs, run.result.end))
///       fmt::print("{} .. {} s: miss {}\n", ph.from_s, ph.to_s, ph.all.miss_rate);

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// One phase's time span: [from, to), and the workload events that open it.
struct PhaseSpan {
  TimePoint from{0};
  TimePoint to{0};
  /// Indices into Scenario::events of the events that opened it; for the first phase, those
  /// at or before the end of the warm-up (usually none).
  std::vector<int> events;
};

/// The figures of a set of jobs (one operation, or all) in one phase.
struct PhaseFigures {
  std::int64_t jobs = 0;  ///< released in the phase (all outcomes)
  std::int64_t completed = 0, missed = 0, dropped = 0, unfinished = 0;
  double miss_rate = 0, drop_rate = 0, qoe = 0;   ///< as in summary.json, over this phase
  double latency_p50_ms = 0, latency_p99_ms = 0;  ///< of completed jobs, nearest rank
  /// Why its jobs did not meet their deadlines: JobRow::cause → number of jobs (metrics/why.hpp).
  std::map<std::string, std::int64_t> causes;
};

/// One phase: its span and its figures, overall and per operation.
struct PhaseMetrics {
  PhaseSpan span;
  PhaseFigures all;
  /// (operation name, figures) for each operation with a job released in the phase, in
  /// scenario order.
  std::vector<std::pair<std::string, PhaseFigures>> operations;
};

/// The phases of a run that ended at `end`: the first starts at the warm-up's end (with the
/// events at or before it), and a new one starts at each distinct workload event time
/// after it and before `end`.
std::vector<PhaseSpan> workload_phases(const Scenario& s, TimePoint end);

/// Figures of `jobs` (rows of one policy's run) per phase of `workload_phases(s, end)`.
std::vector<PhaseMetrics> phase_metrics(const Scenario& s, const std::vector<JobRow>& jobs,
                                        TimePoint end);

/// A short name for a phase: "start", "whole run" (no events), "after add_nodes (event 0)".
std::string phase_label(const Scenario& s, const PhaseSpan& span);

/// The phase table printed by `--phases`: one block per policy, one row per (phase,
/// operation), plus an "all" row when a phase has several operations.
std::string phase_table(const Scenario& s, const std::vector<std::string>& policies,
                        const std::vector<std::vector<PhaseMetrics>>& phases);

}  // namespace red
