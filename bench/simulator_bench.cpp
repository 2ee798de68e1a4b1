/// \file
/// Simulator speed (docs/DESIGN.md, "Performance targets": ≥ 2 million unit events per second on
/// one core; one simulated hour of a four-head 30 Hz robot in under 2 s).
///
/// Both run red::simulate_policy exactly as `red simulate` does without --out
/// (keep_units = false: job rows and metrics are kept, per-unit rows are not), so the
/// figures include the metrics observer.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red::bench {

namespace {

/// One camera at 30 Hz; one operation: lane, seg and det feed steer (a four-head robot).
std::string robot4_yaml(int duration_s) {
  return "name: robot4-30hz\n"
         "duration_s: " +
         std::to_string(duration_s) +
         "\n"
         "warmup_s: 1\n"
         "seed: 1\n"
         "device: {lanes: 1}\n"
         "model: {builtin: mimonet, heads: [lane, seg, steer, det]}\n"
         "sensors:\n"
         "  camera: {rate_hz: 30}\n"
         "operations:\n"
         "  - name: drive\n"
         "    trigger: camera\n"
         "    deadline_ms: 50\n"
         "    nodes:\n"
         "      L: {head: lane, sensor: camera}\n"
         "      S: {head: seg, sensor: camera}\n"
         "      O: {head: det, sensor: camera}\n"
         "      C: {head: steer, sensor: camera}\n"
         "    edges: [[L, C], [S, C], [O, C]]\n";
}

/// The project's scenarios/ directory: $RED_SCENARIOS, else the source tree's (RED_SOURCE_DIR:
/// not __FILE__, which a compiler cache with a base directory makes relative).
std::filesystem::path scenarios_dir() {
  if (const char* env = std::getenv("RED_SCENARIOS")) return env;
  return std::filesystem::path(RED_SOURCE_DIR) / "scenarios";
}

[[noreturn]] void die(const Error& e) {
  std::fprintf(stderr, "red_bench: %s\n", e.to_string().c_str());
  std::abort();
}

/// Scenarios by name, loaded once: "minibench-tight" (from scenarios/), "robot4" (60 s),
/// "robot4-hour" (3600 s).
const Scenario& scenario(const std::string& name) {
  static std::map<std::string, Scenario> cache;
  if (auto it = cache.find(name); it != cache.end()) return it->second;
  Expected<Scenario> s = name == "robot4" ? parse_scenario(robot4_yaml(60), "robot4.yaml")
                         : name == "robot4-hour"
                             ? parse_scenario(robot4_yaml(3600), "robot4.yaml")
                             : load_scenario(scenarios_dir() / (name + ".yaml"));
  if (!s) die(s.error());
  return cache.emplace(name, std::move(s.value())).first->second;
}

const Profile& profile_for(const Scenario& s) {
  static std::map<const Scenario*, Profile> cache;
  if (auto it = cache.find(&s); it != cache.end()) return it->second;
  auto p = resolve_profile(s, std::nullopt);
  if (!p) die(p.error());
  return cache.emplace(&s, std::move(p.value())).first->second;
}

PolicyRun run_once(const Scenario& s, const Profile& p, const std::string& policy) {
  auto r = simulate_policy(s, p, policy, s.seed, {}, /*keep_units=*/false);
  if (!r) die(r.error());
  return std::move(r.value());
}

void BM_SimulatorEventsPerSecond(benchmark::State& state, const char* scenario_name,
                                 const char* policy) {
  const Scenario& s = scenario(scenario_name);
  const Profile& p = profile_for(s);
  double unit_events = 0;
  double per_run = 0;
  double wall = 0;
  for (auto _ : state) {
    PolicyRun r = run_once(s, p, policy);
    per_run = static_cast<double>(r.result.unit_events);
    unit_events += per_run;
    wall += r.wall_s;
    benchmark::DoNotOptimize(r);
  }
  // Per second of this thread's CPU time (what one core does), and per second of wall
  // time inside the simulator (lower when other processes share the core).
  state.counters["unit_events_per_s"] =
      benchmark::Counter(unit_events, benchmark::Counter::kIsRate);
  state.counters["per_wall_s"] = wall > 0 ? unit_events / wall : 0.0;
  state.counters["unit_events"] = per_run;
}

void BM_SimulatedHour(benchmark::State& state, const char* policy) {
  const Scenario& s = scenario("robot4-hour");
  const Profile& p = profile_for(s);
  double wall = 0, unit_events = 0, jobs = 0, miss_rate = 0;
  for (auto _ : state) {
    PolicyRun r = run_once(s, p, policy);
    wall += r.wall_s;
    unit_events = static_cast<double>(r.result.unit_events);
    jobs = static_cast<double>(r.metrics.jobs);
    miss_rate = r.metrics.miss_rate;
    benchmark::DoNotOptimize(r);
  }
  // Wall time inside the simulator; the CPU column is what one unshared core needs.
  state.counters["wall_s"] = wall / static_cast<double>(state.iterations());
  state.counters["unit_events"] = unit_events;
  state.counters["jobs"] = jobs;
  state.counters["miss_rate"] = miss_rate;
}

}  // namespace

BENCHMARK_CAPTURE(BM_SimulatorEventsPerSecond, minibench_tight_red, "minibench-tight", "red")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulatorEventsPerSecond, minibench_tight_edf, "minibench-tight", "edf")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulatorEventsPerSecond, robot4_red, "robot4", "red")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulatorEventsPerSecond, robot4_edf, "robot4", "edf")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SimulatedHour, red, "red")->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace red::bench
