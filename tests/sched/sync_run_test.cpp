// docs/DESIGN.md, "Synchronization" on-demand synchronization, placement, round trips in dispatch
// estimates and the end of a run, on small scenarios with fixed costs (every unit's min = max), so
// that each schedule is worked out by hand in the comments and compared row by row with units.csv's
// records. Encoder 10 ms; heads lane 2, seg 3, steer 1, det 4 ms; batch of two heads of a
// kind 1.5 × one.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

LatencyStats fixed(double ms) {
  LatencyStats s;
  s.min = s.mean = s.p50 = s.p95 = s.p99 = s.max = from_ms(ms);
  s.samples = 1;
  return s;
}

// Every unit costs exactly its figure; a batch of b costs (1 + (b − 1) / 2) × one.
Profile fixed_profile() {
  Profile p = default_profile();
  auto set = [&](const std::string& unit, double ms) {
    UnitProfile u;
    for (int b = 1; b <= 4; ++b) u.by_batch.push_back(fixed(ms * (1.0 + (b - 1) / 2.0)));
    p.units[unit] = u;
  };
  set("encoder", 10);
  set("head/lane", 2);
  set("head/seg", 3);
  set("head/steer", 1);
  set("head/det", 4);
  return p;
}

PolicyRun run(const std::string& yaml, const std::string& policy) {
  auto s = parse_scenario(yaml, "sync.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  auto r = simulate_policy(*s, fixed_profile(), policy, 1, {}, true);
  EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().to_string());
  return *r;
}

struct Row {
  double start, end;
  int lane;
  bool round_trip;
};

std::vector<Row> rows(const PolicyRun& r) {
  std::vector<Row> v;
  for (const UnitRow& u : r.units)
    v.push_back({to_ms(u.start), to_ms(u.end), u.lane, u.round_trip});
  return v;
}

// One job, encoder → L, S, O → C; `scheduler` is the scenario's scheduler section.
std::string height_job(const std::string& scheduler = "") {
  return R"(
name: height
duration_s: 0.05
device: {lanes: 1, sync_cost_us: 100}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
)" + scheduler +
         R"(
sensors:
  cam: {rate_hz: 10}
operations:
  - name: drive
    trigger: cam
    deadline_ms: 100
    nodes:
      L: {head: lane, sensor: cam}
      S: {head: seg, sensor: cam}
      O: {head: det, sensor: cam}
      C: {head: steer, sensor: cam}
    edges: [[L, C], [S, C], [O, C]]
)";
}

// Item 1: one job, encoder → L, S, O (parallel heads) → C, one lane, round trip 0.1 ms.
// The handler is handed the job's run: the encoder, then the heads it feeds, then C, back
// to back. One round trip, before the encoder:
//   enc 0.1–10.1, L 10.1–12.1, S 12.1–15.1, O 15.1–19.1, C 19.1–20.1.
TEST(SyncRun, OnDemandRunsAWholeJobBackToBack) {
  const PolicyRun r = run(height_job(), "red");
  const std::vector<Row> v = rows(r);
  ASSERT_EQ(v.size(), 5u);
  const std::vector<Row> expected{{0.1, 10.1, 0, true},
                                  {10.1, 12.1, 0, false},
                                  {12.1, 15.1, 0, false},
                                  {15.1, 19.1, 0, false},
                                  {19.1, 20.1, 0, false}};
  for (std::size_t i = 0; i < v.size(); ++i) {
    EXPECT_NEAR(v[i].start, expected[i].start, 1e-9) << i;
    EXPECT_NEAR(v[i].end, expected[i].end, 1e-9) << i;
    EXPECT_EQ(v[i].round_trip, expected[i].round_trip) << i;
  }
  EXPECT_EQ(r.metrics.sync_round_trips, 1);
  // Per-edge pays one per unit: 5 round trips, the job ends at 20.5.
  const PolicyRun pe = run(height_job("scheduler: {sync: per-edge}"), "red");
  EXPECT_EQ(pe.metrics.sync_round_trips, 5);
  EXPECT_NEAR(to_ms(pe.units.back().end), 20.5, 1e-9);
}

// Item 2: two operations on one frame (op1: L → S; op2: C), merged encoder. Every member's
// heads follow the merged encoder without a round trip:
//   enc(op1, op2) 0.1–10.1; op1 L (deadline share earlier) 10.1–12.1, then op1 S and op2 C
//   in EDF order, all without a round trip.
TEST(SyncRun, EveryMemberOfAMergedEncoderContinuesTheRun) {
  const PolicyRun r = run(R"(
name: merged
duration_s: 0.05
device: {lanes: 1, sync_cost_us: 100}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - name: op1
    trigger: cam
    deadline_ms: 60
    nodes:
      L: {head: lane, sensor: cam}
      S: {head: seg, sensor: cam}
    edges: [[L, S]]
  - name: op2
    trigger: cam
    deadline_ms: 80
    nodes:
      C: {head: steer, sensor: cam}
)",
                          "red");
  const std::vector<Row> v = rows(r);
  ASSERT_EQ(v.size(), 4u);
  EXPECT_EQ(r.units[0].members, 3);  // one encoder run for the three nodes of both jobs
  EXPECT_TRUE(v[0].round_trip);
  for (std::size_t i = 1; i < v.size(); ++i) {
    EXPECT_FALSE(v[i].round_trip) << r.units[i].jobs;
    EXPECT_NEAR(v[i].start, v[i - 1].end, 1e-9) << r.units[i].jobs;
  }
  EXPECT_NEAR(v.back().end, 0.1 + 10 + 2 + 3 + 1, 1e-9);
  EXPECT_EQ(r.metrics.sync_round_trips, 1);
}

// Item 3: two cameras, one lane, round trip 1 ms; X (lane head, deadline 18.6 ms) and Y
// (lane head, deadline 40 ms). Both frames at 0. Encoders batch (15 ms, cheaper than 20)
// only if the batch, started after its round trip, meets X's encoder deadline; it does
// not (1 + 15 = 16 > X's share of 18.6), so X's encoder runs alone 1–11, X's head 11–13
// (X met at 13), then Y.
TEST(SyncRun, BatchingCountsTheRoundTripItPays) {
  const PolicyRun r = run(R"(
name: batch-rt
duration_s: 0.1
device: {lanes: 1, sync_cost_us: 1000}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  a: {rate_hz: 5}
  b: {rate_hz: 5}
operations:
  - name: X
    trigger: a
    deadline_ms: 18.6
    nodes:
      L: {head: lane, sensor: a}
  - name: Y
    trigger: b
    deadline_ms: 40
    nodes:
      L: {head: lane, sensor: b}
)",
                          "red");
  ASSERT_GE(r.units.size(), 2u);
  EXPECT_EQ(r.units[0].batch, 1) << "a batch would end X's encoder after its deadline";
  EXPECT_NEAR(to_ms(r.units[0].start), 1.0, 1e-9);
  EXPECT_NEAR(to_ms(r.units[0].end), 11.0, 1e-9);
  bool x_met = false;
  for (const JobRow& j : r.jobs)
    if (j.operation == 0) x_met = j.outcome == JobOutcome::Met;
  EXPECT_TRUE(x_met);
}

// Item 5: 50 Hz, a 30 ms node, D = 25 ms, max_inflight 1, 0.1 s, edf. Job 0 runs 0–30
// (dropped at 25, its unit goes on), the frame at 20 is skipped (job 0 still in flight),
// job 2 runs 40–70, job 4 from 80; releases stop at 100 and the run ends at job 4's drop
// at 105 with its unit still running: that unit has its row, cut at 105, and the lane was
// busy 30 + 30 + 25 of 105 ms (81 %).
TEST(SyncRun, AUnitStillRunningAtTheEndHasItsRow) {
  const PolicyRun r = run(R"(
name: end
duration_s: 0.1
device: {lanes: 1, sync_cost_us: 0}
operations:
  - name: op
    rate_hz: 50
    deadline_ms: 25
    max_inflight: 1
    nodes:
      N: {cost_ms: 30}
)",
                          "edf");
  ASSERT_EQ(r.units.size(), 3u);
  EXPECT_EQ(r.units.back().status, UnitStatus::Unfinished);
  EXPECT_NEAR(to_ms(r.units.back().start), 80.0, 1e-9);
  EXPECT_NEAR(to_ms(r.units.back().end), 105.0, 1e-9);
  EXPECT_EQ(r.metrics.dispatches, 3);
  ASSERT_EQ(r.metrics.lane_utilization.size(), 1u);
  EXPECT_NEAR(r.metrics.lane_utilization[0], 85.0 / 105.0, 1e-6);
}

// Item 6: two lanes; a job A → B of plain nodes (5 ms each) and a second operation's job
// released later keep the lanes apart. When A ends on lane 1 (the lane it was placed on) B
// follows on lane 1 without a round trip although lane 0 is idle too.
TEST(SyncRun, ASuccessorStaysOnTheLaneThatCanContinue) {
  const PolicyRun r = run(R"(
name: placement
duration_s: 0.05
device: {lanes: 2, sync_cost_us: 500}
operations:
  - name: first
    release: {count: 1}
    deadline_ms: 40
    nodes:
      P: {cost_ms: 2}
  - name: chain
    release: {count: 1}
    deadline_ms: 40
    nodes:
      A: {cost_ms: 5}
      B: {cost_ms: 5}
    edges: [[A, B]]
)",
                          "red");
  // 0: P on lane 0 (0.5–2.5), A on lane 1 (0.5–5.5); at 5.5 both lanes are idle and B
  // continues A's run on lane 1 (5.5–10.5), no round trip.
  ASSERT_EQ(r.units.size(), 3u);
  const UnitRow& a = r.units[1];
  const UnitRow& b = r.units[2];
  EXPECT_EQ(b.lane, a.lane);
  EXPECT_FALSE(b.round_trip);
  EXPECT_NEAR(to_ms(b.start), to_ms(a.end), 1e-9);
  EXPECT_EQ(r.metrics.sync_round_trips, 2);
}

// A chain is one run under on-demand synchronization; per-edge presets pay a round trip
// before every unit.
TEST(SyncRun, PerEdgePresetsPayOneRoundTripPerUnit) {
  const std::string yaml = R"(
name: chain
duration_s: 0.05
device: {lanes: 1, sync_cost_us: 200}
operations:
  - name: c
    release: {count: 1}
    deadline_ms: 40
    nodes:
      A: {cost_ms: 1}
      B: {cost_ms: 1}
      C: {cost_ms: 1}
    edges: [[A, B], [B, C]]
)";
  EXPECT_EQ(run(yaml, "red").metrics.sync_round_trips, 1);
  EXPECT_EQ(run(yaml, "red-ida").metrics.sync_round_trips, 3);
  EXPECT_NEAR(to_ms(run(yaml, "red").units.back().end), 3.2, 1e-9);
  EXPECT_NEAR(to_ms(run(yaml, "red-ida").units.back().end), 3.6, 1e-9);
}

}  // namespace
}  // namespace red
