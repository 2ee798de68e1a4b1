// Faults in the real-time runtime (docs/DESIGN.md, "Synchronization"), on the synthetic backend: a
// unit that throws, one that runs out of memory, one that hangs past the watchdog. Assertions are
// structural (who failed with which reason, every job accounted for, lanes that go on), never about
// how long anything took.

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/report/report.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

// Two operations on one camera; `lanes` is filled in. The deadlines are longer than the
// watchdog's limit for any unit (10 x p99, at least 50 ms), so a hung unit's jobs are
// still alive when it times out (otherwise they are dropped at their deadline first).
constexpr const char* kScenario = R"(
name: faults
duration_s: 1.2
seed: 5
device: {lanes: %LANES%}
model: {builtin: mimonet, heads: [lane, seg, steer, det], input: [3, 192, 384]}
sensors:
  camera: {rate_hz: 40}
operations:
  - name: cruise
    trigger: camera
    deadline_ms: 300
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
    edges: [[L, S]]
  - name: detect
    rate_hz: 25
    deadline_ms: 250
    nodes:
      O: {head: det, sensor: camera}
)";

Scenario scenario(int lanes) {
  std::string text = kScenario;
  text.replace(text.find("%LANES%"), 7, std::to_string(lanes));
  auto s = parse_scenario(text, "faults.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return s ? std::move(s).value() : Scenario{};
}

// Every job and every unit end, with lanes, times and reasons.
struct Watcher final : Observer {
  struct UnitEnd {
    int lane;
    TimePoint end;
    UnitStatus status;
  };
  std::set<JobId> released;
  std::map<JobId, JobOutcome> ended;
  std::map<JobId, std::string> reasons;
  std::vector<UnitEnd> units;
  int duplicate_ends = 0;
  void on_job_release(const JobRecord& j) override { released.insert(j.id); }
  void on_job_end(const JobRecord& j) override {
    if (!ended.emplace(j.id, j.outcome).second) ++duplicate_ends;
    if (!j.reason.empty()) reasons[j.id] = std::string(j.reason);
  }
  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) override {
    units.push_back({d.lane, end, s});
  }
  [[nodiscard]] int count(JobOutcome o) const {
    int n = 0;
    for (const auto& [id, outcome] : ended) n += outcome == o ? 1 : 0;
    return n;
  }
  [[nodiscard]] int reason_count(const std::string& r) const {
    int n = 0;
    for (const auto& [id, reason] : reasons) n += reason == r ? 1 : 0;
    return n;
  }
};

struct FaultRun {
  RuntimeReport report;
  Watcher watch;
  PolicyMetrics metrics;
  std::vector<JobRow> jobs;
};

FaultRun run_with(const Scenario& s, const std::string& policy, SyntheticBackend::Options o,
                  RuntimeOptions ro = {}) {
  const Profile p = default_profile();
  SyntheticBackend backend(s, p, 1, std::move(o));
  ro.realtime = false;
  Runtime rt(s, p, make_policy(policy), backend, ro);
  FaultRun r;
  MetricsCollector metrics(s, 1.0);
  rt.add_observer(&r.watch);
  rt.add_observer(&metrics);
  r.report = rt.run();
  r.metrics = metrics.summarize(policy, r.report.end);
  r.jobs = metrics.jobs();
  return r;
}

// The `nth` encoder run hangs for `hang` (once); the lane it ran on is recorded.
struct HangOnce {
  std::atomic<int> encoders{0};
  std::atomic<int> lane{-1};
  int nth = 3;
  SyntheticBackend::Options options(Duration hang, double time_scale) {
    SyntheticBackend::Options o;
    o.time_scale = time_scale;
    o.hang = hang;
    o.inject = [this](const Dispatch& d) {
      if (d.kind != UnitKind::Encoder) return 0;
      if (encoders.fetch_add(1) != nth) return 0;
      lane.store(d.lane);
      return 3;
    };
    return o;
  }
};

// The watchdog of the hang tests: no limit under 150 ms. The injected hang (400 ms) is far
// past it, while an ordinary unit slowed by a loaded machine (a sanitizer build beside
// other tests) is not: with the default 50 ms a second, spurious timeout was seen in CI.
RuntimeOptions hang_watchdog() {
  RuntimeOptions ro;
  ro.watchdog_min = std::chrono::milliseconds{150};
  return ro;
}

void expect_every_job_once(const FaultRun& r) {
  ASSERT_FALSE(r.watch.released.empty());
  EXPECT_EQ(r.watch.duplicate_ends, 0);
  EXPECT_EQ(r.watch.ended.size(), r.watch.released.size()) << "a released job was lost";
  EXPECT_EQ(r.metrics.completed + r.metrics.dropped + r.metrics.unfinished, r.metrics.jobs);
}

TEST(RuntimeFaults, HungUnitTimesOutAndTheOtherLaneGoesOn) {
  const Scenario s = scenario(2);
  HangOnce hang;
  // The hang lasts far past the watchdog's limit (10 x the encoder's p99, at least 150 ms).
  FaultRun r =
      run_with(s, "red", hang.options(std::chrono::milliseconds{400}, 0.3), hang_watchdog());
  expect_every_job_once(r);
  ASSERT_GE(hang.lane.load(), 0);
  EXPECT_EQ(r.report.timeouts, 1U);
  EXPECT_EQ(r.report.late_returns, 1U);
  EXPECT_GT(r.report.out_of_service, Duration{0});
  EXPECT_GE(r.watch.reason_count("timeout"), 1);
  EXPECT_EQ(r.metrics.failure_reasons.count("timeout"), 1U);
  // The unit that timed out, and what each lane completed while it was out of service.
  TimePoint failed_at = kNever;
  for (const auto& u : r.watch.units)
    if (u.status == UnitStatus::Failed && u.lane == hang.lane.load()) failed_at = u.end;
  ASSERT_NE(failed_at, kNever);
  const TimePoint back_at = failed_at + r.report.out_of_service;
  int other_lane_during = 0, hung_lane_after = 0;
  for (const auto& u : r.watch.units) {
    if (u.status != UnitStatus::Completed) continue;
    if (u.lane != hang.lane.load() && u.end > failed_at && u.end < back_at) ++other_lane_during;
    if (u.lane == hang.lane.load() && u.end > back_at) ++hung_lane_after;
  }
  EXPECT_GT(other_lane_during, 0) << "the other lane must go on";
  EXPECT_GT(hung_lane_after, 0) << "the lane must recover after the call returns";
}

TEST(RuntimeFaults, OneLaneHangDropsJobsAtTheirDeadlinesAndLosesNone) {
  const Scenario s = scenario(1);
  HangOnce hang;
  FaultRun r =
      run_with(s, "red", hang.options(std::chrono::milliseconds{400}, 0.2), hang_watchdog());
  expect_every_job_once(r);
  EXPECT_EQ(r.report.timeouts, 1U);
  EXPECT_EQ(r.report.late_returns, 1U);
  EXPECT_GE(r.watch.reason_count("timeout"), 1);
  // While the only lane is out of service, jobs pass their deadlines: dropped (strict) or
  // skipped at release (max_inflight), each reported.
  EXPECT_GT(r.watch.count(JobOutcome::Dropped) + r.watch.count(JobOutcome::Skipped), 0);
  // And the lane recovers: jobs complete after the hang.
  TimePoint failed_at = kNever;
  for (const auto& u : r.watch.units)
    if (u.status == UnitStatus::Failed) failed_at = std::min(failed_at, u.end);
  ASSERT_NE(failed_at, kNever);
  int completed_after = 0;
  for (const auto& u : r.watch.units)
    completed_after +=
        u.status == UnitStatus::Completed && u.end > failed_at + r.report.out_of_service ? 1 : 0;
  EXPECT_GT(completed_after, 0);
}

TEST(RuntimeFaults, PerEdgeSynchronizationHandlesATimeoutToo) {
  const Scenario s = scenario(2);
  HangOnce hang;
  FaultRun r =
      run_with(s, "red-ida", hang.options(std::chrono::milliseconds{400}, 0.3), hang_watchdog());
  expect_every_job_once(r);
  EXPECT_EQ(r.report.timeouts, 1U);
  EXPECT_EQ(r.report.late_returns, 1U);
  EXPECT_GE(r.watch.reason_count("timeout"), 1);
}

TEST(RuntimeFaults, WatchdogOffLetsAHungUnitFinish) {
  const Scenario s = scenario(2);
  HangOnce hang;
  RuntimeOptions ro;
  ro.watchdog_x = 0;
  FaultRun r = run_with(s, "red", hang.options(std::chrono::milliseconds{200}, 0.3), ro);
  expect_every_job_once(r);
  EXPECT_EQ(r.report.timeouts, 0U);
  EXPECT_EQ(r.report.failures, 0U);
  EXPECT_EQ(r.watch.reason_count("timeout"), 0);
}

TEST(RuntimeFaults, EveryFailureReasonReachesJobsCsvAndSummary) {
  const Scenario s = scenario(2);
  std::atomic<int> n{0};
  std::atomic<bool> threw{false}, oom{false}, hung{false};
  SyntheticBackend::Options o;
  o.time_scale = 0.2;
  o.hang = std::chrono::milliseconds{300};
  // After a few units: one encoder throws, one head runs out of memory, later one encoder
  // hangs (each once).
  o.inject = [&](const Dispatch& d) {
    const int k = n.fetch_add(1);
    if (k < 4) return 0;
    if (d.kind == UnitKind::Encoder && !threw.exchange(true)) return 1;
    if (d.kind == UnitKind::Head && !oom.exchange(true)) return 2;
    if (k >= 20 && d.kind == UnitKind::Encoder && !hung.exchange(true)) return 3;
    return 0;
  };
  FaultRun r = run_with(s, "red", std::move(o));
  expect_every_job_once(r);
  const std::string csv = jobs_csv(s, {{"red", &r.jobs}});
  SummaryHeader header;
  header.scenario = "faults";
  const std::string summary = summary_json(header, {r.metrics});
  for (const auto& [reason, count] : r.metrics.failure_reasons) {
    EXPECT_NE(csv.find("failed"), std::string::npos);
    EXPECT_NE(csv.find(reason.substr(0, 12)), std::string::npos) << reason;
    EXPECT_NE(summary.find("\"" + reason + "\": " + std::to_string(count)), std::string::npos)
        << reason;
  }
  // Faults inside the warm-up window would not be counted; this scenario has none.
  EXPECT_EQ(r.metrics.failure_reasons.count("injected failure"), 1U);
  EXPECT_EQ(r.metrics.failure_reasons.count("timeout"), 1U);
  bool saw_oom = false;
  for (const auto& [reason, count] : r.metrics.failure_reasons)
    saw_oom = saw_oom || reason.find("out of memory") != std::string::npos;
  EXPECT_TRUE(saw_oom);
  EXPECT_EQ(r.report.timeouts, 1U);
  // Unit by unit too, whether or not their jobs were still alive.
  EXPECT_EQ(r.report.failure_reasons.count("injected failure"), 1U);
  EXPECT_EQ(r.report.failure_reasons.count("timeout"), 1U);
}

}  // namespace
}  // namespace red
