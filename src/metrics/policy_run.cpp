#include "red/metrics/policy_run.hpp"

#include <chrono>
#include <utility>

#include "red/core/stop.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sim/run.hpp"

namespace red {

Expected<PolicyRun> simulate_policy(const Scenario& s, const Profile& p, const std::string& policy,
                                    std::uint64_t seed, const std::vector<Observer*>& extra,
                                    bool keep_units, std::optional<SyncMode> sync,
                                    const Profile* costs) {
  // A scenario loaded by a library caller may not have had its policy options checked.
  if (auto e = check_policy_options(s)) return *e;
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

}  // namespace red
