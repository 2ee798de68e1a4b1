// `red analyze` as a library (docs/ANALYSIS.md): every verdict on a small hand-built
// scenario, the verdicts against the simulator on the bundled and on seeded random
// scenarios, and the searched headroom's monotonicity.

#include "red/analysis/analyze.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "../support/load_grid.hpp"
#include "../support/random_scenario.hpp"
#include "../support/size.hpp"
#include "red/analysis/nptest.hpp"
#include "red/analysis/workload.hpp"
#include "red/scenario/builder.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

// One operation of one plain node (mean, p99) at `hz` on one lane with deadline `d`.
Scenario single(double hz, Duration d, Duration mean, Duration p99, int lanes = 1) {
  ScenarioBuilder b("single");
  b.duration(std::chrono::seconds{10}).warmup(milliseconds{500}).seed(3).lanes(lanes);
  b.operation("op").rate(hz).deadline(d).max_inflight(4).plain("A", mean, p99);
  auto s = b.build();
  EXPECT_TRUE(s) << (s ? "" : s.error().to_string());
  return std::move(s).value();
}

Analysis run(const Scenario& s, const std::string& policy = "edf") {
  AnalysisOptions o;
  o.policy = policy;
  o.headroom = false;
  auto a = analyze(s, default_profile(), o);
  EXPECT_TRUE(a) << (a ? "" : a.error().to_string());
  return std::move(a).value();
}

const OperationAnalysis& only_op(const Analysis& a) {
  EXPECT_EQ(a.phases.size(), 1u);
  EXPECT_EQ(a.phases.front().operations.size(), 1u);
  return a.phases.front().operations.front();
}

TEST(AnalyzeVerdict, OkWhenLightAndLoose) {
  const Analysis a = run(single(20, milliseconds{40}, milliseconds{10}, milliseconds{12}));
  const OperationAnalysis& op = only_op(a);
  EXPECT_EQ(op.verdict, Verdict::Ok) << op.reason;
  EXPECT_EQ(a.verdict, Verdict::Ok);
  EXPECT_NEAR(op.utilization, 0.2, 1e-9);  // 10 ms × 20 Hz on one lane
  EXPECT_NEAR(op.rate_hz, 20, 1e-12);
  EXPECT_EQ(op.deadline, milliseconds{40});
  EXPECT_LE(op.miss_profiled, 0.01);
  EXPECT_GT(op.jobs_profiled, 0);
}

TEST(AnalyzeVerdict, InfeasibleWhenTheDeadlineIsBelowTheBestCaseCriticalPath) {
  // A chain of two deterministic 10 ms nodes cannot finish in 15 ms on any lane.
  ScenarioBuilder b("chain");
  b.duration(std::chrono::seconds{5}).lanes(2);
  b.operation("op")
      .rate(10)
      .deadline(milliseconds{15})
      .plain("A", milliseconds{10})
      .plain("B", milliseconds{10})
      .edge("A", "B");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const Analysis a = run(*s);
  const OperationAnalysis& op = only_op(a);
  EXPECT_EQ(op.verdict, Verdict::Infeasible) << op.reason;
  EXPECT_EQ(op.alone_min, milliseconds{20});
  EXPECT_NE(op.reason.find("every job misses"), std::string::npos) << op.reason;
  // The simulator agrees: every job misses.
  EXPECT_GT(op.jobs_profiled, 0);
  EXPECT_DOUBLE_EQ(op.miss_profiled, 1.0);
}

TEST(AnalyzeVerdict, InfeasibleWhenTheJobsOwnWorkExceedsTheDeadlineOnOneLane) {
  // Two parallel 10 ms nodes: critical path 10 ms, but one lane needs 20 ms.
  ScenarioBuilder b("fork");
  b.duration(std::chrono::seconds{5}).lanes(1);
  b.operation("op")
      .rate(10)
      .deadline(milliseconds{15})
      .plain("A", milliseconds{10})
      .plain("B", milliseconds{10});
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const Analysis a = run(*s);
  const OperationAnalysis& op = only_op(a);
  EXPECT_EQ(op.verdict, Verdict::Infeasible) << op.reason;
  EXPECT_DOUBLE_EQ(op.miss_profiled, 1.0);
}

TEST(AnalyzeVerdict, OverloadedWhenDemandExceedsCapacity) {
  // 10 ms every 8 ms: 125 % of one lane.
  const Analysis a = run(single(125, milliseconds{40}, milliseconds{10}, milliseconds{10}));
  const OperationAnalysis& op = only_op(a);
  EXPECT_EQ(op.verdict, Verdict::Overloaded) << op.reason;
  EXPECT_NEAR(a.peak_utilization, 1.25, 1e-9);
  EXPECT_LT(a.on_time_bound, 1.0);
  EXPECT_GT(op.miss_profiled, 0.01);
  // Two lanes carry it.
  const Analysis two =
      run(single(125, milliseconds{40}, milliseconds{10}, milliseconds{10}, 2), "edf");
  EXPECT_NEAR(two.peak_utilization, 0.625, 1e-9);
}

TEST(AnalyzeVerdict, AtRiskWhenOnlyWorstCaseCostsMiss) {
  // mean 10, p99 20, so max 21.5 ms (plain_stats): a 21.4 ms deadline is missed only by
  // the rare draws above it (< 0.1 %), and by every job at worst-case costs.
  const Analysis a = run(single(20, Duration{21'400'000}, milliseconds{10}, milliseconds{20}));
  const OperationAnalysis& op = only_op(a);
  EXPECT_EQ(op.verdict, Verdict::AtRisk) << op.reason;
  EXPECT_LE(op.miss_profiled, 0.01);
  EXPECT_DOUBLE_EQ(op.miss_worst, 1.0);
}

TEST(AnalyzeVerdict, EachPhaseThatEventsCreateIsJudged) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/case-dynamic.yaml");
  ASSERT_TRUE(s) << s.error().to_string();
  const Analysis a = run(*s, "red");
  // Before detection joins, while it is in, after it left.
  ASSERT_EQ(a.phases.size(), 3u);
  EXPECT_LT(a.phases[0].utilization, a.phases[1].utilization);
  EXPECT_NEAR(a.phases[0].utilization, a.phases[2].utilization, 1e-12);
  EXPECT_GT(a.phases[1].operations.front().work_fine, a.phases[0].operations.front().work_fine);
  // Coarse work counts an encoder run per node; fine shares the job's one run.
  const OperationAnalysis& nav = a.phases[1].operations.front();
  EXPECT_GT(nav.work_coarse, nav.work_fine);
  EXPECT_GE(nav.cp_coarse_estimate, nav.cp_coarse_mean);
  EXPECT_GE(nav.cp_coarse_mean, nav.cp_fine_mean);
}

// The physical limit (docs/DESIGN.md, "Performance targets"): the necessary work of each phase of
// the measured window (red/graph/necessary_work.hpp) over the lanes; the largest rate_scale at
// which no phase is overloaded, a phase being overloaded past capacity by more than the latest
// deadline over its length.
TEST(NecessaryLoad, PlainWorkAtItsRateOverTheLanes) {
  const NecessaryLoad one = necessary_load(
      single(20, milliseconds{40}, milliseconds{10}, milliseconds{12}), default_profile());
  EXPECT_NEAR(one.total(), 0.2, 1e-9);  // 10 ms × 20 Hz on one lane
  ASSERT_EQ(one.phases.size(), 1u);
  EXPECT_NEAR(one.phases[0].deadline_s, 0.04, 1e-12);
  // Measured from 0.5 s to 10 s: the jobs may run 40 ms past it.
  EXPECT_NEAR(one.limit_scale(), (1 + 0.04 / 9.5) / 0.2, 1e-5);
  const NecessaryLoad two = necessary_load(
      single(20, milliseconds{40}, milliseconds{10}, milliseconds{12}, 2), default_profile());
  EXPECT_NEAR(two.total(), 0.1, 1e-9);
  EXPECT_NEAR(two.limit_scale(), 2 * one.limit_scale(), 1e-4);
}

TEST(NecessaryLoad, OneEncoderRunPerFrameForEveryOperationItTriggers) {
  auto s = parse_scenario(R"(
name: shared
duration_s: 4
warmup_s: 1
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
scheduler: {max_batch: 1}
sensors:
  cam: {rate_hz: 10}
operations:
  - name: a
    trigger: cam
    deadline_ms: 200
    nodes: {L: {head: lane, sensor: cam}}
  - name: b
    trigger: cam
    deadline_ms: 200
    nodes: {S: {head: seg, sensor: cam}}
  - name: once
    release: {count: 8}
    deadline_ms: 500
    nodes: {P: {cost_ms: 5}}
)",
                          "shared.yaml");
  ASSERT_TRUE(s) << s.error().to_string();
  const Profile p = default_profile();
  const UnitCosts mean(*s, p, CostPoint::Mean);
  const NecessaryLoad n = necessary_load(*s, p);
  const auto head = [&](const char* name) { return to_s(mean.head(s->model.head_index(name))); };
  // No batching (max_batch 1): one encoder run per frame, each head per job, 8 plain jobs of 5 ms.
  const double scaled = (to_s(mean.encoder()) + head("lane") + head("seg")) * 10;
  const double fixed = 0.005 * 8 / 4.0;
  EXPECT_NEAR(n.total(), scaled + fixed, 1e-9);
  EXPECT_NEAR(n.limit_scale(), (1 + 0.5 / 3 - fixed) / scaled, 1e-4);
}

TEST(NecessaryLoad, PhasesWeighByTheirLengthInTheMeasuredWindow) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/minibench-tight.yaml");
  ASSERT_TRUE(s) << s.error().to_string();
  const Profile p = default_profile();
  const NecessaryLoad n = necessary_load(*s, p);
  // Measured from 1 s to 20 s: detection runs in [1, 2), [3, 4), ..., [19, 20): 10 of 19 s.
  double weighted = 0, length = 0, peak = 0;
  for (const NecessaryLoad::Phase& ph : n.phases) {
    const double len = to_s(ph.span.to - ph.span.from);
    weighted += ph.load * len;
    length += len;
    peak = std::max(peak, ph.load);
  }
  EXPECT_NEAR(length, 19.0, 1e-9);
  EXPECT_NEAR(n.total(), weighted / length, 1e-12);
  EXPECT_LT(n.total(), peak);  // the detection phases need more
  // The limit is where the phases with detection overload: between the scale at which their
  // load reaches capacity and a little past it.
  EXPECT_GT(n.limit_scale(), 0);
  Scenario at = *s;
  ASSERT_FALSE(apply_override(at, "rate_scale", n.limit_scale() * 1.02).has_value());
  const NecessaryLoad past = necessary_load(at, p);
  double past_peak = 0;
  for (const NecessaryLoad::Phase& ph : past.phases) past_peak = std::max(past_peak, ph.load);
  EXPECT_GT(past_peak, 1.0);
  EXPECT_NEAR(past.limit_scale() * n.limit_scale() * 1.02, n.limit_scale(), 1e-3 * n.limit_scale());
}

// The verdicts agree with the simulator: an `ok` operation shows <= 1 % misses at the
// profile's costs; an operation infeasible on best-case costs misses every job.
void expect_consistent(const Analysis& a, const std::string& what) {
  for (const PhaseAnalysis& ph : a.phases)
    for (const OperationAnalysis& op : ph.operations) {
      SCOPED_TRACE(what + " / " + ph.label + " / " + op.name + ": " + op.reason);
      if (op.verdict == Verdict::Ok) {
        EXPECT_LE(op.miss_profiled, a.miss_limit);
      }
      // At risk: meets on profiled costs but not on worst-case ones, or this policy misses
      // although the necessary work fits (another policy may meet it).
      if (op.verdict == Verdict::AtRisk && op.miss_profiled <= a.miss_limit) {
        EXPECT_GT(op.miss_worst, a.miss_limit);
      }
      if (op.verdict == Verdict::AtRisk && op.miss_profiled > a.miss_limit) {
        EXPECT_NE(op.reason.find("does not fit the work"), std::string::npos);
      }
      if (op.verdict == Verdict::Infeasible && op.deadline < op.alone_min && op.jobs_profiled > 0) {
        EXPECT_DOUBLE_EQ(op.miss_profiled, 1.0);
      }
    }
}

TEST(AnalyzeAgreement, BundledScenarios) {
  const std::string dir = std::string(RED_SOURCE_DIR) + "/scenarios";
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    auto s = load_scenario(entry.path().string());
    ASSERT_TRUE(s) << s.error().to_string();
    for (const std::string policy : {"red", "edf"}) {
      const Analysis a = run(*s, policy);
      expect_consistent(a, entry.path().filename().string() + " " + policy);
      ++seen;
    }
  }
  EXPECT_GE(seen, 2 * 9);
}

TEST(AnalyzeAgreement, SeededRandomScenariosAcrossTheLoad) {
  const Profile p = default_profile();
  int verdicts[4] = {0, 0, 0, 0};
  for (const grid::SetSpec& spec : grid::grid_sets(1, 2.0))
    for (double load : {0.5, 1.4}) {
      const Scenario s = grid::set_scenario(spec, p, load);
      for (const std::string policy : {"red", "edf"}) {
        AnalysisOptions o;
        o.policy = policy;
        o.headroom = false;
        auto a = analyze(s, p, o);
        ASSERT_TRUE(a) << a.error().to_string();
        expect_consistent(*a, s.name + " " + policy);
        for (const PhaseAnalysis& ph : a->phases)
          for (const OperationAnalysis& op : ph.operations)
            ++verdicts[static_cast<int>(op.verdict)];
        // Past capacity on the policy's work, no operation is called ok.
        if (a->peak_utilization > 1.0) {
          EXPECT_NE(a->verdict, Verdict::Ok) << s.name;
        }
      }
    }
  // The grid reaches more than one verdict.
  EXPECT_GT(verdicts[static_cast<int>(Verdict::Ok)], 0);
  EXPECT_GT(verdicts[static_cast<int>(Verdict::Overloaded)], 0);
}

TEST(AnalyzeAgreement, RandomScenariosWithEveryFeature) {
  // Events, depends_on, own rates, jitter, plain nodes, several lanes: the analysis and the
  // export run through without error, and the verdicts agree with the simulator.
  const Profile p = default_profile();
  for (std::uint64_t seed = 1; seed <= test::sized(40, 8); ++seed) {  // size.hpp
    test::RandomScenarioOptions ro;
    ro.duration_s = 1.5;
    ro.events = true;
    ro.depends_on = true;
    auto s = parse_scenario(test::random_scenario_yaml(seed, ro), "");
    ASSERT_TRUE(s) << s.error().to_string();
    for (const std::string policy : {"red", "edf", "mono", "fifo", "red-robust"}) {
      AnalysisOptions o;
      o.policy = policy;
      o.headroom = seed % 8 == 0;
      auto a = analyze(*s, p, o);
      ASSERT_TRUE(a) << a.error().to_string();
      expect_consistent(*a, s->name + " " + policy);
      EXPECT_FALSE(analysis_text(*a).empty());
      EXPECT_FALSE(analysis_json(*a).empty());
      EXPECT_TRUE(a->response.applies || !a->response.why_not.empty());
      auto x = export_nptest(*s, p, *policy_options(*s, policy));
      ASSERT_TRUE(x) << x.error().to_string();
      EXPECT_GT(x->jobs, 0u) << s->name;
    }
  }
}

TEST(AnalyzeHeadroom, TheSearchedRateIsMonotoneAtItsEdge) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/minibench-tight.yaml");
  ASSERT_TRUE(s) << s.error().to_string();
  const Profile p = default_profile();
  for (const std::string policy : {"red", "edf"})
    for (bool worst : {false, true}) {
      SCOPED_TRACE(policy + (worst ? " worst-case" : " profiled"));
      auto h = search_headroom(*s, p, policy, worst);
      ASSERT_TRUE(h) << h.error().to_string();
      EXPECT_EQ(h->costs, worst ? "worst-case" : "profiled");
      const Scenario base = worst ? worst_case_scenario(*s, p) : *s;
      const Profile prof = worst ? worst_case_profile(p) : p;
      auto at = [&](const char* key, double v) {
        Scenario x = base;
        EXPECT_FALSE(apply_override(x, key, v).has_value());
        auto t = run_trial(x, prof, policy, 0.01);
        EXPECT_TRUE(t);
        return t->pass;
      };
      if (h->rate.pass > 0 && h->rate.fail > 0) {
        EXPECT_LT(h->rate.pass, h->rate.fail);
        EXPECT_LE(h->rate.fail / h->rate.pass, 1.0101);
        EXPECT_TRUE(at("rate_scale", h->rate.pass));   // a slightly lower rate passes
        EXPECT_FALSE(at("rate_scale", h->rate.fail));  // a slightly higher one fails
        EXPECT_FALSE(h->rate.first_to_fail.empty());
        EXPECT_GT(h->rate.first_miss, 0.01);
      }
      if (h->deadline.pass > 0 && h->deadline.fail > 0) {
        EXPECT_GT(h->deadline.pass, h->deadline.fail);
        EXPECT_TRUE(at("deadline_scale", h->deadline.pass));
        EXPECT_FALSE(at("deadline_scale", h->deadline.fail));
      }
      if (policy == "red") {
        // RED fits minibench-tight (its scenario comment): headroom above 1 on profiled costs.
        if (!worst) {
          EXPECT_GT(h->rate.pass, 1.0);
        }
      } else {
        // Coarse EDF is overloaded by it: it fails already at the scenario's rate.
        EXPECT_LT(h->rate.pass, 1.0);
      }
      EXPECT_GT(h->simulations, 2);
    }
}

TEST(AnalyzeWorstCase, ProfileAndScenarioPinEveryCostAtItsMax) {
  const Profile w = worst_case_profile(default_profile());
  for (const auto& [name, unit] : w.units)
    for (const LatencyStats& l : unit.by_batch) {
      EXPECT_EQ(l.quantile(0.0), l.max) << name;
      EXPECT_EQ(l.quantile(0.5), l.max) << name;
      EXPECT_EQ(l.mean, l.max) << name;
    }
  ScenarioBuilder b("cp-x");
  b.duration(std::chrono::seconds{2}).sensor("camera", 10);
  b.operation("op").trigger("camera").deadline_critical_path(1.5).inference("L", "lane", "camera");
  b.operation("post")
      .rate(5)
      .deadline(milliseconds{50})
      .plain("P", milliseconds{4}, milliseconds{6});
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const Profile p = default_profile();
  const Scenario ws = worst_case_scenario(*s, p);
  const CostModel est{&p, &s->model, s->scheduler.estimate};
  // The deadline stays what the profiled estimate made it.
  EXPECT_EQ(resolve_deadline(*ws.initial[0], CostModel{&w, &ws.model, ws.scheduler.estimate}),
            resolve_deadline(*s->initial[0], est));
  const PlainCost& c = *ws.initial[1]->nodes[0].cost;
  EXPECT_EQ(c.mean, c.p99);
  EXPECT_EQ(c.mean, plain_stats(*s->initial[1]->nodes[0].cost).max);
}

// A calibrated profile's worst case pins every part of the simulator's cost model at its
// largest measured value: residual at its max, the largest time and lane factors.
TEST(AnalyzeWorstCase, CalibratedProfilesPinResidualsAndFactors) {
  Profile p = default_profile();
  Calibration c;
  using std::chrono::milliseconds;
  c.residual["encoder"] = {{milliseconds{10}, milliseconds{11}, milliseconds{14}}};
  c.factors = {0.9, 1.0, 1.6, 1.1};
  c.lane_factors = {1.0, 1.3};
  p.calibration = c;
  const Profile w = worst_case_profile(p);
  ASSERT_TRUE(w.calibration.has_value());
  const std::vector<Duration>* t = w.calibration->table("encoder", 1);
  ASSERT_NE(t, nullptr);
  for (Duration d : *t) EXPECT_EQ(d, milliseconds{14});
  EXPECT_EQ(w.calibration->factors, std::vector<double>{1.6});
  for (double f : w.calibration->lane_factors) EXPECT_DOUBLE_EQ(f, 1.3);
  for (int i = 0; i < 50; ++i)
    EXPECT_DOUBLE_EQ(w.calibration->factor_at(TimePoint{milliseconds{i * 113}}, 9), 1.6);
}

// The text of an analysis: a headroom search that ends between two scales closer than three
// digits tell apart prints as many digits as tell them apart ("1.2 (fails at 1.2)" before),
// and the operation column is as wide as the longest name, so rows stay under their header.
TEST(AnalysisText, DigitsTellTheScalesApartAndColumnsAlign) {
  Analysis a;
  a.scenario = "s";
  a.policy = "red";
  Headroom h;
  h.policy = "red";
  h.costs = "profiled";
  h.rate.pass = 1.2001;
  h.rate.fail = 1.2004;
  h.deadline.pass = 0.75;
  h.deadline.fail = 0.7;
  a.headroom.push_back(h);
  PhaseAnalysis ph;
  ph.label = "at start";
  for (const char* name : {"lane", "cruise_control_with_a_long_name"}) {
    OperationAnalysis o;
    o.name = name;
    o.rate_hz = 20;
    o.reason = "fits";
    ph.operations.push_back(o);
  }
  a.phases.push_back(ph);
  const std::string t = analysis_text(a);
  EXPECT_NE(t.find("1.2001 (fails at 1.2004)"), std::string::npos) << t;
  EXPECT_NE(t.find("0.75 (fails at 0.7)"), std::string::npos) << t;
  // Every row's rate column ends where the header's does.
  const std::size_t header = t.find("  operation ");
  ASSERT_NE(header, std::string::npos) << t;
  const std::size_t header_end = t.find("rate Hz", header) + std::string("rate Hz").size() - header;
  for (const char* name : {"  lane ", "  cruise_control_with_a_long_name "}) {
    const std::size_t row = t.find(name);
    ASSERT_NE(row, std::string::npos) << name << "\n" << t;
    EXPECT_EQ(t.find("20.00", row) + std::string("20.00").size() - row, header_end) << name << "\n"
                                                                                    << t;
  }
}

}  // namespace
}  // namespace red
