// The real-time runtime (docs/DESIGN.md, "Synchronization") with the synthetic backend: real
// threads and a real clock, scaled-down unit times. Assertions are structural (accounting,
// failures, who decided), never about timing.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "red/metrics/metrics.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

constexpr const char* kScenario = R"(
name: rt
duration_s: 0.6
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det], input: [3, 192, 384]}
sensors:
  camera: {rate_hz: 40}
operations:
  - name: cruise
    trigger: camera
    deadline_ms: 60
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
      C: {head: steer, sensor: camera}
    edges: [[L, S], [S, C]]
  - name: detect
    rate_hz: 25
    deadline_ms: 50
    nodes:
      O: {head: det, sensor: camera}
)";

struct Accounting final : Observer {
  std::set<JobId> released;
  std::map<JobId, JobOutcome> ended;
  std::map<JobId, std::string> reasons;
  int duplicate_ends = 0;
  void on_job_release(const JobRecord& j) override { released.insert(j.id); }
  void on_job_end(const JobRecord& j) override {
    if (!ended.emplace(j.id, j.outcome).second) ++duplicate_ends;
    if (!j.reason.empty()) reasons[j.id] = std::string(j.reason);
  }
};

struct RunResult {
  RuntimeReport report;
  Accounting acc;
  PolicyMetrics metrics;
};

// kScenario, and `extra` YAML after it, running for `duration` when one is given.
Scenario rt_scenario(const std::string& extra = "",
                     std::optional<std::chrono::milliseconds> duration = std::nullopt) {
  auto s = parse_scenario(std::string(kScenario) + extra, "rt.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  if (!s) return Scenario{};
  if (duration) s->duration = *duration;
  return std::move(*s);
}

// Unit times scaled by `x` on the synthetic backend.
SyntheticBackend::Options scaled(double x) {
  SyntheticBackend::Options o;
  o.time_scale = x;
  return o;
}

// No watchdog: these tests count jobs, and under a sanitizer on a loaded machine a unit
// can overrun 10 x its p99 without being hung (the watchdog has its own fault tests).
RuntimeOptions no_watchdog(bool realtime = false) {
  RuntimeOptions ro;
  ro.realtime = realtime;
  ro.watchdog_x = 0.0;
  return ro;
}

// A scenario on the synthetic backend with the default profile, ready to run `policy`.
struct Rig {
  Scenario s;
  Profile p = default_profile();
  SyntheticBackend backend;
  Runtime rt;
  Rig(const std::string& policy, Scenario scenario, SyntheticBackend::Options o,
      const RuntimeOptions& ro)
      : s(std::move(scenario)),
        backend(s, p, 1, std::move(o)),
        rt(s, p, make_policy(policy), backend, ro) {}
};

RunResult run_runtime(const std::string& policy, SyntheticBackend::Options o) {
  Rig rig(policy, rt_scenario(), std::move(o), no_watchdog());
  RunResult r;
  MetricsCollector metrics(rig.s, 1.0);
  rig.rt.add_observer(&r.acc);
  rig.rt.add_observer(&metrics);
  r.report = rig.rt.run();
  r.metrics = metrics.summarize(policy, r.report.end);
  return r;
}

class RuntimeTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RuntimeTest, EveryReleasedJobEndsExactlyOnce) {
  SyntheticBackend::Options o;
  o.time_scale = 0.3;
  RunResult r = run_runtime(GetParam(), o);
  ASSERT_FALSE(r.acc.released.empty());
  EXPECT_EQ(r.acc.duplicate_ends, 0);
  EXPECT_EQ(r.acc.ended.size(), r.acc.released.size());
  for (JobId id : r.acc.released) EXPECT_TRUE(r.acc.ended.count(id) == 1) << "job " << id;
  EXPECT_EQ(r.metrics.completed + r.metrics.dropped + r.metrics.unfinished, r.metrics.jobs);
  EXPECT_GT(r.metrics.completed, 0);
  EXPECT_EQ(r.report.failures, 0U);
  EXPECT_FALSE(r.report.decision_us.empty());
  // The run ends when the scenario's releases are over and nothing is in flight, not at the
  // drain limit (5 s past the end) when the last frames arrive with the end of the
  // scenario. (Not a timing figure: a run that waits for the drain limit ends 5 s late.)
  EXPECT_LT(r.report.end, std::chrono::milliseconds{600} + std::chrono::seconds{2});
}

INSTANTIATE_TEST_SUITE_P(Presets, RuntimeTest,
                         ::testing::Values("fifo", "mono", "edf", "red-fg", "red-ida", "red",
                                           "red-robust"));

TEST(Runtime, FailingUnitsFailTheirJobsAndTheRuntimeGoesOn) {
  std::atomic<int> n{0};
  SyntheticBackend::Options o;
  o.time_scale = 0.2;
  // Every fifth encoder run throws; every seventh head runs out of memory.
  o.inject = [&n](const Dispatch& d) {
    const int k = n.fetch_add(1);
    if (d.kind == UnitKind::Encoder && k % 5 == 0) return 1;
    if (d.kind == UnitKind::Head && k % 7 == 0) return 2;
    return 0;
  };
  RunResult r = run_runtime("red", o);
  EXPECT_GT(r.report.failures, 0U);
  EXPECT_GT(r.metrics.failed, 0);
  EXPECT_GT(r.metrics.completed, 0) << "the runtime must keep going after failures";
  bool saw_injected = false, saw_oom = false;
  for (const auto& [id, reason] : r.acc.reasons) {
    saw_injected = saw_injected || reason == "injected failure";
    saw_oom = saw_oom || reason.find("out of memory") != std::string::npos;
  }
  EXPECT_TRUE(saw_injected);
  EXPECT_TRUE(saw_oom);
  for (const auto& [id, outcome] : r.acc.ended)
    if (r.acc.reasons.count(id) != 0 && outcome == JobOutcome::Failed) SUCCEED();
  EXPECT_EQ(r.acc.ended.size(), r.acc.released.size());
}

TEST(Runtime, OnDemandDecidesAtUnitBoundariesPerEdgeDoesNot) {
  SyntheticBackend::Options o;
  o.time_scale = 0.3;
  RunResult red = run_runtime("red", o);      // on-demand
  RunResult ida = run_runtime("red-ida", o);  // per-edge
  EXPECT_GT(red.report.local_decisions, 0U);
  EXPECT_EQ(ida.report.local_decisions, 0U);
  EXPECT_LT(red.report.stats.round_trips, red.report.stats.dispatches);
  EXPECT_EQ(ida.report.stats.round_trips, ida.report.stats.dispatches);
}

// A frame that arrives with the end of the scenario releases nothing; the run must still
// end then, not wait for the drain limit (5 s) with nothing in flight.
TEST(Runtime, RunEndsWhenTheLastFrameComesWithTheEnd) {
  auto s = parse_scenario(R"(
name: end
duration_s: 0.5
warmup_s: 0.1
sensors:
  camera: {rate_hz: 20}
operations:
  - name: chain
    trigger: camera
    deadline_ms: 40
    nodes:
      A: {cost_ms: 5}
      B: {cost: {mean_ms: 8, p99_ms: 10}}
    edges: [[A, B]]
)",
                          "end.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile p = default_profile();
  SyntheticBackend backend(*s, p, 1, {});
  RuntimeOptions ro;
  ro.realtime = false;
  for (const char* policy : {"edf", "red", "red-robust"}) {
    Runtime rt(*s, p, make_policy(policy), backend, ro);
    const RuntimeReport report = rt.run();
    EXPECT_LT(report.end, std::chrono::milliseconds{500} + std::chrono::seconds{2}) << policy;
  }
}

TEST(Runtime, ExternalFramesAreTheReleasesAndStopEndsThem) {
  RuntimeOptions ro;
  ro.realtime = false;
  ro.external_frames = true;
  // stop() ends it long before 60 s.
  Rig rig("red", rt_scenario("", std::chrono::seconds{60}), scaled(0.05), ro);
  Runtime& rt = rig.rt;
  Accounting acc;
  MetricsCollector metrics(rig.s, 1.0);
  rt.add_observer(&acc);
  rt.add_observer(&metrics);
  EXPECT_FALSE(rt.push_frame(0, 0)) << "frames before run() are ignored";
  std::thread feeder([&rt] {
    // No synthetic camera: only the frames pushed here release the triggered operation.
    std::uint64_t accepted = 0;
    for (std::uint64_t f = 0; accepted < 10 && f < 100000; ++f) {
      if (rt.push_frame(0, f)) ++accepted;
      std::this_thread::sleep_for(std::chrono::milliseconds{20});
    }
    EXPECT_FALSE(rt.push_frame(7, 1000)) << "an unknown sensor is ignored";
    rt.stop();
  });
  const RuntimeReport report = rt.run();
  feeder.join();
  EXPECT_FALSE(rt.push_frame(0, 200000)) << "frames after the run are ignored";
  const PolicyMetrics m = metrics.summarize("red", report.end);
  std::map<int, int> per_op;
  for (const auto& row : metrics.jobs()) ++per_op[row.operation];
  // The triggered operation got exactly one release per accepted frame.
  EXPECT_EQ(per_op[0], 10);
  EXPECT_EQ(report.frame_release_us.size(), 10U) << "one arrival-to-release time per frame";
  EXPECT_EQ(acc.ended.size(), acc.released.size());
  EXPECT_GT(m.completed, 0);
}

// A scenario's background load competes with the units: its threads run at the lane
// handlers' SCHED_FIFO priority where real-time settings apply, never at the
// synchronizer's (above the units, the load preempted them for its whole busy share), and
// at the ordinary priority where they do not (no permission).
TEST(Runtime, BackgroundLoadRunsAtTheHandlersPriority) {
  Rig rig(
      "red",
      rt_scenario("interference: {kind: cpu, intensity: 0.1}\n", std::chrono::milliseconds{200}),
      scaled(0.3), no_watchdog(true));
  const RuntimeReport report = rig.rt.run();
  const std::string priority =
      "SCHED_FIFO priority " + std::to_string(RuntimeOptions{}.rt_priority);
  bool realtime = false;
  std::string load;
  for (const std::string& line : report.realtime) {
    if (line.rfind(priority + " (", 0) == 0 && line.find("applied") != std::string::npos &&
        line.find("not applied") == std::string::npos)
      realtime = true;
    if (line.rfind("background load: ", 0) == 0) load = line;
  }
  ASSERT_FALSE(load.empty()) << "no background-load line in the report";
  EXPECT_NE(load.find(realtime ? priority : std::string("ordinary priority")), std::string::npos)
      << load;
  EXPECT_EQ(load.find("mixed"), std::string::npos) << load;
}

// Each lane's handler is pinned to its own share of the cores (cores / lanes, at least one),
// pinning needs no privilege, and the report states the share the masks were built from.
TEST(Runtime, EveryHandlerIsPinnedToItsLanesShareOfTheCores) {
  Rig rig("red", rt_scenario("", std::chrono::milliseconds{100}), scaled(0.3), no_watchdog(true));
  const RuntimeReport report = rig.rt.run();
  const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
  const long share = std::max(1L, cores / rig.s.device.lanes);
  const std::string want = "CPU affinity: 2 of 2 handler(s) pinned, " + std::to_string(share) +
                           " core(s) each of " + std::to_string(cores);
  std::string line;
  for (const std::string& l : report.realtime)
    if (l.rfind("CPU affinity: ", 0) == 0) line = l;
  EXPECT_EQ(line, want);
}

// The CPU wake-up latency is held at 0 for the run's length only (PM QoS: the request lives
// as long as /dev/cpu_dma_latency is open): reported either way (held, or not held and why:
// no such file, no permission), open in the process while the run goes on when held, and
// closed once run() returns; not asked for with hold_wakeup_latency off or without real-time.
TEST(Runtime, TheCpuWakeupLatencyIsHeldForTheRunOnlyAndReported) {
  auto latency_files = [] {
    int n = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd", ec)) {
      std::error_code rec;
      if (std::filesystem::read_symlink(e.path(), rec).string() == "/dev/cpu_dma_latency") ++n;
    }
    return n;
  };
  ASSERT_EQ(latency_files(), 0);
  auto line_of = [](const RuntimeReport& r) {
    for (const std::string& l : r.realtime)
      if (l.rfind("CPU wake-up latency: ", 0) == 0) return l;
    return std::string();
  };
  {
    Rig rig("red", rt_scenario("", std::chrono::milliseconds{300}), scaled(0.3), no_watchdog(true));
    // Looked at on the first release, while the run goes on (after the settings apply).
    struct Look final : Observer {
      std::function<int()> files;
      int during = -1;
      void on_job_release(const JobRecord& /*job*/) override {
        if (during < 0) during = files();
      }
    } look;
    look.files = latency_files;
    rig.rt.add_observer(&look);
    const RuntimeReport report = rig.rt.run();
    const int during = look.during;
    const std::string line = line_of(report);
    ASSERT_FALSE(line.empty()) << "no wake-up latency line in the report";
    if (line == "CPU wake-up latency: held at 0 us (/dev/cpu_dma_latency)") {
      EXPECT_EQ(during, 1) << "held: the file is open while the run goes on";
    } else {
      EXPECT_EQ(line.rfind("CPU wake-up latency: not held (/dev/cpu_dma_latency: ", 0), 0U) << line;
      EXPECT_EQ(during, 0);
    }
    EXPECT_EQ(latency_files(), 0) << "the hold ends with the run";
  }
  RuntimeOptions off = no_watchdog(true);
  off.hold_wakeup_latency = false;
  Rig rig("red", rt_scenario("", std::chrono::milliseconds{100}), scaled(0.3), off);
  EXPECT_TRUE(line_of(rig.rt.run()).empty()) << "not asked for: not reported";
  Rig plain("red", rt_scenario("", std::chrono::milliseconds{100}), scaled(0.3), no_watchdog());
  EXPECT_TRUE(line_of(plain.rt.run()).empty()) << "without real-time settings: not asked for";
}

// decision_us_since() (the node's diagnostics read it while a run goes on): from cursor 0 the
// newest decision times the runtime holds (all of them up to 4096), then nothing new.
TEST(Runtime, DecisionTimesSinceACursorAreTheNewestAndThenNone) {
  Rig rig("red", rt_scenario("", std::chrono::milliseconds{200}), scaled(0.3), no_watchdog());
  const RuntimeReport report = rig.rt.run();
  ASSERT_GT(report.decisions, 0U);
  std::uint64_t cursor = 0;
  const std::vector<double> all = rig.rt.decision_us_since(cursor);
  EXPECT_EQ(all.size(), std::min<std::uint64_t>(report.decisions, 4096));
  EXPECT_EQ(cursor, report.decisions);
  for (double us : all) EXPECT_GE(us, 0.0);
  EXPECT_TRUE(rig.rt.decision_us_since(cursor).empty());
  std::uint64_t last = report.decisions - 1;  // the newest one alone
  const std::vector<double> newest = rig.rt.decision_us_since(last);
  ASSERT_EQ(newest.size(), 1U);
  EXPECT_EQ(newest.front(), all.back());
}

// stop_now() (SIGINT in the CLI) ends the run without draining: the jobs in flight are
// reported unfinished, every released job still ends exactly once.
TEST(Runtime, StopNowEndsTheRunWithJobsInFlightUnfinished) {
  // Units at their profiled times (a cruise job is a ~20 ms chain): at 0.05 × a job took
  // ~1 ms, and on a loaded machine (CI's sanitizer suite, two tests at once) the
  // synchronizer could be descheduled that long after stop_now(), so every job in flight
  // had ended by the time it acted. stop_now() ends it long before 60 s.
  RuntimeOptions ro;
  ro.realtime = false;
  Rig rig("red", rt_scenario("", std::chrono::seconds{60}), scaled(1.0), ro);
  Runtime& rt = rig.rt;
  // Stops at the 10th release of `cruise`, from the scheduler's thread (stop_now() only sets
  // a flag and wakes the synchronizer): that job has three nodes in a chain to run, and at
  // most the units already running finish, so it is still in flight when the run ends.
  struct StopAt final : Observer {
    Runtime* rt = nullptr;
    int releases = 0;
    void on_job_release(const JobRecord& j) override {
      if (j.operation == 0 && ++releases == 10) rt->stop_now();
    }
  } stop_at;
  stop_at.rt = &rt;
  Accounting acc;
  MetricsCollector metrics(rig.s, 1.0);
  rt.add_observer(&acc);
  rt.add_observer(&metrics);
  rt.add_observer(&stop_at);
  const RuntimeReport report = rt.run();
  const PolicyMetrics m = metrics.summarize("red", report.end);
  EXPECT_EQ(acc.ended.size(), acc.released.size());
  EXPECT_EQ(acc.duplicate_ends, 0);
  EXPECT_LT(acc.released.size(), 40U) << "no releases after the stop's round";
  EXPECT_GE(m.unfinished, 1) << "the 20th job was still in flight";
  std::size_t unfinished = 0;
  for (const auto& [id, outcome] : acc.ended) unfinished += outcome == JobOutcome::Unfinished;
  EXPECT_GE(unfinished, 1U);
}

// Frames pushed from two threads at once: a frame is released by the pushing thread when
// the scheduler's lock is free (a direct release), else by the global synchronizer. Either
// way every accepted frame releases its operation exactly once, and the decisions, taken by
// whichever thread holds the lock, stay in EDF order: on the one lane, a unit starts only
// when no released job still waiting has an earlier deadline.
TEST(Runtime, DirectReleasesAreAccountedOnceAndDecisionsStayInEdfOrder) {
  auto s = parse_scenario(R"(
name: direct
duration_s: 60
device: {lanes: 1}
sensors:
  a: {rate_hz: 200}
  b: {rate_hz: 200}
operations:
  - name: pa
    trigger: a
    deadline_ms: 40
    nodes: {A: {cost_ms: 3}}
  - name: pb
    trigger: b
    deadline_ms: 15
    nodes: {B: {cost_ms: 2}}
)",
                          "direct.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile p = default_profile();
  // One job is one unit, ready at its release, whose deadline is the job's.
  struct EdfOrder final : Observer {
    std::map<JobId, TimePoint> waiting;  // released, not started, not ended
    std::set<JobId> started;
    std::map<int, int> released_per_op;
    int starts = 0, out_of_order = 0;
    void on_job_release(const JobRecord& j) override {
      waiting.emplace(j.id, j.deadline);
      ++released_per_op[j.operation];
    }
    void on_job_end(const JobRecord& j) override { waiting.erase(j.id); }
    void on_unit_start(const Dispatch& d) override {
      ++starts;
      for (const Member& m : d.members) waiting.erase(m.job);
      for (const auto& [id, deadline] : waiting)
        if (deadline < d.deadline) ++out_of_order;
    }
  };
  for (const char* policy : {"edf", "red"}) {  // per-edge, on-demand
    SyntheticBackend::Options o;
    o.time_scale = 1.0;
    SyntheticBackend backend(*s, p, 1, o);
    RuntimeOptions ro;
    ro.realtime = false;
    ro.watchdog_x = 0.0;
    ro.external_frames = true;
    Runtime rt(*s, p, make_policy(policy), backend, ro);
    Accounting acc;
    EdfOrder order;
    rt.add_observer(&acc);
    rt.add_observer(&order);
    constexpr int kFrames = 40;
    std::atomic<int> feeding{2};
    std::array<int, 2> accepted{0, 0};
    auto feed = [&](int sensor) {
      // About 4 ms apart on each sensor: more work than the lane can do, so jobs queue.
      for (std::uint64_t f = 0; accepted[static_cast<std::size_t>(sensor)] < kFrames && f < 100000;
           ++f) {
        if (rt.push_frame(sensor, f)) ++accepted[static_cast<std::size_t>(sensor)];
        std::this_thread::sleep_for(std::chrono::microseconds{4000 + 700 * sensor});
      }
      if (--feeding == 0) rt.stop();
    };
    std::thread fa(feed, 0), fb(feed, 1);
    const RuntimeReport report = rt.run();
    fa.join();
    fb.join();
    EXPECT_EQ(order.released_per_op[0], kFrames) << policy << ": one release per frame";
    EXPECT_EQ(order.released_per_op[1], kFrames) << policy;
    EXPECT_EQ(report.frame_release_us.size(), static_cast<std::size_t>(2 * kFrames)) << policy;
    EXPECT_GT(report.direct_releases, 0U) << policy << ": the lock is mostly free";
    EXPECT_LE(report.direct_releases, static_cast<std::uint64_t>(2 * kFrames)) << policy;
    EXPECT_EQ(acc.duplicate_ends, 0) << policy;
    EXPECT_EQ(acc.ended.size(), acc.released.size()) << policy;
    EXPECT_GT(order.starts, 0) << policy;
    EXPECT_EQ(order.out_of_order, 0) << policy;
  }
}

TEST(Runtime, HandlerStatesHaveNames) {
  EXPECT_STREQ(to_string(HandlerState::Idle), "idle");
  EXPECT_STREQ(to_string(HandlerState::OutOfMemory), "out-of-memory");
  EXPECT_STREQ(to_string(HandlerState::Cancelled), "cancelled");
}

}  // namespace
}  // namespace red
