// Asynchronous lanes in the real-time runtime (docs/DESIGN.md, "Queued lanes"), on the CPU
// stand-in: the synthetic backend whose lanes are worker threads fed by Backend::enqueue and waited
// for by Backend::wait. Assertions are structural (every job ends once, units end in the order
// their lane was given them, who queued what, failures and timeouts reported), never about
// timing.

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

constexpr const char* kScenario = R"(
name: async
duration_s: 0.8
seed: 3
device: {lanes: 2}
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
      C: {head: steer, sensor: camera}
    edges: [[L, S], [S, C]]
  - name: detect
    rate_hz: 25
    deadline_ms: 250
    nodes:
      O: {head: det, sensor: camera}
)";

struct Watch final : Observer {
  std::set<JobId> released;
  std::map<JobId, JobOutcome> ended;
  std::map<JobId, std::string> reasons;
  int duplicate_ends = 0;
  std::map<int, std::vector<std::uint64_t>> ends_by_lane;  // dispatch ids in end order
  std::map<int, std::vector<std::uint64_t>> starts_by_lane;
  void on_job_release(const JobRecord& j) override { released.insert(j.id); }
  void on_job_end(const JobRecord& j) override {
    if (!ended.emplace(j.id, j.outcome).second) ++duplicate_ends;
    if (!j.reason.empty()) reasons[j.id] = std::string(j.reason);
  }
  void on_unit_start(const Dispatch& d) override { starts_by_lane[d.lane].push_back(d.id); }
  void on_unit_end(const Dispatch& d, TimePoint, UnitStatus) override {
    ends_by_lane[d.lane].push_back(d.id);
  }
};

struct AsyncRun {
  RuntimeReport report;
  Watch watch;
  PolicyMetrics metrics;
};

AsyncRun run_async(const std::string& policy, SyntheticBackend::Options o, RuntimeOptions ro = {},
                   int lanes = 2) {
  auto s = parse_scenario(kScenario, "async.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  s->device.lanes = lanes;
  const Profile p = default_profile();
  o.asynchronous = true;
  SyntheticBackend backend(*s, p, 1, std::move(o));
  EXPECT_TRUE(backend.asynchronous());
  ro.realtime = false;
  Runtime rt(*s, p, make_policy(policy), backend, ro);
  AsyncRun r;
  MetricsCollector metrics(*s, 1.0);
  rt.add_observer(&r.watch);
  rt.add_observer(&metrics);
  r.report = rt.run();
  r.metrics = metrics.summarize(policy, r.report.end);
  return r;
}

void expect_every_job_once(const AsyncRun& r) {
  ASSERT_FALSE(r.watch.released.empty());
  EXPECT_EQ(r.watch.duplicate_ends, 0);
  EXPECT_EQ(r.watch.ended.size(), r.watch.released.size()) << "a released job was lost";
  EXPECT_EQ(r.metrics.completed + r.metrics.dropped + r.metrics.unfinished, r.metrics.jobs);
}

// A lane ends its units in the order it was given them (a stream's order).
void expect_lane_order(const AsyncRun& r) {
  for (const auto& [lane, ends] : r.watch.ends_by_lane) {
    const auto& starts = r.watch.starts_by_lane.at(lane);
    ASSERT_LE(ends.size(), starts.size());
    for (std::size_t i = 0; i < ends.size(); ++i)
      EXPECT_EQ(ends[i], starts[i]) << "lane " << lane << ", unit " << i;
  }
}

class AsyncLanes : public ::testing::TestWithParam<std::string> {};

TEST_P(AsyncLanes, EveryReleasedJobEndsOnceAndLanesKeepTheirOrder) {
  SyntheticBackend::Options o;
  o.time_scale = 0.5;
  // No watchdog: a loaded sanitizer machine may stretch a unit past 10 x its p99.
  RuntimeOptions ro;
  ro.watchdog_x = 0;
  const AsyncRun r = run_async(GetParam(), o, ro);
  expect_every_job_once(r);
  expect_lane_order(r);
  EXPECT_GT(r.metrics.completed, 0);
  EXPECT_EQ(r.report.failures, 0U);
  const bool on_demand = make_policy(GetParam())->options().sync == SyncMode::OnDemand;
  if (on_demand) {
    EXPECT_GT(r.report.enqueued_ahead, 0U) << "an on-demand handler queues behind its unit";
    EXPECT_GT(r.report.queued_gaps, 0U);
  } else {
    EXPECT_EQ(r.report.enqueued_ahead, 0U) << "per-edge: one round trip per unit";
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, AsyncLanes,
                         ::testing::Values("fifo", "mono", "edf", "red-fg", "red-ida", "red",
                                           "red-robust"));

TEST(AsyncLanesFaults, FailuresAndOutOfMemoryFailTheirJobsAndTheLaneGoesOn) {
  std::atomic<int> n{0};
  SyntheticBackend::Options o;
  o.time_scale = 0.3;
  o.inject = [&n](const Dispatch& d) {
    const int k = n.fetch_add(1);
    if (d.kind == UnitKind::Encoder && k % 5 == 0) return 1;
    if (d.kind == UnitKind::Head && k % 7 == 0) return 2;
    return 0;
  };
  RuntimeOptions ro;
  ro.watchdog_x = 0;
  const AsyncRun r = run_async("red", o, ro);
  expect_every_job_once(r);
  expect_lane_order(r);
  EXPECT_GT(r.report.failures, 0U);
  EXPECT_GT(r.metrics.failed, 0);
  EXPECT_GT(r.metrics.completed, 0) << "the runtime must keep going after failures";
  bool injected = false, oom = false;
  for (const auto& [id, reason] : r.watch.reasons) {
    injected = injected || reason == "injected failure";
    oom = oom || reason == "out of memory: injected out-of-memory";
  }
  EXPECT_TRUE(injected);
  EXPECT_TRUE(oom);
}

TEST(AsyncLanesFaults, AHungUnitTimesOutAndItsLaneRecovers) {
  std::atomic<int> encoders{0};
  SyntheticBackend::Options o;
  o.time_scale = 0.3;
  o.hang = std::chrono::milliseconds{400};
  o.inject = [&encoders](const Dispatch& d) {
    return d.kind == UnitKind::Encoder && encoders.fetch_add(1) == 3 ? 3 : 0;
  };
  RuntimeOptions ro;
  ro.watchdog_min = std::chrono::milliseconds{150};  // far below the hang, above a slow unit
  for (const char* policy : {"red", "red-ida"}) {
    encoders = 0;
    const AsyncRun r = run_async(policy, o, ro, 1);
    expect_every_job_once(r);
    EXPECT_EQ(r.report.timeouts, 1U) << policy;
    EXPECT_EQ(r.report.late_returns, 1U) << policy;
    int timeouts = 0;
    for (const auto& [id, reason] : r.watch.reasons) timeouts += reason == "timeout" ? 1 : 0;
    EXPECT_GE(timeouts, 1) << policy;
    EXPECT_GT(r.metrics.completed, 0) << policy;
  }
}

// A unit the device never finishes (the lane's later units wait behind it, as on a hung
// stream): the watchdog fails its jobs, and when the run ends the handler gives up on what
// its lane still holds instead of blocking the run's end on it.
TEST(AsyncLanesFaults, AUnitHungForGoodIsAbandonedAndTheRunEnds) {
  std::atomic<int> encoders{0};
  SyntheticBackend::Options o;
  o.time_scale = 0.3;
  o.inject = [&encoders](const Dispatch& d) {
    return d.kind == UnitKind::Encoder && encoders.fetch_add(1) == 3 ? 4 : 0;
  };
  RuntimeOptions ro;
  ro.watchdog_min = std::chrono::milliseconds{150};
  ro.drain_limit = std::chrono::milliseconds{300};
  for (const char* policy : {"red", "red-ida"}) {
    encoders = 0;
    const AsyncRun r = run_async(policy, o, ro, 1);
    expect_every_job_once(r);
    EXPECT_EQ(r.report.timeouts, 1U) << policy;
    EXPECT_EQ(r.report.late_returns, 0U) << policy << ": it never returned";
    EXPECT_GE(r.report.abandoned, 1U) << policy;
    EXPECT_GT(r.metrics.completed, 0) << policy;
  }
}

// A fault that sticks to the device: the unit that saw it fails with "device lost", the run
// stops at once instead of failing every later unit, and the report names the lane.
TEST(AsyncLanesFaults, ALostDeviceStopsTheRunAndNamesTheLaneThatSawIt) {
  auto s = parse_scenario(kScenario, "async.yaml");
  ASSERT_TRUE(s.has_value());
  s->duration = std::chrono::seconds{30};
  const Profile p = default_profile();
  std::atomic<int> encoders{0};
  SyntheticBackend::Options o;
  o.asynchronous = true;
  o.time_scale = 0.3;
  o.inject = [&encoders](const Dispatch& d) {
    return d.kind == UnitKind::Encoder && encoders.fetch_add(1) == 4 ? 5 : 0;
  };
  SyntheticBackend backend(*s, p, 1, o);
  RuntimeOptions ro;
  ro.realtime = false;
  Runtime rt(*s, p, make_policy("red"), backend, ro);
  Watch watch;
  rt.add_observer(&watch);
  const RuntimeReport report = rt.run();
  EXPECT_LT(report.end, std::chrono::seconds{10}) << "the run went on after the device was lost";
  EXPECT_EQ(report.device_lost, "device lost: injected device fault");
  EXPECT_TRUE(report.device_lost_lane == 0 || report.device_lost_lane == 1)
      << report.device_lost_lane;
  EXPECT_EQ(report.failure_reasons.count("device lost: injected device fault"), 1U);
  ASSERT_FALSE(watch.released.empty());
  EXPECT_EQ(watch.duplicate_ends, 0);
  EXPECT_EQ(watch.ended.size(), watch.released.size());
}

// The handler polls Backend::ready() (spinning, then parked) and calls wait() only for a unit
// that has ended: it never blocks in the backend, so it can give up on a hung unit.
class Polled final : public Backend {
 public:
  explicit Polled(SyntheticBackend& inner) : inner_(inner) {}
  [[nodiscard]] std::string_view name() const noexcept override { return inner_.name(); }
  void init_lane(int lane) override { inner_.init_lane(lane); }
  void on_frame(int sensor, std::uint64_t frame) override { inner_.on_frame(sensor, frame); }
  void run(int lane, const Dispatch& d) override { inner_.run(lane, d); }
  [[nodiscard]] bool asynchronous() const noexcept override { return inner_.asynchronous(); }
  void enqueue(int lane, const Dispatch& d) override { inner_.enqueue(lane, d); }
  UnitDone wait(int lane) override {
    if (!inner_.ready(lane)) blocked_waits.fetch_add(1);
    waits.fetch_add(1);
    return inner_.wait(lane);
  }
  [[nodiscard]] bool ready(int lane) override {
    polls.fetch_add(1);
    return inner_.ready(lane);
  }
  void abandon(int lane) override { inner_.abandon(lane); }
  std::atomic<int> polls{0};
  std::atomic<int> waits{0};
  std::atomic<int> blocked_waits{0};

 private:
  SyntheticBackend& inner_;
};

TEST(AsyncLanesPolling, TheHandlerWaitsOnlyForUnitsThatHaveEnded) {
  auto s = parse_scenario(kScenario, "async.yaml");
  ASSERT_TRUE(s.has_value());
  const Profile p = default_profile();
  SyntheticBackend::Options o;
  o.asynchronous = true;
  o.time_scale = 0.5;
  SyntheticBackend inner(*s, p, 1, o);
  Polled backend(inner);
  for (const char* policy : {"red", "edf"}) {
    RuntimeOptions ro;
    ro.realtime = false;
    ro.watchdog_x = 0;
    Runtime rt(*s, p, make_policy(policy), backend, ro);
    Watch watch;
    rt.add_observer(&watch);
    const RuntimeReport report = rt.run();
    EXPECT_EQ(report.failures, 0U) << policy;
    EXPECT_GT(backend.waits.load(), 0) << policy;
    EXPECT_GE(backend.polls.load(), backend.waits.load()) << policy;
    EXPECT_EQ(backend.blocked_waits.load(), 0) << policy << ": wait() called before ready()";
    EXPECT_EQ(watch.ended.size(), watch.released.size()) << policy;
  }
}

TEST(AsyncLanesFaults, StopNowReportsWhatIsInFlightUnfinished) {
  auto s = parse_scenario(kScenario, "async.yaml");
  ASSERT_TRUE(s.has_value());
  s->duration = std::chrono::seconds{30};
  const Profile p = default_profile();
  SyntheticBackend::Options o;
  o.asynchronous = true;
  SyntheticBackend backend(*s, p, 1, o);
  RuntimeOptions ro;
  ro.realtime = false;
  Runtime rt(*s, p, make_policy("red"), backend, ro);
  Watch watch;
  rt.add_observer(&watch);
  std::thread stopper([&rt] {
    std::this_thread::sleep_for(std::chrono::milliseconds{300});
    rt.stop_now();
  });
  const RuntimeReport report = rt.run();
  stopper.join();
  EXPECT_LT(report.end, std::chrono::seconds{10});
  ASSERT_FALSE(watch.released.empty());
  EXPECT_EQ(watch.duplicate_ends, 0);
  EXPECT_EQ(watch.ended.size(), watch.released.size());
}

}  // namespace
}  // namespace red
