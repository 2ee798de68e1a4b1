#pragma once
/// \file
/// Reading scenario files (docs/SCENARIOS.md): YAML text in, a completely validated Scenario out.
/// Every problem comes back as an Error naming the file, the 1-based line and what is
/// wrong; nothing throws and no half-built scenario is ever returned. The scheduler section's
/// policy options are kept as the file writes them: check them with red::check_policy_options
/// (red/sched/policy.hpp) after loading, as the CLI does.
///
///     Expected<Scenario> s = load_scenario("scenarios/minibench-tight.yaml");
///     if (!s) { std::cerr << s.error().to_string() << '\n'; return 2; }
///     if (auto e = apply_override(*s, "deadline_scale", 1.2)) { ... }

#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// Loads and validates a scenario file. Errors: Error{file, line, message}; a file that
/// cannot be read gives "cannot open" with line 0.
Expected<Scenario> load_scenario(const std::string& path);

/// Same from text; `file` labels messages and anchors relative paths (profile:, model
/// manifest:). An empty `file` leaves relative paths as written.
Expected<Scenario> parse_scenario(const std::string& yaml_text, const std::string& file);

/// The keys of a scenario's `scheduler:` section that the scenario itself reads (gamma_ms,
/// estimate, level_cost, max_batch, qoe_lambda, online_costs). Every other key is kept as the
/// file writes it (SchedulerSpec::policy_options) for the policy layer to read and check
/// (red::check_policy_options in red/sched/policy.hpp).
const std::vector<std::string>& scheduler_keys();

/// Applies one `key=value` override (`red sweep --set`, the CLI). Keys:
/// * `deadline_scale` (> 0): multiplies every fixed deadline (end-to-end and per-node
///   overrides) and every critical_path_x, in the initial snapshots and inside events;
/// * `qoe_lambda` (> 0), `gamma_ms` (>= 0), `lanes` (integer >= 1);
/// * `rate_scale` (> 0): multiplies every sensor rate and every operation's own rate,
///   including set_rate events;
/// * `duration_s` (> 0, must stay after warmup; events at or after the new end are left out,
///   with a line in `warnings`); `seed` (integer >= 0).
/// Returns an error naming the key on an unknown key or a bad value; `s` is then
/// unchanged (an override never half-applies). What the override changed besides the key
/// (events left out) is appended to `warnings` when given.
std::optional<Error> apply_override(Scenario& s, const std::string& key, double value,
                                    std::vector<std::string>* warnings = nullptr);

}  // namespace red
