// OutcomeTally: what counts as a miss and how QoE is averaged, written once for the run's
// summary (MetricsCollector), the phase table and the ROS 2 node's diagnostics.

#include "red/metrics/tally.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

TEST(OutcomeTally, ALateJobAndAJobWithoutResultAreMissesOverTheDecidedJobs) {
  OutcomeTally t;
  t.add(JobOutcome::Met, 1.0);
  t.add(JobOutcome::Missed, 0.5);
  t.add(JobOutcome::Dropped, 0.9);  // no result: its QoE is not counted
  t.add(JobOutcome::Skipped, 0.0);
  t.add(JobOutcome::Failed, 0.0);
  t.add(JobOutcome::Unfinished, 0.7);
  EXPECT_EQ(t.jobs, 6);
  EXPECT_EQ(t.met, 1);
  EXPECT_EQ(t.late, 1);
  EXPECT_EQ(t.completed(), 2);
  EXPECT_EQ(t.dropped, 3);
  EXPECT_EQ(t.skipped, 1);
  EXPECT_EQ(t.failed, 1);
  EXPECT_EQ(t.unfinished, 1);
  EXPECT_EQ(t.decided(), 5);  // the unfinished one aside
  EXPECT_EQ(t.missed(), 4);   // late, dropped, skipped, failed
  EXPECT_DOUBLE_EQ(t.qoe_sum, 1.5);
  EXPECT_DOUBLE_EQ(t.miss_rate(), 4.0 / 5.0);
  EXPECT_DOUBLE_EQ(t.drop_rate(), 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(t.qoe(), 1.5 / 5.0);  // a job without result scores 0
}

TEST(OutcomeTally, RatesAreZeroUntilAJobIsDecided) {
  OutcomeTally t;
  EXPECT_EQ(t.miss_rate(), 0.0);
  EXPECT_EQ(t.qoe(), 0.0);
  t.add(JobOutcome::Unfinished, 0.0);
  EXPECT_EQ(t.jobs, 1);
  EXPECT_EQ(t.decided(), 0);
  EXPECT_EQ(t.miss_rate(), 0.0);
  EXPECT_EQ(t.drop_rate(), 0.0);
  EXPECT_EQ(t.qoe(), 0.0);
}

constexpr const char* kScenario = R"(
name: tally
duration_s: 10
warmup_s: 0
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane], input: [3, 192, 384]}
sensors:
  camera: {rate_hz: 30}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 50
    nodes:
      L: {head: lane, sensor: camera}
)";

// The run's summary takes its counts and rates from the same tally (rounded to 6 decimals).
TEST(OutcomeTally, TheSummaryCountsWithIt) {
  auto s = parse_scenario(kScenario, "tally.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const double lambda = 1.0;
  MetricsCollector m(*s, lambda);
  OutcomeTally t;
  const std::vector<JobOutcome> outcomes = {
      JobOutcome::Met,     JobOutcome::Missed, JobOutcome::Missed, JobOutcome::Dropped,
      JobOutcome::Skipped, JobOutcome::Failed, JobOutcome::Met,    JobOutcome::Unfinished};
  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    JobRecord j;
    j.id = static_cast<JobId>(i + 1);
    j.operation = 0;
    j.seq = i;
    j.release = TimePoint{std::chrono::milliseconds{33 * static_cast<std::int64_t>(i)}};
    j.deadline = j.release + std::chrono::milliseconds{50};
    j.finish = j.release + std::chrono::milliseconds{20 + 17 * static_cast<std::int64_t>(i)};
    j.outcome = outcomes[i];
    j.reason = j.outcome == JobOutcome::Failed ? "timeout" : "";
    m.on_job_end(j);
    t.add(j.outcome, qoe_score(j.finish - j.release, j.deadline - j.release, lambda));
  }
  const PolicyMetrics pm = m.summarize("red", TimePoint{std::chrono::seconds{10}});
  const auto round6 = [](double x) { return std::round(x * 1e6) / 1e6; };
  EXPECT_EQ(pm.jobs, t.jobs);
  EXPECT_EQ(pm.completed, t.completed());
  EXPECT_EQ(pm.met, t.met);
  EXPECT_EQ(pm.missed, t.missed());
  EXPECT_EQ(pm.dropped, t.dropped);
  EXPECT_EQ(pm.skipped, t.skipped);
  EXPECT_EQ(pm.failed, t.failed);
  EXPECT_EQ(pm.unfinished, t.unfinished);
  EXPECT_EQ(pm.missed, 5);  // two late, three without result
  EXPECT_EQ(pm.miss_rate, round6(t.miss_rate()));
  EXPECT_EQ(pm.drop_rate, round6(t.drop_rate()));
  EXPECT_EQ(pm.qoe, round6(t.qoe()));
  EXPECT_GT(pm.qoe, 0.0);
}

}  // namespace
}  // namespace red
