/// \file
/// Real runs: backends by name, one policy on the runtime, its report (docs/DESIGN.md,
/// "Synchronization", docs/CLI.md).

#include <fmt/format.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <optional>
#include <thread>
#include <utility>

#include "commands.hpp"
#include "common.hpp"
#include "real_run.hpp"
#include "red/report/report.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "signals.hpp"

#ifdef RED_HAVE_TORCH
#include "red/torch/model.hpp"
#include "red/torch/torch_backend.hpp"
#endif

namespace red::cli {

void add_device_options(CLI::App* cmd, RealRunOptions& o) {
  cmd->add_option("--device", o.device,
                  "Where the torch backend runs: cpu, cuda or cuda:N (no fallback: a device "
                  "that is not there is an error)")
      ->capture_default_str();
  cmd->add_option("--threads", o.threads,
                  "LibTorch intra-op threads per lane (0: the hardware threads shared among "
                  "the lanes)")
      ->check(whole_number(1024));
  cmd->add_flag("--debug-sync", o.debug_sync,
                "LibTorch warns on stderr at every operation that makes the host wait for the "
                "GPU (its CUDA sync debug mode, torch.cuda.set_sync_debug_mode('warn')), so that "
                "a hidden synchronization in a lane's path is named; nothing on the CPU");
  cmd->add_flag("--async", o.asynchronous,
                "Run each lane asynchronously on the CPU too: units are enqueued on a lane's "
                "worker and waited for, and an on-demand policy queues the next unit while "
                "one runs (device.queue_depth; always so on a GPU; docs/GPU.md)");
}

std::optional<Error> check_device(const RealRunOptions& o) {
  if (o.debug_sync && o.backend != "torch")
    return Error{"", 0,
                 "--debug-sync: the " + o.backend +
                     " backend has no device to synchronize with; --debug-sync is for "
                     "--backend torch"};
  if (o.device == "cpu") return std::nullopt;
  if (o.backend != "torch")
    return Error{"", 0,
                 "--device " + o.device + ": the " + o.backend +
                     " backend has no device (it runs on the CPU); --device is for --backend "
                     "torch"};
#ifdef RED_HAVE_TORCH
  if (auto d = torchb::parse_device(o.device); !d) return d.error();
  return std::nullopt;
#else
  return Error{"", 0,
               "--device " + o.device +
                   ": this red was built without LibTorch (install libtorch-dev, or build "
                   "against a CUDA LibTorch: docs/GPU.md)"};
#endif
}

std::string profile_device(const Profile& p) {
  if (p.source != "measured") return {};
  return p.device.substr(0, p.device.find(' '));
}

std::optional<std::string> measured_elsewhere(const Profile& p, const std::string& device) {
  const std::string measured_on = profile_device(p);
  const auto kind = [](const std::string& d) { return d.substr(0, d.find(':')); };
  if (measured_on.empty() || kind(measured_on) == kind(device)) return std::nullopt;
  return measured_on;
}

std::optional<std::string> profile_origin_note(const Scenario& s, const Profile& p,
                                               const RealRunOptions& o) {
  if (o.backend != "torch") return std::nullopt;  // the synthetic backend runs the profile
  std::string why;
  const std::string here = this_host();
  if (p.source == "builtin-default") {
    why = "the built-in profile holds costs of no particular machine";
  } else if (!p.quality || !p.quality->has_machine || p.quality->machine.host.empty()) {
    why = "the profile does not say which machine it was measured on";
  } else if (p.quality->machine.host != here) {
    why = "the profile was measured on " + p.quality->machine.host + ", this is " + here;
  } else if (const auto elsewhere = measured_elsewhere(p, o.device)) {
    why = "the profile was measured on " + *elsewhere + ", this run is on " + o.device;
  }
  if (why.empty()) return std::nullopt;
  std::string model;
  if (!s.model.manifest.empty()) {
    model = " --model " + s.model.manifest;
  } else if (!s.model.input.empty()) {
    model = " --input ";
    for (std::size_t i = 0; i < s.model.input.size(); ++i)
      model += (i > 0 ? "," : "") + std::to_string(s.model.input[i]);
  }
  return why +
         ": its costs may not be this run's (online estimates correct them as the run goes, "
         "docs/DESIGN.md#online-costs, but the first second plans on them). Measure them: red "
         "profile" +
         model + " --device " + o.device +
         " --out profile.json, then run with --profile profile.json";
}

std::optional<std::string> costs_differed(const PolicyMetrics& m, const std::string& label) {
  std::string parts;
  double worst = 1.0;
  for (const UnitCostFigures& f : m.costs) {
    if (f.runs < 10) continue;
    const double r = f.ratio();
    if (r <= 0.0 || std::abs(r - 1.0) <= 0.3) continue;
    if (std::abs(r - 1.0) > std::abs(worst - 1.0)) worst = r;
    if (!parts.empty()) parts += ", ";
    parts += fmt::format("{} batch {}: {:.2f}x ({} runs)", f.unit, f.batch, r, f.runs);
  }
  if (parts.empty()) return std::nullopt;
  return fmt::format(
      "policy {}: in this run units cost up to {:.2f}x the profile's mean ({}){}; summary.json's "
      "costs has every unit. The profile is not this run's machine or load: red profile --from "
      "PROFILE --calibrate SCENARIO --out calibrated.json measures it in a run",
      label, worst, parts,
      m.online_costs ? fmt::format(", the plan followed ({} change(s))", m.plan_changes)
                     : " and the plan stayed on the profile (scheduler.online_costs: false)");
}

Expected<std::unique_ptr<Backend>> make_backend(const Scenario& s, const Profile& p,
                                                const RealRunOptions& o) {
  if (auto e = check_device(o)) return *e;
  // A profile of another kind of device (a CPU profile for a GPU run, or the reverse) puts
  // the scheduler's estimates and the watchdog's limits off by a device's factor.
  const auto measured_on = measured_elsewhere(p, o.device);
  if (o.backend == "torch" && measured_on)
    std::cerr << "red: warning: the profile was measured on " << *measured_on << ", this run is on "
              << o.device << ": its unit costs are another device's (red profile --device "
              << o.device << ")\n";
  if (o.backend == "synthetic") {
    SyntheticBackend::Options so;
    so.spin = true;  // occupy the lane's core like real compute does
    so.asynchronous = o.asynchronous;
    return std::unique_ptr<Backend>(std::make_unique<SyntheticBackend>(s, p, o.seed, so));
  }
  if (o.backend == "torch") {
#ifdef RED_HAVE_TORCH
    // Every hardware thread shared among the lanes (one lane: all of them, as `red profile`
    // measures), so lanes running side by side do not oversubscribe the cores.
    const int hw = static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
    const int threads = o.threads > 0 ? o.threads : std::max(1, hw / std::max(1, s.device.lanes));
    if (o.debug_sync) std::cerr << "red: " << torchb::warn_on_device_sync() << '\n';
    return torchb::make_torch_backend(s, o.device, threads, o.asynchronous);
#else
    return Error{"", 0,
                 "this red was built without LibTorch (install libtorch-dev and rebuild), "
                 "or use --backend synthetic"};
#endif
  }
  return Error{"", 0, "unknown backend '" + o.backend + "' (known: torch, synthetic)"};
}

void use_one_malloc_arena() noexcept {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (std::getenv("MALLOC_ARENA_MAX") != nullptr ||
      (tunables != nullptr && std::strstr(tunables, "arena_max") != nullptr))
    return;
  (void)mallopt(M_ARENA_MAX, 1);
}

namespace {

// Says once, on stderr, that the measured part of a run has begun (the first job released
// after the warm-up): from here a stop signal leaves jobs in flight, reported unfinished.
class MeasuringNotice final : public Observer {
 public:
  explicit MeasuringNotice(std::string policy) : policy_(std::move(policy)) {}
  void on_job_release(const JobRecord& j) override {
    if (said_ || !j.counted) return;
    said_ = true;
    std::cerr << "red: policy " << policy_
              << ": warm-up over, measuring (SIGINT or SIGTERM ends the run early)\n";
  }

 private:
  std::string policy_;
  bool said_ = false;
};

double round_us_to_ms(double us) {
  return std::round(us) / 1000;
}

// The frames a run's sensors offered and released, and how late (RuntimeReport).
PolicyMetrics::Releases releases_of(const RuntimeReport& r) {
  PolicyMetrics::Releases out;
  out.offered = static_cast<std::int64_t>(r.frames_offered);
  out.released = static_cast<std::int64_t>(r.frames_released);
  out.behind = static_cast<std::int64_t>(r.frames_behind);
  std::vector<double> late = r.release_late_us;
  std::sort(late.begin(), late.end());
  out.late_p50_ms = round_us_to_ms(percentile_sorted(late, 0.5));
  out.late_p99_ms = round_us_to_ms(percentile_sorted(late, 0.99));
  out.late_max_ms = round_us_to_ms(percentile_sorted(late, 1.0));
  return out;
}

}  // namespace

Expected<PolicyRun> run_real(const Scenario& s, const Profile& p, const std::string& policy,
                             Backend& backend, const RealRunOptions& o,
                             const std::vector<Observer*>& extra, RuntimeReport* out) {
  auto pol = make_policy(policy, policy_options(s, policy, o.sync));
  if (!pol) return Error{"", 0, unknown_policy_message(policy)};
  RuntimeOptions ro;
  ro.realtime = o.realtime;
  ro.watchdog_x = o.watchdog_x;
  Runtime rt(s, p, std::move(pol), backend, ro);
  MetricsCollector metrics(s, s.scheduler.qoe_lambda, o.keep_units);
  metrics.set_keep_rows(o.keep_rows);
  metrics.set_sink(o.rows);
  rt.add_observer(&metrics);
  for (Observer* e : extra) rt.add_observer(e);
  MeasuringNotice notice(o.label.empty() ? policy : o.label);
  rt.add_observer(&notice);
  const auto t0 = std::chrono::steady_clock::now();
  // SIGINT/SIGTERM (when installed) end the run at once: jobs in flight are unfinished.
  std::optional<StopWatch> watch;
  watch.emplace([&rt] { rt.stop_now(); });
  RuntimeReport report = rt.run();
  watch.reset();
  // What the run kept in the backend goes, and the heap's free pages go back to the system
  // (glibc keeps them otherwise), so that policies run one after another do not add up.
  backend.end_run();
  malloc_trim(0);
  report.resident_bytes_released = resident_bytes();
  PolicyRun run;
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.metrics = metrics.summarize(policy, report.end);
  run.metrics.decision_p50_us = std::round(percentile(report.decision_us, 0.5) * 1000) / 1000;
  run.metrics.decision_p99_us = std::round(percentile(report.decision_us, 0.99) * 1000) / 1000;
  std::int64_t peak = 0;
  for (const RuntimeSample& x : report.samples) peak = std::max(peak, x.rss_bytes);
  if (peak > 0) run.metrics.peak_rss_mb = std::round(static_cast<double>(peak) / 1e5) / 10;
  run.metrics.releases = releases_of(report);
  run.metrics.online_costs = report.online_costs;  // followed (measured: costs non-empty)
  run.metrics.plan_changes = report.plan_changes;
  run.metrics.costs = report.costs;
  if (auto w = costs_differed(run.metrics, o.label.empty() ? policy : o.label))
    std::cerr << "red: " << *w << '\n';
  if (auto w = releases_warning(run.metrics)) std::cerr << "red: warning: " << *w << '\n';
  if (!report.device_lost.empty()) {
    // Every later unit would have failed the same way: the run stopped, and so does red.
    print_runtime_report(o.label.empty() ? policy : o.label, report);
    return Error{"", 0,
                 "policy " + (o.label.empty() ? policy : o.label) + ": " + report.device_lost +
                     "; the run stopped there (reported by lane " +
                     std::to_string(report.device_lost_lane) +
                     "; the faulting kernel may have been on any lane: run again with "
                     "CUDA_LAUNCH_BLOCKING=1 to place it, docs/GPU.md)"};
  }
  run.jobs = metrics.take_jobs();
  run.units = metrics.take_units();
  run.result.end = report.end;
  run.result.stats = report.stats;
  if (out != nullptr) *out = std::move(report);
  return run;
}

CalibrationRun calibration_run(const Scenario& s, const std::string& policy,
                               const std::vector<UnitRow>& units, std::vector<double> handoff_us,
                               std::optional<SyncMode> sync) {
  CalibrationRun run{policy, {}, std::move(handoff_us), false, {}};
  const auto opts = policy_options(s, policy, sync);
  run.round_trips = opts && opts->sync == SyncMode::PerEdge;
  for (const UnitRow& u : units)
    if (u.start >= TimePoint{s.warmup}) run.units.push_back(u);
  return run;
}

std::string samples_csv(const std::vector<std::string>& policies,
                        const std::vector<RuntimeReport>& reports) {
  std::string out = "policy,t_s,rss_mb,ready,in_flight\n";
  for (std::size_t i = 0; i < reports.size() && i < policies.size(); ++i)
    for (const RuntimeSample& x : reports[i].samples)
      out += fmt::format("{},{:.3f},{:.1f},{},{}\n", policies[i], to_s(x.t),
                         static_cast<double>(x.rss_bytes) / 1e6, x.ready, x.in_flight);
  return out;
}

void print_runtime_report(const std::string& policy, const RuntimeReport& r) {
  std::cerr << fmt::format(
      "red: policy {}: decisions {} (p50 {:.2f} us, p99 {:.2f} us), completion->next start p50 "
      "{:.2f} us, p99 {:.2f} us "
      "({} handoffs), sync round trips {}, local decisions {}, failures {} (timeouts {})\n",
      policy, r.decisions, percentile(r.decision_us, 0.5), percentile(r.decision_us, 0.99),
      percentile(r.handoff_us, 0.5), percentile(r.handoff_us, 0.99), r.handoffs,
      r.stats.round_trips, r.local_decisions, r.failures, r.timeouts);
  std::cerr << fmt::format(
      "red:   scheduler lock: {} local decision(s) waited for it (p99 {:.2f} us); {} frame(s) "
      "released by the thread that brought them; global synchronizer woke {} time(s)\n",
      r.lock_waits, percentile(r.lock_wait_us, 0.99), r.direct_releases, r.wakeups);
  if (r.enqueued_ahead > 0 || r.queued_gaps > 0)
    std::cerr << fmt::format(
        "red:   asynchronous lanes: {} unit(s) queued behind a running one; end -> start of "
        "the queued unit p50 {:.2f} us, p99 {:.2f} us ({} gaps)\n",
        r.enqueued_ahead, percentile(r.queued_gap_us, 0.5), percentile(r.queued_gap_us, 0.99),
        r.queued_gaps);
  std::int64_t peak = 0;
  for (const RuntimeSample& x : r.samples) peak = std::max(peak, x.rss_bytes);
  auto mb = [](std::int64_t b) { return static_cast<double>(b) / 1e6; };
  std::cerr << fmt::format(
      "red:   RSS MB: before {:.1f}, after warm-up {:.1f}, peak {:.1f}, end {:.1f}{}\n",
      mb(r.resident_bytes_before), mb(r.resident_bytes_warm), mb(peak), mb(r.resident_bytes_after),
      r.resident_bytes_released > 0
          ? fmt::format(", after release {:.1f}", mb(r.resident_bytes_released))
          : std::string());
  if (r.late_returns > 0)
    std::cerr << fmt::format(
        "red:   {} timed-out unit(s) returned late; lanes out of service {:.1f} ms\n",
        r.late_returns, to_ms(r.out_of_service));
  if (r.abandoned > 0)
    std::cerr << fmt::format(
        "red:   {} unit(s) abandoned at the end of the run: the device had not finished them "
        "past their watchdog limit (a hung device)\n",
        r.abandoned);
  for (const auto& [reason, n] : r.failure_reasons)
    std::cerr << fmt::format("red:   {} unit(s) failed: {}\n", n, reason);
  for (const std::string& line : r.realtime) std::cerr << "red:   " << line << '\n';
}

}  // namespace red::cli
