/// \file
/// `red run S.yaml [--policy P] [--out DIR]`: real execution (§6, §12).

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

#include "commands.hpp"
#include "common.hpp"
#include "real_run.hpp"
#include "red/report/report.hpp"
#include "red/runtime/synthetic_backend.hpp"

#ifdef RED_HAVE_TORCH
#include "red/torch/torch_backend.hpp"
#endif

namespace red::cli {

Expected<std::unique_ptr<Backend>> make_backend(const Scenario& s, const Profile& p,
                                                const RealRunOptions& o) {
  if (o.backend == "synthetic") {
    SyntheticBackend::Options so;
    so.spin = true;  // occupy the lane's core like real compute does
    return std::unique_ptr<Backend>(std::make_unique<SyntheticBackend>(s, p, o.seed, so));
  }
  if (o.backend == "torch") {
#ifdef RED_HAVE_TORCH
    return torchb::make_torch_backend(s, o.device, o.threads);
#else
    return Error{"", 0,
                 "this red was built without LibTorch (install libtorch-dev and rebuild), "
                 "or use --backend synthetic"};
#endif
  }
  return Error{"", 0, "unknown backend '" + o.backend + "' (known: torch, synthetic)"};
}

namespace {

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, rank == 0 ? 0 : rank - 1)];
}

}  // namespace

Expected<PolicyRun> run_real(const Scenario& s, const Profile& p, const std::string& policy,
                             Backend& backend, const RealRunOptions& o, RuntimeReport* out) {
  auto pol = make_policy(policy);
  if (!pol) return Error{"", 0, "unknown policy '" + policy + "'"};
  RuntimeOptions ro;
  ro.realtime = o.realtime;
  Runtime rt(s, p, std::move(pol), backend, ro);
  MetricsCollector metrics(s, s.scheduler.qoe_lambda, true);
  rt.add_observer(&metrics);
  const auto t0 = std::chrono::steady_clock::now();
  RuntimeReport report = rt.run();
  PolicyRun run;
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.metrics = metrics.summarize(policy, report.end, report.stats);
  run.metrics.decision_p50_us = std::round(pct(report.decision_us, 0.5) * 1000) / 1000;
  run.metrics.decision_p99_us = std::round(pct(report.decision_us, 0.99) * 1000) / 1000;
  run.jobs = metrics.jobs();
  run.units = metrics.units();
  run.result.end = report.end;
  run.result.stats = report.stats;
  if (out != nullptr) *out = report;
  return run;
}

void print_runtime_report(const std::string& policy, const RuntimeReport& r) {
  std::cerr << fmt::format(
      "red: {}: decisions {} (p50 {:.2f} us, p99 {:.2f} us), completion->next start p99 {:.2f} us "
      "({} handoffs), sync round trips {}, local decisions {}, failures {}, RSS {:.1f} MB\n",
      policy, r.decision_us.size(), pct(r.decision_us, 0.5), pct(r.decision_us, 0.99),
      pct(r.handoff_us, 0.99), r.handoff_us.size(), r.stats.round_trips, r.local_decisions,
      r.failures, static_cast<double>(r.resident_bytes_after) / 1e6);
  for (const std::string& line : r.realtime) std::cerr << "red:   " << line << '\n';
}

void register_run(CLI::App& app, int& exit_code) {
  struct Args {
    ScenarioArgs scenario;
    std::string policy = "red";
    RealRunOptions real;
    bool no_realtime = false;
    std::optional<std::uint64_t> seed;
    std::optional<std::string> out;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("run", "Real execution on the LibTorch backend (real time)");
  cmd->add_option("scenario", a->scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--policy", a->policy,
                  "Policy preset: fifo, mono, edf, red-fg, red-ida, red, lst");
  cmd->add_option("--profile", a->scenario.profile,
                  "Profile JSON (from `red profile`; default: the scenario's, else built-in)");
  cmd->add_option("--set", a->scenario.sets, "Override key=value");
  cmd->add_option("--backend", a->real.backend,
                  "torch (real inference) or synthetic (spends profiled times)")
      ->check(CLI::IsMember({"torch", "synthetic"}));
  cmd->add_option("--device", a->real.device, "LibTorch device: cpu, cuda, cuda:N");
  cmd->add_option("--threads", a->real.threads, "LibTorch intra-op threads (0: default)");
  cmd->add_flag("--no-realtime", a->no_realtime, "Do not try SCHED_FIFO, CPU affinity, mlockall");
  cmd->add_option("--seed", a->seed, "Seed for synthetic frames and costs")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--out", a->out, "Directory for summary.json, jobs.csv, units.csv");
  cmd->callback([a, &exit_code] {
    auto s = load(a->scenario);
    if (!s) {
      print_error(s.error());
      exit_code = kBadInput;
      return;
    }
    auto p = resolve_profile(*s, a->scenario.profile);
    if (!p) {
      print_error(p.error());
      exit_code = kBadInput;
      return;
    }
    if (!make_policy(a->policy)) {
      print_error(Error{"", 0, "unknown policy '" + a->policy + "'"});
      exit_code = kBadInput;
      return;
    }
    a->real.realtime = !a->no_realtime;
    a->real.seed = a->seed ? *a->seed : s->seed;
    auto backend = make_backend(*s, *p, a->real);
    if (!backend) {
      print_error(backend.error());
      exit_code = kBadInput;
      return;
    }
    RuntimeReport report;
    auto run = run_real(*s, *p, a->policy, **backend, a->real, &report);
    if (!run) {
      print_error(run.error());
      exit_code = kRunFailure;
      return;
    }
    print_runtime_report(a->policy, report);
    std::vector<PolicyRun> runs;
    runs.push_back(std::move(run.value()));
    std::vector<PolicyMetrics> m{runs.front().metrics};
    fmt::print("scenario {} (backend {}, {} lane(s), {:g} s measured)\n", s->name, a->real.backend,
               s->device.lanes, m.front().measured_s);
    fmt::print("{}", comparison_table(m, "edf"));
    if (a->out) {
      if (auto e = write_outputs(*a->out, *s, *p, a->real.backend, a->real.seed, runs)) {
        print_error(*e);
        exit_code = kRunFailure;
        return;
      }
      fmt::print("wrote {}/summary.json, jobs.csv, units.csv\n", *a->out);
    }
    exit_code = kOk;
  });
}

}  // namespace red::cli
