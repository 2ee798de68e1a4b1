// Figures per workload phase (docs/REPORTS.md, "Phases"): the measured window split at the
// scenario's events; every job in exactly one phase, the one of its release; the phases'
// counts add up to the run's.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "red/metrics/phases.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

Scenario load(const std::string& name) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
  EXPECT_TRUE(s.has_value()) << name;
  return std::move(s.value());
}

JobRow job(int op, std::uint64_t seq, double release_s, JobOutcome o, double response_ms = 10,
           double qoe = 1.0) {
  JobRow j;
  j.operation = op;
  j.seq = seq;
  j.release = from_s(release_s);
  j.deadline = j.release + std::chrono::milliseconds{65};
  j.finish = j.release + from_ms(response_ms);
  j.outcome = o;
  j.qoe = o == JobOutcome::Met || o == JobOutcome::Missed ? qoe : 0.0;
  return j;
}

TEST(Phases, SplitAtEachWorkloadEventAfterTheWarmUp) {
  const Scenario s = load("case-dynamic.yaml");  // warm-up 0.5 s, events at 3 and 6 s
  const auto p = workload_phases(s, from_s(9.0));
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].from, from_s(0.5));
  EXPECT_EQ(p[0].to, from_s(3.0));
  EXPECT_TRUE(p[0].events.empty());
  EXPECT_EQ(p[1].from, from_s(3.0));
  EXPECT_EQ(p[1].to, from_s(6.0));
  EXPECT_EQ(p[1].events, std::vector<int>{0});
  EXPECT_EQ(p[2].to, from_s(9.0));
  EXPECT_EQ(phase_label(s, p[0]), "start");
  EXPECT_EQ(phase_label(s, p[1]), "after add_nodes (event 0)");
  // A run that ends before the second event: two phases.
  EXPECT_EQ(workload_phases(s, from_s(5.0)).size(), 2u);
}

TEST(Phases, EventsAtOneTimeOpenOnePhaseAndEventsBeforeTheWarmUpNone) {
  Scenario s = load("case-dynamic.yaml");
  EventSpec early = s.events[0];
  early.at = from_s(0.2);
  EventSpec twin = s.events[1];
  twin.at = from_s(3.0);
  s.events = {early, s.events[0], twin, s.events[1]};  // 0.2, 3, 3, 6 s
  const auto p = workload_phases(s, from_s(9.0));
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].from, s.warmup);
  EXPECT_EQ(p[0].events, std::vector<int>{0});  // before the warm-up's end: in the first
  EXPECT_EQ(p[1].events, (std::vector<int>{1, 2}));
  EXPECT_EQ(phase_label(s, p[1]), "after add_nodes, remove_nodes (events 1, 2)");
  s.events.clear();
  ASSERT_EQ(workload_phases(s, from_s(9.0)).size(), 1u);
  EXPECT_EQ(phase_label(s, workload_phases(s, from_s(9.0))[0]), "whole run");
}

TEST(Phases, AJobBelongsToThePhaseOfItsRelease) {
  const Scenario s = load("case-dynamic.yaml");
  const std::vector<JobRow> jobs = {
      job(0, 1, 2.999, JobOutcome::Met, 10),  // before the event at 3 s
      job(0, 2, 3.0, JobOutcome::Met, 20),    // at it: the next phase
      job(0, 3, 3.01, JobOutcome::Dropped),   // released while C is in
      job(0, 4, 5.999, JobOutcome::Missed, 80, 0.5),
      job(0, 5, 6.0, JobOutcome::Skipped),  // after C left
      job(0, 6, 8.9, JobOutcome::Unfinished),
  };
  const auto p = phase_metrics(s, jobs, from_s(9.0));
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p[0].all.jobs, 1);
  EXPECT_EQ(p[1].all.jobs, 3);
  EXPECT_EQ(p[2].all.jobs, 2);
  // Phase 1: one met, one dropped, one late: misses 2 of 3, drops 1 of 3.
  EXPECT_EQ(p[1].all.completed, 2);
  EXPECT_EQ(p[1].all.dropped, 1);
  EXPECT_EQ(p[1].all.missed, 2);
  EXPECT_DOUBLE_EQ(p[1].all.miss_rate, 0.666667);
  EXPECT_DOUBLE_EQ(p[1].all.drop_rate, 0.333333);
  EXPECT_DOUBLE_EQ(p[1].all.qoe, 0.5);  // (1 + 0 + 0.5) / 3
  EXPECT_DOUBLE_EQ(p[1].all.latency_p50_ms, 20.0);
  EXPECT_DOUBLE_EQ(p[1].all.latency_p99_ms, 80.0);
  // Phase 2: a skipped release is a drop; an unfinished job is in no rate.
  EXPECT_EQ(p[2].all.unfinished, 1);
  EXPECT_DOUBLE_EQ(p[2].all.miss_rate, 1.0);
  ASSERT_EQ(p[1].operations.size(), 1u);
  EXPECT_EQ(p[1].operations[0].first, "navigate");
  EXPECT_EQ(p[1].operations[0].second.jobs, 3);
}

TEST(Phases, CountsAddUpToTheRunsTotals) {
  const Scenario s = load("minibench-tight.yaml");  // 19 events, detection in and out
  auto prof = resolve_profile(s, std::nullopt);
  ASSERT_TRUE(prof.has_value());
  for (const char* policy : {"edf", "red", "fifo"}) {
    auto run = simulate_policy(s, *prof, policy, s.seed);
    ASSERT_TRUE(run.has_value());
    const PolicyMetrics& m = run->metrics;
    const auto phases = phase_metrics(s, run->jobs, run->result.end);
    ASSERT_EQ(phases.size(), 19u) << policy;  // the warm-up (1 s) swallows the event at 1 s
    EXPECT_EQ(phases.front().span.events, std::vector<int>{0});
    std::int64_t jobs = 0, completed = 0, missed = 0, dropped = 0, unfinished = 0;
    for (std::size_t i = 0; i < phases.size(); ++i) {
      const PhaseMetrics& ph = phases[i];
      if (i > 0) {
        EXPECT_EQ(ph.span.from, phases[i - 1].span.to);
      }
      jobs += ph.all.jobs;
      completed += ph.all.completed;
      missed += ph.all.missed;
      dropped += ph.all.dropped;
      unfinished += ph.all.unfinished;
      std::int64_t op_jobs = 0;
      for (const auto& [name, f] : ph.operations) op_jobs += f.jobs;
      EXPECT_EQ(op_jobs, ph.all.jobs);
      // Each job counted where it was released.
      std::int64_t released = 0;
      for (const JobRow& j : run->jobs)
        released += j.release >= ph.span.from && j.release < ph.span.to ? 1 : 0;
      EXPECT_EQ(released, ph.all.jobs) << policy << " phase " << i;
    }
    EXPECT_EQ(phases.front().span.from, s.warmup);
    EXPECT_EQ(phases.back().span.to, run->result.end);
    EXPECT_EQ(jobs, m.jobs) << policy;
    EXPECT_EQ(completed, m.completed) << policy;
    EXPECT_EQ(missed, m.missed) << policy;
    EXPECT_EQ(dropped, m.dropped) << policy;
    EXPECT_EQ(unfinished, m.unfinished) << policy;
  }
}

TEST(Phases, SummaryJsonHasAPhasesArrayPerPolicy) {
  const Scenario s = load("case-dynamic.yaml");
  auto prof = resolve_profile(s, std::nullopt);
  ASSERT_TRUE(prof.has_value());
  auto run = simulate_policy(s, *prof, "edf", s.seed);
  ASSERT_TRUE(run.has_value());
  SummaryHeader h;
  h.scenario = s.name;
  const auto j = nlohmann::json::parse(
      summary_json(h, {run->metrics}, {phase_metrics(s, run->jobs, run->result.end)}));
  EXPECT_EQ(j.at("schema"), 1);
  const auto& phases = j.at("policies")[0].at("phases");
  ASSERT_EQ(phases.size(), 3u);
  EXPECT_EQ(phases[0].at("from_s"), 0.5);
  EXPECT_EQ(phases[1].at("from_s"), 3.0);
  EXPECT_EQ(phases[1].at("events"), nlohmann::json::array({0}));
  std::int64_t jobs = 0;
  for (const auto& ph : phases) {
    jobs += ph.at("jobs").get<std::int64_t>();
    const auto& op = ph.at("operations").at("navigate");
    for (const char* key : {"jobs", "miss_rate", "drop_rate", "qoe"})
      EXPECT_TRUE(op.contains(key)) << key;
    EXPECT_TRUE(op.at("latency_ms").contains("p50"));
    EXPECT_TRUE(op.at("latency_ms").contains("p99"));
  }
  EXPECT_EQ(jobs, run->metrics.jobs);
  // Without phases the file is as before (the golden files).
  EXPECT_FALSE(
      nlohmann::json::parse(summary_json(h, {run->metrics})).at("policies")[0].contains("phases"));
}

TEST(Phases, TableHasARowPerPhaseAndOperation) {
  const Scenario s = load("case-dynamic.yaml");
  const std::vector<JobRow> jobs = {job(0, 1, 1.0, JobOutcome::Met),
                                    job(0, 2, 4.0, JobOutcome::Dropped)};
  const std::string t = phase_table(s, {"edf"}, {phase_metrics(s, jobs, from_s(9.0))});
  EXPECT_NE(t.find("phases of edf"), std::string::npos);
  EXPECT_NE(t.find("after add_nodes (event 0)"), std::string::npos);
  EXPECT_NE(t.find("after remove_nodes (event 1)"), std::string::npos);
  EXPECT_NE(t.find("100.00"), std::string::npos);  // the phase with the drop
}

}  // namespace
}  // namespace red
