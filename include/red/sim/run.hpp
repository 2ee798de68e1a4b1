#pragma once
/// \file
/// One simulated run of one policy, with metrics: what `red simulate`, `red compare`,
/// `red sweep`, the tests and the benchmarks share.

#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sim/simulator.hpp"

namespace red {

/// Everything one simulated run produced.
struct PolicyRun {
  PolicyMetrics metrics;
  std::vector<JobRow> jobs;
  std::vector<UnitRow> units;
  SimResult result;
  double wall_s = 0.0;  ///< host time the simulation took (not in summary.json)
};

/// Simulates `policy` (a preset name) on the scenario. `extra` observers see the run too;
/// `sync` overrides the preset's synchronization mode; `costs`, when given, is the profile
/// whose unit costs the simulator draws while the scheduler plans with `p` (SimOptions).
/// Error for an unknown policy name.
Expected<PolicyRun> simulate_policy(const Scenario& s, const Profile& p, const std::string& policy,
                                    std::uint64_t seed, const std::vector<Observer*>& extra = {},
                                    bool keep_units = true,
                                    std::optional<SyncMode> sync = std::nullopt,
                                    const Profile* costs = nullptr);

/// The options a preset runs with on this scenario: the preset's (docs/DESIGN.md, "Policies"), then
/// the scenario's `scheduler:` policy options (which include the CLI's --with), then `sync` if
/// given. nullopt for an unknown preset.
std::optional<PolicyOptions> policy_options(const Scenario& s, const std::string& policy,
                                            std::optional<SyncMode> sync = std::nullopt);

/// The profile a run uses: `cli_path` if given, else the scenario's `profile:`, else the
/// built-in default. Errors: a manifest model with neither (the built-in profile holds
/// MIMONet's costs; at the scenario's `manifest:` line), a profile of another model or
/// input size (check_profile_identity()), one that does not cover every head the scenario
/// uses. What could not be checked is appended to `warnings` when given.
Expected<Profile> resolve_profile(const Scenario& s, const std::optional<std::string>& cli_path,
                                  std::vector<std::string>* warnings = nullptr);

}  // namespace red
