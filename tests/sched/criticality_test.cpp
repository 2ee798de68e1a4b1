// Criticality (docs/DESIGN.md, "Criticality"): under overload, lower-criticality operations are
// shed first.

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>

#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

// Two operations on one camera and one lane, together slightly more than the lane can do.
// EDF alone favours comfort (earlier deadline, listed first).
std::string overloaded(int safety_criticality) {
  return R"(
name: criticality
duration_s: 10
seed: 5
device: {lanes: 1, sync_cost_us: 0}
sensors:
  camera: {rate_hz: 40}
operations:
  - name: comfort
    trigger: camera
    deadline_ms: 25
    nodes:
      B: {cost: {mean_ms: 16, p99_ms: 20}}
  - name: safety
    trigger: camera
    deadline_ms: 35
    criticality: )" +
         std::to_string(safety_criticality) + R"(
    nodes:
      A: {cost: {mean_ms: 10, p99_ms: 14}}
)";
}

struct Misses {
  int safety = 0, comfort = 0, safety_jobs = 0, comfort_jobs = 0;
};

Misses run(const std::string& policy, int safety_criticality) {
  auto s = parse_scenario(overloaded(safety_criticality), "criticality.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  auto r = simulate_policy(*s, default_profile(), policy, 5, {}, false);
  EXPECT_TRUE(r.has_value());
  Misses m;
  for (const JobRow& j : r->jobs) {
    if (j.outcome == JobOutcome::Unfinished) continue;
    const bool missed = j.outcome != JobOutcome::Met;
    if (s->operation_name(j.operation) == "safety") {
      ++m.safety_jobs;
      m.safety += missed ? 1 : 0;
    } else {
      ++m.comfort_jobs;
      m.comfort += missed ? 1 : 0;
    }
  }
  return m;
}

class Criticality : public ::testing::TestWithParam<std::string> {};

TEST_P(Criticality, LowerCriticalityIsShedFirstUnderOverload) {
  const Misses equal = run(GetParam(), 0);
  const Misses ranked = run(GetParam(), 1);
  ASSERT_GT(equal.safety_jobs, 300);
  // Overloaded: with equal criticality both operations miss.
  EXPECT_GT(equal.safety + equal.comfort, 0);
  // With safety more critical, it misses less than before and less than comfort.
  EXPECT_LT(ranked.safety, equal.safety);
  EXPECT_LT(ranked.safety, ranked.comfort);
  RecordProperty("safety_misses_equal", equal.safety);
  RecordProperty("safety_misses_ranked", ranked.safety);
}

INSTANTIATE_TEST_SUITE_P(Deadline, Criticality, ::testing::Values("edf", "red-ida", "red"));

}  // namespace
}  // namespace red

namespace red {
namespace {

// Issue 37: on a workload nobody tuned it for (a delivery robot whose critical `avoid`
// operation joins for three seconds), red-robust must not miss more than red. It did: an
// operation at its max_inflight (saturation) and the "finish what was started" hold also
// put the criticality rule in force, so every unit of the critical operation's shared
// encoder went ahead of drive's unfinished heads even though the lanes could carry both
// (16.3 % of all jobs missed at 2x against red's 5.4 %). The rule now follows the demand
// test alone, as docs/DESIGN.md, "Criticality" says. At 2.5x admission and shed_lone then
// rejected 5.3 % of the critical operation's jobs (red: none) without regard to criticality;
// they now reject a job only where the jobs of its criticality or more overrun by themselves.
double miss_pct(const PolicyRun& r, int operation = -1) {
  int jobs = 0, missed = 0;
  for (const JobRow& j : r.jobs) {
    if (operation >= 0 && j.operation != operation) continue;
    ++jobs;
    missed += j.outcome == JobOutcome::Met ? 0 : 1;
  }
  return jobs == 0 ? 0.0 : 100.0 * missed / jobs;
}

TEST(CriticalityUnderLoad, RedRobustMissesNoMoreThanRedOnADeliveryRobot) {
  auto base = load_scenario(std::string(RED_TEST_DATA) + "/scenarios/delivery-robot.yaml");
  ASSERT_TRUE(base.has_value()) << base.error().to_string();
  const Profile p = default_profile();
  for (double rate : {1.0, 1.6, 2.0, 2.5}) {
    SCOPED_TRACE(rate);
    Scenario s = *base;
    ASSERT_FALSE(apply_override(s, "rate_scale", rate).has_value());
    auto red = simulate_policy(s, p, "red", s.seed);
    auto robust = simulate_policy(s, p, "red-robust", s.seed);
    ASSERT_TRUE(red.has_value() && robust.has_value());
    EXPECT_LE(miss_pct(*robust), miss_pct(*red) + 0.5);
    // The critical operation (`avoid`, added by the event: the last operation) is not
    // missed more under red-robust than under red.
    const int avoid = s.operation_count() - 1;
    ASSERT_EQ(s.operation_name(avoid), "avoid");
    EXPECT_LE(miss_pct(*robust, avoid), miss_pct(*red, avoid) + 0.5);
  }
}

// The same robot as written outside the project with the profile it was written with
// (tests/data/workloads/delivery-mnv3: a MobileNetV3-small encoder whose batch of 2 costs about
// what one frame costs). red-robust used to reject at release work that red finishes (14.81 %
// missed against 4.81 % at 1.0x): its demand test counted every frame's encoder run alone.
TEST(CriticalityUnderLoad, RedRobustMissesNoMoreThanRedOnTheDeliveryRobotsOwnProfile) {
  const std::string dir = std::string(RED_TEST_DATA) + "/workloads/delivery-mnv3/";
  auto base = load_scenario(dir + "delivery-mnv3.yaml");
  ASSERT_TRUE(base.has_value()) << base.error().to_string();
  auto p = load_profile(dir + "prof-mnv3-t1.json");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  for (double rate : {0.7, 1.0, 1.3}) {
    SCOPED_TRACE(rate);
    Scenario s = *base;
    ASSERT_FALSE(apply_override(s, "rate_scale", rate).has_value());
    auto red = simulate_policy(s, *p, "red", s.seed);
    auto robust = simulate_policy(s, *p, "red-robust", s.seed);
    ASSERT_TRUE(red.has_value() && robust.has_value());
    EXPECT_LE(miss_pct(*robust), miss_pct(*red) + 0.5);
    int rejected = 0;
    for (const JobRow& j : robust->jobs) rejected += j.reason == "rejected at release" ? 1 : 0;
    if (rate <= 1.0) {
      EXPECT_EQ(rejected, 0);
    }
  }
}

}  // namespace
}  // namespace red

namespace red {
namespace {

// Issue 53, item 3: the warehouse robot of tests/data/workloads/warehouse (a pedestrian detector of
// the highest criticality on the front camera, 50 ms; a lax shelf-label reader whose batch of
// two encoder runs took longer than the detector's slack) with its units costing 1.6 and 2 times
// the built-in profile (the simulator draws from the slower profile, --costs) and the plan
// following them (online estimates). Without the criticality guard the most critical operation
// missed the most: a less critical encoder batch started a few ms before a front frame and held
// the lane past the detector's slack. With it the detector misses no more than any other
// operation.
struct ByOperation {
  std::map<int, double> miss;  // operation -> percent of its jobs not met
  std::uint64_t holds = 0;     // the scheduler's guard_holds
};

ByOperation warehouse(double factor, std::uint64_t seed, const std::string& with) {
  auto s = load_scenario(std::string(RED_TEST_DATA) + "/workloads/warehouse/warehouse.yaml");
  EXPECT_TRUE(s.has_value()) << s.error().to_string();
  s->scheduler.online_costs = true;
  s->scheduler.policy_with = with;
  Profile slow = default_profile();
  for (auto& [name, u] : slow.units)
    for (LatencyStats& st : u.by_batch) st = st.scaled(factor);
  auto r =
      simulate_policy(*s, default_profile(), "red-robust", seed, {}, false, std::nullopt, &slow);
  EXPECT_TRUE(r.has_value());
  ByOperation out;
  out.holds = r->result.stats.guard_holds;
  std::map<int, int> jobs, missed;
  for (const JobRow& j : r->jobs) {
    if (j.release < TimePoint{} + s->warmup) continue;
    ++jobs[j.operation];
    missed[j.operation] += j.outcome == JobOutcome::Met ? 0 : 1;
  }
  for (const auto& [op, n] : jobs) out.miss[op] = 100.0 * missed[op] / n;
  return out;
}

TEST(CriticalityGuard, TheMostCriticalOperationMissesLeastInTheWarehouseAtSlowerCosts) {
  int violated_without = 0;
  for (double factor : {1.6, 2.0}) {
    for (std::uint64_t seed : {1U, 2U, 3U}) {
      SCOPED_TRACE(::testing::Message() << factor << "x, seed " << seed);
      const ByOperation on = warehouse(factor, seed, "");
      const ByOperation off = warehouse(factor, seed, "guard=no");
      ASSERT_TRUE(on.miss.contains(0));  // pedestrian, criticality 2
      EXPECT_GT(on.holds, 0U) << "the guard never waited for a release";
      EXPECT_EQ(off.holds, 0U);
      for (const auto& [op, m] : on.miss) EXPECT_LE(on.miss.at(0), m) << "operation " << op;
      for (const auto& [op, m] : off.miss) violated_without += off.miss.at(0) > m ? 1 : 0;
    }
  }
  // What the guard is for: without it the rule is broken in these runs.
  EXPECT_GT(violated_without, 0);
}

// A less critical frame joins a more critical job's batch only where that job still makes its
// deadline after the larger run with the guard's 5 % margin. One lane, two cameras at 10 Hz, their
// frames at the same instants: `critical` (criticality 1) runs a steer head (p99 0.75 ms) on
// camera a within 23.2 ms; `lax` a seg head on camera b within 200 ms. The built-in profile's
// encoder costs 14 ms (p99) alone and 21.7 ms for a batch of two: the batch makes the critical
// deadline by estimate (21.7 + 0.75 <= 23.2, and the encoder's intermediate deadline, 14 / 14.75
// of the job's, allows it) but not with the margin (22.785 + 0.75 > 23.2). Without the guard the
// two frames' encoder runs are batched; with it each runs alone.
TEST(CriticalityGuard, ALessCriticalFrameJoinsACriticalBatchOnlyWithTheMargin) {
  const std::string yaml = R"(
name: guard-join
duration_s: 3
seed: 3
device: {lanes: 1, sync_cost_us: 0}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  a: {rate_hz: 10}
  b: {rate_hz: 10}
operations:
  - name: critical
    trigger: a
    deadline_ms: 23.2
    criticality: 1
    nodes:
      S: {head: steer, sensor: a}
  - name: lax
    trigger: b
    deadline_ms: 200
    nodes:
      L: {head: seg, sensor: b}
)";
  auto s = parse_scenario(yaml, "guard-join.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  std::map<std::string, std::map<int, int>> encoder_runs;  // guard -> batch size -> runs
  for (const char* with : {"guard=yes", "guard=no"}) {
    s->scheduler.policy_with = with;
    auto r = simulate_policy(*s, default_profile(), "red-robust", 3);
    ASSERT_TRUE(r.has_value());
    for (const UnitRow& u : r->units)
      if (u.kind == UnitKind::Encoder) ++encoder_runs[with][u.batch];
  }
  EXPECT_GT(encoder_runs["guard=no"][2], 0) << "the frames no longer batch without the guard";
  EXPECT_EQ(encoder_runs["guard=yes"][2], 0);
  EXPECT_GT(encoder_runs["guard=yes"][1], 0);
}

// A more critical operation that waits on a less critical one (depends_on, use: latest) is not
// protected from the work it waits on: holding that work would hold the critical operation too.
// One lane; `sense` (criticality 0) runs a 30 ms plain node (p99 36 ms) at 10 Hz; `act`
// (criticality 1), released 25 ms after each, waits for sense's newest job and has 16 ms. By
// the p99 estimate a sense job started just before act's release would end too late for act
// (36 + 6 > 25 + 16 ms), and holding it costs sense nothing: without the rule the guard would
// hold sense until act's release, and act, waiting for that very job, would miss.
TEST(CriticalityGuard, NeverHoldsWorkThatAMoreCriticalOperationWaitsOn) {
  const std::string yaml = R"(
name: guard-depends
duration_s: 5
seed: 3
device: {lanes: 1, sync_cost_us: 0}
operations:
  - name: sense
    rate_hz: 10
    deadline_ms: 100
    nodes:
      S: {cost: {mean_ms: 30, p99_ms: 36}}
  - name: act
    rate_hz: 10
    phase_ms: 25
    deadline_ms: 16
    criticality: 1
    depends_on: {operation: sense, use: latest}
    nodes:
      A: {cost: {mean_ms: 5, p99_ms: 6}}
)";
  auto s = parse_scenario(yaml, "guard-depends.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  for (const char* with : {"guard=yes", "guard=no"}) {
    SCOPED_TRACE(with);
    s->scheduler.policy_with = with;
    auto r = simulate_policy(*s, default_profile(), "red-robust", 3, {}, false);
    ASSERT_TRUE(r.has_value());
    int sense = 0, act = 0, missed = 0;
    for (const JobRow& j : r->jobs) {
      if (j.outcome == JobOutcome::Unfinished) continue;
      (s->operation_name(j.operation) == "sense" ? sense : act) += 1;
      missed += j.outcome == JobOutcome::Met ? 0 : 1;
    }
    EXPECT_GT(sense, 40);
    EXPECT_GT(act, 40);
    EXPECT_EQ(missed, 0);
    EXPECT_EQ(r->result.stats.guard_holds, 0U);
  }
}

}  // namespace
}  // namespace red
