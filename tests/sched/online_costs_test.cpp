// Online cost estimates (docs/DESIGN.md, "Online costs"; issue 53): the estimator on its own
// (what moves the plan and what does not), and in the simulator, with costs drawn from a
// profile other than the one the scheduler was given (`--costs`), deterministically.

#include "red/sched/online_costs.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

Profile scaled_profile(const Profile& p, double f) {
  Profile o = p;
  for (auto& [name, u] : o.units)
    for (LatencyStats& s : u.by_batch) s = s.scaled(f);
  return o;
}

ModelSpec four_heads() {
  ModelSpec m;
  m.heads = {"lane", "seg", "steer", "det"};
  return m;
}

Dispatch encoder_run(int batch) {
  Dispatch d;
  d.kind = UnitKind::Encoder;
  d.batch = batch;
  d.members.resize(static_cast<std::size_t>(batch));
  return d;
}

TEST(OnlineCosts, ASlowerRunMovesThePlanWithinASecond) {
  const Profile base = default_profile();
  const ModelSpec model = four_heads();
  OnlineCosts oc(base, model);
  const Duration p50 = base.find("encoder")->at(1).p50;
  TimePoint now{0};
  TimePoint moved = kNever;
  for (int i = 0; i < 100 && moved == kNever; ++i) {
    now += milliseconds{25};
    // Twice the profile's median, give or take 5 %.
    const double f = 2.0 + 0.1 * ((i % 3) - 1);
    oc.observe(encoder_run(1), scaled_by(p50, f), now);
    if (oc.update(now)) moved = now;
  }
  ASSERT_NE(moved, kNever);
  EXPECT_LE(moved, TimePoint{std::chrono::seconds{1}});
  const LatencyStats& planned = oc.plan().find("encoder")->at(1);
  EXPECT_NEAR(static_cast<double>(planned.p50.count()) / static_cast<double>(p50.count()), 2.0,
              0.11);
  // Batch sizes not seen take the unit's factor; the heads, unseen, keep the profile's.
  EXPECT_NEAR(static_cast<double>(oc.plan().find("encoder")->at(3).p99.count()) /
                  static_cast<double>(base.find("encoder")->at(3).p99.count()),
              2.0, 0.11);
  EXPECT_EQ(oc.plan().find("head/seg")->at(1).p99, base.find("head/seg")->at(1).p99);
  // The figures say so.
  bool seen = false;
  for (const UnitCostFigures& f : oc.figures())
    if (f.unit == "encoder" && f.batch == 1) {
      seen = true;
      EXPECT_NEAR(f.ratio(),
                  2.0 * static_cast<double>(p50.count()) /
                      static_cast<double>(base.find("encoder")->at(1).mean.count()),
                  0.2);
      EXPECT_GT(f.runs, 0);
    }
  EXPECT_TRUE(seen);
}

TEST(OnlineCosts, RunsAsTheProfileSaysLeaveThePlanAlone) {
  const Profile base = default_profile();
  const ModelSpec model = four_heads();
  OnlineCosts oc(base, model);
  const LatencyStats& s = base.find("encoder")->at(1);
  TimePoint now{0};
  // Draws spread over the profile's own distribution, in a scrambled order.
  for (int i = 0; i < 400; ++i) {
    now += milliseconds{10};
    const double u = std::fmod(0.618033988749895 * (i + 1), 1.0);
    oc.observe(encoder_run(1), s.quantile(u), now);
    EXPECT_FALSE(oc.update(now)) << "at run " << i;
  }
  EXPECT_EQ(oc.changes(), 0);
  EXPECT_EQ(&oc.plan(), &base);
}

TEST(OnlineCosts, AStrayOutlierDoesNotMoveThePlan) {
  const Profile base = default_profile();
  const ModelSpec model = four_heads();
  OnlineCosts oc(base, model);
  const LatencyStats& s = base.find("encoder")->at(1);
  TimePoint now{0};
  for (int i = 0; i < 60; ++i) {
    now += milliseconds{10};
    const double u = std::fmod(0.618033988749895 * (i + 1), 1.0);
    // One run in ten takes ten times its draw (a page fault, a preemption).
    const Duration took = i % 10 == 0 ? s.quantile(u) * 10 : s.quantile(u);
    oc.observe(encoder_run(1), took, now);
    oc.update(now);
  }
  EXPECT_EQ(oc.changes(), 0);
}

TEST(OnlineCosts, NotFollowedNeverMovesButMeasures) {
  const Profile base = default_profile();
  const ModelSpec model = four_heads();
  OnlineCostOptions o;
  o.follow = false;
  OnlineCosts oc(base, model, o);
  TimePoint now{0};
  for (int i = 0; i < 100; ++i) {
    now += milliseconds{25};
    oc.observe(encoder_run(1), base.find("encoder")->at(1).p50 * 3, now);
    EXPECT_FALSE(oc.update(now));
  }
  ASSERT_FALSE(oc.figures().empty());
  EXPECT_NEAR(oc.figures().front().ratio(),
              3.0 * static_cast<double>(base.find("encoder")->at(1).p50.count()) /
                  static_cast<double>(base.find("encoder")->at(1).mean.count()),
              0.01);
  EXPECT_EQ(oc.figures().front().factor, 1.0);
}

// The case in the simulator: the scheduler is given the built-in profile while the
// units cost more (a machine slower than the profile's, or a co-located process). Planning on
// the profile alone, red-robust misses more than with online estimates; with them the plan
// moves, and it misses at most 1.2× what planning on the right costs misses, + 2 points.
struct Outcome {
  double miss = 0;
  std::map<int, double> miss_by_op;
  int plan_changes = 0;
};

Outcome run(const Scenario& s, const Profile& plan, const Profile& costs, bool online,
            std::uint64_t seed) {
  Scenario sc = s;
  sc.scheduler.online_costs = online;
  auto r = simulate_policy(sc, plan, "red-robust", seed, {}, false, std::nullopt, &costs);
  EXPECT_TRUE(r.has_value()) << (r.has_value() ? "" : r.error().to_string());
  Outcome o;
  if (!r.has_value()) return o;
  o.miss = r->metrics.miss_rate;
  o.plan_changes = r->metrics.plan_changes;
  std::map<int, std::pair<int, int>> n;
  for (const JobRow& j : r->jobs) {
    auto& [all, missed] = n[j.operation];
    ++all;
    missed += j.outcome == JobOutcome::Met ? 0 : 1;
  }
  for (const auto& [op, c] : n)
    o.miss_by_op[op] = c.first > 0 ? static_cast<double>(c.second) / c.first : 0.0;
  return o;
}

TEST(OnlineCosts, TheSimulatorFollowsCostsOtherThanTheProfiles) {
  auto s = load_scenario(RED_SOURCE_DIR "/tests/data/workloads/warehouse/warehouse.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile given = default_profile();
  for (double factor : {1.6, 3.0}) {
    const Profile slow = scaled_profile(given, factor);
    double off = 0, on = 0, right = 0;
    std::map<int, double> top_on;
    for (std::uint64_t seed : {1U, 2U, 3U}) {
      off += run(*s, given, slow, false, seed).miss / 3;
      const Outcome o_on = run(*s, given, slow, true, seed);
      EXPECT_GE(o_on.plan_changes, 1) << "at " << factor << "x, seed " << seed;
      on += o_on.miss / 3;
      right += run(*s, slow, slow, true, seed).miss / 3;
      for (const auto& [op, m] : o_on.miss_by_op) top_on[op] += m / 3;
    }
    std::cout << "warehouse at " << factor
              << "x the built-in profile's costs, red-robust, 3 seeds: miss " << off
              << " planning on the profile, " << on << " with online estimates, " << right
              << " planning on the right costs; by operation with online estimates:";
    for (const auto& [op, m] : top_on) std::cout << " op" << op << " " << m;
    std::cout << "\n";
    EXPECT_LE(on, 1.2 * right + 0.02) << "at " << factor << "x";
    EXPECT_LT(on, off) << "at " << factor << "x";
  }
}

}  // namespace
}  // namespace red
