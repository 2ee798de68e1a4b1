// One conformance suite that every policy passes (as rclcpp runs one suite over all its
// executors), on the bundled scenarios and on random ones, through both drivers of the
// scheduler (tests/support/driver.hpp):
// * precedence respected for every job, and the refinement semantics of docs/DESIGN.md,
// "Refinement";
// * every released job accounted for exactly once, and the summary agrees;
// * no lane idles while a unit is ready (except a DynamicMerge wait), and a lane runs one
//   unit at a time;
// * deterministic under a seed, and sensitive to it where costs are random (the simulator
//   only: a real run's times, and so its decisions, differ from run to run).
//
// Instantiations: `AllPolicies` runs every policy on every scenario in the simulator;
// `Runtime` runs a subset (every bundled scenario with `red` and `red-robust`, `edf` on one,
// lanes that hold two units on the asynchronous backend) in the real-time runtime on the
// synthetic backend, each scenario's timeline compressed to kRuntimeDuration of wall time.
// Every expectation above holds in the runtime as it is stated: they are about what the
// scheduler decided and in which order its callbacks came (under its lock), never about how
// long anything took. (A lane's real idle time between a unit's end and the next start, the
// dispatch latency, is not asserted; the idle check reads the scheduler's own lane state at
// each decision.) The `Runtime` tests also run under ThreadSanitizer (names `*Runtime*`).

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <tuple>
#include <vector>

#include "../support/driver.hpp"
#include "../support/random_scenario.hpp"
#include "../support/recording_observer.hpp"
#include "../support/semantics.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using test::Driver;

/// Wall time of one runtime run (the scenario's timeline is compressed to it).
constexpr Duration kRuntimeDuration = std::chrono::milliseconds{600};

/// A scenario of the suite: a bundled file, or a random one from a seed.
struct Source {
  std::string label;
  std::string path;        ///< bundled: the file
  std::uint64_t seed = 0;  ///< random: the generator's seed
  int queue_depth = 0;     ///< > 0: lanes hold this many units (docs/DESIGN.md, "Queued lanes")
};

// How gtest prints a parameter (instead of its bytes).
void PrintTo(const Source& s, std::ostream* os) {
  *os << s.label;
}

std::vector<std::string> bundled_files() {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(RED_SOURCE_DIR) + "/scenarios", ec))
    if (e.path().extension() == ".yaml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

std::string bundled(const std::string& stem) {
  return std::string(RED_SOURCE_DIR) + "/scenarios/" + stem + ".yaml";
}

const std::vector<Source>& sources() {
  static const std::vector<Source> v = [] {
    std::vector<Source> out;
    const std::vector<std::string> files = bundled_files();
    for (const std::string& f : files)
      out.push_back({std::filesystem::path(f).stem().string(), f, 0});
    for (std::uint64_t seed = 101; seed <= 106; ++seed)
      out.push_back({"random-" + std::to_string(seed), "", seed});
    // Asynchronous lanes: a unit queued behind the running one (dispatch_ahead).
    out.push_back({"minibench-tight-queued", bundled("minibench-tight"), 0, 2});
    for (std::uint64_t seed = 101; seed <= 104; ++seed)
      out.push_back({"random-" + std::to_string(seed) + "-queued", "", seed, 2});
    return out;
  }();
  return v;
}

/// Random scenarios of the suite: events, depends_on, and enough load to drop jobs.
std::string random_yaml(std::uint64_t seed) {
  test::RandomScenarioOptions o;
  o.duration_s = 2.0;
  o.events = true;
  o.depends_on = true;
  o.max_load = 3.0;
  return test::random_scenario_yaml(seed, o);
}

Expected<Scenario> load(const Source& src) {
  auto s = !src.path.empty() ? load_scenario(src.path)
                             : parse_scenario(random_yaml(src.seed), src.label + ".yaml");
  if (s && src.queue_depth > 0) s->device.queue_depth = src.queue_depth;
  return s;
}

using Param = std::tuple<Driver, std::string, Source>;

std::string param_name(const testing::TestParamInfo<Param>& info) {
  std::string n = std::get<1>(info.param) + "_" + std::get<2>(info.param).label;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

/// The runtime's share of the suite: every bundled scenario with `red` and `red-robust`,
/// `edf` on one, and lanes that hold two units (asynchronous backend) with `red`.
std::vector<Param> runtime_params() {
  std::vector<Param> out;
  for (const std::string& f : bundled_files())
    for (const char* policy : {"red", "red-robust"})
      out.emplace_back(Driver::Runtime, policy,
                       Source{std::filesystem::path(f).stem().string(), f, 0, 0});
  out.emplace_back(Driver::Runtime, "edf", Source{"minibench-tight", bundled("minibench-tight")});
  out.emplace_back(Driver::Runtime, "red",
                   Source{"minibench-tight-queued", bundled("minibench-tight"), 0, 2});
  return out;
}

/// One run and what its observer recorded.
struct Recorded {
  test::RecordingObserver rec;
  test::DriverRun r;
};

// A runtime run lasts kRuntimeDuration of wall time: the suite's tests of one parameter
// check the same run, made by the first of them to ask (each check is independent of the
// others). Runs of an earlier iteration (--gtest_repeat) are not reused: a listener empties
// the cache as each iteration starts (a global environment would not: gtest sets those up
// once for all iterations).
std::map<std::string, std::shared_ptr<const Recorded>>& runtime_runs() {
  static std::map<std::string, std::shared_ptr<const Recorded>> runs;
  return runs;
}

class FreshRuntimeRunsPerIteration final : public testing::EmptyTestEventListener {
 public:
  void OnTestIterationStart(const testing::UnitTest& /*unit*/, int /*iteration*/) override {
    runtime_runs().clear();
  }
  void OnTestIterationEnd(const testing::UnitTest& /*unit*/, int /*iteration*/) override {
    runtime_runs().clear();
  }
};

[[maybe_unused]] const bool kFreshRuns = [] {
  testing::UnitTest::GetInstance()->listeners().Append(new FreshRuntimeRunsPerIteration);
  return true;
}();

class Conformance : public testing::TestWithParam<Param> {
 protected:
  void SetUp() override {
    const auto& [driver, policy, src] = GetParam();
    auto s = load(src);
    ASSERT_TRUE(s.has_value()) << s.error().to_string();
    scenario_ = driver == Driver::Runtime ? test::compressed(std::move(s.value()), kRuntimeDuration)
                                          : std::move(s.value());
    auto p = resolve_profile(scenario_, std::nullopt);
    ASSERT_TRUE(p.has_value()) << p.error().to_string();
    profile_ = std::move(p.value());
  }

  [[nodiscard]] Driver driver() const { return std::get<0>(GetParam()); }
  [[nodiscard]] const std::string& policy() const { return std::get<1>(GetParam()); }

  /// One run of the parameter's policy at `seed`, watched by `extra`.
  test::DriverRun run(std::uint64_t seed, const std::vector<Observer*>& extra = {}) {
    test::DriverOptions o;
    o.seed = seed;
    o.asynchronous = std::get<2>(GetParam()).queue_depth > 1;
    auto r = test::run_with_driver(driver(), scenario_, profile_, policy(), o, extra);
    EXPECT_TRUE(r.has_value()) << r.error().to_string();
    return r.has_value() ? std::move(r.value()) : test::DriverRun{};
  }

  /// The parameter's run at the scenario's seed and what it recorded: a fresh simulation,
  /// or the runtime's run of this parameter (see runtime_runs()).
  const Recorded& recorded() {
    if (driver() == Driver::Simulator) {
      own_ = std::make_shared<Recorded>();
      own_->r = run(scenario_.seed, {&own_->rec});
      return *own_;
    }
    const std::string key = policy() + "/" + std::get<2>(GetParam()).label;
    std::shared_ptr<const Recorded>& cached = runtime_runs()[key];
    if (!cached) {
      auto fresh = std::make_shared<Recorded>();
      fresh->r = run(scenario_.seed, {&fresh->rec});
      cached = std::move(fresh);
    }
    return *cached;
  }

  Scenario scenario_;
  Profile profile_;
  std::shared_ptr<Recorded> own_;
};

TEST_P(Conformance, PrecedenceAndRefinementSemantics) {
  const test::RecordingObserver& rec = recorded().rec;
  ASSERT_GT(rec.units().size(), 0U);
  test::SemanticsOptions opt;
  // Where wall time enters (a frame's stamp, an asynchronous lane's recorded end), the
  // runtime is checked for order, not lateness (SemanticsOptions::wall_clock).
  opt.wall_clock = driver() == Driver::Runtime;
  const auto problems = test::check_semantics(scenario_, rec, opt);
  EXPECT_TRUE(problems.empty()) << test::join_lines(problems);
  EXPECT_EQ(rec.unknown_unit_ends(), 0U);
  EXPECT_EQ(rec.double_unit_ends(), 0U);
}

TEST_P(Conformance, EveryReleasedJobAccountedForOnce) {
  const Recorded& run = recorded();
  const test::RecordingObserver& rec = run.rec;
  const PolicyRun& r = run.r.run;
  ASSERT_GT(rec.release_events(), 0U);
  EXPECT_EQ(rec.release_events(), r.result.stats.releases);
  EXPECT_EQ(rec.end_events(), rec.release_events());
  std::int64_t completed = 0, dropped = 0, unfinished = 0;
  std::int64_t counted = 0, c_completed = 0, c_dropped = 0, c_unfinished = 0, c_skipped = 0,
               c_failed = 0;
  for (const test::SeenJob& j : rec.jobs()) {
    EXPECT_EQ(j.releases, 1) << "job " << j.id << " released " << j.releases << " times";
    EXPECT_EQ(j.ends, 1) << "job " << j.id << " (" << to_string(j.outcome) << ") ended " << j.ends
                         << " times";
    if (j.skipped_at_release) {
      EXPECT_EQ(j.outcome, JobOutcome::Skipped) << "job " << j.id;
    }
    const bool done = j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
    const bool drop = j.outcome == JobOutcome::Dropped || j.outcome == JobOutcome::Skipped ||
                      j.outcome == JobOutcome::Failed;
    const bool open = j.outcome == JobOutcome::Unfinished;
    completed += done ? 1 : 0;
    dropped += drop ? 1 : 0;
    unfinished += open ? 1 : 0;
    if (j.outcome == JobOutcome::Met) {
      EXPECT_LE(j.finish, j.deadline) << "job " << j.id;
    }
    if (j.outcome == JobOutcome::Missed) {
      EXPECT_GT(j.finish, j.deadline) << "job " << j.id;
    }
    if (!j.counted) continue;
    ++counted;
    c_completed += done ? 1 : 0;
    c_dropped += drop ? 1 : 0;
    c_unfinished += open ? 1 : 0;
    c_skipped += j.outcome == JobOutcome::Skipped ? 1 : 0;
    c_failed += j.outcome == JobOutcome::Failed ? 1 : 0;
  }
  EXPECT_EQ(completed + dropped + unfinished, static_cast<std::int64_t>(rec.release_events()));
  const PolicyMetrics& m = r.metrics;
  EXPECT_EQ(m.jobs, counted);
  EXPECT_EQ(m.completed, c_completed);
  EXPECT_EQ(m.dropped, c_dropped);
  EXPECT_EQ(m.unfinished, c_unfinished);
  EXPECT_EQ(m.skipped, c_skipped);
  EXPECT_EQ(m.failed, c_failed);
  EXPECT_EQ(m.jobs, m.completed + m.dropped + m.unfinished);
  // missed includes dropped (docs/DESIGN.md, "Metrics")
  EXPECT_EQ(m.met + (m.missed - m.dropped), m.completed);
  EXPECT_EQ(static_cast<std::int64_t>(r.jobs.size()), counted);
  // No unit failed (the synthetic backend injects none here), so no job failed either.
  EXPECT_EQ(run.r.failures, 0U);
}

TEST_P(Conformance, NoLaneIdlesWhileWorkIsReadyAndOneUnitPerLane) {
  const test::RecordingObserver& rec = recorded().rec;
  ASSERT_GT(rec.decisions(), 0U);
  std::string first;
  for (const test::IdleViolation& v : rec.idle_violations())
    first += "  at " + std::to_string(v.now.count()) + " ns: ready " + std::to_string(v.ready) +
             ", idle lanes " + std::to_string(v.idle_lanes) + ", in a merge wait " +
             std::to_string(v.waiting) + "\n";
  EXPECT_EQ(rec.idle_violation_count(), 0U) << first;
  const auto lanes = test::check_lanes(scenario_, rec, driver() == Driver::Runtime);
  EXPECT_TRUE(lanes.empty()) << test::join_lines(lanes);
}

// Issue 53, "No batch that cannot finish": a batch is formed only where, at the costs the
// scheduler plans with when it decides (its online estimates, docs/DESIGN.md, "Online
// costs"), it ends by every member's deadline. Checked on what was decided, not on the time
// it took, so it holds in the runtime as stated.
TEST_P(Conformance, NoBatchThatCannotFinishByTheEstimate) {
  const test::RecordingObserver& rec = recorded().rec;
  int batches = 0;
  std::string first;
  for (const test::SeenUnit& u : rec.units()) {
    if (u.d.batch < 2) continue;
    ++batches;
    TimePoint due = kNever;
    for (const Member& m : u.d.members)
      if (m.graph != nullptr) due = std::min(due, m.release + m.graph->deadline);
    const TimePoint end = u.d.decided_at + u.d.expected;
    if (end > due && first.empty())
      first = "dispatch " + std::to_string(u.d.id) + ": batch of " + std::to_string(u.d.batch) +
              " decided at " + std::to_string(u.d.decided_at.count()) + " ns expected to end at " +
              std::to_string(end.count()) + " ns, after a member's deadline " +
              std::to_string(due.count()) + " ns";
  }
  EXPECT_TRUE(first.empty()) << first << " (" << batches << " batches)";
}

// The simulator only: a real run's unit times are the clock's, and its decisions follow
// them, so two runtime runs of one seed differ.
class SimulatorConformance : public Conformance {};

TEST_P(SimulatorConformance, DeterministicUnderASeed) {
  const PolicyRun a = run(scenario_.seed).run;
  const PolicyRun b = run(scenario_.seed).run;
  const SummaryHeader h{scenario_.name, "sim", "edf", scenario_.seed, profile_.source, {}, {}};
  EXPECT_EQ(summary_json(h, {a.metrics}), summary_json(h, {b.metrics}));
  EXPECT_EQ(jobs_csv(scenario_, {{policy(), &a.jobs}}), jobs_csv(scenario_, {{policy(), &b.jobs}}));
  EXPECT_EQ(units_csv(scenario_, {{policy(), &a.units}}),
            units_csv(scenario_, {{policy(), &b.units}}));
}

INSTANTIATE_TEST_SUITE_P(AllPolicies, Conformance,
                         testing::Combine(testing::Values(Driver::Simulator),
                                          testing::ValuesIn(known_policies()),
                                          testing::ValuesIn(sources())),
                         param_name);

INSTANTIATE_TEST_SUITE_P(Runtime, Conformance, testing::ValuesIn(runtime_params()), param_name);

INSTANTIATE_TEST_SUITE_P(AllPolicies, SimulatorConformance,
                         testing::Combine(testing::Values(Driver::Simulator),
                                          testing::ValuesIn(known_policies()),
                                          testing::ValuesIn(sources())),
                         param_name);

// Regression: a DynamicMerge wait that ends (its predicted member came) while every lane is
// busy used to leave a stale wake-up in the past, and the simulator spun at one instant.
TEST(ConformanceRegression, MergeWaitEndsWhileTheLaneIsBusy) {
  const std::string yaml = R"(name: merge-wait-busy-lane
duration_s: 1
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
scheduler: {gamma_ms: 10}
sensors:
  cam: {rate_hz: 100}
operations:
  - name: A
    rate_hz: 10
    deadline_ms: 100
    nodes: {a: {head: steer, sensor: cam}}
  - name: B
    rate_hz: 10
    phase_ms: 5
    deadline_ms: 100
    nodes: {b: {head: det, sensor: cam}}
  - name: C
    rate_hz: 10
    deadline_ms: 200
    nodes: {c: {cost_ms: 20}}
)";
  const auto s = parse_scenario(yaml, "merge-wait-busy-lane.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  for (const std::string& policy : known_policies()) {
    SCOPED_TRACE(policy);
    test::RecordingObserver rec;
    const auto r = simulate_policy(*s, default_profile(), policy, 1, {&rec}, false);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->metrics.jobs, 30);
    EXPECT_EQ(r->metrics.completed, 30);
    const auto problems = test::check_semantics(*s, rec);
    EXPECT_TRUE(problems.empty()) << test::join_lines(problems);
    if (policy == "red-fg") {
      EXPECT_GT(rec.merge_waits(), 0U) << "the scenario no longer exercises a merge wait";
    }
  }
}

// A different seed draws different execution times (the built-in profile's costs are
// random), so the per-job results differ.
class SeedSensitivity : public testing::TestWithParam<std::string> {};

TEST_P(SeedSensitivity, ADifferentSeedChangesJobsCsv) {
  const auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/minibench-tight.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const auto p = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const std::string& policy = GetParam();
  const auto a = simulate_policy(*s, *p, policy, 1, {}, false);
  const auto b = simulate_policy(*s, *p, policy, 2, {}, false);
  ASSERT_TRUE(a.has_value() && b.has_value());
  EXPECT_NE(jobs_csv(*s, {{policy, &a->jobs}}), jobs_csv(*s, {{policy, &b->jobs}}));
}

std::string policy_name(const testing::TestParamInfo<std::string>& p) {
  std::string n = p.param;
  std::replace(n.begin(), n.end(), '-', '_');
  return n;
}

INSTANTIATE_TEST_SUITE_P(AllPolicies, SeedSensitivity, testing::ValuesIn(known_policies()),
                         policy_name);

}  // namespace
}  // namespace red
