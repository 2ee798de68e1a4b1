// Refinement is semantics-preserving (docs/DESIGN.md, "Refinement"): on random DAG scenarios and
// under every preset policy (coarse, fine with merging and batching, mono), every node output of
// every completed job is produced exactly once, by a unit that read a frame of the node's own
// sensor — a frame that sensor had produced — and only after all its predecessors ended;
// no unit of a job starts after the job was reported ended. The same holds for ablations
// (option combinations no preset uses) and for sensors that start late.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "../support/random_scenario.hpp"
#include "../support/recording_observer.hpp"
#include "../support/semantics.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/simulator.hpp"

namespace red {
namespace {

constexpr std::uint64_t kScenarios = 40;

struct Tally {
  std::int64_t jobs = 0, completed = 0, met = 0, units = 0, merged = 0, batched = 0;
};

/// Runs `policy` on `s` and checks the recorded run; adds what it saw to `t`.
void run_and_check(const Scenario& s, const std::string& policy, Tally& t) {
  test::RecordingObserver rec;
  const auto run = simulate_policy(s, default_profile(), policy, s.seed, {&rec}, false);
  ASSERT_TRUE(run.has_value()) << run.error().to_string();
  const auto problems = test::check_semantics(s, rec);
  EXPECT_TRUE(problems.empty()) << test::join_lines(problems);
  EXPECT_EQ(rec.unknown_unit_ends(), 0U);
  EXPECT_EQ(rec.double_unit_ends(), 0U);
  for (const test::SeenJob& j : rec.jobs()) {
    ++t.jobs;
    t.completed += j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed ? 1 : 0;
    t.met += j.outcome == JobOutcome::Met ? 1 : 0;
  }
  for (const test::SeenUnit& u : rec.units()) {
    ++t.units;
    t.batched += u.d.batch > 1 ? 1 : 0;
    t.merged += static_cast<int>(u.d.members.size()) > u.d.batch ? 1 : 0;
  }
}

std::string policy_name(const testing::TestParamInfo<std::string>& info) {
  std::string n = info.param;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
}

class RefineSemantics : public testing::TestWithParam<std::string> {};

TEST_P(RefineSemantics, RandomDagsKeepNodeOutputsPrecedenceAndSensors) {
  const std::string& policy = GetParam();
  Tally t;
  for (std::uint64_t seed = 1; seed <= kScenarios; ++seed) {
    test::RandomScenarioOptions o;
    o.duration_s = 2.0;
    o.depends_on = seed % 4 == 0;
    o.events = seed % 3 == 0;  // graph versions change while jobs of the old one run
    const std::string yaml = test::random_scenario_yaml(seed, o);
    const auto s = parse_scenario(yaml, "random-" + std::to_string(seed) + ".yaml");
    ASSERT_TRUE(s.has_value()) << s.error().to_string() << "\n" << yaml;
    SCOPED_TRACE("scenario seed " + std::to_string(seed) + ":\n" + yaml);
    run_and_check(*s, policy, t);
    if (HasFailure()) return;  // one scenario's report is enough to debug
  }
  RecordProperty("jobs", static_cast<int>(t.jobs));
  RecordProperty("completed", static_cast<int>(t.completed));
  RecordProperty("met", static_cast<int>(t.met));
  RecordProperty("units", static_cast<int>(t.units));
  RecordProperty("merged", static_cast<int>(t.merged));
  RecordProperty("batched", static_cast<int>(t.batched));
  // The scenarios are sized so that most jobs complete: the check must have material.
  EXPECT_GT(t.completed * 2, t.jobs) << "completed " << t.completed << " of " << t.jobs;
  EXPECT_GT(t.units, 1000);
  if (policy == "red-fg" || policy == "red-ida" || policy == "red") {
    EXPECT_GT(t.merged, 0) << "no merged encoder run: DynamicMerge was not exercised";
  }
  if (policy == "red") {
    EXPECT_GT(t.batched, 0) << "no batch: inter-DAG batching was not exercised";
  }
}

INSTANTIATE_TEST_SUITE_P(Presets, RefineSemantics, testing::ValuesIn(default_presets()),
                         policy_name);

// A job whose nodes read two cameras: in the fine graph each head must read the frame its
// own encoder computed, of its own camera, even when the encoders of one sensor are merged
// across operations.
TEST(RefineSemantics, TwoSensorsTwoRatesFineGraph) {
  const std::string yaml = R"(name: two-sensors
duration_s: 3
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
scheduler: {gamma_ms: 20}
sensors:
  front: {rate_hz: 15}
  rear: {rate_hz: 10, phase_ms: 7, jitter_ms: 2}
operations:
  - name: fuse
    trigger: front
    deadline_ms: 150
    nodes:
      F: {head: lane, sensor: front}
      R: {head: det, sensor: rear}
      P: {cost_ms: 1.5}
      C: {head: steer, sensor: front}
    edges: [[F, P], [R, P], [P, C]]
  - name: watch
    rate_hz: 9
    deadline_ms: 200
    nodes:
      W: {head: seg, sensor: rear}
      V: {head: steer, sensor: front}
    edges: [[W, V]]
)";
  const auto s = parse_scenario(yaml, "two-sensors.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  for (const std::string& policy : default_presets()) {
    SCOPED_TRACE(policy);
    Tally t;
    run_and_check(*s, policy, t);
    EXPECT_GT(t.met, 20);
  }
}

// A job reads frames its sensors produced: before a sensor's first frame, trigger frames
// and release ticks of operations that read it release nothing, and a one-shot release
// waits for the frame (regression: such jobs used to read a "frame 0" that did not exist).
TEST(RefineSemantics, NoJobBeforeItsSensorsHaveFrames) {
  const std::string yaml = R"(name: late-camera
duration_s: 1
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  front: {rate_hz: 10}
  rear: {rate_hz: 10, phase_ms: 150}
operations:
  - name: once
    release: {count: 2}
    deadline_ms: 500
    nodes: {r: {head: steer, sensor: rear}}
  - name: fused
    trigger: front
    deadline_ms: 300
    nodes: {f: {head: lane, sensor: front}, r: {head: steer, sensor: rear}}
)";
  const auto s = parse_scenario(yaml, "late-camera.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  for (const std::string& policy : default_presets()) {
    SCOPED_TRACE(policy);
    test::RecordingObserver rec;
    const auto r = simulate_policy(*s, default_profile(), policy, 1, {&rec}, false);
    ASSERT_TRUE(r.has_value());
    const auto problems = test::check_semantics(*s, rec);
    EXPECT_TRUE(problems.empty()) << test::join_lines(problems);
    int once = 0, fused = 0;
    for (const test::SeenJob& j : rec.jobs()) {
      if (j.operation == 0) {
        ++once;
        EXPECT_EQ(j.release, std::chrono::milliseconds{150});
      } else {
        ++fused;
        EXPECT_GE(j.release, std::chrono::milliseconds{200});
      }
      EXPECT_EQ(j.outcome, JobOutcome::Met) << "job " << j.id;
    }
    EXPECT_EQ(once, 2);
    EXPECT_EQ(fused, 8);  // front frames at 200, 300, ..., 900 ms
  }
}

// Every column of the table in docs/DESIGN.md, "Policies", is an option of its own, so ablations
// combine them freely; refinement must stay semantics-preserving under any combination.
TEST(RefineSemantics, AblationsKeepTheInvariant) {
  struct Ablation {
    const char* name;
    PolicyOptions o;
  };
  const Ablation ablations[] = {
      {"fine-no-merge",
       {GraphMode::Fine, DeadlineMode::Proportional, false, false, false, SyncMode::PerEdge,
        DropMode::Strict}},
      {"fine-batch-no-merge",
       {GraphMode::Fine, DeadlineMode::Equal, true, false, true, SyncMode::OnDemand,
        DropMode::None}},
      {"coarse-proportional-hopeless",
       {GraphMode::Coarse, DeadlineMode::Proportional, true, false, true, SyncMode::PerEdge,
        DropMode::Hopeless}},
      {"mono-ondemand-hopeless",
       {GraphMode::Mono, DeadlineMode::EndToEnd, false, false, false, SyncMode::OnDemand,
        DropMode::Hopeless}},
      {"red-no-drop",
       {GraphMode::Fine, DeadlineMode::Proportional, true, true, true, SyncMode::OnDemand,
        DropMode::None}},
  };
  const Profile profile = default_profile();
  for (const Ablation& a : ablations) {
    for (std::uint64_t seed = 201; seed <= 215; ++seed) {
      test::RandomScenarioOptions o;
      o.depends_on = seed % 2 == 0;
      o.events = seed % 3 == 0;
      o.max_load = 2.5;
      const std::string yaml = test::random_scenario_yaml(seed, o);
      const auto s = parse_scenario(yaml, "random.yaml");
      ASSERT_TRUE(s.has_value()) << s.error().to_string();
      SCOPED_TRACE(std::string(a.name) + ", scenario seed " + std::to_string(seed) + ":\n" + yaml);
      test::RecordingObserver rec;
      SimOptions options;
      options.seed = s->seed;
      Simulator sim(*s, profile, make_policy("red", a.o), options);
      sim.add_observer(&rec);
      sim.run();
      const auto problems = test::check_semantics(*s, rec);
      ASSERT_TRUE(problems.empty()) << test::join_lines(problems);
      const auto lanes = test::check_lanes(*s, rec);
      ASSERT_TRUE(lanes.empty()) << test::join_lines(lanes);
      ASSERT_EQ(rec.idle_violation_count(), 0U);
      ASSERT_EQ(rec.end_events(), rec.release_events());
    }
  }
}

}  // namespace
}  // namespace red
