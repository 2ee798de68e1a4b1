#pragma once
/// \file
/// One simulated run of one policy, with its metrics: what `red simulate`, `red compare`,
/// `red sweep`, `red analyze`, the tests and the benchmarks share. It sits above both the
/// simulator and the metrics it collects (docs/ARCHITECTURE.md, "Layers").

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
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

/// Simulates `policy` (a preset name) on the scenario, with the options policy_options() gives
/// it. `extra` observers see the run too; `sync` overrides the preset's synchronization mode;
/// `costs`, when given, is the profile whose unit costs the simulator draws while the scheduler
/// plans with `p` (SimOptions). Error for an unknown policy name.
Expected<PolicyRun> simulate_policy(const Scenario& s, const Profile& p, const std::string& policy,
                                    std::uint64_t seed, const std::vector<Observer*>& extra = {},
                                    bool keep_units = true,
                                    std::optional<SyncMode> sync = std::nullopt,
                                    const Profile* costs = nullptr);

}  // namespace red
