#pragma once
/// \file
/// Writing results: summary.json (schema of docs/CLI.md), jobs.csv, units.csv, and the
/// paper-style comparison table for the terminal.

#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/phases.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// What a summary file describes besides the policies.
struct SummaryHeader {
  std::string scenario;
  std::string backend = "sim";  ///< "sim" or "torch"
  std::string baseline = "edf";
  std::uint64_t seed = 1;
  std::string profile_source;  ///< "builtin-default", "measured" or a path
  /// The run id of the output set (report/manifest.hpp); empty: no "run_id" field.
  std::string run_id;
  /// summary.json's "page" object as JSON text (report/redraw.hpp, page_json); empty: none.
  std::string page;
};

/// summary.json text: deterministic for the same inputs (byte-identical apart from the run
/// id). `phases[i]`, when
/// given, becomes the "phases" array of policy i (docs/REPORTS.md).
std::string summary_json(const SummaryHeader& h, const std::vector<PolicyMetrics>& policies,
                         const std::vector<std::vector<PhaseMetrics>>& phases = {});

/// Rows of one policy's run, for the CSV writers.
template <typename Row>
struct PolicyRows {
  std::string policy;
  const std::vector<Row>* rows = nullptr;
};

/// jobs.csv text: policy, operation, job, release_ms, finish_ms, deadline_ms, outcome,
/// response_ms, qoe, frame_age_ms, reason, ended_ms, cause, cause_ms (docs/REPORTS.md).
std::string jobs_csv(const Scenario& s, const std::vector<PolicyRows<JobRow>>& runs);

/// jobs.csv's header line, with its line break.
std::string jobs_csv_header();

/// Appends one jobs.csv row (with its line break) of `policy`'s run to `out`.
void append_job_row(std::string& out, const Scenario& s, const std::string& policy,
                    const JobRow& j);

/// units.csv's header line, with its line break.
std::string units_csv_header();

/// Appends one units.csv row (with its line break) of `policy`'s run to `out`.
void append_unit_row(std::string& out, const Scenario& s, const std::string& policy,
                     const UnitRow& u);

/// units.csv text: one row per unit execution (docs/REPORTS.md).
std::string units_csv(const Scenario& s, const std::vector<PolicyRows<UnitRow>>& runs);

/// The comparison table: policy, jobs, miss rate, drop rate, mean and p99 latency, QoE,
/// encoder runs, and ratios vs the baseline.
std::string comparison_table(const std::vector<PolicyMetrics>& policies,
                             const std::string& baseline);

/// Real runs: the frames each policy's sensors offered and the run released, and how late
/// (release - nominal capture time); empty when no policy has those figures (simulations).
std::string releases_table(const std::vector<PolicyMetrics>& policies);

/// A sentence saying that a real run's releases fell behind its sensors (frames offered but
/// never released, or released more than a period late), or nullopt when they kept up.
std::optional<std::string> releases_warning(const PolicyMetrics& m);

/// Writes `text` to `dir/name`, creating `dir`, atomically (core/output_file.hpp: through
/// `dir/name.partial`). Error names the path and the system's reason.
std::optional<Error> write_file(const std::string& dir, const std::string& name,
                                const std::string& text);

}  // namespace red
