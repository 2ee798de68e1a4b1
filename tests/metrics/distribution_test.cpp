// BoundedDistribution and a collector's bounded state (issue 10 item 3): percentiles exact
// up to the cap, within the stated relative error past it; a run of many jobs keeps a
// bounded number of records when its rows are not kept.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "red/metrics/distribution.hpp"
#include "red/metrics/metrics.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

const std::vector<double> kPs = {0.0,  0.001, 0.01, 0.1,  0.25,  0.5,
                                 0.75, 0.9,   0.95, 0.99, 0.999, 1.0};

std::vector<double> latencies(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::lognormal_distribution<double> d(3.0, 0.8);  // a long tail, like response times in ms
  std::vector<double> v(n);
  for (double& x : v) x = d(rng);
  return v;
}

TEST(BoundedDistribution, ExactUpToTheCap) {
  const std::vector<double> v = latencies(1000, 1);
  BoundedDistribution d(1000);
  double sum = 0, max = 0;
  for (double x : v) {
    d.add(x);
    sum += x;
    max = std::max(max, x);
  }
  EXPECT_TRUE(d.exact());
  EXPECT_EQ(d.count(), 1000);
  EXPECT_EQ(d.sum(), sum);  // same order, same rounding: the mean is byte-identical
  EXPECT_EQ(d.max(), max);
  for (double p : kPs) EXPECT_EQ(d.percentile(p), percentile(v, p)) << "p " << p;
  const std::vector<double> many = d.percentiles(kPs);
  for (std::size_t i = 0; i < kPs.size(); ++i) EXPECT_EQ(many[i], percentile(v, kPs[i]));
}

TEST(BoundedDistribution, PastTheCapWithinTheRelativeError) {
  const std::vector<double> v = latencies(50'000, 2);
  BoundedDistribution d(100, 0.005);
  for (double x : v) d.add(x);
  EXPECT_FALSE(d.exact());
  EXPECT_EQ(d.count(), 50'000);
  // The histogram's buckets cover the values' range, not their number.
  EXPECT_LT(d.kept(), 5'000U);
  for (double p : kPs) {
    const double exact = percentile(v, p);
    EXPECT_LE(std::abs(d.percentile(p) - exact), 0.005 * exact * (1 + 1e-9)) << "p " << p;
  }
  EXPECT_EQ(d.percentile(1.0), *std::max_element(v.begin(), v.end()));
}

TEST(BoundedDistribution, ZerosAndAnEmptyOne) {
  BoundedDistribution empty;
  EXPECT_EQ(empty.percentile(0.5), 0.0);
  EXPECT_EQ(empty.count(), 0);
  BoundedDistribution d(4, 0.01);
  for (int i = 0; i < 100; ++i) d.add(i < 60 ? 0.0 : 10.0);
  EXPECT_FALSE(d.exact());
  EXPECT_EQ(d.percentile(0.5), 0.0);
  EXPECT_NEAR(d.percentile(0.9), 10.0, 0.1);
  EXPECT_EQ(d.percentile(1.0), 10.0);
}

constexpr const char* kScenario = R"(
name: bounded
duration_s: 10
warmup_s: 0
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane, seg], input: [3, 192, 384]}
sensors:
  camera: {rate_hz: 30}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 50
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
    edges: [[L, S]]
)";

// Feeds `n` ended jobs (met, missed, dropped and skipped in turn) to the collector.
void feed(MetricsCollector& m, std::int64_t n) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<int> ms(5, 80);
  for (std::int64_t i = 0; i < n; ++i) {
    JobRecord j;
    j.id = static_cast<JobId>(i + 1);
    j.operation = 0;
    j.seq = static_cast<std::uint64_t>(i);
    j.release = TimePoint{std::chrono::milliseconds{33 * i}};
    j.deadline = j.release + std::chrono::milliseconds{50};
    j.finish = j.release + std::chrono::milliseconds{ms(rng)};
    j.frame_age = std::chrono::milliseconds{ms(rng)};
    switch (i % 4) {
      case 0:
      case 1:
        j.outcome = j.finish <= j.deadline ? JobOutcome::Met : JobOutcome::Missed;
        break;
      case 2:
        j.outcome = JobOutcome::Dropped;
        j.reason = "deadline passed";
        break;
      default:
        j.outcome = JobOutcome::Skipped;
        j.reason = "max_inflight";
    }
    m.on_job_end(j);
  }
}

TEST(MetricsCollector, ARunOfManyJobsKeepsBoundedState) {
  auto s = parse_scenario(kScenario, "bounded.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  std::size_t kept_at_cap = 0;
  for (const std::int64_t n : {std::int64_t{40'000}, std::int64_t{400'000}}) {
    MetricsCollector m(*s, 1.0);
    m.set_keep_rows(false);
    feed(m, n);
    const PolicyMetrics pm = m.summarize("red", TimePoint{std::chrono::seconds{10}});
    EXPECT_EQ(pm.jobs, n);
    EXPECT_EQ(pm.completed + pm.dropped + pm.unfinished, n);
    EXPECT_TRUE(m.jobs().empty());
    // Two distributions of at most their cap (then buckets), a few reasons and counters.
    EXPECT_LE(m.kept(), 2 * BoundedDistribution::kDefaultCap + 16);
    if (n == 40'000) {
      kept_at_cap = m.kept();
      EXPECT_FALSE(pm.percentile_error.has_value()) << "20,000 completed jobs: exact";
    } else {
      // Ten times the jobs, fewer records: past the cap the histogram replaces the samples.
      EXPECT_LT(m.kept(), kept_at_cap);
      ASSERT_TRUE(pm.percentile_error.has_value());
      EXPECT_EQ(*pm.percentile_error, BoundedDistribution::kDefaultRelativeError);
      EXPECT_EQ(pm.percentile_exact_up_to,
                static_cast<std::int64_t>(BoundedDistribution::kDefaultCap));
    }
  }
}

TEST(MetricsCollector, TheSummaryIsTheSameWithOrWithoutTheRows) {
  auto s = parse_scenario(kScenario, "bounded.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  MetricsCollector with(*s, 1.0), without(*s, 1.0);
  without.set_keep_rows(false);
  feed(with, 5'000);
  feed(without, 5'000);
  EXPECT_EQ(with.jobs().size(), 5'000U);
  const TimePoint end{std::chrono::seconds{10}};
  SummaryHeader h;
  h.scenario = s->name;
  EXPECT_EQ(summary_json(h, {with.summarize("red", end)}),
            summary_json(h, {without.summarize("red", end)}));
}

}  // namespace
}  // namespace red
