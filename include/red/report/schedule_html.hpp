#pragma once
/// \file
/// The parts of the report that show the schedule and its phases (docs/REPORTS.md): the
/// timeline SVGs under plots/ with the index.html section embedding them, and the
/// section with the figures per workload phase.
///
///     auto t = write_timelines(dir, s, runs, default_timeline_windows(s, runs));
///     page.sections.push_back(phase_section(s, names, phases));
///     page.sections.push_back(t->section);

#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/phases.hpp"
#include "red/report/html.hpp"
#include "red/report/timeline.hpp"

namespace red {

/// What write_timelines wrote.
struct TimelineReport {
  std::vector<std::string> files;  ///< relative to the output directory: plots/NAME.svg
  HtmlSection section;             ///< the SVGs inline, for index.html
};

/// Draws each window (timeline_svg) into `dir/subdir/NAME.svg`. Error: a file that cannot
/// be written (names the path).
Expected<TimelineReport> write_timelines(const std::string& dir, const Scenario& s,
                                         const std::vector<TimelineRun>& runs,
                                         const std::vector<TimelineWindow>& windows,
                                         const std::string& subdir = "plots");

/// The index.html section "Per workload phase": miss rate per phase side by side for every
/// policy, then each policy's jobs, miss rate, drop rate, QoE and latency per phase and
/// operation. `phases[i]` belongs to `policies[i]`.
HtmlSection phase_section(const Scenario& s, const std::vector<std::string>& policies,
                          const std::vector<std::vector<PhaseMetrics>>& phases);

/// The index.html section "Why jobs missed": per policy, one row per phase and operation with
/// a job not met: how many, the top cause (PhaseFigures::causes) and its share, the next
/// causes. `phases[i]` belongs to `policies[i]`.
/// index.html's "Costs: the profile against this run": per policy, each unit and batch size
/// that ran, the profile's mean against the run's, and the factor the plan used
/// (PolicyMetrics::costs); nullopt when no run measured its costs (the simulator's, unless
/// it drew costs from another profile).
std::optional<HtmlSection> costs_section(const std::vector<PolicyMetrics>& runs);

HtmlSection why_section(const Scenario& s, const std::vector<std::string>& policies,
                        const std::vector<std::vector<PhaseMetrics>>& phases);

}  // namespace red
