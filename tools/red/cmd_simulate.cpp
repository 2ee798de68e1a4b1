/// \file
/// `red simulate` and `red compare --backend sim`.

#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "red/core/clock.hpp"

#include "commands.hpp"
#include "common.hpp"
#include "red/report/report.hpp"

namespace red::cli {

namespace {

struct RunArgs {
  ScenarioArgs scenario;
  std::string policy = "red";
  std::string policies;
  std::string backend = "sim";
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
  std::size_t trace_events = kDefaultTraceEvents;
};

// Runs the given policies on one scenario (common random numbers: same seed, §10) and
// prints and writes the results. Returns the exit code.
int run_policies(const RunArgs& a, const std::vector<std::string>& names, bool table) {
  auto s = load(a.scenario);
  if (!s) {
    print_error(s.error());
    return kBadInput;
  }
  auto p = resolve_profile(*s, a.scenario.profile);
  if (!p) {
    print_error(p.error());
    return kBadInput;
  }
  for (const std::string& n : names) {
    if (!make_policy(n)) {
      std::string known;
      for (const std::string& k : known_policies()) known += (known.empty() ? "" : ", ") + k;
      print_error(Error{"", 0, "unknown policy '" + n + "' (known: " + known + ")"});
      return kBadInput;
    }
  }
  const std::uint64_t seed = a.seed ? *a.seed : s->seed;
  std::vector<PolicyRun> runs;
  // Observers beside the metrics: the timeline (only when it will be written) and the
  // progress line (only on a terminal, only for runs longer than a few seconds).
  std::vector<std::unique_ptr<TraceObserver>> traces;
  const SteadyClock clock;
  ProgressReporter progress(clock, std::cerr, ProgressReporter::stderr_is_terminal());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& n = names[i];
    traces.push_back(a.out ? make_trace(*s, a.trace_events, names.size()) : nullptr);
    std::vector<Observer*> extra{&progress};
    if (traces.back()) extra.push_back(traces.back().get());
    progress.begin_run(names.size() == 1 ? n : fmt::format("{} [{}/{}]", n, i + 1, names.size()),
                       s->duration);
    auto r = simulate_policy(*s, *p, n, seed, extra, a.out.has_value());
    progress.finish();
    if (!r) {
      print_error(r.error());
      return kBadInput;
    }
    std::cerr << fmt::format(
        "red: simulated {} on {} in {:.3f} s ({:.2f} M unit events/s)\n", n, s->name, r->wall_s,
        static_cast<double>(r->result.unit_events) / std::max(r->wall_s, 1e-9) / 1e6);
    if (traces.back() && traces.back()->truncated())
      std::cerr << fmt::format(
          "red: trace of {} stops at {:.3f} s (limit of {} events; see --trace-events)\n", n,
          to_s(traces.back()->truncated_at()), traces.back()->events());
    runs.push_back(std::move(r.value()));
  }
  std::vector<PolicyMetrics> metrics;
  for (const PolicyRun& r : runs) metrics.push_back(r.metrics);
  apply_ratios(metrics, "edf");
  fmt::print("scenario {} (backend sim, seed {}, profile {}, {} lane(s), {:g} s measured)\n",
             s->name, seed, p->source, s->device.lanes, metrics.front().measured_s);
  fmt::print("{}", comparison_table(metrics, "edf"));
  if (!table) {
    const PolicyMetrics& m = metrics.front();
    fmt::print(
        "completed {}, met {}, missed {} (dropped {}, skipped {}, failed {}), unfinished {}\n",
        m.completed, m.completed - (m.missed - m.dropped), m.missed, m.dropped, m.skipped, m.failed,
        m.unfinished);
    fmt::print("latency ms: mean {:.2f}, p50 {:.2f}, p90 {:.2f}, p99 {:.2f}, max {:.2f}\n",
               m.latency.mean, m.latency.p50, m.latency.p90, m.latency.p99, m.latency.max);
    fmt::print("encoder runs {} (saved {}), dispatches {}, sync round trips {}, merge waits {}\n",
               m.encoder_runs, m.encoder_runs_saved, m.dispatches, m.sync_round_trips,
               m.merge_waits);
    std::string util;
    for (double u : m.lane_utilization) util += fmt::format(" {:.1f}%", 100 * u);
    fmt::print("lane utilization:{}; frame age mean {:.2f} ms\n", util, m.frame_age_mean_ms);
  }
  if (a.out) {
    OutputOptions o;
    for (const auto& t : traces) o.traces.push_back(t.get());
    o.index_html = table;  // red compare
    OutputReport written;
    if (auto e = write_outputs(*a.out, *s, *p, "sim", seed, runs, o, &written)) {
      print_error(*e);
      return kRunFailure;
    }
    fmt::print("{}\n", wrote_message(*a.out, written));
  }
  return kOk;
}

void add_common(CLI::App* cmd, RunArgs& a) {
  cmd->add_option("scenario", a.scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--profile", a.scenario.profile,
                  "Profile JSON (default: the scenario's, else built-in)");
  cmd->add_option("--set", a.scenario.sets,
                  "Override key=value (deadline_scale, rate_scale, qoe_lambda, ...)");
  cmd->add_option("--seed", a.seed, "Random seed (default: the scenario's)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--out", a.out,
                  "Directory for summary.json, jobs.csv, units.csv, trace.json and plots");
  cmd->add_option("--trace-events", a.trace_events,
                  "Most events in trace.json, over all policies (0: no trace.json)")
      ->capture_default_str();
}

}  // namespace

void register_simulate(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("simulate", "Discrete-event simulation of one policy");
  add_common(cmd, *a);
  cmd->add_option("--policy", a->policy,
                  "Policy preset: fifo, mono, edf, red-fg, red-ida, red, lst");
  cmd->callback([a, &exit_code] { exit_code = run_policies(*a, {a->policy}, false); });
}

void register_compare(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd =
      app.add_subcommand("compare", "Every policy on the identical workload, side by side");
  add_common(cmd, *a);
  cmd->add_option("--policies", a->policies,
                  "Comma-separated presets (default: fifo,mono,edf,red-fg,red-ida,red)");
  cmd->add_option("--backend", a->backend, "sim (simulator) or torch (real LibTorch inference)")
      ->check(CLI::IsMember({"sim", "torch"}));
  cmd->callback([a, &exit_code] {
    const auto names = a->policies.empty() ? default_presets() : split_list(a->policies);
    if (names.empty()) {
      print_error(Error{"", 0, "--policies: empty list"});
      exit_code = kBadInput;
      return;
    }
    if (a->backend == "torch") {
      print_error(Error{
          "", 0, "--backend torch: the real-time LibTorch runtime is not part of this build yet"});
      exit_code = kRunFailure;
      return;
    }
    exit_code = run_policies(*a, names, true);
  });
}

}  // namespace red::cli
