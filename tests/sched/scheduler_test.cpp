// The Scheduler driven directly with a virtual time (a fake scheduling context, no
// simulator): re-assignment (docs/DESIGN.md, "Re-assignment"), dynamic workloads (docs/DESIGN.md,
// "Task model" events), drop modes and overload (docs/DESIGN.md, "Dispatch"), failed units
// (docs/DESIGN.md, "Synchronization") and deterministic EDF tie-breaking (docs/DESIGN.md,
// "Dispatch"). Scenarios use plain nodes (`cost_ms`) so every cost is exact.

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "../support/harness.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
#include "red/sched/scheduler.hpp"

namespace red {
namespace {

using namespace std::chrono_literals;
using test::kWorked;
using test::parse;

std::string with_max_inflight(int n) {
  std::string text = kWorked;
  text.replace(text.find("max_inflight: 4"), 15, "max_inflight: " + std::to_string(n));
  return text;
}

/// A job as an observer saw it (the record's string_view reason copied).
struct SeenJob {
  JobId id = 0;
  int operation = -1;
  std::uint64_t seq = 0;
  TimePoint release{0};
  TimePoint deadline{0};
  TimePoint finish{0};
  JobOutcome outcome = JobOutcome::Unfinished;
  std::string reason;
  const RefinedGraph* graph = nullptr;
};

class Recorder final : public Observer {
 public:
  void on_job_release(const JobRecord& j) override { released.push_back(seen(j)); }
  void on_job_end(const JobRecord& j) override { ended.push_back(seen(j)); }
  void on_unit_start(const Dispatch& d) override { started.push_back(d); }

  /// The end record of job `id`, or null.
  [[nodiscard]] const SeenJob* end_of(JobId id) const {
    for (const SeenJob& j : ended)
      if (j.id == id) return &j;
    return nullptr;
  }
  /// How many dispatches included a member of job `id`.
  [[nodiscard]] int dispatches_of(JobId id) const {
    int n = 0;
    for (const Dispatch& d : started)
      n += std::any_of(d.members.begin(), d.members.end(),
                       [id](const Member& m) { return m.job == id; })
               ? 1
               : 0;
    return n;
  }

  std::vector<SeenJob> released;
  std::vector<SeenJob> ended;
  std::vector<Dispatch> started;

 private:
  static SeenJob seen(const JobRecord& j) {
    return SeenJob{j.id,      j.operation,           j.seq,  j.release, j.deadline, j.finish,
                   j.outcome, std::string(j.reason), j.graph};
  }
};

using Harness = test::Harness<Recorder>;

int unit_of(const RefinedGraph& g, const std::string& node) {
  const int v = g.spec->node_index(node);
  for (std::size_t i = 0; i < g.units.size(); ++i)
    if (g.units[i].node == v && g.units[i].kind != UnitKind::Encoder) return static_cast<int>(i);
  throw std::runtime_error("no unit for node " + node);
}

std::string node_name(const Member& m) {
  return m.graph->spec->nodes[static_cast<std::size_t>(m.node)].name;
}

PolicyOptions options_of(const char* preset, DropMode drop) {
  PolicyOptions o = *preset_options(preset);
  o.drop = drop;
  return o;
}

// ---- re-assignment (docs/DESIGN.md, "Re-assignment")
// ---------------------------------------------------------------------

TEST(Reassignment, LongRunningUnitMovesLaterDeadlines) {
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida");
  h.frame(0, 1, r);
  const auto d0 = h.step(r);
  ASSERT_EQ(d0.size(), 1u);
  EXPECT_EQ(node_name(d0[0].members[0]), "A");
  EXPECT_EQ(d0[0].deadline, r + 40ms);
  const RefinedGraph& g = *h.s().graph(0);
  const int a = unit_of(g, "A"), b = unit_of(g, "B"), c = unit_of(g, "C");

  // Mid-way, A running for 10 ms: its remaining cost is 10, B's 20: L_0 = 20, L_1 = 40,
  // budget 110 ms from now.
  EXPECT_EQ(h.s().unit_deadline(0, a, r + 10ms), r + 10ms + Duration{mul_div(110'000'000, 20, 60)});
  EXPECT_EQ(h.s().unit_deadline(0, b, r + 10ms), r + 10ms + Duration{mul_div(110'000'000, 20, 60)});
  EXPECT_EQ(h.s().unit_deadline(0, c, r + 10ms), r + 120ms);

  // A runs long: completes at r + 50. B gets 20/60 of the 70 ms left, from now.
  h.complete(0, r + 50ms);
  const auto d1 = h.step(r + 50ms);
  ASSERT_EQ(d1.size(), 1u);
  EXPECT_EQ(node_name(d1[0].members[0]), "B");
  EXPECT_EQ(d1[0].deadline, r + 50ms + Duration{mul_div(70'000'000, 20, 60)});

  // After A and B: all that is left of the budget goes to C: r + 120.
  h.complete(0, r + 70ms);
  EXPECT_EQ(h.s().unit_deadline(0, c, r + 70ms), r + 120ms);
  const auto d2 = h.step(r + 70ms);
  ASSERT_EQ(d2.size(), 1u);
  EXPECT_EQ(node_name(d2[0].members[0]), "C");
  EXPECT_EQ(d2[0].deadline, r + 120ms);
  h.complete(0, r + 110ms);
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Met);
}

TEST(Reassignment, StaticRedFgDeadlinesDoNotMove) {
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-fg");
  h.frame(0, 1, r);
  const auto d0 = h.step(r);
  ASSERT_EQ(d0.size(), 1u);
  EXPECT_EQ(d0[0].deadline, r + 40ms);
  const RefinedGraph& g = *h.s().graph(0);
  EXPECT_EQ(h.s().unit_deadline(0, unit_of(g, "A"), r + 10ms), r + 40ms);
  EXPECT_EQ(h.s().unit_deadline(0, unit_of(g, "B"), r + 30ms), r + 40ms);
  h.complete(0, r + 50ms);
  const auto d1 = h.step(r + 50ms);
  ASSERT_EQ(d1.size(), 1u);
  EXPECT_EQ(node_name(d1[0].members[0]), "B");
  EXPECT_EQ(d1[0].deadline, r + 40ms);  // already past: static deadlines never move
  h.complete(0, r + 70ms);
  const auto d2 = h.step(r + 70ms);
  ASSERT_EQ(d2.size(), 1u);
  EXPECT_EQ(d2[0].deadline, r + 120ms);
}

TEST(Reassignment, RemainingCostOfRunningUnitsIsCostMinusElapsed) {
  // Two lanes: A and B run together from r.
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida", std::nullopt, 2);
  h.frame(0, 1, r);
  ASSERT_EQ(h.step(r).size(), 2u);
  const RefinedGraph& g = *h.s().graph(0);
  const int a = unit_of(g, "A"), c = unit_of(g, "C");
  // At r + 10: L_0 = 20 − 10 = 10, L_1 = 40; budget 110: D_0 = 22.
  EXPECT_EQ(h.s().unit_deadline(0, a, r + 10ms), r + 32ms);
  EXPECT_EQ(h.s().unit_deadline(0, c, r + 10ms), r + 120ms);
  // At r + 30 both overran: max(0, 20 − 30) = 0, so height 0 gets none of the budget.
  EXPECT_EQ(h.s().unit_deadline(0, a, r + 30ms), r + 30ms);
  EXPECT_EQ(h.s().unit_deadline(0, c, r + 30ms), r + 120ms);
}

TEST(Reassignment, LateJobGetsItsEndToEndDeadline) {
  // drop: none, so the late job stays and its budget goes ≤ 0.
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida", options_of("red-ida", DropMode::None));
  h.frame(0, 1, r);
  ASSERT_EQ(h.step(r).size(), 1u);
  const RefinedGraph& g = *h.s().graph(0);
  EXPECT_EQ(h.s().unit_deadline(0, unit_of(g, "B"), r + 125ms), r + 120ms);
  EXPECT_EQ(h.s().unit_deadline(0, unit_of(g, "C"), r + 125ms), r + 120ms);
  EXPECT_EQ(h.s().unit_deadline(0, unit_of(g, "B"), r + 120ms), r + 120ms);  // budget == 0
  h.complete(0, r + 130ms);
  const auto d = h.step(r + 130ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(node_name(d[0].members[0]), "B");
  EXPECT_EQ(d[0].deadline, r + 120ms);
}

// ---- docs/DESIGN.md, "Task model" dynamic workload
// -------------------------------------------------------------------

TEST(DynamicWorkload, EventChangesTheGraphForLaterJobsOnly) {
  const std::string text = R"(name: evt
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: job
    trigger: cam
    deadline_ms: 900
    max_inflight: 5
    nodes:
      A: {cost_ms: 20}
      C: {cost_ms: 40}
    edges: [[A, C]]
events:
  - {at_s: 1, add_nodes: {operation: job, nodes: {D: {cost_ms: 5}}, edges: [[C, D]]}}
)";
  Harness h(text, "red-ida");
  const RefinedGraph* before = h.s().graph(0);
  ASSERT_NE(before, nullptr);
  h.frame(0, 1, 800ms);
  h.frame(0, 2, 900ms);
  ASSERT_EQ(h.step(900ms).size(), 1u);
  h.frame(0, 3, 1000ms);  // the event is applied first: this job has the new graph
  h.frame(0, 4, 1100ms);
  h.frame(0, 5, 1200ms);
  const RefinedGraph* after = h.s().graph(0);
  ASSERT_NE(after, nullptr);
  EXPECT_NE(after, before);
  EXPECT_EQ(before->units.size(), 2u);
  EXPECT_EQ(after->units.size(), 3u);
  EXPECT_EQ(after->levels, 3);

  const auto& rel = h.rec().released;
  ASSERT_EQ(rel.size(), 5u);
  EXPECT_EQ(rel[0].graph, before);
  EXPECT_EQ(rel[1].graph, before);
  // One refinement per graph version: every later job shares the same RefinedGraph.
  EXPECT_EQ(rel[2].graph, after);
  EXPECT_EQ(rel[3].graph, after);
  EXPECT_EQ(rel[4].graph, after);

  h.run_out(1200ms);
  ASSERT_EQ(h.rec().ended.size(), 5u);
  for (const SeenJob& j : h.rec().ended) EXPECT_EQ(j.outcome, JobOutcome::Met) << j.seq;
  EXPECT_EQ(h.rec().dispatches_of(rel[0].id), 2);  // A, C: its old graph
  EXPECT_EQ(h.rec().dispatches_of(rel[1].id), 2);
  EXPECT_EQ(h.rec().dispatches_of(rel[2].id), 3);  // A, C, D
  EXPECT_EQ(h.rec().dispatches_of(rel[4].id), 3);
}

// ---- docs/DESIGN.md, "Drops" drops and overload
// -----------------------------------------------------------------

TEST(Drops, StrictAbortsAtTheDeadlineAndDiscardsTheRunningUnit) {
  for (const char* policy : {"red-fg", "red-ida", "edf"}) {
    SCOPED_TRACE(policy);
    const TimePoint r = 100ms;
    Harness h(kWorked, policy);
    h.frame(0, 1, r);
    const auto d0 = h.step(r);
    ASSERT_EQ(d0.size(), 1u);
    EXPECT_EQ(h.s().next_wakeup(), r + 120ms);
    EXPECT_EQ(h.s().ready_tasks(), 1);  // B queued (C blocked)
    // A runs far too long; the deadline passes while it runs.
    EXPECT_TRUE(h.step(r + 120ms).empty());
    ASSERT_EQ(h.rec().ended.size(), 1u);
    EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Dropped);
    EXPECT_EQ(h.rec().ended[0].finish, r + 120ms);
    EXPECT_EQ(h.s().ready_tasks(), 0);  // B removed from the queue
    EXPECT_EQ(h.s().jobs_in_flight(), 0);
    EXPECT_NE(h.s().running(0), nullptr);  // non-preemptive: A still runs
    h.complete(0, r + 130ms);
    EXPECT_TRUE(h.step(r + 130ms).empty());  // A's output discarded: C never becomes ready
    EXPECT_EQ(h.rec().ended.size(), 1u);     // reported once
    EXPECT_EQ(h.rec().started.size(), 1u);
  }
}

// A runtime's deadline timer can fire after the last unit's completion reached the
// scheduler: under strict drops that job is still aborted (its output discarded), as the
// simulator, which orders events by time, has it.
TEST(Drops, StrictDropsAJobWhoseLastUnitEndedPastTheDeadlineBeforeItsTimer) {
  // mono: one unit ending at r + 130; edf: A, B, C ending at r + 45, r + 90, r + 135.
  const std::pair<const char*, Duration> cases[] = {{"mono", 130ms}, {"edf", 45ms}};
  for (const auto& [policy, each] : cases) {
    SCOPED_TRACE(policy);
    const TimePoint r = 100ms;
    Harness h(kWorked, policy);
    h.frame(0, 1, r);
    ASSERT_FALSE(h.step(r).empty());
    TimePoint t = r;
    // Complete every unit as it is dispatched, the last one past the deadline (r + 120),
    // without a step at the deadline itself.
    for (int guard = 0; guard < 8 && h.rec().ended.empty(); ++guard) {
      t += each;
      h.complete(0, t);
      if (h.rec().ended.empty()) h.step(t);
    }
    ASSERT_EQ(h.rec().ended.size(), 1u);
    EXPECT_GT(h.rec().ended[0].finish, r + 120ms);
    EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Dropped);
    EXPECT_EQ(h.rec().ended[0].reason, "deadline passed");
  }
}

TEST(Drops, NoneLetsLateJobsFinishAsMissed) {
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida", options_of("red-ida", DropMode::None));
  h.frame(0, 1, r);
  ASSERT_EQ(h.step(r).size(), 1u);
  EXPECT_EQ(h.s().next_wakeup(), kNever);  // no deadline wake-up without drops
  EXPECT_TRUE(h.step(r + 120ms).empty());
  EXPECT_TRUE(h.rec().ended.empty());
  h.complete(0, r + 130ms);
  const TimePoint end = h.run_out(r + 130ms);
  EXPECT_EQ(end, r + 190ms);  // B 20 then C 40
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Missed);
  EXPECT_EQ(h.rec().ended[0].finish, r + 190ms);
  EXPECT_EQ(h.rec().ended[0].deadline, r + 120ms);
  EXPECT_EQ(h.rec().started.size(), 3u);
}

TEST(Drops, HopelessAbortsAtDispatch) {
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida", options_of("red-ida", DropMode::Hopeless));
  h.frame(0, 1, r);
  ASSERT_EQ(h.step(r).size(), 1u);  // r + 60 (critical path) fits in r + 120
  // A ends at r + 70: B and C still need 60 ms, r + 130 > r + 120: hopeless.
  h.complete(0, r + 70ms);
  EXPECT_TRUE(h.step(r + 70ms).empty());
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Dropped);
  EXPECT_EQ(h.rec().ended[0].finish, r + 70ms);
  EXPECT_EQ(h.s().ready_tasks(), 0);
  EXPECT_EQ(h.s().jobs_in_flight(), 0);

  // Strict waits for the deadline itself: B is dispatched at r + 70.
  Harness strict(kWorked, "red-ida");
  strict.frame(0, 1, r);
  ASSERT_EQ(strict.step(r).size(), 1u);
  strict.complete(0, r + 70ms);
  EXPECT_EQ(strict.step(r + 70ms).size(), 1u);
  EXPECT_TRUE(strict.rec().ended.empty());
}

TEST(Drops, HopelessKeepsJobsThatCanStillMakeIt) {
  const TimePoint r = 100ms;
  Harness h(kWorked, "red-ida", options_of("red-ida", DropMode::Hopeless));
  h.frame(0, 1, r);
  ASSERT_EQ(h.step(r).size(), 1u);
  h.complete(0, r + 55ms);  // B + C = 60: r + 115 ≤ r + 120
  EXPECT_EQ(h.step(r + 55ms).size(), 1u);
  h.run_out(r + 55ms);
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Met);
}

TEST(Drops, MaxInflightSkipsTheFrame) {
  Harness h(with_max_inflight(1), "red-ida");
  h.frame(0, 1, 0ms);
  ASSERT_EQ(h.step(0ms).size(), 1u);
  h.frame(0, 2, 10ms);  // job 1 is still in flight
  EXPECT_EQ(h.s().jobs_in_flight(), 1);
  ASSERT_EQ(h.rec().released.size(), 2u);
  EXPECT_EQ(h.rec().released[1].outcome, JobOutcome::Skipped);
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Skipped);
  EXPECT_EQ(h.rec().ended[0].seq, 1u);
  EXPECT_EQ(h.rec().ended[0].finish, 10ms);
  EXPECT_EQ(h.rec().ended[0].reason, "max_inflight");
  EXPECT_EQ(h.s().stats().releases, 2u);
  EXPECT_EQ(h.s().ready_tasks(), 1);  // only job 1's B: the skipped job queued nothing

  h.complete(0, 20ms);
  h.run_out(20ms);
  EXPECT_EQ(h.s().jobs_in_flight(), 0);
  h.frame(0, 3, 100ms);  // room again
  EXPECT_EQ(h.s().jobs_in_flight(), 1);
  EXPECT_EQ(h.rec().released.back().outcome, JobOutcome::Unfinished);
}

TEST(Drops, MaxInflightTwoByDefault) {
  std::string text = kWorked;
  text.erase(text.find("    max_inflight: 4\n"), 20);
  Harness h(text, "edf");
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 1ms);
  h.frame(0, 3, 2ms);
  EXPECT_EQ(h.s().jobs_in_flight(), 2);
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Skipped);
  EXPECT_EQ(h.rec().ended[0].seq, 2u);
}

TEST(Failures, FailedUnitFailsItsJobAndTheSchedulerGoesOn) {
  for (const char* policy : {"edf", "red-fg", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(kWorked, policy);
    h.frame(0, 1, 0ms);
    h.frame(0, 2, 10ms);
    const auto d0 = h.step(10ms);
    ASSERT_EQ(d0.size(), 1u);
    const JobId first = h.rec().released[0].id;
    const JobId second = h.rec().released[1].id;
    EXPECT_EQ(d0[0].members[0].job, first);
    h.complete(0, 30ms, UnitStatus::Failed, "CUDA error: device-side assert");
    const SeenJob* f = h.rec().end_of(first);
    ASSERT_NE(f, nullptr);
    EXPECT_EQ(f->outcome, JobOutcome::Failed);
    EXPECT_EQ(f->reason, "CUDA error: device-side assert");
    EXPECT_EQ(f->finish, 30ms);
    // The failed job's queued B is gone; the other job runs to completion.
    const auto d1 = h.step(30ms);
    ASSERT_EQ(d1.size(), 1u);
    EXPECT_EQ(d1[0].members[0].job, second);
    h.run_out(30ms);
    const SeenJob* s = h.rec().end_of(second);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->outcome, JobOutcome::Met);
    EXPECT_EQ(h.rec().ended.size(), 2u);
    EXPECT_EQ(h.rec().dispatches_of(first), 1);
    EXPECT_EQ(h.s().jobs_in_flight(), 0);
    EXPECT_EQ(h.s().ready_tasks(), 0);
  }
}

TEST(Failures, OutOfMemoryWithoutReasonNamesTheStatus) {
  Harness h(kWorked, "red-ida");
  h.frame(0, 1, 0ms);
  ASSERT_EQ(h.step(0ms).size(), 1u);
  h.complete(0, 5ms, UnitStatus::OutOfMemory);
  ASSERT_EQ(h.rec().ended.size(), 1u);
  EXPECT_EQ(h.rec().ended[0].outcome, JobOutcome::Failed);
  EXPECT_EQ(h.rec().ended[0].reason, "out-of-memory");
  EXPECT_TRUE(h.step(5ms).empty());
  // The next job is scheduled normally.
  h.frame(0, 2, 100ms);
  h.run_out(100ms);
  ASSERT_EQ(h.rec().ended.size(), 2u);
  EXPECT_EQ(h.rec().ended[1].outcome, JobOutcome::Met);
}

// ---- docs/DESIGN.md, "Dispatch" EDF tie-breaking
// -------------------------------------------------------------------

constexpr const char* kTwoOps = R"(name: ties
duration_s: 10
sensors:
  a: {rate_hz: 10}
  b: {rate_hz: 10}
operations:
  - name: zeta
    trigger: a
    deadline_ms: 100
    nodes: {Z: {cost_ms: 5}}
  - name: alpha
    trigger: b
    deadline_ms: 110
    nodes: {Y: {cost_ms: 5}}
)";

std::vector<int> ops_in_dispatch_order(const Recorder& r) {
  std::vector<int> out;
  for (const Dispatch& d : r.started) out.push_back(d.members.at(0).operation);
  return out;
}

// Own-clock releases come in tick order, ties in operation order, through an operation
// that leaves and comes back and a rate change (the scheduler keeps them in a heap of
// (tick, operation) whose stale entries it skips).
TEST(OwnClock, ReleasesInTickOrderTiesInOperationOrderAcrossEvents) {
  const std::string text = R"(name: ticks
duration_s: 10
operations:
  - {name: a, rate_hz: 10, phase_ms: 5, deadline_ms: 50, nodes: {x: {cost_ms: 0.1}}}
  - {name: b, rate_hz: 10, deadline_ms: 50, nodes: {x: {cost_ms: 0.1}}}
  - {name: c, rate_hz: 20, deadline_ms: 50, nodes: {x: {cost_ms: 0.1}}}
events:
  - {at_s: 0.22, remove_operation: {operation: b}}
  - {at_s: 0.26, set_rate: {operation: c, rate_hz: 10}}
  - {at_s: 0.32, add_operation: {name: b, rate_hz: 10, deadline_ms: 50, nodes: {x: {cost_ms: 0.1}}}}
)";
  Harness h(text, "red");
  TimePoint t{0};
  while (t < 400ms) {
    const TimePoint done = h.run_out(t);
    const TimePoint next = h.s().next_wakeup();
    ASSERT_GT(next, done);
    t = std::min(next, TimePoint{400ms});
  }
  std::vector<std::pair<std::int64_t, std::string>> got;
  for (const SeenJob& j : h.rec().released) {
    got.emplace_back(std::chrono::duration_cast<std::chrono::milliseconds>(j.release).count(),
                     j.graph != nullptr ? j.graph->spec->name : "?");
  }
  const std::vector<std::pair<std::int64_t, std::string>> want = {
      {0, "b"},   {0, "c"},   {5, "a"},   {50, "c"},  {100, "b"},
      {100, "c"}, {105, "a"}, {150, "c"}, {200, "b"}, {200, "c"},
      {205, "a"}, {250, "c"}, {305, "a"}, {320, "b"}, {360, "c"}};
  EXPECT_EQ(got, want);
}

TEST(TieBreaking, EqualDeadlinesEarlierReleaseFirst) {
  for (const char* policy : {"edf", "red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(kTwoOps, policy);
    h.frame(1, 1, 0ms);   // alpha: released at 0, deadline 110
    h.frame(0, 1, 10ms);  // zeta: released at 10, deadline 110
    const auto d = h.step(10ms);
    ASSERT_EQ(d.size(), 1u);
    EXPECT_EQ(d[0].deadline, 110ms);
    EXPECT_EQ(d[0].members[0].operation, 1);  // alpha, although zeta comes first in the file
    h.run_out(10ms);
    EXPECT_EQ(ops_in_dispatch_order(h.rec()), (std::vector<int>{1, 0}));
  }
}

TEST(TieBreaking, EqualDeadlinesAndReleasesOperationOrder) {
  std::string text = kTwoOps;
  text.replace(text.find("deadline_ms: 110"), 16, "deadline_ms: 100");
  for (const char* policy : {"edf", "red-fg", "red-ida", "red", "fifo"}) {
    SCOPED_TRACE(policy);
    Harness h(text, policy);
    h.frame(1, 1, 0ms);  // alpha's frame arrives first, at the same time
    h.frame(0, 1, 0ms);
    h.run_out(0ms);
    EXPECT_EQ(ops_in_dispatch_order(h.rec()), (std::vector<int>{0, 1}));  // scenario order
  }
}

TEST(TieBreaking, EqualDeadlinesNodeOrder) {
  const std::string text = R"(name: nodes
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: job
    trigger: cam
    deadline_ms: 100
    nodes:
      Y: {cost_ms: 5}
      X: {cost_ms: 5}
      W: {cost_ms: 5}
)";
  for (const char* policy : {"edf", "red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    Harness h(text, policy);
    h.frame(0, 1, 0ms);
    h.run_out(0ms);
    std::vector<std::string> order;
    for (const Dispatch& d : h.rec().started) order.push_back(node_name(d.members.at(0)));
    EXPECT_EQ(order, (std::vector<std::string>{"Y", "X", "W"}));  // file order, not names
  }
}

TEST(TieBreaking, NodeOrderIsTheScenarioOrderNotTheTopologicalOrder) {
  // R is listed before S, but S comes first in a topological order (R waits for Q, which is
  // listed after it). Once Q is done, R and S are ready with equal deadlines (same job, same
  // height): node order says R first.
  const std::string text = R"(name: topo
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: job
    trigger: cam
    deadline_ms: 100
    nodes:
      R: {cost_ms: 5}
      Q: {cost_ms: 5}
      S: {cost_ms: 5}
    edges: [[Q, R], [Q, S]]
)";
  for (const char* policy : {"edf", "red-fg", "red-ida"}) {
    SCOPED_TRACE(policy);
    Harness h(text, policy);
    h.frame(0, 1, 0ms);
    h.run_out(0ms);
    std::vector<std::string> order;
    for (const Dispatch& d : h.rec().started) order.push_back(node_name(d.members.at(0)));
    EXPECT_EQ(order, (std::vector<std::string>{"Q", "R", "S"}));
  }
}

TEST(TieBreaking, EarlierJobOfTheSameOperationFirst) {
  std::string text = kWorked;
  text.replace(text.find("deadline_ms: 120"), 16, "deadline_ms: 500");
  Harness h(text, "edf");
  // Job 0 released at 0 with D = 500; job 1 at 0 too (two frames at once): equal deadlines
  // and releases, so the job sequence decides; then node order within each job.
  h.frame(0, 1, 0ms);
  h.frame(0, 2, 0ms);
  h.run_out(0ms);
  std::vector<std::pair<std::uint64_t, std::string>> order;
  for (const Dispatch& d : h.rec().started)
    order.emplace_back(d.members.at(0).job_seq, node_name(d.members.at(0)));
  const std::vector<std::pair<std::uint64_t, std::string>> expect{{0, "A"}, {0, "B"}, {0, "C"},
                                                                  {1, "A"}, {1, "B"}, {1, "C"}};
  EXPECT_EQ(order, expect);
}

TEST(TieBreaking, RepeatedRunsDecideIdentically) {
  auto trace = [] {
    Harness h(kWorked, "red", std::nullopt, 2);
    std::vector<std::tuple<std::uint64_t, int, int, std::int64_t>> out;
    for (std::uint64_t f = 1; f <= 6; ++f) h.frame(0, f, std::chrono::milliseconds{15 * f});
    h.run_out(90ms);
    for (const Dispatch& d : h.rec().started)
      for (const Member& m : d.members)
        out.emplace_back(m.job_seq, m.unit, d.lane, d.deadline.count());
    return out;
  };
  const auto a = trace();
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, trace());
}

}  // namespace
}  // namespace red
