// Overload (docs/DESIGN.md, "Overload"): red-robust on seeded random DAG task sets
// (tests/support/load_grid.hpp) against edf and red, the wasted lane time, the accounting of every
// release, and criticality under combined overload.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "../support/load_grid.hpp"
#include "../support/size.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/scenario/builder.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"
#include "red/sim/simulator.hpp"

namespace red {
namespace {

// 18 cells (1, 2, 4 lanes × chain, fork-join, wide × plain, MIMONet) × 12 seeds, 2 s each; 2
// seeds a cell under a sanitizer (tests/support/size.hpp).
constexpr int kPerCell = test::sized(12, 2);
const std::vector<grid::SetSpec>& sets() {
  static const std::vector<grid::SetSpec> v = grid::grid_sets(kPerCell, 2.0);
  return v;
}

struct Worst {
  double diff = 1.0;
  std::string where;
  void see(double d, const grid::SetSpec& s, double load) {
    if (d >= diff) return;
    diff = d;
    where = std::string(grid::to_string(s.nodes)) + " " + grid::to_string(s.shape) + " seed " +
            std::to_string(s.seed) + " lanes " + std::to_string(s.lanes) + " load " +
            std::to_string(load);
  }
};

// At every load, on average over the grid, red-robust does at least as well as edf and as red
// (within 0.5 points); from capacity on, it is never worse than edf by more than 0.5 points at any
// single point. The worst single points are recorded (and in docs/journal/overload-grid.md): below
// capacity "never worse at any point" is not met everywhere yet (a few 2 s task sets on 4 lanes
// lose up to 4 points to hopeless aborts and admission).
TEST(Overload, RedRobustKeepsUpWithEdfAndRedAtEveryLoad) {
  const Profile p = default_profile();
  for (double load : {0.6, 1.0, 1.2, 2.0}) {
    Worst vs_edf, vs_red;
    double robust = 0, edf = 0, red = 0;
    for (const grid::SetSpec& spec : sets()) {
      const Scenario s = grid::set_scenario(spec, p, load);
      const double a = grid::evaluate(s, p, "red-robust").on_time;
      const double b = grid::evaluate(s, p, "edf").on_time;
      const double c = grid::evaluate(s, p, "red").on_time;
      vs_edf.see(a - b, spec, load);
      vs_red.see(a - c, spec, load);
      if (load >= 1.0) {
        EXPECT_GE(a, b - 0.005) << s.name << " at load " << load;
      }
      robust += a;
      edf += b;
      red += c;
    }
    const auto n = static_cast<double>(sets().size());
    RecordProperty("load_" + std::to_string(load) + "_worst_vs_edf",
                   std::to_string(vs_edf.diff) + " at " + vs_edf.where);
    RecordProperty("load_" + std::to_string(load) + "_worst_vs_red",
                   std::to_string(vs_red.diff) + " at " + vs_red.where);
    RecordProperty("load_" + std::to_string(load) + "_mean_robust_edf_red",
                   std::to_string(robust / static_cast<double>(sets().size())) + " " +
                       std::to_string(edf / static_cast<double>(sets().size())) + " " +
                       std::to_string(red / static_cast<double>(sets().size())));
    EXPECT_GE(robust / n, edf / n - 0.005) << "load " << load;
    EXPECT_GE(robust / n, red / n - 0.005) << "load " << load;
  }
}

// Where red already meets (nearly) every deadline, red-robust changes little: on average
// over those points within 0.5 points of red. The worst single point is recorded; it is a
// hopeless abort (mean estimate) of a job whose units then ran faster than their means.
TEST(Overload, BelowCapacityRedRobustMatchesRedOnAverage) {
  const Profile p = default_profile();
  Worst low;
  double sum = 0;
  int compared = 0;
  for (const grid::SetSpec& spec : sets()) {
    for (double load : {0.5, 0.8}) {
      const Scenario s = grid::set_scenario(spec, p, load);
      const double red = grid::evaluate(s, p, "red").on_time;
      if (red < 0.99) continue;  // nominally below capacity, but not for red
      const double d = grid::evaluate(s, p, "red-robust").on_time - red;
      low.see(-std::abs(d), spec, load);
      sum += std::abs(d);
      ++compared;
    }
  }
  ASSERT_GT(compared, 200 * kPerCell / 12);  // of 2 loads x 216 sets (x 36 under a sanitizer)
  RecordProperty("largest_difference", std::to_string(-low.diff) + " at " + low.where);
  RecordProperty("mean_difference", std::to_string(sum / compared));
  EXPECT_LE(sum / compared, 0.005);
}

TEST(Overload, WastedLaneTimeStaysSmallAtTwiceCapacity) {
  const Profile p = default_profile();
  double worst = 0, sum = 0;
  int n = 0, over = 0;
  std::string where;
  for (const grid::SetSpec& spec : sets()) {
    const Scenario s = grid::set_scenario(spec, p, 2.0);
    const grid::Point robust = grid::evaluate(s, p, "red-robust");
    const grid::Point edf = grid::evaluate(s, p, "edf");
    // Shedding early wastes less of the lanes than aborting at the deadline.
    EXPECT_LE(robust.wasted, edf.wasted + 1e-9) << s.name;
    sum += robust.wasted;
    ++n;
    over += robust.wasted > 0.20 ? 1 : 0;
    if (robust.wasted > worst) {
      worst = robust.wasted;
      where = s.name;
    }
  }
  RecordProperty("worst_wasted", std::to_string(worst) + " at " + where);
  RecordProperty("mean_wasted", std::to_string(sum / n));
  RecordProperty("points_over_20_percent", std::to_string(over));
  // The issue's 20 % holds on average with room to spare; a few single points exceed it
  // (recorded above and in docs/journal/overload-grid.md).
  EXPECT_LT(sum / n, 0.10) << "mean wasted lane time at 2x";
  EXPECT_LE(over * 20, n) << "more than 1 point in 20 wastes over 20 % of the lanes at 2x";
}

TEST(Overload, EveryReleaseIsAccountedFor) {
  const Profile p = default_profile();
  for (const grid::SetSpec& spec : sets()) {
    for (double load : {0.7, 1.5, 2.5}) {
      const Scenario s = grid::set_scenario(spec, p, load);
      for (const char* policy : {"edf", "red", "red-robust"}) {
        auto r = simulate_policy(s, p, policy, s.seed, {}, false);
        ASSERT_TRUE(r.has_value());
        const PolicyMetrics& m = r->metrics;
        // completed + dropped (which counts skipped and failed) + unfinished = released.
        EXPECT_EQ(m.completed + m.dropped + m.unfinished, m.jobs) << s.name << " " << policy;
        std::int64_t by_reason = 0;
        for (const auto& [why, count] : m.drop_reasons) by_reason += count;
        EXPECT_EQ(by_reason, m.dropped) << s.name << " " << policy;
        for (const JobRow& j : r->jobs) {
          if (j.outcome != JobOutcome::Dropped && j.outcome != JobOutcome::Skipped) continue;
          EXPECT_TRUE(j.reason == "deadline passed" || j.reason == "hopeless" ||
                      j.reason == "rejected at release" || j.reason == "max_inflight")
              << j.reason;
        }
      }
    }
  }
}

TEST(Overload, RedRobustBeatsEveryPaperPresetPastCapacityOnTheGrid) {
  // Not a target of its own: the reason red-robust exists, measured on the grid.
  const Profile p = default_profile();
  double robust = 0, red = 0, edf = 0;
  for (const grid::SetSpec& spec : sets()) {
    const Scenario s = grid::set_scenario(spec, p, 1.5);
    robust += grid::evaluate(s, p, "red-robust").on_time;
    red += grid::evaluate(s, p, "red").on_time;
    edf += grid::evaluate(s, p, "edf").on_time;
  }
  EXPECT_GT(robust, red);
  EXPECT_GT(robust, edf);
}

// The minibenchmark past its breakdown rate: every miss is a frame skipped at max_inflight.
// Ranking by job deadline while an operation is at its limit finishes the older job first,
// as mono (one unit per frame) does, so red-robust keeps up with mono where red does not.
TEST(Overload, RedRobustKeepsUpWithMonoOnTheMinibenchmarkPastItsLimit) {
  for (const char* name : {"minibench-tight", "minibench-loose"}) {
    auto base = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name + ".yaml");
    ASSERT_TRUE(base.has_value()) << base.error().to_string();
    for (double load : {1.5, 2.0, 2.5}) {
      Scenario s = *base;
      ASSERT_FALSE(apply_override(s, "rate_scale", load).has_value());
      const Profile p = default_profile();
      const grid::Point robust = grid::evaluate(s, p, "red-robust");
      const grid::Point mono = grid::evaluate(s, p, "mono");
      const grid::Point red = grid::evaluate(s, p, "red");
      EXPECT_GE(robust.on_time, mono.on_time - 0.005) << name << " at " << load;
      EXPECT_GE(robust.on_time, red.on_time - 0.005) << name << " at " << load;
    }
  }
}

// Criticality (docs/DESIGN.md, "Criticality") with issue 13's case: one lane, Hi (10 ms, deadline
// 11) and Lo (10 ms, deadline 12, criticality 5); each fits alone, not both. The demand test sees
// the combined overload: Lo, the critical one, goes first and meets its deadline; Hi is shed.
class CombinedOverload : public testing::TestWithParam<std::string> {};

TEST_P(CombinedOverload, TheLessCriticalJobIsShed) {
  auto s = parse_scenario(R"(
name: combined
duration_s: 0.05
device: {lanes: 1, sync_cost_us: 0}
operations:
  - name: Hi
    release: {count: 1}
    deadline_ms: 11
    nodes:
      H: {cost_ms: 10}
  - name: Lo
    release: {count: 1}
    deadline_ms: 12
    criticality: 5
    nodes:
      L: {cost_ms: 10}
)",
                          "combined.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  auto r = simulate_policy(*s, default_profile(), GetParam(), 1, {}, true);
  ASSERT_TRUE(r.has_value());
  ASSERT_EQ(r->jobs.size(), 2u);
  for (const JobRow& j : r->jobs) {
    if (s->operation_name(j.operation) == "Lo") {
      EXPECT_EQ(j.outcome, JobOutcome::Met);
      EXPECT_EQ(to_ms(j.finish - j.release), 10.0);  // it ran first, from 0 to 10
    } else {
      EXPECT_EQ(j.outcome, JobOutcome::Dropped);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Policies, CombinedOverload,
                         testing::Values("edf", "red-fg", "red-ida", "red", "red-robust"),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

TEST(Overload, MostCriticalOperationMissesLeastUnderOverload) {
  // Three operations on one lane at 1.6x the lane's capacity, criticality 0, 1, 2.
  auto s = parse_scenario(R"(
name: criticality-three
duration_s: 6
warmup_s: 0.5
seed: 3
device: {lanes: 1, sync_cost_us: 0}
operations:
  - name: low
    rate_hz: 40
    deadline_ms: 25
    nodes: {A: {cost: {mean_ms: 13, p99_ms: 15}}}
  - name: mid
    rate_hz: 40
    phase_ms: 3
    deadline_ms: 25
    criticality: 1
    nodes: {B: {cost: {mean_ms: 13, p99_ms: 15}}}
  - name: high
    rate_hz: 40
    phase_ms: 6
    deadline_ms: 25
    criticality: 2
    nodes: {C: {cost: {mean_ms: 13, p99_ms: 15}}}
)",
                          "three.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  for (const char* policy : {"edf", "red", "red-robust"}) {
    auto r = simulate_policy(*s, default_profile(), policy, 3, {}, false);
    ASSERT_TRUE(r.has_value());
    std::vector<int> miss(3, 0), jobs(3, 0);
    for (const JobRow& j : r->jobs) {
      if (j.outcome == JobOutcome::Unfinished) continue;
      ++jobs[static_cast<std::size_t>(j.operation)];
      miss[static_cast<std::size_t>(j.operation)] += j.outcome == JobOutcome::Met ? 0 : 1;
    }
    ASSERT_GT(jobs[2], 100) << policy;
    EXPECT_LT(miss[2], miss[1]) << policy;
    EXPECT_LT(miss[2], miss[0]) << policy;
    EXPECT_GT(miss[0] + miss[1], 0) << policy << ": not overloaded";
  }
}

// A profile taken under load says no job fits its deadline, yet the machine runs them in
// time: red-robust must not reject a job at release when no other job is due with it (a
// rejection would free the lane for nobody), and so must do as well as red.
TEST(Overload, APessimisticProfileDoesNotMakeRedRobustRejectLoneJobs) {
  ScenarioBuilder b("lone");
  b.duration(std::chrono::seconds{3}).lanes(1).sensor("camera", 10.0);
  b.operation("perceive")
      .trigger("camera")
      .deadline(std::chrono::milliseconds{40})
      .inference("L", "lane", "camera")
      .inference("C", "steer", "camera")
      .edge("L", "C");
  auto s = b.build();
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile real = default_profile();  // encoder 12 ms, lane 3 ms, steer 0.6 ms
  Profile pessimistic = real;              // the planning profile: 4x every cost
  for (auto& [name, unit] : pessimistic.units)
    for (LatencyStats& l : unit.by_batch)
      for (Duration* d : {&l.min, &l.mean, &l.p50, &l.p95, &l.p99, &l.max}) *d *= 4;
  auto red = simulate_policy(*s, pessimistic, "red", 1, {}, false, std::nullopt, &real);
  auto robust = simulate_policy(*s, pessimistic, "red-robust", 1, {}, false, std::nullopt, &real);
  ASSERT_TRUE(red.has_value() && robust.has_value());
  EXPECT_EQ(red->metrics.missed, 0);
  EXPECT_EQ(robust->metrics.missed, 0);
  EXPECT_EQ(robust->metrics.drop_reasons.count("rejected at release"), 0u);
  EXPECT_EQ(robust->metrics.completed, red->metrics.completed);
}

// Admission's margin (docs/DESIGN.md, "Overload"), worked out by hand: one lane, fixed costs, A and
// B (C ms each, deadline 2.1 C) released together. On the bare estimates both fit (2 C of work
// by 2.1 C). With C = 200 ms the offered load (0.4 s of work in the last 0.25 s) is past the lane's
// capacity and the margin applies: at 10 % the work due is 2.2 C, so B (equal work and
// criticality: the later of the two) is rejected at release and A runs alone from 0 to C;
// at 5 % (2.1 C) both still fit. With C = 10 ms the lane is below capacity and no margin
// applies: both run, back to back.
TEST(Overload, AdmissionMarginAppliesPastCapacity) {
  for (const int cost : {200, 10}) {
    auto s =
        parse_scenario(fmt::format(R"(
name: margin
duration_s: {}
device: {{lanes: 1, sync_cost_us: 0}}
operations:
  - name: A
    release: {{count: 1}}
    deadline_ms: {}
    nodes:
      X: {{cost_ms: {}}}
  - name: B
    release: {{count: 1}}
    deadline_ms: {}
    nodes:
      Y: {{cost_ms: {}}}
)",
                                   cost * 2.5 / 1000, cost * 21 / 10, cost, cost * 21 / 10, cost),
                       "margin.yaml");
    ASSERT_TRUE(s.has_value()) << s.error().to_string();
    for (const int margin : {0, 5, 10}) {
      Scenario sm = *s;
      sm.scheduler.policy_with = "admit_margin=" + std::to_string(margin);
      auto r = simulate_policy(sm, default_profile(), "red-robust", 1, {}, true);
      ASSERT_TRUE(r.has_value());
      ASSERT_EQ(r->jobs.size(), 2u);
      for (const JobRow& j : r->jobs) {
        const bool a = sm.operation_name(j.operation) == "A";
        if (a || margin < 10 || cost == 10) {
          EXPECT_EQ(j.outcome, JobOutcome::Met) << cost << " ms, margin " << margin;
          EXPECT_EQ(to_ms(j.finish - j.release), a ? cost : 2 * cost) << margin;
        } else {
          EXPECT_EQ(j.outcome, JobOutcome::Dropped) << cost << " ms, margin " << margin;
          EXPECT_EQ(j.reason, "rejected at release");
        }
      }
    }
  }
}

TEST(Overload, AdmissionMarginIsAWholePercent) {
  PolicyOptions o = *preset_options("red-robust");
  EXPECT_EQ(apply_options(o, "admit_margin=15"), "");
  EXPECT_EQ(o.admit_margin, 15);
  for (const char* bad : {"admit_margin=101", "admit_margin=-1", "admit_margin=5%",
                          "admit_margin=1.5", "admit_margin=x"}) {
    const std::string err = apply_options(o, bad);
    EXPECT_NE(err.find("admit_margin"), std::string::npos) << bad;
    EXPECT_EQ(o.admit_margin, 15) << bad;  // a bad value changes nothing
  }
  EXPECT_NE(describe(o).find("admit_margin=15"), std::string::npos);
}

// red-robust on `base` at rate_scale `load`, with the policy options `with` (--with's).
PolicyRun robust_at(const Scenario& base, double load, const char* with, bool keep_units = false) {
  Scenario s = base;
  EXPECT_FALSE(apply_override(s, "rate_scale", load).has_value());
  s.scheduler.policy_with = with;
  auto r = simulate_policy(s, default_profile(), "red-robust", s.seed, {}, keep_units);
  EXPECT_TRUE(r.has_value()) << r.error().to_string();
  return r ? std::move(*r) : PolicyRun{};
}

// The work bound admits the cheapest jobs first. One cheap operation (a 6.3 ms chain, 8.2 ms
// deadline) alone asks for 1.35 lanes at 2x; an expensive one (a 20.7 ms chain) asks for
// 0.65 more. Admission by deadline windows admits the expensive jobs (the cheap ones due
// after them are not released yet) and their units then block the cheap jobs, which are
// shed. shed_rate rejects the expensive operation's jobs at release instead, while the
// cheap one sheds: more jobs meet their deadlines. Below capacity it rejects nothing.
TEST(Overload, ShedByRateRejectsTheJobsThatCheaperOnesOutrank) {
  auto base = parse_scenario(R"(
name: shed-rate
duration_s: 4
warmup_s: 0.5
seed: 2
device: {lanes: 1, sync_cost_us: 0}
operations:
  - name: expensive
    rate_hz: 15.78
    phase_ms: 7.879
    deadline_ms: 85.757
    max_inflight: 4
    nodes:
      N0: {cost: {mean_ms: 1.528, p99_ms: 1.987}}
      N1: {cost: {mean_ms: 3.686, p99_ms: 4.792}}
      N2: {cost: {mean_ms: 5.518, p99_ms: 7.173}}
      N3: {cost: {mean_ms: 5.836, p99_ms: 7.586}}
      N4: {cost: {mean_ms: 4.173, p99_ms: 5.425}}
    edges: [[N0, N1], [N1, N2], [N2, N3], [N3, N4]]
  - name: cheap
    rate_hz: 107.0793
    phase_ms: 0.024
    deadline_ms: 8.167
    max_inflight: 4
    nodes:
      N0: {cost: {mean_ms: 3.817, p99_ms: 4.962}}
      N1: {cost: {mean_ms: 2.466, p99_ms: 3.205}}
    edges: [[N0, N1]]
)",
                             "shed-rate.yaml");
  ASSERT_TRUE(base.has_value()) << base.error().to_string();
  struct Count {
    int met = 0, expensive = 0, expensive_rejected = 0;
  };
  auto run = [&](double load, const char* with) {
    const PolicyRun r = robust_at(*base, load, with);
    Count c;
    for (const JobRow& j : r.jobs) {
      c.met += j.outcome == JobOutcome::Met ? 1 : 0;
      if (base->operation_name(j.operation) != "expensive") continue;
      ++c.expensive;
      c.expensive_rejected += j.reason == "rejected at release" ? 1 : 0;
    }
    return c;
  };
  const Count with = run(2.0, "lookahead=no");
  const Count without = run(2.0, "shed_rate=no,lookahead=no");
  ASSERT_GT(with.expensive, 100);
  EXPECT_EQ(without.expensive_rejected, 0);
  EXPECT_GT(with.expensive_rejected, with.expensive * 9 / 10);
  EXPECT_GT(with.met, without.met * 13 / 10) << with.met << " vs " << without.met;
  // At 1.0 the cheap operation asks for 0.67 of the lane: nothing is outranked.
  EXPECT_EQ(run(1.0, "lookahead=no").expensive_rejected, 0);

  // Lookahead alone finds the same: by each expensive job's deadline, the cheap jobs to
  // come (about eleven of 6.3 ms in its 85.8 ms) leave no room for its 20.7 ms, and it
  // has more work than any of them, so it is rejected at release. At 1.0 the offered load
  // stays below 1.1 × the lane and admission does not look ahead.
  const Count ahead = run(2.0, "shed_rate=no");
  EXPECT_GT(ahead.expensive_rejected, ahead.expensive * 9 / 10);
  EXPECT_GT(ahead.met, without.met * 13 / 10) << ahead.met << " vs " << without.met;
  EXPECT_EQ(run(1.0, "shed_rate=no").expensive_rejected, 0);
  // At 1.3 no operation is outranked (the cheap one asks for 0.87 of the lane), yet the
  // expensive one's units, longer than the cheap jobs' 1.9 ms of slack, make them miss:
  // looking ahead sheds it and meets nearly every cheap job.
  const Count plain = run(1.3, "lookahead=no");
  const Count looked = run(1.3, "");
  EXPECT_GT(looked.met, plain.met * 12 / 10) << looked.met << " vs " << plain.met;
}

// A boolean docs/DESIGN.md, "Overload" option that only red-robust's preset sets, reachable from
// --with.
void expect_option_of_red_robust_only(const std::string& key, bool PolicyOptions::*field) {
  for (const std::string& p : known_policies())
    EXPECT_EQ((*preset_options(p)).*field, p == "red-robust") << key << ", " << p;
  PolicyOptions o = *preset_options("red");
  EXPECT_EQ(apply_options(o, "admission=shed," + key + "=yes"), "");
  EXPECT_TRUE(o.*field);
  EXPECT_NE(describe(o).find(key + "=yes"), std::string::npos);
  const std::string err = apply_options(o, key + "=maybe");
  EXPECT_NE(err.find(key), std::string::npos);
  EXPECT_TRUE(o.*field) << key;  // a bad value changes nothing
}

TEST(Overload, MissGateIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("miss_gate", &PolicyOptions::miss_gate);
}

TEST(Overload, InheritIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("inherit", &PolicyOptions::inherit);
}

// Every command's message for a name no preset has: the name, then every preset in table order.
TEST(Overload, UnknownPolicyMessageNamesTheNameAndEveryPreset) {
  const std::string m = unknown_policy_message("bogus");
  EXPECT_EQ(m.rfind("unknown policy 'bogus' (known: ", 0), 0U) << m;
  std::size_t at = 0;
  for (const std::string& p : known_policies()) {
    const std::size_t found = m.find(p, at);
    ASSERT_NE(found, std::string::npos) << p << " in " << m;
    at = found + p.size();
  }
  EXPECT_EQ(m.substr(at), ")");
}

// describe() lists every option as apply_options() reads it: each preset's description, applied
// to the defaults, gives the preset back.
TEST(Overload, DescribeRoundTripsThroughApplyOptions) {
  for (const std::string& p : known_policies()) {
    const std::string text = describe(*preset_options(p));
    PolicyOptions o;
    EXPECT_EQ(apply_options(o, text), "") << p << ": " << text;
    EXPECT_EQ(describe(o), text) << p;
  }
}

TEST(Overload, LookaheadIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("lookahead", &PolicyOptions::lookahead);
}

TEST(Overload, ShedByRateIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("shed_rate", &PolicyOptions::shed_by_rate);
}

TEST(Overload, ShedLoneIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("shed_lone", &PolicyOptions::shed_lone);
}

// MIMONet chain seed 41 on 4 lanes of the load grid: four operations on one camera.
Expected<Scenario> shared_frames_scenario() {
  return parse_scenario(R"(
name: grid-mimonet-chain-41-l4
duration_s: 4
warmup_s: 0.5
seed: 41
device: {lanes: 4, sync_cost_us: 0}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam0: {rate_hz: 85.4701, phase_ms: 2.855}
operations:
  - name: op0
    trigger: cam0
    deadline_ms: 60.450
    max_inflight: 4
    nodes:
      N0: {head: det, sensor: cam0}
      N1: {head: lane, sensor: cam0}
      N2: {head: lane, sensor: cam0}
    edges: [[N0, N1], [N1, N2]]
  - name: op1
    trigger: cam0
    deadline_ms: 41.600
    max_inflight: 4
    nodes:
      N0: {head: seg, sensor: cam0}
      N1: {head: seg, sensor: cam0}
    edges: [[N0, N1]]
  - name: op2
    trigger: cam0
    deadline_ms: 94.510
    max_inflight: 4
    nodes:
      N0: {head: det, sensor: cam0}
      N1: {head: steer, sensor: cam0}
      N2: {head: lane, sensor: cam0}
      N3: {head: seg, sensor: cam0}
      N4: {head: steer, sensor: cam0}
    edges: [[N0, N1], [N1, N2], [N2, N3], [N3, N4]]
  - name: op3
    trigger: cam0
    deadline_ms: 35.880
    max_inflight: 4
    nodes:
      N0: {head: lane, sensor: cam0}
      N1: {head: steer, sensor: cam0}
    edges: [[N0, N1]]
)",
                        "shared-frames.yaml");
}

// shed_lone (docs/DESIGN.md, "Overload", docs/journal/overload-grid.md, round 7), on grid set
// MIMONet chain seed 41 on 4 lanes: four operations on one camera, 213 frames a second at 2.5x,
// max_inflight 4 each. Every operation fills its slots and skips the frames that come meanwhile, so
// the frames each one takes drift apart and an encoder run (12 ms, as long as the heads of a whole
// job) serves 1.9 jobs on average. Rejecting the jobs that would run their frame's encoder alone
// and leave their operation fewer than half its slots keeps those for frames the operations share:
// more jobs per encoder run, more jobs met. Below capacity it rejects nothing.
TEST(Overload, ShedLoneKeepsTheOperationsOnSharedFrames) {
  auto base = shared_frames_scenario();
  ASSERT_TRUE(base.has_value()) << base.error().to_string();
  auto run = [&](double load, const char* with) { return robust_at(*base, load, with).metrics; };
  for (const double load : {2.0, 2.5}) {
    const PolicyMetrics with = run(load, "");
    const PolicyMetrics without = run(load, "shed_lone=no");
    ASSERT_GT(without.jobs, 2000) << load;
    // Some jobs are rejected at release instead; fewer frames are then skipped at
    // max_inflight, and fewer jobs turn hopeless.
    EXPECT_GT(with.drop_reasons.at("rejected at release"),
              without.drop_reasons.at("rejected at release"))
        << load;
    EXPECT_LT(with.drop_reasons.at("max_inflight"), without.drop_reasons.at("max_inflight"))
        << load;
    const auto per_run = [](const PolicyMetrics& m) {
      return static_cast<double>(m.met) / static_cast<double>(m.encoder_runs);
    };
    EXPECT_GT(per_run(with), per_run(without) * 1.1) << load;
    EXPECT_GT(with.met, without.met * 21 / 20) << load << ": " << with.met << " vs " << without.met;
  }
  // Below capacity (0.8x) admission is not past capacity: the same run either way.
  const PolicyMetrics with = run(0.8, "");
  const PolicyMetrics without = run(0.8, "shed_lone=no");
  EXPECT_EQ(with.missed, 0);
  EXPECT_EQ(with.met, without.met);
  EXPECT_EQ(with.encoder_runs, without.encoder_runs);
}

TEST(Overload, BatchByJobIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("batch_by_job", &PolicyOptions::batch_by_job);
}

// batch_by_job (docs/DESIGN.md, "Overload", docs/journal/overload-grid.md, round 7), on the same
// set: while ranked by job deadline, a head batch was checked against the task's intermediate
// deadline, which is past due under overload, so heads of different frames seldom ran together.
// Checked against each member's job deadline less the path after the head, they do: more batched
// head dispatches, fewer head runs in all, more jobs met. Below capacity nothing changes.
TEST(Overload, BatchByJobBatchesHeadsAcrossFramesUnderOverload) {
  auto base = shared_frames_scenario();
  ASSERT_TRUE(base.has_value()) << base.error().to_string();
  struct Heads {
    PolicyMetrics m;
    int runs = 0, batched = 0;
  };
  auto run = [&](double load, const char* with) {
    const PolicyRun r = robust_at(*base, load, with, true);
    Heads h;
    h.m = r.metrics;
    for (const UnitRow& u : r.units) {
      if (u.kind != UnitKind::Head) continue;
      ++h.runs;
      h.batched += u.batch > 1 ? 1 : 0;
    }
    return h;
  };
  for (const double load : {2.0, 2.5}) {
    // The mechanism, on the ranking it was made for (job deadline alone, path_rank=no).
    const Heads with = run(load, "path_rank=no");
    const Heads without = run(load, "path_rank=no,batch_by_job=no");
    EXPECT_GT(with.batched, without.batched * 3 / 2) << load;
    EXPECT_LT(with.runs, without.runs) << load;
    EXPECT_GT(with.m.met, without.m.met * 21 / 20)
        << load << ": " << with.m.met << " vs " << without.m.met;
    // With path_rank (red-robust as it ships) heads rank by what their jobs still need after
    // them, and more of them batch without it too (round 9): it still meets more jobs.
    const Heads shipped = run(load, "");
    const Heads shipped_without = run(load, "batch_by_job=no");
    EXPECT_GT(shipped.m.met, shipped_without.m.met)
        << load << ": " << shipped.m.met << " vs " << shipped_without.m.met;
  }
  const Heads with = run(0.8, "");
  const Heads without = run(0.8, "batch_by_job=no");
  EXPECT_EQ(with.m.missed, 0);
  EXPECT_EQ(with.m.met, without.m.met);
  EXPECT_EQ(with.batched, without.batched);
}

TEST(Overload, PathRankIsAnOptionOfRedRobustOnly) {
  expect_option_of_red_robust_only("path_rank", &PolicyOptions::path_rank);
}

// path_rank (docs/DESIGN.md, "Overload", docs/journal/overload-grid.md, round 9): while ranked by
// job deadline, every unit of a job ranked alike, so on several lanes a job's units off its
// critical path ran ahead of another job's critical path, and red-robust fell to edf's figure below
// capacity, where the demand test fires on a job's own critical path (plain fork-join and wide sets
// of the grid). Ranked by the job's deadline less the path after the unit (p99), it meets as many
// as red and edf there.
TEST(Overload, PathRankRunsOtherJobsCriticalPathsFirstOnSeveralLanes) {
  const Profile p = default_profile();
  struct Set {
    std::uint64_t seed;
    int lanes;
    grid::Shape shape;
  };
  int below_without = 0, points = 0;
  for (const Set& set : {Set{25, 2, grid::Shape::ForkJoin}, Set{50, 4, grid::Shape::Wide},
                         Set{51, 4, grid::Shape::Wide}}) {
    grid::SetSpec spec;
    spec.seed = set.seed;
    spec.lanes = set.lanes;
    spec.shape = set.shape;
    for (const double load : {0.5, 0.8}) {
      Scenario s = grid::set_scenario(spec, p, load);
      const double red = grid::evaluate(s, p, "red").on_time;
      const double edf = grid::evaluate(s, p, "edf").on_time;
      const double with = grid::evaluate(s, p, "red-robust").on_time;
      s.scheduler.policy_with = "path_rank=no";
      const double without = grid::evaluate(s, p, "red-robust").on_time;
      EXPECT_GE(with, std::max(red, edf) - 0.005) << s.name << " at " << load;
      below_without += without < red - 0.005 ? 1 : 0;
      ++points;
    }
  }
  EXPECT_GE(below_without, points - 1);
}

// Ranks as EdfPolicy does, but is another type: the scheduler ranks its tasks the long way
// (every member's deadlines, through rank()), where with EdfPolicy it ranks by job deadline
// from what each task keeps and computes a task's own deadline only where batching reads it.
class LongWayEdf final : public Policy {
 public:
  explicit LongWayEdf(PolicyOptions o) : options_(o) {}
  [[nodiscard]] std::string_view name() const noexcept override { return "long-way-edf"; }
  [[nodiscard]] const PolicyOptions& options() const noexcept override { return options_; }
  [[nodiscard]] std::int64_t rank(const TaskView& t, TimePoint) const noexcept override {
    return t.deadline.count();
  }

 private:
  PolicyOptions options_;
};

// Ranks as EdfPolicy does and says so (Policy::ranks_by_deadline_only): another type that
// gets the fast path, as any policy that keeps the promise may.
class PromisedEdf final : public Policy {
 public:
  explicit PromisedEdf(PolicyOptions o) : options_(o) {}
  [[nodiscard]] std::string_view name() const noexcept override { return "promised-edf"; }
  [[nodiscard]] const PolicyOptions& options() const noexcept override { return options_; }
  [[nodiscard]] std::int64_t rank(const TaskView& t, TimePoint) const noexcept override {
    return t.deadline.count();
  }
  [[nodiscard]] bool ranks_by_deadline_only() const noexcept override { return true; }

 private:
  PolicyOptions options_;
};

// Every unit start: when it was decided and started, lane, deadline, batch and members.
struct StartLog : Observer {
  std::string text;
  std::uint64_t batched = 0;  // dispatches of more than one task
  void on_unit_start(const Dispatch& d) override {
    batched += d.batch > 1 ? 1 : 0;
    text += fmt::format("{} {} {} {} {}:", d.decided_at.count(), d.start.count(), d.lane,
                        d.deadline.count(), d.batch);
    for (const Member& m : d.members) text += fmt::format(" {}/{}", m.job, m.unit);
    text += '\n';
  }
};

struct Starts {
  std::string log;
  std::uint64_t batched = 0;
  SchedulerStats stats;
};

Starts starts(const Scenario& s, const Profile& p, std::unique_ptr<Policy> policy) {
  SimOptions options;
  options.seed = s.seed;
  Simulator sim(s, p, std::move(policy), options);
  StartLog log;
  sim.add_observer(&log);
  const SimResult r = sim.run();
  return {std::move(log.text), log.batched, r.stats};
}

// red-robust's decisions do not depend on how its tasks are ranked: on overloaded grid sets
// (plain and MIMONet, 1 to 4 lanes) and the minibenchmark past its limit, EdfPolicy,
// LongWayEdf and PromisedEdf with red-robust's options start the same units at the same times.
TEST(Overload, RankingByJobDeadlineFromTheTasksChangesNoDecision) {
  const Profile p = default_profile();
  std::vector<Scenario> cases;
  for (const grid::SetSpec& spec : grid::grid_sets(test::sized(2, 1), 1.0))
    for (double load : {1.5, 2.5}) cases.push_back(grid::set_scenario(spec, p, load));
  for (const char* name : {"minibench-tight", "case-dynamic"}) {
    auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name + ".yaml");
    ASSERT_TRUE(s.has_value()) << s.error().to_string();
    ASSERT_FALSE(apply_override(*s, "rate_scale", 2.5).has_value());
    cases.push_back(*s);
  }
  std::uint64_t shed = 0, batched = 0;
  for (const Scenario& s : cases) {
    const auto o = policy_options(s, "red-robust");
    ASSERT_TRUE(o.has_value());
    const Starts fast = starts(s, p, std::make_unique<EdfPolicy>("red-robust", *o));
    const Starts long_way = starts(s, p, std::make_unique<LongWayEdf>(*o));
    const Starts promised = starts(s, p, std::make_unique<PromisedEdf>(*o));
    ASSERT_FALSE(fast.log.empty()) << s.name;
    EXPECT_EQ(fast.log, long_way.log) << s.name;
    EXPECT_EQ(promised.log, fast.log) << s.name;
    EXPECT_EQ(fast.stats.dispatches, long_way.stats.dispatches) << s.name;
    shed += fast.stats.hopeless + fast.stats.rejected;
    batched += fast.batched;
  }
  // The cases are past capacity (red-robust shed jobs in them) and batch tasks (whose
  // deadlines only batching reads).
  EXPECT_GT(shed, 0U);
  EXPECT_GT(batched, 0U);
}

}  // namespace
}  // namespace red
