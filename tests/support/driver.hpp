#pragma once
/// \file
/// Test support: one scenario and policy run through either driver of the scheduler, so a
/// suite states its expectations once and checks them on both (as rclcpp runs one suite over
/// every executor):
/// * Driver::Simulator: simulate_policy (virtual clock, sampled costs; deterministic);
/// * Driver::Runtime: the real-time runtime (real threads, real clock) on the synthetic
///   backend, which spends each unit's sampled cost sleeping on its lane's thread.
/// Both report the same observer callbacks and the same PolicyRun (metrics, job and unit rows,
/// scheduler statistics), so the checks do not care which driver ran.

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"

namespace red::test {

enum class Driver { Simulator, Runtime };

inline const char* to_string(Driver d) noexcept {
  return d == Driver::Simulator ? "simulator" : "runtime";
}

/// How run_with_driver runs.
struct DriverOptions {
  std::uint64_t seed = 1;  ///< the simulator's seed; the synthetic backend's cost seed
  // The runtime's options: unit costs at the profile's times (time_scale 1), spent
  // sleeping (a spinning lane would take one of the few cores from the other threads).
  double time_scale = 1.0;
  /// Lanes that hold several units (device.queue_depth > 1) need an asynchronous backend:
  /// the synthetic one's worker thread per lane.
  bool asynchronous = false;
};

/// What one run produced, whichever driver ran it.
struct DriverRun {
  /// metrics, job and unit rows, result.stats and result.end (the runtime fills these as
  /// `red run` does; result.unit_events and result.events are the simulator's only).
  PolicyRun run;
  std::uint64_t failures = 0;  ///< runtime: units that ended failed (the simulator has none)
};

/// The scenario's timeline (duration, warm-up, workload events) scaled to last `target`;
/// rates, phases, costs and deadlines unchanged. A real run lasts as long as its scenario:
/// this keeps the runtime's runs short while every event still happens, in the same order.
/// A scenario already no longer than `target` is returned as it is.
inline Scenario compressed(Scenario s, Duration target) {
  if (s.duration <= target || s.duration.count() <= 0) return s;
  const double f = static_cast<double>(target.count()) / static_cast<double>(s.duration.count());
  const auto scale = [f](Duration d) {
    return Duration{static_cast<std::int64_t>(static_cast<double>(d.count()) * f)};
  };
  s.duration = target;
  s.warmup = scale(s.warmup);
  for (EventSpec& e : s.events) e.at = scale(e.at);
  return s;
}

/// Runs `policy` (a preset, with the scenario's `scheduler:` options) on `s` through
/// `driver`; `observers` see every callback. The runtime runs without real-time settings and
/// without its watchdog (a test on a loaded machine must not fail a slow unit), as long as
/// the scenario lasts: shorten it first (compressed()). `s` and `p` must outlive the
/// observers' use of what they recorded.
inline Expected<DriverRun> run_with_driver(Driver driver, const Scenario& s, const Profile& p,
                                           const std::string& policy, const DriverOptions& o,
                                           const std::vector<Observer*>& observers = {}) {
  DriverRun out;
  if (driver == Driver::Simulator) {
    auto r = simulate_policy(s, p, policy, o.seed, observers, true);
    if (!r) return r.error();
    out.run = std::move(r.value());
    return out;
  }
  auto pol = make_policy(policy, policy_options(s, policy));
  if (!pol) return Error{"", 0, "unknown policy '" + policy + "'"};
  SyntheticBackend::Options so;
  so.time_scale = o.time_scale;
  so.spin = false;
  so.asynchronous = o.asynchronous;
  SyntheticBackend backend(s, p, o.seed, so);
  RuntimeOptions ro;
  ro.realtime = false;
  ro.watchdog_x = 0.0;
  ro.sample_period = Duration{0};
  Runtime rt(s, p, std::move(pol), backend, ro);
  MetricsCollector metrics(s, s.scheduler.qoe_lambda, true);
  rt.add_observer(&metrics);
  for (Observer* ob : observers) rt.add_observer(ob);
  const auto t0 = std::chrono::steady_clock::now();
  const RuntimeReport report = rt.run();
  out.run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.run.metrics = metrics.summarize(policy, report.end);
  out.run.jobs = metrics.take_jobs();
  out.run.units = metrics.take_units();
  out.run.result.end = report.end;
  out.run.result.stats = report.stats;
  out.failures = report.failures;
  return out;
}

}  // namespace red::test
