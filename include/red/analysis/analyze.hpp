#pragma once
/// \file
/// `red analyze` (docs/ANALYSIS.md): will this robot meet its deadlines, and with how much
/// headroom? Per operation and per workload phase: rate, deadline, critical paths, work per
/// job, utilization and a verdict with its reason; for the device: utilization and the work
/// bound on the on-time fraction; the headroom searched in the simulator; a response-time
/// bound where a published analysis applies.
///
///     auto a = red::analyze(scenario, profile, {.policy = "red"});
///     if (!a) { std::cerr << a.error().to_string() << '\n'; return 2; }
///     std::cout << red::analysis_text(*a);
///     return a->verdict == red::Verdict::Ok ? 0 : 1;  // `red analyze --check`

#include <cstdint>
#include <string>
#include <vector>

#include "red/analysis/headroom.hpp"
#include "red/analysis/response_bound.hpp"
#include "red/core/expected.hpp"
#include "red/metrics/phases.hpp"
#include "red/profile/profile.hpp"
#include "red/report/html.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// Will an operation keep its deadlines? Ordered from good to bad.
enum class Verdict : std::uint8_t {
  Ok,          ///< ≤ 1 % misses in simulation on profiled and on worst-case costs
  AtRisk,      ///< meets in simulation on profiled costs, misses on worst-case (max) costs
  Overloaded,  ///< demand above capacity, or misses in simulation on profiled costs
  Infeasible,  ///< deadline below the shortest response alone on the device (critical path,
               ///< and the job's own work spread over the lanes)
};

/// "ok", "at risk", "overloaded", "infeasible".
const char* to_string(Verdict v) noexcept;

/// One operation in one phase.
struct OperationAnalysis {
  int operation = -1;
  std::string name;
  double rate_hz = 0;
  Duration deadline{0};
  /// Critical paths (docs/DESIGN.md, "Refinement"): coarse and fine graph, on mean costs and on the
  /// scheduler's estimate.
  Duration cp_coarse_mean{0}, cp_coarse_estimate{0}, cp_fine_mean{0}, cp_fine_estimate{0};
  /// The shortest response of a job alone on the device on the policy's graph: max(critical
  /// path, the job's own work / lanes), on best-case (min) and on mean costs.
  Duration alone_min{0}, alone_mean{0};
  /// Work per job on mean costs: coarse; fine with a job's encoder runs shared; with
  /// DynamicMerge across operations (estimate, merged_encoder_runs); the policy's.
  Duration work_coarse{0}, work_fine{0}, work_merged{0}, work_policy{0};
  /// Its share of the phase's necessary work (red/graph/necessary_work.hpp) over the lanes:
  /// encoder runs per frame shared by the operations reading it, runs batched as the deadlines
  /// allow, whatever the policy.
  double utilization = 0;
  /// Simulation of the policy: jobs of this operation released in the phase and miss rate,
  /// on profiled costs and on worst-case costs.
  std::int64_t jobs_profiled = 0, jobs_worst = 0;
  double miss_profiled = 0, miss_worst = 0;
  Verdict verdict = Verdict::Ok;
  std::string reason;
};

/// One workload phase (metrics/phases.hpp): the operations in it and the device's load.
struct PhaseAnalysis {
  PhaseSpan span;
  std::string label;
  std::vector<OperationAnalysis> operations;
  /// The necessary work of the phase over the lanes (WorkModel): above 1 by more than its latest
  /// deadline over its length, no policy meets every deadline.
  double utilization = 0;
  Verdict verdict = Verdict::Ok;
};

/// What analyze() does besides the verdicts.
struct AnalysisOptions {
  std::string policy = "red";  ///< the chosen policy (a preset name)
  bool headroom = true;        ///< search the headroom of the policy and of edf
  HeadroomOptions search;      ///< its knobs; search.miss_limit is also the verdicts' limit
};

/// Everything `red analyze` reports (analysis.json holds all of it).
struct Analysis {
  std::string scenario;
  std::string policy;
  std::string profile;  ///< the profile's source ("builtin-default", "measured", ...)
  int lanes = 1;
  EstimateKind estimate = EstimateKind::P99;
  double slowdown = 1;  ///< interference: every cost × this
  double miss_limit = 0.01;
  std::vector<PhaseAnalysis> phases;
  double peak_utilization = 0;  ///< the highest phase utilization
  double on_time_bound = 1;     ///< work_bound(): the most on-time fraction any policy gets
  double on_time_profiled = 0, on_time_worst = 0;  ///< the policy's, simulated
  /// Busy share of each lane in the simulation on profiled costs (after warm-up).
  std::vector<double> lane_busy;
  Verdict verdict = Verdict::Ok;   ///< the worst of every phase
  std::vector<Headroom> headroom;  ///< policy then edf, each on profiled then worst-case costs
  ResponseBound response;          ///< of the chosen policy
  double wall_s = 0;               ///< host time of the analysis
};

/// Analyzes `s` under `o.policy` with profile `p` (resolve_profile()). Error: unknown policy.
Expected<Analysis> analyze(const Scenario& s, const Profile& p, const AnalysisOptions& o = {});

/// The report `red analyze` prints.
std::string analysis_text(const Analysis& a);

/// analysis.json (schema 1; fields in docs/ANALYSIS.md).
std::string analysis_json(const Analysis& a);

/// The verdict table at the top of `red compare`'s index.html: one row per (phase,
/// operation) of the first analysis, one verdict column per analysis (one per policy, all
/// of the same scenario), then the first policy's reason.
HtmlTable verdict_html_table(const std::vector<Analysis>& per_policy);

}  // namespace red
