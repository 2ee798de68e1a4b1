#pragma once
/// \file
/// Each real run checks the prediction it was given (docs/FIDELITY.md, "The check at the end of
/// a run"): how far the simulator's prediction made with the run's profile (ahead) and the one
/// fed the costs the run's own units met lie from the real figures, in points of miss rate and
/// percent of mean latency; how the units' in-run costs stood against the profile's; and, with
/// `--write-profile`, the run's own costs written as the next calibrated profile.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "real_run.hpp"
#include "red/core/expected.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/report/html.hpp"
#include "red/scenario/scenario.hpp"

namespace red::cli {

/// The fidelity target a prediction is held to: miss rate within 5 points and mean latency
/// within 10 % of the real run's.
inline constexpr double kMissTargetPts = 5.0;
inline constexpr double kMeanTargetPct = 10.0;

/// A prediction against the real run: simulated minus real, in points of miss rate and in
/// percent of the real mean latency (nullopt where the run or the prediction completed no job
/// to average).
struct PredictionGap {
  double miss_pts = 0.0;
  std::optional<double> mean_pct;
  bool within = true;  ///< both within the target
};

PredictionGap prediction_gap(double real_miss_pct, double real_mean_ms, double sim_miss_pct,
                             double sim_mean_ms);

/// One policy's two predictions against its run (own: nullopt where none was made).
struct PredictionCheck {
  std::string policy;
  PredictionGap ahead;
  std::optional<PredictionGap> own;
  /// The policy's units against the profile (cost_drift of its run; nullopt: no model unit).
  std::optional<double> unit_ratio;
};

/// The run's units against the profile's means, weighted by the time the profile gives them
/// (sum of runs x in-run mean over sum of runs x profile mean): over every unit, and per kind
/// (encoder, heads, coarse, mono, separate). `runs` 0: the run completed no model unit.
struct CostDrift {
  double ratio = 0.0;
  int runs = 0;
  std::vector<std::pair<std::string, double>> kinds;  ///< kind, ratio (kinds run, in order)
};

CostDrift cost_drift(const std::vector<const PolicyMetrics*>& runs);

/// The printed check: a table of the gaps, the count within the target, the cost drift and
/// what the two together say. Appends its table to `html` and its figures to `doc`
/// (prediction.json: "check", and each policy row's "gap").
std::string prediction_check(const std::vector<PredictionCheck>& checks, const CostDrift& drift,
                             std::vector<HtmlTable>& html, nlohmann::ordered_json& doc);

/// The calibrated profile of the run's own costs (`--write-profile`): every policy's units
/// after the warm-up and the hand-offs the runtime timed, fitted on top of the run's profile as
/// `red profile --calibrate-from` does. Error when the runs completed too few units to fit.
Expected<Profile> run_profile(const Scenario& s, const Profile& p,
                              const std::vector<PolicyRun>& runs,
                              const std::vector<Handoffs>& handoffs, std::optional<SyncMode> sync);

}  // namespace red::cli
