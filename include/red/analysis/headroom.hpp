#pragma once
/// \file
/// Headroom searched, not guessed (`red analyze`, docs/ANALYSIS.md): by bisection in the
/// deterministic simulator, the largest `rate_scale` and the smallest `deadline_scale`
/// (the `red sweep` overrides, apply_override) at which a policy keeps every operation's
/// miss rate within a limit, and the first operation to fail as the load grows.

#include <cstdint>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// Knobs of the search.
struct HeadroomOptions {
  /// An operation fails above this miss rate (docs/DESIGN.md, "Metrics").
  double miss_limit = 0.01;
  double max_rate_scale = 16.0;          ///< the rate search stops (passing) here
  double min_rate_scale = 1.0 / 64;      ///< the rate search stops (failing) here
  double max_deadline_scale = 16.0;      ///< the deadline search stops (failing) here
  double min_deadline_scale = 1.0 / 64;  ///< the deadline search stops (passing) here
  double tolerance = 0.01;               ///< bisection ends when fail / pass is within 1 + this
};

/// One simulated trial: every operation's miss rate at one setting.
struct Trial {
  double scale = 0;
  bool pass = false;
  std::vector<double> miss;  ///< by operation index (0 for an operation with no jobs)
};

/// The outcome of one bisection.
struct ScaleSearch {
  /// Rate: the largest scale that passed. Deadline: the smallest scale that passed. 0 when
  /// none passed within the search range.
  double pass = 0;
  /// The neighbouring scale that failed (rate: pass < fail; deadline: fail < pass), or 0
  /// when every scale tried passed (the range's end is then `pass`).
  double fail = 0;
  /// The operation with the highest miss rate at `fail` (the first to fail), or empty.
  std::string first_to_fail;
  double first_miss = 0;  ///< its miss rate at `fail`
};

/// The headroom of one policy on one set of costs.
struct Headroom {
  std::string policy;
  std::string costs;  ///< "profiled" or "worst-case"
  ScaleSearch rate;
  ScaleSearch deadline;
  int simulations = 0;
  double wall_s = 0;  ///< host time of the search (not a test figure)
};

/// Per-operation miss rates of `policy` on `s` (seed: the scenario's); Error for an unknown
/// policy. A miss is a job finished late or dropped, over completed + dropped (docs/DESIGN.md,
/// "Metrics").
Expected<Trial> run_trial(const Scenario& s, const Profile& p, const std::string& policy,
                          double miss_limit);

/// Searches the headroom of `policy` on `s` with profile `p`. With `worst_case`, both are
/// first turned into their worst-case variants (worst_case_scenario, worst_case_profile).
Expected<Headroom> search_headroom(const Scenario& s, const Profile& p, const std::string& policy,
                                   bool worst_case, const HeadroomOptions& o = {});

}  // namespace red
