#pragma once
/// \file
/// Calibration (docs/FIDELITY.md): from the units of real runs of a scenario, the costs a
/// real run really sees and how they depart from costs measured one unit at a time — the
/// per-unit distributions inside the run, slow and fast stretches of the machine (a time
/// factor), the slowdown when other lanes compute at once (a lane factor) and the hand-off
/// between units. The simulator replays them (CostSampler, Simulator).

#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The units one real run of one policy executed.
struct CalibrationRun {
  std::string policy;
  std::vector<UnitRow> units;
  /// Hand-offs the runtime timed (unit completion -> next start on the lane, μs), and
  /// whether they were round trips through the global synchronizer (per-edge sync) or local
  /// decisions (on-demand).
  std::vector<double> handoff_us;
  bool round_trips = false;
  /// Completion -> start of the unit already queued behind it (asynchronous lanes, μs).
  std::vector<double> queued_gap_us;
};

/// How the fit cuts the data.
struct CalibrationOptions {
  Duration block{std::chrono::milliseconds{500}};  ///< time-factor block
  int run_blocks = 8;  ///< replayed stretch, in blocks (the slow spells measured last seconds)
  /// Residual quantiles at u = 0, 0.005, ..., 1. The simulator draws between neighbouring
  /// quantiles, so the last step spreads its share of the draws up to the slowest unit seen:
  /// with 21 points a single outlier among hundreds of units made 5 % of the draws slow
  /// (docs/FIDELITY.md).
  int table_points = 201;
  int min_samples = 5;  ///< fewer completed runs of a unit: it keeps its isolated figures
  double seconds_per_policy = 0.0;  ///< recorded in the profile
};

/// The profile name of a unit row: `encoder`, `head/<h>`, `coarse/<h>` or `mono/<operation>`;
/// empty for plain nodes (their cost comes from the scenario).
std::string calibration_unit_name(const UnitRow& row, const Scenario& s);

/// The isolated profile with what the runs measured: each unit seen often enough gets its
/// in-run statistics (batch sizes not seen are scaled by the unit's in-run / isolated ratio),
/// the round trip and hand-off become the measured ones, and Profile::calibration holds the
/// simulator's model. Error when the runs hold too few completed units to fit anything.
Expected<Profile> calibrate_profile(const Profile& isolated, const Scenario& s,
                                    const std::vector<CalibrationRun>& runs,
                                    const CalibrationOptions& options = {});

/// One line per unit: isolated mean, in-run mean and p99, their ratio, samples — how the real
/// run departs from the isolated profile (printed by `red profile --calibrate`).
std::string calibration_table(const Profile& isolated, const Profile& calibrated);

}  // namespace red
