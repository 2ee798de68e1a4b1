#pragma once
/// \file
/// `red analyze --export-nptest DIR`: a scenario's job set in the CSV formats of the
/// np-schedulability-analysis tool (`nptest`, M. Nasri and B. Brandenburg, "An Exact and
/// Sustainable Analysis of Non-Preemptive Scheduling", RTSS 2017; precedence constraints
/// as in its later versions), so that independent exact analysis runs on RED's workloads.
/// Every schedulable unit of every job released in the window is one nptest job; times are
/// integer microseconds. The mapping is documented in docs/ANALYSIS.md.

#include <cstddef>
#include <optional>
#include <string>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/policy.hpp"

namespace red {

/// The three files of an export and what they hold.
struct NptestExport {
  std::string
      jobs_csv;  ///< jobs.csv: Task ID, Job ID, Arrival min/max, Cost min/max, Deadline, Priority
  std::string
      prec_csv;  ///< jobs.prec.csv: Predecessor TID, Predecessor JID, Successor TID, Successor JID
  std::string tasks_csv;     ///< tasks.csv: Task ID, kind, operation, node (what each task ID is)
  std::size_t jobs = 0;      ///< rows of jobs.csv
  std::size_t edges = 0;     ///< rows of jobs.prec.csv
  Duration window{0};        ///< releases in [0, window) are exported
  bool hyperperiod = false;  ///< the window is one hyperperiod of the workload
  std::string note;          ///< why the window is what it is
};

/// The most rows an export writes (beyond: an error asking for a shorter window).
inline constexpr std::size_t kNptestMaxJobs = 500000;

/// Exports the jobs released in [0, window) under a policy with options `o` (its graph,
/// deadlines and sharing of encoder runs). Without `window`: one hyperperiod of the
/// workload when it has no events and the hyperperiod fits the scenario's duration, else
/// the scenario's duration. Error: a non-positive window, or more than kNptestMaxJobs jobs.
Expected<NptestExport> export_nptest(const Scenario& s, const Profile& p, const PolicyOptions& o,
                                     std::optional<Duration> window = std::nullopt);

}  // namespace red
