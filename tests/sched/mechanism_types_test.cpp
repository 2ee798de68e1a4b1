// The scheduler's mechanism types driven alone, without a scheduler around them (docs/
// ARCHITECTURE.md, "sched/scheduler"): on-demand synchronization's placement and runs
// (OnDemandSync), who ranks by job deadline in a round (Ranking), and a re-assigned deadline
// from a job's shares (Reassignment). The schedules they make are checked end to end by
// sync_run_test.cpp, overload_test.cpp and scheduler_test.cpp.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../../src/sched/deadlines.hpp"
#include "../../src/sched/pools.hpp"
#include "../../src/sched/ranking.hpp"
#include "../../src/sched/sync.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

using sched_detail::Job;
using sched_detail::JobPool;
using sched_detail::Lane;
using sched_detail::OnDemandSync;
using sched_detail::Placement;
using sched_detail::Ranking;
using sched_detail::Reassignment;
using sched_detail::Task;

// ---- OnDemandSync -------------------------------------------------------------------------

// Three idle lanes and two jobs in flight (slots 0 and 1). Lane 0's run holds job 0 and lane 2's
// job 1, both after a unit that completed at `now`; lane 1 holds no open run.
struct Lanes {
  std::vector<Lane> lanes = std::vector<Lane>(3);
  JobPool jobs;  // slots 0 and 1
  OnDemandSync sync;
  Duration rt = from_ms(2);
  TimePoint now = from_ms(10);

  explicit Lanes(SyncMode mode) {
    jobs.alloc();
    jobs.alloc();
    jobs[0].id = 11;
    jobs[1].id = 12;
    sync.set_up(mode, rt, 3);
    run(0, 0);
    run(2, 1);
  }
  // A dispatch of job `slot` on `lane` that paid a round trip and completed at `now`.
  void run(int lane, int slot) {
    sync.started(lane, true);
    sync.joins(lane, slot, jobs[slot].id);
    sync.completed(lane, now, UnitStatus::Completed);
  }
  Placement place(int slot, int ahead = -1) const {
    Task k;
    k.members.emplace_back(slot, 0);
    return sync.place(lanes, jobs, k, now, ahead);
  }
};

TEST(OnDemandSync, ATaskOfARunsJobContinuesItOnItsLaneWithoutARoundTrip) {
  const Lanes l(SyncMode::OnDemand);
  const Placement p = l.place(1);
  EXPECT_EQ(p.lane, 2);
  EXPECT_FALSE(p.round_trip);
  EXPECT_EQ(p.rt, Duration{0});
  EXPECT_EQ(l.place(0).lane, 0);
}

TEST(OnDemandSync, OtherWorkGoesToALaneWithoutAnOpenRunAndPaysARoundTrip) {
  Lanes l(SyncMode::OnDemand);
  ASSERT_EQ(l.jobs.alloc(), 2);
  l.jobs[2].id = 13;
  const Placement p = l.place(2);
  EXPECT_EQ(p.lane, 1);  // lanes 0 and 2 are kept for their runs' own work
  EXPECT_TRUE(p.round_trip);
  EXPECT_EQ(p.rt, l.rt);
}

TEST(OnDemandSync, ARunContinuesOnlyAtTheInstantItsUnitCompleted) {
  Lanes l(SyncMode::OnDemand);
  l.now += from_ms(1);
  const Placement p = l.place(1);
  EXPECT_EQ(p.lane, 0);  // no run open now: the first idle lane
  EXPECT_TRUE(p.round_trip);
}

TEST(OnDemandSync, AFailureEndsTheRun) {
  Lanes l(SyncMode::OnDemand);
  l.sync.completed(2, l.now, UnitStatus::Failed);
  EXPECT_TRUE(l.place(1).round_trip);
}

TEST(OnDemandSync, ASlotReusedByAnotherJobDoesNotContinueTheRun) {
  Lanes l(SyncMode::OnDemand);
  l.jobs[1].id = 14;  // job 12 ended; its slot holds a new job
  EXPECT_TRUE(l.place(1).round_trip);
}

TEST(OnDemandSync, ARoundTripStartsANewRun) {
  Lanes l(SyncMode::OnDemand);
  l.run(2, 0);  // lane 2 handed job 0's work after a round trip: job 1 left its run
  EXPECT_TRUE(l.place(1).round_trip);
  EXPECT_FALSE(l.place(0).round_trip);
}

TEST(OnDemandSync, PerEdgeSynchronizationPaysARoundTripForEveryDispatch) {
  const Lanes l(SyncMode::PerEdge);
  for (int slot : {0, 1}) {
    const Placement p = l.place(slot);
    EXPECT_TRUE(p.round_trip);
    EXPECT_EQ(p.rt, l.rt);
  }
}

TEST(OnDemandSync, ATaskQueuedAheadGoesToTheLaneGivenWithoutARoundTrip) {
  Lanes l(SyncMode::OnDemand);
  l.lanes[1].count = 1;  // busy
  const Placement p = l.place(0, 1);
  EXPECT_EQ(p.lane, 1);
  EXPECT_TRUE(p.ahead);
  EXPECT_FALSE(p.round_trip);
  EXPECT_EQ(p.rt, Duration{0});
}

TEST(OnDemandSync, NoIdleLaneNoPlacement) {
  Lanes l(SyncMode::OnDemand);
  for (Lane& lane : l.lanes) lane.count = 1;
  EXPECT_EQ(l.place(0).lane, -1);
}

// ---- Ranking ------------------------------------------------------------------------------

// Two lanes; a comfort and a safety operation on one camera, of criticalities 0 and `safety`.
Scenario two_lanes(int safety) {
  auto s = parse_scenario(R"(
name: ranking
duration_s: 1
device: {lanes: 2}
sensors:
  camera: {rate_hz: 40}
operations:
  - name: comfort
    trigger: camera
    deadline_ms: 25
    nodes:
      B: {cost: {mean_ms: 6, p99_ms: 8}}
  - name: safety
    trigger: camera
    deadline_ms: 35
    criticality: )" + std::to_string(safety) +
                              R"(
    nodes:
      A: {cost: {mean_ms: 4, p99_ms: 5}}
)",
                          "ranking.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return *s;
}

Task of_kind(UnitKind kind) {
  Task k;
  k.kind = kind;
  return k;
}

TEST(Ranking, RankOverloadRanksByJobDeadlineWhileOverloadedEncodersOnlyWhenTheDemandTestOverran) {
  const Scenario s = two_lanes(0);
  const auto policy = make_policy("red-robust");
  ASSERT_NE(policy, nullptr);
  ASSERT_EQ(policy->options().rank, RankMode::Overload);
  Ranking r;
  r.set_up(*policy, s, SchedulerConfig::from(s));
  EXPECT_TRUE(r.overload_aware());
  const Task head = of_kind(UnitKind::Head), encoder = of_kind(UnitKind::Encoder);
  r.at_pick(false, false);
  EXPECT_FALSE(r.by_job_deadline(head));
  EXPECT_FALSE(r.by_job_deadline(encoder));
  EXPECT_FALSE(r.ranks_from_tasks());
  r.at_pick(true, false);  // overloaded (at max_inflight, or holding), the demand test passed
  EXPECT_TRUE(r.by_job_deadline(head));
  EXPECT_FALSE(r.by_job_deadline(encoder));
  // With equal criticalities and a rank by deadline only, the tasks' kept ranks are enough.
  EXPECT_EQ(r.ranks_from_tasks(), policy->ranks_by_deadline_only());
  r.at_pick(true, true);
  EXPECT_TRUE(r.by_job_deadline(encoder));
}

TEST(Ranking, RankPolicyNeverRanksByJobDeadline) {
  const Scenario s = two_lanes(0);
  const auto policy = make_policy("red");
  ASSERT_NE(policy, nullptr);
  ASSERT_EQ(policy->options().rank, RankMode::Policy);
  Ranking r;
  r.set_up(*policy, s, SchedulerConfig::from(s));
  EXPECT_FALSE(r.overload_aware());
  r.at_pick(true, true);
  EXPECT_FALSE(r.by_job_deadline(of_kind(UnitKind::Head)));
  EXPECT_FALSE(r.by_job_deadline(of_kind(UnitKind::Encoder)));
  EXPECT_FALSE(r.ranks_from_tasks());
}

TEST(Ranking, MixedCriticalitiesAreTheScenariosAndRankFromTheJobs) {
  const Scenario equal = two_lanes(0), mixed = two_lanes(2);
  const auto policy = make_policy("red-robust");
  ASSERT_NE(policy, nullptr);
  Ranking r;
  r.set_up(*policy, equal, SchedulerConfig::from(equal));
  EXPECT_FALSE(r.mixed_criticality());
  r.set_up(*policy, mixed, SchedulerConfig::from(mixed));
  EXPECT_TRUE(r.mixed_criticality());
  EXPECT_EQ(r.top_criticality(), 2);
  r.at_pick(true, true);
  EXPECT_TRUE(r.by_job_deadline(of_kind(UnitKind::Head)));
  EXPECT_FALSE(r.ranks_from_tasks());  // criticalities are read from the jobs
}

// ---- Reassignment -------------------------------------------------------------------------

// The job's cache as Scheduler::Impl keeps it: refresh() and eval() counted, eval() giving the
// shares at `now` of a job with a unit running.
struct Caches {
  int refreshed = 0, evaluated = 0;
  std::vector<double> now_shares;
  void refresh(Job&) { ++refreshed; }
  void eval(Job& j, TimePoint) {
    ++evaluated;
    j.frac_now = now_shares;
  }
};

TEST(Reassignment, AHeightEndsAtItsShareOfTheBudgetLeft) {
  Job j;
  j.plan = from_ms(100);
  j.frac = {0.25, 1.0};
  Caches c;
  const TimePoint now = from_ms(20);
  // Budget 80 ms: the first height ends a quarter of it from now, the last at the plan.
  EXPECT_EQ(Reassignment::deadline(c, j, 0, now), from_ms(40));
  EXPECT_EQ(Reassignment::deadline(c, j, 1, now), j.plan);
  EXPECT_EQ(c.refreshed, 2);
  EXPECT_EQ(c.evaluated, 0);  // no unit running: the shares of the rebuilt cache
  // Past the plan every height is due at it.
  EXPECT_EQ(Reassignment::deadline(c, j, 0, from_ms(120)), j.plan);
}

TEST(Reassignment, AJobWithAUnitRunningReadsItsSharesAtNow) {
  Job j;
  j.plan = from_ms(100);
  j.frac = {0.25, 1.0};
  j.running_units = {0};
  Caches c;
  c.now_shares = {0.5, 1.0};
  EXPECT_EQ(Reassignment::deadline(c, j, 0, from_ms(20)), from_ms(60));
  EXPECT_EQ(c.evaluated, 1);
}

TEST(Reassignment, GroupsKeyOnTheShareOnlyWhenTheBudgetIsSplitAndReassigned) {
  Reassignment r;
  r.set_up(true, DeadlineMode::Proportional);
  EXPECT_TRUE(r.shares_deadline());
  r.set_up(false, DeadlineMode::Proportional);
  EXPECT_FALSE(r.shares_deadline());
  r.set_up(true, DeadlineMode::EndToEnd);
  EXPECT_FALSE(r.shares_deadline());
}

}  // namespace
}  // namespace red
