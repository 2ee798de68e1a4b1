// Intermediate deadline assignment (docs/DESIGN.md, "Intermediate deadlines"): the worked example,
// equal and proportional splits, level cost max vs sum, split_budget edge cases and per-node
// overrides, checked on refine() and through the Scheduler driven with a virtual time (no
// simulator).

#include <gtest/gtest.h>

#include <memory>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "../support/harness.hpp"
#include "red/graph/refine.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"
#include "red/sched/scheduler.hpp"

namespace red {
namespace {

using namespace std::chrono_literals;
using test::kWorked;
using test::parse;

// The paper's case study: A -> C -> B with per-node budgets 50 / 50 / 30 in 130 ms.
constexpr const char* kCaseStudy = R"(name: case
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: nav
    trigger: cam
    deadline_ms: 130
    nodes:
      A: {cost_ms: 10, deadline_ms: 50}
      B: {cost_ms: 10, deadline_ms: 30}
      C: {cost_ms: 10, deadline_ms: 50}
    edges: [[A, C], [C, B]]
)";

std::shared_ptr<const RefinedGraph> refine_first(const Scenario& s, const Profile& p,
                                                 RefineOptions opt) {
  const CostModel costs{&p, &s.model, s.scheduler.estimate};
  return refine(s.initial.at(0), 0, costs, opt);
}

int unit_of(const RefinedGraph& g, const std::string& node) {
  const int v = g.spec->node_index(node);
  for (std::size_t i = 0; i < g.units.size(); ++i)
    if (g.units[i].node == v && g.units[i].kind != UnitKind::Encoder) return static_cast<int>(i);
  throw std::runtime_error("no unit for node " + node);
}

std::vector<Duration> ms_list(std::initializer_list<std::int64_t> v) {
  std::vector<Duration> out;
  for (std::int64_t x : v) out.push_back(std::chrono::milliseconds{x});
  return out;
}

TEST(Deadlines, WorkedExampleOnRefinedGraph) {
  const Scenario s = parse(kWorked);
  const Profile p = default_profile();
  for (GraphMode mode : {GraphMode::Coarse, GraphMode::Fine}) {
    SCOPED_TRACE(to_string(mode));
    const auto g = refine_first(s, p, {mode, DeadlineMode::Proportional, LevelCost::Max});
    ASSERT_EQ(g->levels, 2);
    EXPECT_EQ(g->deadline, 120ms);
    EXPECT_EQ(g->units[static_cast<std::size_t>(unit_of(*g, "A"))].height, 0);
    EXPECT_EQ(g->units[static_cast<std::size_t>(unit_of(*g, "B"))].height, 0);
    EXPECT_EQ(g->units[static_cast<std::size_t>(unit_of(*g, "C"))].height, 1);
    EXPECT_EQ(g->level_cost, ms_list({20, 40}));  // L_0 = 20, L_1 = 40
    // D_0 = 40, D_1 = 80: offsets 40 and 120.
    EXPECT_EQ(g->static_offset, ms_list({40, 120}));
    EXPECT_EQ(g->critical_path, 60ms);
  }
}

TEST(Deadlines, WorkedExampleThroughTheScheduler) {
  const Scenario s = parse(kWorked);
  const Profile p = default_profile();
  for (const char* policy : {"red-fg", "red-ida", "red"}) {
    SCOPED_TRACE(policy);
    SchedulerConfig cfg = SchedulerConfig::from(s);
    cfg.lanes = 2;
    Scheduler sched(s, p, make_policy(policy), cfg);
    const TimePoint r = 1000ms;
    sched.apply_events(r);
    sched.on_frame(0, 1, r);
    sched.advance(r);
    const RefinedGraph& g = *sched.graph(0);
    // d(A) = d(B) = r + 40 ms, d(C) = r + 120 ms.
    EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "A"), r), r + 40ms);
    EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "B"), r), r + 40ms);
    EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "C"), r), r + 120ms);
    std::vector<Dispatch> first;
    for (const Dispatch* d : sched.dispatch(r)) first.push_back(*d);
    ASSERT_EQ(first.size(), 2u);
    for (const Dispatch& d : first) {
      sched.on_start(d.lane, r);
      ASSERT_EQ(d.members.size(), 1u);
      EXPECT_EQ(d.kind, UnitKind::Plain);
      EXPECT_EQ(d.deadline, r + 40ms);
    }
    EXPECT_EQ(first[0].members[0].node, 0);  // A before B: node order
    EXPECT_EQ(first[1].members[0].node, 1);
    sched.on_complete(0, r + 20ms, UnitStatus::Completed);
    sched.on_complete(1, r + 20ms, UnitStatus::Completed);
    const auto next = sched.dispatch(r + 20ms);
    ASSERT_EQ(next.size(), 1u);
    EXPECT_EQ(next[0]->members.at(0).node, 2);
    EXPECT_EQ(next[0]->deadline, r + 120ms);
  }
}

TEST(Deadlines, EqualAssignment) {
  const Scenario s = parse(kWorked);
  const Profile p = default_profile();
  // D / (K + 1) per height: 60 and 60, whatever the costs.
  const auto g = refine_first(s, p, {GraphMode::Coarse, DeadlineMode::Equal, LevelCost::Max});
  EXPECT_EQ(g->static_offset, ms_list({60, 120}));

  PolicyOptions o = *preset_options("red-fg");
  o.deadlines = DeadlineMode::Equal;
  Scheduler sched(s, p, make_policy("red-fg", o), SchedulerConfig::from(s));
  sched.on_frame(0, 1, 50ms);
  sched.advance(50ms);
  const auto d = sched.dispatch(50ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->deadline, 110ms);
  EXPECT_EQ(sched.unit_deadline(0, unit_of(*sched.graph(0), "C"), 50ms), 170ms);

  // Three levels: 40, 80, 120.
  EXPECT_EQ(split_budget(120ms, ms_list({1, 7, 100}), DeadlineMode::Equal), ms_list({40, 80, 120}));
}

TEST(Deadlines, EndToEndAndNoneModes) {
  const Scenario s = parse(kWorked);
  const Profile p = default_profile();
  for (DeadlineMode m : {DeadlineMode::EndToEnd, DeadlineMode::None}) {
    const auto g = refine_first(s, p, {GraphMode::Coarse, m, LevelCost::Max});
    EXPECT_EQ(g->static_offset, ms_list({120, 120})) << to_string(m);
  }
  // Coarse edf: every unit carries the job's end-to-end deadline.
  Scheduler sched(s, p, make_policy("edf"), SchedulerConfig::from(s));
  sched.on_frame(0, 1, 10ms);
  sched.advance(10ms);
  const auto d = sched.dispatch(10ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->deadline, 130ms);
  EXPECT_EQ(d[0]->kind, UnitKind::Plain);
}

TEST(Deadlines, LevelCostMaxVersusSum) {
  const Scenario s = parse(kWorked);
  const Profile p = default_profile();
  const auto gmax =
      refine_first(s, p, {GraphMode::Coarse, DeadlineMode::Proportional, LevelCost::Max});
  const auto gsum =
      refine_first(s, p, {GraphMode::Coarse, DeadlineMode::Proportional, LevelCost::Sum});
  EXPECT_EQ(gmax->level_cost, ms_list({20, 40}));
  EXPECT_EQ(gsum->level_cost, ms_list({40, 40}));  // A + B at height 0
  EXPECT_EQ(gmax->static_offset, ms_list({40, 120}));
  EXPECT_EQ(gsum->static_offset, ms_list({60, 120}));

  // The scenario's scheduler.level_cost reaches the scheduler.
  std::string sum_text = kWorked;
  sum_text.insert(sum_text.find("sensors:"), "scheduler: {level_cost: sum}\n");
  const Scenario ssum = parse(sum_text);
  ASSERT_EQ(ssum.scheduler.level_cost, LevelCost::Sum);
  Scheduler sched(ssum, p, make_policy("red-fg"), SchedulerConfig::from(ssum));
  sched.on_frame(0, 1, 0ms);
  sched.advance(0ms);
  const auto d = sched.dispatch(0ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0]->deadline, 60ms);
}

TEST(Deadlines, FineGraphHeightsWithInferenceNodes) {
  // Encoders are sources (height 0); heads follow their encoder and their predecessors.
  const Scenario s = parse(R"(name: fine
duration_s: 10
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - name: drive
    trigger: cam
    deadline_ms: 100
    nodes:
      L: {head: lane, sensor: cam}
      S: {head: seg, sensor: cam}
    edges: [[L, S]]
)");
  const Profile p = default_profile();
  const auto fine =
      refine_first(s, p, {GraphMode::Fine, DeadlineMode::Proportional, LevelCost::Max});
  ASSERT_EQ(fine->units.size(), 4u);
  EXPECT_EQ(fine->levels, 3);
  for (const RefinedUnit& u : fine->units) {
    if (u.kind == UnitKind::Encoder) {
      EXPECT_EQ(u.height, 0);
    }
  }
  EXPECT_EQ(fine->units[static_cast<std::size_t>(unit_of(*fine, "L"))].height, 1);
  EXPECT_EQ(fine->units[static_cast<std::size_t>(unit_of(*fine, "S"))].height, 2);
  // L_0 = encoder p99 14, L_1 = lane 3.6, L_2 = seg 4.8 (default profile).
  EXPECT_EQ(fine->level_cost, (std::vector<Duration>{14ms, 3600us, 4800us}));
  EXPECT_EQ(fine->static_offset.back(), 100ms);
  const std::vector<Duration> expect =
      split_budget(100ms, {14ms, 3600us, 4800us}, DeadlineMode::Proportional);
  EXPECT_EQ(fine->static_offset, expect);

  const auto coarse =
      refine_first(s, p, {GraphMode::Coarse, DeadlineMode::Proportional, LevelCost::Max});
  ASSERT_EQ(coarse->units.size(), 2u);
  EXPECT_EQ(coarse->level_cost, (std::vector<Duration>{17600us, 18800us}));
}

TEST(SplitBudget, ProportionalCumulativeOffsets) {
  EXPECT_EQ(split_budget(120ms, ms_list({20, 40}), DeadlineMode::Proportional), ms_list({40, 120}));
  EXPECT_EQ(split_budget(100ms, ms_list({1, 3}), DeadlineMode::Proportional), ms_list({25, 100}));
}

TEST(SplitBudget, EmptyWeights) {
  EXPECT_TRUE(split_budget(100ms, {}, DeadlineMode::Proportional).empty());
  EXPECT_TRUE(split_budget(100ms, {}, DeadlineMode::Equal).empty());
}

TEST(SplitBudget, AllZeroWeightsSplitEqually) {
  EXPECT_EQ(split_budget(90ms, ms_list({0, 0, 0}), DeadlineMode::Proportional),
            ms_list({30, 60, 90}));
}

TEST(SplitBudget, ZeroWeightHeightGetsNothing) {
  EXPECT_EQ(split_budget(90ms, ms_list({0, 10, 0}), DeadlineMode::Proportional),
            ms_list({0, 90, 90}));
  EXPECT_EQ(split_budget(90ms, ms_list({10, 0}), DeadlineMode::Proportional), ms_list({90, 90}));
}

TEST(SplitBudget, LastOffsetIsExactlyTheBudget) {
  // Shares that do not divide evenly still add up to the budget, with no rounding drift.
  const std::vector<Duration> thirds = split_budget(
      Duration{100}, {Duration{1}, Duration{1}, Duration{1}}, DeadlineMode::Proportional);
  EXPECT_EQ(thirds, (std::vector<Duration>{Duration{33}, Duration{66}, Duration{100}}));
  const std::vector<Duration> w{7ms, 13ms, 3ms, 11ms, 17ms, 5ms};
  for (Duration budget : {Duration{1}, Duration{999'999'937}, Duration{120ms}, Duration{3600s}}) {
    for (DeadlineMode m : {DeadlineMode::Proportional, DeadlineMode::Equal}) {
      const auto off = split_budget(budget, w, m);
      ASSERT_EQ(off.size(), w.size());
      EXPECT_EQ(off.back(), budget);
      for (std::size_t h = 1; h < off.size(); ++h) EXPECT_LE(off[h - 1], off[h]);
    }
  }
  // Large weights and budgets do not overflow (128-bit intermediate).
  const Duration day = std::chrono::hours{24};
  const auto big = split_budget(day, {day, day}, DeadlineMode::Proportional);
  EXPECT_EQ(big, (std::vector<Duration>{day / 2, day}));
}

TEST(SplitBudget, SingleLevelGetsEverything) {
  EXPECT_EQ(split_budget(77ms, ms_list({5}), DeadlineMode::Proportional), ms_list({77}));
  EXPECT_EQ(split_budget(77ms, ms_list({0}), DeadlineMode::Proportional), ms_list({77}));
  EXPECT_EQ(split_budget(77ms, ms_list({5}), DeadlineMode::Equal), ms_list({77}));
}

TEST(Deadlines, PerNodeOverridesCaseStudy) {
  const Scenario s = parse(kCaseStudy);
  const Profile p = default_profile();
  for (GraphMode mode : {GraphMode::Coarse, GraphMode::Fine}) {
    SCOPED_TRACE(to_string(mode));
    const auto g = refine_first(s, p, {mode, DeadlineMode::Proportional, LevelCost::Max});
    ASSERT_EQ(g->levels, 3);
    EXPECT_EQ(g->override_budget, ms_list({50, 50, 30}));
    // A 50, C 50, B 30: exactly the given budgets.
    EXPECT_EQ(g->static_offset, ms_list({50, 100, 130}));
  }
  Scheduler sched(s, p, make_policy("red-fg"), SchedulerConfig::from(s));
  const TimePoint r = 200ms;
  sched.on_frame(0, 1, r);
  sched.advance(r);
  const RefinedGraph& g = *sched.graph(0);
  EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "A"), r), r + 50ms);
  EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "C"), r), r + 100ms);
  EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "B"), r), r + 130ms);
}

TEST(Deadlines, OverridesWeighTheRemainingBudgetUnderReassignment) {
  const Scenario s = parse(kCaseStudy);
  const Profile p = default_profile();
  Scheduler sched(s, p, make_policy("red-ida"), SchedulerConfig::from(s));
  const TimePoint r = 200ms;
  sched.on_frame(0, 1, r);
  sched.advance(r);
  const auto d0 = sched.dispatch(r);
  ASSERT_EQ(d0.size(), 1u);
  EXPECT_EQ(d0[0]->deadline, r + 50ms);
  sched.on_start(0, r);
  // A done at r + 20: 110 ms left, split 50 : 30 between C and B.
  sched.on_complete(0, r + 20ms, UnitStatus::Completed);
  const auto d1 = sched.dispatch(r + 20ms);
  ASSERT_EQ(d1.size(), 1u);
  EXPECT_EQ(d1[0]->deadline, r + 20ms + Duration{mul_div(110'000'000, 50, 80)});
  const RefinedGraph& g = *sched.graph(0);
  EXPECT_EQ(sched.unit_deadline(0, unit_of(g, "B"), r + 20ms), r + 130ms);
}

TEST(Deadlines, OverridesAreWeightsOfTheirLevel) {
  // Overrides that do not add up to D are scaled with the other levels' weights: here
  // 50 / 50 / 30 in 260 ms gives 100 / 100 / 60.
  std::string text = kCaseStudy;
  text.replace(text.find("deadline_ms: 130"), 16, "deadline_ms: 260");
  const Scenario s = parse(text);
  const Profile p = default_profile();
  const auto g =
      refine_first(s, p, {GraphMode::Coarse, DeadlineMode::Proportional, LevelCost::Max});
  EXPECT_EQ(g->static_offset, ms_list({100, 200, 260}));

  // An override on one level only: A's override (120) replaces its cost (10) as the weight
  // of height 0; C and B keep their costs: weights 120, 10, 20 in 160 ms.
  const Scenario s2 = parse(R"(name: partial
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: nav
    trigger: cam
    deadline_ms: 160
    nodes:
      A: {cost_ms: 10, deadline_ms: 120}
      C: {cost_ms: 10}
      B: {cost_ms: 20}
    edges: [[A, C], [C, B]]
)");
  const auto g2 =
      refine_first(s2, p, {GraphMode::Coarse, DeadlineMode::Proportional, LevelCost::Max});
  EXPECT_EQ(g2->override_budget, ms_list({120, 0, 0}));
  EXPECT_EQ(g2->static_offset,
            split_budget(160ms, ms_list({120, 10, 20}), DeadlineMode::Proportional));
  EXPECT_EQ(g2->static_offset.front(), 128ms);  // 160 * 120 / 150
}

}  // namespace
}  // namespace red
