// DynamicMerge(γ) and inter-DAG batching (docs/DESIGN.md, "DynamicMerge" and "Batching"), through
// the Scheduler driven with a virtual time (no simulator). Inference nodes and the built-in default
// profile: encoder 12 ms mean / 14 ms p99; heads lane 3.6, seg 4.8, steer 0.75 ms p99; batch b
// costs (1 + 0.55 (b − 1)) single runs.

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "../support/harness.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
#include "red/sched/scheduler.hpp"

namespace red {
namespace {

using namespace std::chrono_literals;
using test::parse;

struct Wait {
  int sensor = -1;
  TimePoint now{0};
  TimePoint until{0};
};

struct Decision {
  TimePoint now{0};
  int ready = 0, idle = 0, waiting = 0;
};

class Recorder final : public Observer {
 public:
  void on_unit_start(const Dispatch& d) override { started.push_back(d); }
  void on_merge_wait(int sensor, TimePoint now, TimePoint until) override {
    waits.push_back({sensor, now, until});
  }
  void on_decision(TimePoint now, int ready, int idle, int waiting) override {
    decisions.push_back({now, ready, idle, waiting});
  }
  void on_job_end(const JobRecord& j) override { outcomes.push_back(j.outcome); }

  /// Decision rounds that left a lane idle while a task that was not waiting was ready.
  [[nodiscard]] int idle_with_ready() const {
    return static_cast<int>(
        std::count_if(decisions.begin(), decisions.end(),
                      [](const Decision& d) { return d.idle > 0 && d.ready > d.waiting; }));
  }
  [[nodiscard]] int count(UnitKind k) const {
    return static_cast<int>(std::count_if(started.begin(), started.end(),
                                          [k](const Dispatch& d) { return d.kind == k; }));
  }

  std::vector<Dispatch> started;
  std::vector<Wait> waits;
  std::vector<Decision> decisions;
  std::vector<JobOutcome> outcomes;
};

using Harness = test::Harness<Recorder>;

std::set<int> operations_of(const Dispatch& d) {
  std::set<int> out;
  for (const Member& m : d.members) out.insert(m.operation);
  return out;
}

/// Min of the members' intermediate deadlines at `now`, as the scheduler assigns them.
TimePoint min_member_deadline(Scheduler& s, const Dispatch& d, TimePoint now) {
  TimePoint best = kNever;
  for (const Member& m : d.members) best = std::min(best, s.unit_deadline(m.slot, m.unit, now));
  return best;
}

constexpr const char* kOneJob = R"(name: one-job
duration_s: 10
device: {lanes: 3}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - name: drive
    trigger: cam
    deadline_ms: 200
    nodes:
      L: {head: lane, sensor: cam}
      S: {head: seg, sensor: cam}
      C: {head: steer, sensor: cam}
)";

// ---- 1. same frame: unconditional merge ------------------------------------------------------

TEST(DynamicMerge, SameJobEncodersRunOnce) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(kOneJob, policy);
    h.frame(0, 7, 0ms);
    const auto d = h.step(0ms);
    ASSERT_EQ(d.size(), 1u);  // one encoder run; the heads wait for it
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
    EXPECT_EQ(d[0].batch, 1);
    ASSERT_EQ(d[0].members.size(), 3u);
    EXPECT_EQ(d[0].task_begin, (std::vector<int>{0, 3}));
    std::set<int> nodes;
    for (const Member& m : d[0].members) {
      nodes.insert(m.node);
      EXPECT_EQ(m.frame, 7u);
      EXPECT_EQ(m.operation, 0);
    }
    EXPECT_EQ(nodes, (std::set<int>{0, 1, 2}));
    h.run_out(0ms);
    EXPECT_EQ(h.rec().count(UnitKind::Encoder), 1);
    EXPECT_EQ(h.rec().count(UnitKind::Coarse), 0);
    int head_members = 0;
    for (const Dispatch& x : h.rec().started)
      if (x.kind == UnitKind::Head) head_members += static_cast<int>(x.members.size());
    EXPECT_EQ(head_members, 3);
    EXPECT_EQ(h.rec().outcomes, (std::vector<JobOutcome>{JobOutcome::Met}));
  }
}

TEST(DynamicMerge, CoarseEdfRunsThreeCoarseUnits) {
  Harness h(kOneJob, "edf");
  h.frame(0, 7, 0ms);
  const auto d = h.step(0ms);
  ASSERT_EQ(d.size(), 3u);  // three lanes, three independent coarse units
  for (const Dispatch& x : d) {
    EXPECT_EQ(x.kind, UnitKind::Coarse);
    EXPECT_EQ(x.members.size(), 1u);
  }
  h.run_out(0ms);
  EXPECT_EQ(h.rec().count(UnitKind::Coarse), 3);
  EXPECT_EQ(h.rec().count(UnitKind::Encoder), 0);
  EXPECT_EQ(h.rec().outcomes, (std::vector<JobOutcome>{JobOutcome::Met}));
}

TEST(DynamicMerge, MonoRunsTheJobAsOneUnit) {
  Harness h(kOneJob, "mono");
  h.frame(0, 7, 0ms);
  const auto d = h.step(0ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].kind, UnitKind::Mono);
  h.run_out(0ms);
  EXPECT_EQ(h.rec().started.size(), 1u);
}

constexpr const char* kTwoTriggered = R"(name: two-ops
duration_s: 10
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - name: lanes
    trigger: cam
    deadline_ms: 100
    nodes: {L: {head: lane, sensor: cam}}
  - name: segs
    trigger: cam
    deadline_ms: 40
    nodes: {S: {head: seg, sensor: cam}}
)";

TEST(DynamicMerge, OperationsTriggeredByTheSameFrameShareOneEncoderRun) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(kTwoTriggered, policy);
    h.frame(0, 3, 50ms);
    const auto d = h.step(50ms);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
    ASSERT_EQ(d[0].members.size(), 2u);
    EXPECT_EQ(operations_of(d[0]), (std::set<int>{0, 1}));
    for (const Member& m : d[0].members) EXPECT_EQ(m.frame, 3u);
    h.run_out(50ms);
    EXPECT_EQ(h.rec().count(UnitKind::Encoder), 1);
    EXPECT_EQ(h.rec().count(UnitKind::Head), 2);
  }
}

TEST(DynamicMerge, DifferentFramesOfTriggeredJobsDoNotMerge) {
  Harness h(kTwoTriggered, "red-ida");
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 1ms);  // second frame before any dispatch: four encoder units, two frames
  h.run_out(1ms);
  EXPECT_EQ(h.rec().count(UnitKind::Encoder), 2);
  for (const Dispatch& d : h.rec().started) {
    if (d.kind != UnitKind::Encoder) continue;
    EXPECT_EQ(d.members.size(), 2u);
    EXPECT_EQ(d.members[0].frame, d.members[1].frame);
  }
}

// ---- 3. the merged deadline ------------------------------------------------------------------

TEST(DynamicMerge, MergedDeadlineIsTheMinimumOfTheMembers) {
  for (const char* policy : {"red-fg", "red-ida"}) {
    SCOPED_TRACE(policy);
    Harness h(kTwoTriggered, policy);
    const TimePoint r = 50ms;
    h.frame(0, 3, r);
    const auto d = h.step(r);
    ASSERT_EQ(d.size(), 1u);
    // Encoders at height 0: lanes 100 · 14 / 17.6, segs 40 · 14 / 18.8 (the smaller).
    const TimePoint lanes = r + h.s().graph(0)->static_offset[0];
    const TimePoint segs = r + h.s().graph(1)->static_offset[0];
    EXPECT_LT(segs, lanes);
    EXPECT_EQ(d[0].deadline, segs);
    EXPECT_EQ(d[0].deadline, min_member_deadline(h.s(), d[0], r));
    EXPECT_EQ(segs, r + Duration{mul_div(40'000'000, 14'000'000, 18'800'000)});
  }
}

// ---- 2. γ-clusters of operations sampling the newest frame -------------------------------------

std::string gamma_yaml(int q_phase_ms, int p_deadline_ms) {
  return fmt::format(R"(name: gamma
duration_s: 10
model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}
scheduler: {{gamma_ms: 10}}
sensors:
  cam: {{rate_hz: 100}}
operations:
  - name: P
    rate_hz: 10
    deadline_ms: {}
    nodes: {{L: {{head: lane, sensor: cam}}}}
  - name: Q
    rate_hz: 10
    phase_ms: {}
    deadline_ms: 100
    nodes: {{S: {{head: seg, sensor: cam}}}}
)",
                     p_deadline_ms, q_phase_ms);
}

TEST(DynamicMerge, ReleasesWithinGammaMerge) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(gamma_yaml(5, 100), policy);
    h.frame(0, 1, 0ms);
    h.release_only(0ms);  // P at 0
    h.frame(0, 2, 4ms);
    const auto d = h.step(5ms);  // Q at 5: within γ = 10 of P
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
    ASSERT_EQ(d[0].members.size(), 2u);
    EXPECT_EQ(operations_of(d[0]), (std::set<int>{0, 1}));
    // The merged run uses the newest frame there is when it starts.
    for (const Member& m : d[0].members) {
      EXPECT_EQ(m.frame, 2u);
      EXPECT_EQ(m.frame_time, 4ms);
    }
    EXPECT_EQ(d[0].deadline, min_member_deadline(h.s(), d[0], 5ms));
  }
}

TEST(DynamicMerge, ReleasesOutsideGammaDoNotMerge) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(gamma_yaml(30, 100), policy);
    h.frame(0, 1, 0ms);
    h.release_only(0ms);  // P at 0
    h.frame(0, 2, 20ms);
    const auto d = h.step(30ms);  // Q at 30: 30 > γ
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
    EXPECT_EQ(d[0].members.at(0).operation, 0);  // P: the earlier deadline
    h.run_out(30ms);
    // Every encoder task has one member: P and Q never share a run. (red may still batch
    // the two tasks: a batch runs each task on its own frame.)
    int tasks = 0;
    for (const Dispatch& x : h.rec().started) {
      if (x.kind != UnitKind::Encoder) continue;
      ASSERT_EQ(x.task_begin.size(), static_cast<std::size_t>(x.batch) + 1);
      for (int t = 0; t < x.batch; ++t) {
        const auto i = static_cast<std::size_t>(t);
        EXPECT_EQ(x.task_begin[i + 1] - x.task_begin[i], 1);
        ++tasks;
      }
      if (std::string_view(policy) != "red") {
        EXPECT_EQ(x.batch, 1);
      }
    }
    EXPECT_EQ(tasks, 2);
  }
}

TEST(DynamicMerge, WaitsForAPredictedMemberWhenSlackCovers) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(gamma_yaml(5, 100), policy);
    h.frame(0, 1, 0ms);
    // P at 0; Q predicted at 5 (periodic), within γ. P's slack 100 − 17.6 covers 5 ms.
    EXPECT_TRUE(h.step(0ms).empty());
    ASSERT_EQ(h.rec().waits.size(), 1u);
    EXPECT_EQ(h.rec().waits[0].sensor, 0);
    EXPECT_EQ(h.rec().waits[0].now, 0ms);
    EXPECT_EQ(h.rec().waits[0].until, 5ms);
    EXPECT_EQ(h.s().stats().merge_waits, 1u);
    ASSERT_FALSE(h.rec().decisions.empty());
    const Decision& dec = h.rec().decisions.back();
    EXPECT_EQ(dec.ready, 1);
    EXPECT_EQ(dec.idle, 1);
    EXPECT_EQ(dec.waiting, 1);
    EXPECT_EQ(h.s().next_wakeup(), 5ms);
    // The lane stays idle until then, without a second wait being announced.
    EXPECT_TRUE(h.step(3ms).empty());
    EXPECT_EQ(h.rec().waits.size(), 1u);
    const auto d = h.step(5ms);
    ASSERT_EQ(d.size(), 1u);
    ASSERT_EQ(d[0].members.size(), 2u);
    EXPECT_EQ(operations_of(d[0]), (std::set<int>{0, 1}));
    h.run_out(5ms);
    EXPECT_EQ(h.rec().count(UnitKind::Encoder), 1);
    // Idling with ready work only ever happened while that work waited for a merge.
    EXPECT_EQ(h.rec().idle_with_ready(), 0);
  }
}

TEST(DynamicMerge, NeverWaitsPastItsSlack) {
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    // P's deadline 20: slack 20 − 17.6 = 2.4 ms does not cover the 5 ms wait.
    Harness h(gamma_yaml(5, 20), policy);
    h.frame(0, 1, 0ms);
    const auto d = h.step(0ms);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
    ASSERT_EQ(d[0].members.size(), 1u);
    EXPECT_EQ(d[0].members[0].operation, 0);
    EXPECT_TRUE(h.rec().waits.empty());
    EXPECT_EQ(h.s().stats().merge_waits, 0u);
    // Q is released at 5 on its own and gets its own encoder run.
    h.run_out(0ms);
    std::vector<std::set<int>> encoder_ops;
    for (const Dispatch& x : h.rec().started)
      if (x.kind == UnitKind::Encoder) encoder_ops.push_back(operations_of(x));
    EXPECT_EQ(encoder_ops, (std::vector<std::set<int>>{{0}, {1}}));
    EXPECT_EQ(h.rec().outcomes.size(), 2u);
    EXPECT_EQ(h.rec().idle_with_ready(), 0);
  }
}

TEST(DynamicMerge, WaitEndsWhenThePredictedMemberLeavesTheWorkload) {
  // P waits at 0 for Q, predicted at 5; at 3 an event removes Q. The wait is pointless from
  // then on: P's encoder must not be left idle past the predicted time (next_wakeup must
  // still bring the scheduler back by 5 ms, or the encoder runs at once).
  std::string text = gamma_yaml(5, 100);
  text += "events:\n  - {at_s: 0.003, remove_operation: {operation: Q}}\n";
  Harness h(text, "red-fg");
  h.frame(0, 1, 0ms);
  EXPECT_TRUE(h.step(0ms).empty());
  ASSERT_EQ(h.rec().waits.size(), 1u);
  const auto d = h.step(3ms);  // the event's scheduling point
  if (d.empty()) {
    EXPECT_LE(h.s().next_wakeup(), 5ms) << "the merge wait was forgotten: the lane idles with "
                                           "ready work until P's next release";
  } else {
    EXPECT_EQ(d[0].kind, UnitKind::Encoder);
  }
}

TEST(DynamicMerge, FinishedMergeWaitDoesNotPinTheWakeup) {
  // One lane. At 0, P's encoder waits for Q (predicted at 5) and the lane takes the plain
  // task of `busy` meanwhile (20 ms). At 5 Q joins the merged encoder: the wait is over, the
  // lane is still busy, so the next thing to wait for is the lane, at 20 ms.
  std::string text = gamma_yaml(5, 100);
  text += R"(  - name: busy
    trigger: cam
    deadline_ms: 200
    nodes: {B: {cost_ms: 20}}
)";
  Harness h(text, "red-fg");
  h.frame(0, 1, 0ms);
  const auto d0 = h.step(0ms);
  ASSERT_EQ(h.rec().waits.size(), 1u);
  ASSERT_EQ(d0.size(), 1u);
  EXPECT_EQ(d0[0].kind, UnitKind::Plain);
  EXPECT_TRUE(h.step(5ms).empty());  // Q released and merged; no lane free
  EXPECT_EQ(h.s().ready_tasks(), 1);
  EXPECT_GT(h.s().next_wakeup(), 5ms) << "a wake-up at or before now: a driver that sleeps "
                                         "until next_wakeup() spins at 5 ms forever";
  h.complete(0, 20ms);
  const auto d1 = h.step(20ms);
  ASSERT_EQ(d1.size(), 1u);
  EXPECT_EQ(d1[0].members.size(), 2u);
}

// ---- inter-DAG batching (red only) -----------------------------------------------------------

std::string batch_yaml(int deadline_ms) {
  return fmt::format(R"(name: batch
duration_s: 10
model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}
sensors:
  cam: {{rate_hz: 100}}
operations:
  - name: drive
    trigger: cam
    deadline_ms: {}
    max_inflight: 4
    nodes: {{L: {{head: lane, sensor: cam}}}}
)",
                     deadline_ms);
}

TEST(Batching, DifferentFramesBatchWhenCheaperAndInTime) {
  Harness h(batch_yaml(100), "red");
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 10ms);
  const auto d = h.step(10ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].kind, UnitKind::Encoder);
  EXPECT_EQ(d[0].batch, 2);  // 1.55 × 14 = 21.7 ms < 28 ms, and 10 + 21.7 is in time
  ASSERT_EQ(d[0].members.size(), 2u);
  EXPECT_EQ(d[0].task_begin, (std::vector<int>{0, 1, 2}));
  EXPECT_NE(d[0].members[0].frame, d[0].members[1].frame);
  EXPECT_EQ(d[0].deadline, min_member_deadline(h.s(), d[0], 10ms));
  // The two heads (different jobs) batch as well.
  h.complete(0, 32ms);
  const auto heads = h.step(32ms);
  ASSERT_EQ(heads.size(), 1u);
  EXPECT_EQ(heads[0].kind, UnitKind::Head);
  EXPECT_EQ(heads[0].batch, 2);
}

TEST(Batching, OnlyRedBatches) {
  for (const char* policy : {"red-fg", "red-ida"}) {
    SCOPED_TRACE(policy);
    Harness h(batch_yaml(100), policy);
    h.frame(0, 1, 0ms);
    h.frame(0, 2, 10ms);
    const auto d = h.step(10ms);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].batch, 1);
    EXPECT_EQ(d[0].members.size(), 1u);
  }
}

TEST(Batching, NotWhenTheBatchWouldMissTheEarliestDeadline) {
  // D = 30: job 1's encoder deadline at 10 is 10 + 20 · 14 / 17.6 ≈ 25.9 ms; alone it ends
  // at 24, batched at 31.7.
  Harness h(batch_yaml(30), "red");
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 10ms);
  const auto d = h.step(10ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].kind, UnitKind::Encoder);
  EXPECT_EQ(d[0].batch, 1);
  ASSERT_EQ(d[0].members.size(), 1u);
  EXPECT_EQ(d[0].members[0].frame, 1u);
  EXPECT_LT(10ms + 14ms, d[0].deadline);
  EXPECT_GT(10ms + Duration{21'700'000}, d[0].deadline);
}

TEST(Batching, NotWhenTheBatchIsNoCheaper) {
  Profile p = default_profile();
  UnitProfile& enc = p.units.at("encoder");
  ASSERT_GE(enc.max_batch(), 2);
  LatencyStats two = enc.by_batch[0];
  for (Duration* x : {&two.min, &two.mean, &two.p50, &two.p95, &two.p99, &two.max}) *x *= 2;
  enc.by_batch[1] = two;  // batch of 2 costs exactly two single runs
  Harness h(batch_yaml(100), "red", std::nullopt, 0, p);
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 10ms);
  const auto d = h.step(10ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].batch, 1);
  EXPECT_EQ(d[0].members.size(), 1u);
}

}  // namespace
}  // namespace red
