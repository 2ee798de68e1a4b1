#include "red/sim/run.hpp"

#include "red/core/stop.hpp"

#include <chrono>

namespace red {

std::optional<PolicyOptions> policy_options(const Scenario& s, const std::string& policy,
                                            std::optional<SyncMode> sync) {
  auto o = preset_options(policy);
  if (!o) return std::nullopt;
  // Checked by check_policy_options (the CLI's load) and the CLI's --with; a bad entry would
  // leave the preset unchanged.
  (void)apply_options(*o, s.scheduler.policy_with);
  if (sync) o->sync = *sync;
  return o;
}

Expected<PolicyRun> simulate_policy(const Scenario& s, const Profile& p, const std::string& policy,
                                    std::uint64_t seed, const std::vector<Observer*>& extra,
                                    bool keep_units, std::optional<SyncMode> sync,
                                    const Profile* costs) {
  auto pol = make_policy(policy, policy_options(s, policy, sync));
  if (!pol) return Error{"", 0, unknown_policy_message(policy)};
  PolicyRun run;
  MetricsCollector metrics(s, s.scheduler.qoe_lambda, keep_units);
  SimOptions options;
  options.seed = seed;
  options.drain_limit = std::chrono::seconds{60};
  options.costs = costs;
  Simulator sim(s, p, std::move(pol), options);
  sim.add_observer(&metrics);
  for (Observer* o : extra) sim.add_observer(o);
  const auto t0 = std::chrono::steady_clock::now();
  run.result = sim.run();
  if (run.result.stopped) return Error{"", 0, kStoppedMessage};
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.metrics = metrics.summarize(policy, run.result.end);
  if (const OnlineCosts* oc = sim.scheduler().online_costs()) {
    run.metrics.online_costs = oc->options().follow;
    run.metrics.plan_changes = oc->changes();
    run.metrics.costs = oc->figures();
  }
  run.jobs = metrics.jobs();
  run.units = metrics.units();
  return run;
}

Expected<Profile> resolve_profile(const Scenario& s, const std::optional<std::string>& cli_path,
                                  std::vector<std::string>* warnings) {
  Profile p;
  if (cli_path) {
    auto loaded = load_profile(*cli_path);
    if (!loaded) return loaded.error();
    p = std::move(loaded.value());
  } else if (!s.profile.empty()) {
    auto loaded = load_profile(s.profile);
    if (!loaded) return loaded.error();
    p = std::move(loaded.value());
  } else if (!s.model.manifest.empty()) {
    // The built-in profile holds MIMONet's costs: a user's model simulated on them, or
    // scheduled by them in a real run (deadlines, estimates), would be another model's.
    return Error{s.file, s.model.manifest_line > 0 ? s.model.manifest_line : s.model.line,
                 "model.manifest: the model '" + s.model.manifest +
                     "' has no profile, and the built-in one holds MIMONet's costs, not "
                     "its own: measure one (red profile --model " +
                     s.model.manifest + " --out P.json) and give it (profile: P.json in the " +
                     "scenario, or --profile P.json)"};
  } else {
    p = default_profile();
  }
  const ProfileIdentity id = check_profile_identity(p, s, cli_path);
  if (id.error) return *id.error;
  if (!id.warning.empty() && warnings != nullptr) warnings->push_back(id.warning);
  if (auto err = check_profile_covers(p, s)) return *err;
  return p;
}

}  // namespace red
