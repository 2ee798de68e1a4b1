// Lanes that hold more than one unit (SchedulerConfig::queue_depth, docs/DESIGN.md, "Queued
// lanes"): the scheduler driven directly with a virtual time. A lane's handler queues a unit behind
// the one running (dispatch_ahead); what is queued counts as dispatched; the lane completes its
// units in the order given; a successor of a unit a lane holds is ready for that lane only.

#include <gtest/gtest.h>

#include <string>

#include "../support/harness.hpp"
#include "red/profile/profile.hpp"
#include "red/sched/policy.hpp"
#include "red/sched/scheduler.hpp"

namespace red {
namespace {

using namespace std::chrono_literals;

// `chain` (A then B) and `other` (X, short) released together at 0 on two lanes.
constexpr const char* kTwoLanes = R"(name: queue
duration_s: 1
device: {lanes: 2, queue_depth: 2}
operations:
  - name: chain
    rate_hz: 10
    deadline_ms: 50
    nodes:
      A: {cost_ms: 5}
      B: {cost_ms: 5}
    edges: [[A, B]]
  - name: other
    rate_hz: 10
    deadline_ms: 80
    nodes:
      X: {cost_ms: 2}
)";

struct Ends final : Observer {
  std::vector<std::pair<std::uint64_t, TimePoint>> units;  // dispatch id, start at its end
  std::vector<JobOutcome> jobs;
  void on_unit_end(const Dispatch& d, TimePoint, UnitStatus) override {
    units.emplace_back(d.id, d.start);
  }
  void on_job_end(const JobRecord& j) override { jobs.push_back(j.outcome); }
};

TEST(QueueDepth, TheScenarioSetsItAndAGpuProfileDefaultsToTwo) {
  Scenario s = test::parse(kTwoLanes);
  ASSERT_TRUE(s.device.queue_depth.has_value());
  EXPECT_EQ(SchedulerConfig::from(s).queue_depth, 2);
  s.device.queue_depth.reset();
  Profile p = default_profile();
  EXPECT_EQ(SchedulerConfig::from(s, p).queue_depth, 1);
  p.source = "measured";
  p.device = "cuda:0 (NVIDIA H100)";
  EXPECT_EQ(SchedulerConfig::from(s, p).queue_depth, 2);
  p.device = "cpu (2 threads)";
  EXPECT_EQ(SchedulerConfig::from(s, p).queue_depth, 1);
}

TEST(QueueDepth, ASuccessorIsQueuedBehindItsPredecessorOnItsLaneOnly) {
  const Scenario s = test::parse(kTwoLanes);
  const Profile p = default_profile();
  Scheduler sched(s, p, make_policy("red"), SchedulerConfig::from(s, p));
  Ends ends;
  sched.add_observer(&ends);
  sched.apply_events(TimePoint{0});
  sched.advance(TimePoint{0});
  auto first = sched.dispatch(TimePoint{0});
  ASSERT_EQ(first.size(), 2U);
  int a_lane = -1;
  for (Dispatch* d : first) {
    sched.on_start(d->lane, TimePoint{0});
    if (d->kind == UnitKind::Plain && d->members.front().operation == 0) a_lane = d->lane;
  }
  ASSERT_GE(a_lane, 0);
  const int x_lane = 1 - a_lane;
  // X ends: its lane is idle, but B waits on A, which the other lane holds.
  sched.on_complete(x_lane, TimePoint{2ms}, UnitStatus::Completed);
  EXPECT_TRUE(sched.dispatch(TimePoint{2ms}).empty()) << "B must not run beside A";
  EXPECT_TRUE(sched.dispatch_ahead(TimePoint{2ms}, x_lane).empty())
      << "an idle lane queues nothing";
  EXPECT_FALSE(sched.has_room_ahead(x_lane));
  // A's lane queues B behind A: no round trip, counted as dispatched.
  ASSERT_TRUE(sched.has_room_ahead(a_lane));
  const std::uint64_t dispatches = sched.stats().dispatches;
  auto ahead = sched.dispatch_ahead(TimePoint{2ms}, a_lane);
  ASSERT_EQ(ahead.size(), 1U);
  const Dispatch* b = ahead.front();
  EXPECT_EQ(b->lane, a_lane);
  EXPECT_FALSE(b->round_trip);
  EXPECT_EQ(b->members.front().node, 1) << "B";
  EXPECT_EQ(sched.stats().dispatches, dispatches + 1);
  sched.on_start(a_lane, TimePoint{2ms});
  EXPECT_FALSE(sched.has_room_ahead(a_lane)) << "full at the queue depth";
  EXPECT_TRUE(sched.dispatch_ahead(TimePoint{2ms}, a_lane).empty());
  // The lane completes in order: A first (still the one running), then B, which started
  // when A ended.
  ASSERT_NE(sched.running(a_lane), nullptr);
  EXPECT_EQ(sched.running(a_lane)->members.front().node, 0);
  sched.on_complete(a_lane, TimePoint{5ms}, UnitStatus::Completed);
  ASSERT_NE(sched.running(a_lane), nullptr);
  EXPECT_EQ(sched.running(a_lane)->id, b->id);
  EXPECT_EQ(sched.running(a_lane)->start, TimePoint{5ms});
  sched.on_complete(a_lane, TimePoint{10ms}, UnitStatus::Completed);
  EXPECT_EQ(sched.running(a_lane), nullptr);
  ASSERT_EQ(ends.units.size(), 3U);
  EXPECT_EQ(ends.units[2].first, b->id);
  EXPECT_EQ(ends.units[2].second, TimePoint{5ms});
  int met = 0;
  for (JobOutcome o : ends.jobs) met += o == JobOutcome::Met ? 1 : 0;
  EXPECT_EQ(met, 2);
}

TEST(QueueDepth, AFailureBeforeAQueuedSuccessorFailsTheJobOnce) {
  const Scenario s = test::parse(kTwoLanes);
  const Profile p = default_profile();
  Scheduler sched(s, p, make_policy("red"), SchedulerConfig::from(s, p));
  Ends ends;
  sched.add_observer(&ends);
  sched.advance(TimePoint{0});
  int a_lane = -1;
  for (Dispatch* d : sched.dispatch(TimePoint{0})) {
    sched.on_start(d->lane, TimePoint{0});
    if (d->members.front().operation == 0) a_lane = d->lane;
  }
  ASSERT_GE(a_lane, 0);
  ASSERT_EQ(sched.dispatch_ahead(TimePoint{1ms}, a_lane).size(), 1U);
  sched.on_start(a_lane, TimePoint{1ms});
  sched.on_complete(a_lane, TimePoint{3ms}, UnitStatus::Failed, "injected");
  // B was on the device behind A: it ends, its output discarded.
  sched.on_complete(a_lane, TimePoint{8ms}, UnitStatus::Completed);
  sched.on_complete(1 - a_lane, TimePoint{8ms}, UnitStatus::Completed);
  int failed = 0, met = 0;
  for (JobOutcome o : ends.jobs) {
    failed += o == JobOutcome::Failed ? 1 : 0;
    met += o == JobOutcome::Met ? 1 : 0;
  }
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(met, 1);
  EXPECT_EQ(sched.jobs_in_flight(), 0);
}

TEST(QueueDepth, OneUnitPerLaneByDefault) {
  std::string text = kTwoLanes;
  text.replace(text.find(", queue_depth: 2"), 16, "");
  const Scenario s = test::parse(text);
  const Profile p = default_profile();
  Scheduler sched(s, p, make_policy("red"), SchedulerConfig::from(s, p));
  sched.advance(TimePoint{0});
  for (Dispatch* d : sched.dispatch(TimePoint{0})) sched.on_start(d->lane, TimePoint{0});
  EXPECT_FALSE(sched.has_room_ahead(0));
  EXPECT_TRUE(sched.dispatch_ahead(TimePoint{1ms}, 0).empty());
}

}  // namespace
}  // namespace red
