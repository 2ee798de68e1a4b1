#pragma once
/// \file
/// What a run of a policy on a scenario is made of: the options a preset runs with there and the
/// profile it plans with. One simulated run with its metrics is simulate_policy
/// (red/metrics/policy_run.hpp); real runs (the CLI's drivers) use these too.

#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/policy.hpp"

namespace red {

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
