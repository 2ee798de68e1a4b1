// The busy-period response-time bound (red/analysis/response_bound.hpp): on a few hundred
// seeded random one-lane workloads, every simulated response time of fifo, edf and mono
// (costs drawn between min and max by the simulator) stays within it; where no analysis
// applies, it says so.

#include "red/analysis/response_bound.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "../support/random_scenario.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/scenario/builder.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

TEST(ResponseBound, HandComputedBusyPeriod) {
  // Two operations, deterministic costs, no round-trip cost: C = 3 ms every 10 ms and
  // C = 2 ms every 5 ms. W(5) = 3 + 2 = 5: the busy period is 5 ms.
  ScenarioBuilder b("two");
  b.duration(std::chrono::seconds{2}).sync_cost(Duration{0});
  b.operation("a").rate(100).deadline(milliseconds{10}).plain("A", milliseconds{3});
  b.operation("b").rate(200).deadline(milliseconds{4}).plain("B", milliseconds{2});
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const ResponseBound r = response_bound(*s, default_profile(), *policy_options(*s, "edf"));
  ASSERT_TRUE(r.applies) << r.why_not;
  EXPECT_EQ(r.busy_period, milliseconds{5});
  ASSERT_EQ(r.operations.size(), 2u);
  EXPECT_TRUE(r.operations[0].guaranteed());
  EXPECT_FALSE(r.operations[1].guaranteed());  // 5 ms > 4 ms
  EXPECT_NEAR(r.utilization, 0.7, 1e-6);
  EXPECT_NE(r.method.find("George"), std::string::npos);
}

TEST(ResponseBound, SaysWhyNoAnalysisApplies) {
  ScenarioBuilder b("x");
  b.duration(std::chrono::seconds{1}).lanes(2);
  b.operation("a").rate(10).deadline(milliseconds{50}).plain("A", milliseconds{3});
  auto s = b.build();
  ASSERT_TRUE(s);
  const Profile p = default_profile();
  const ResponseBound lanes = response_bound(*s, p, *policy_options(*s, "edf"));
  EXPECT_FALSE(lanes.applies);
  EXPECT_NE(lanes.why_not.find("no analysis applies: 2 lanes"), std::string::npos);
  Scenario one = *s;
  ASSERT_FALSE(apply_override(one, "lanes", 1).has_value());
  EXPECT_TRUE(response_bound(one, p, *policy_options(one, "fifo")).applies);
  EXPECT_TRUE(response_bound(one, p, *policy_options(one, "mono")).applies);
  const ResponseBound red = response_bound(one, p, *policy_options(one, "red"));
  EXPECT_FALSE(red.applies);
  EXPECT_NE(red.why_not.find("DynamicMerge"), std::string::npos);
  // Overloaded at max costs: no finite busy period.
  Scenario hot = one;
  ASSERT_FALSE(apply_override(hot, "rate_scale", 40).has_value());
  const ResponseBound over = response_bound(hot, p, *policy_options(hot, "edf"));
  EXPECT_FALSE(over.applies);
  EXPECT_NE(over.why_not.find("unbounded"), std::string::npos);
}

TEST(ResponseBound, NoSimulatedResponseExceedsItOnRandomWorkloads) {
  const Profile p = default_profile();
  int workloads = 0, jobs = 0, tight = 0;
  for (std::uint64_t seed = 1; workloads < 300 && seed < 2000; ++seed) {
    test::RandomScenarioOptions ro;
    ro.duration_s = 2.0;
    ro.events = seed % 2 == 0;
    ro.max_load = 0.9;
    auto parsed = parse_scenario(test::random_scenario_yaml(seed, ro), "");
    ASSERT_TRUE(parsed) << parsed.error().to_string();
    Scenario s = std::move(parsed).value();
    ASSERT_FALSE(apply_override(s, "lanes", 1).has_value());
    const std::string policy = seed % 3 == 0 ? "fifo" : seed % 3 == 1 ? "edf" : "mono";
    const PolicyOptions o = *policy_options(s, policy);
    ResponseBound r = response_bound(s, p, o);
    if (!r.applies && r.why_not.find("unbounded") != std::string::npos) {
      // Bring the utilization at max costs below one and try again.
      const auto e = apply_override(s, "rate_scale", 0.8 / r.utilization);
      ASSERT_FALSE(e.has_value()) << e->to_string() << " " << r.utilization;
      r = response_bound(s, p, o);
    }
    if (!r.applies) continue;  // e.g. an own-rate operation that leaves and comes back
    ++workloads;
    auto run = simulate_policy(s, p, policy, s.seed, {}, false);
    ASSERT_TRUE(run) << run.error().to_string();
    for (const JobRow& j : run->jobs) {
      if (j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Missed) continue;
      ++jobs;
      const Duration response = j.finish - j.release;
      const OperationBound& b = r.operations[static_cast<std::size_t>(
          std::find_if(
              r.operations.begin(), r.operations.end(),
              [&](const OperationBound& x) { return x.name == s.operation_name(j.operation); }) -
          r.operations.begin())];
      EXPECT_LE(response, b.bound) << s.name << " " << policy << " op " << b.name;
      if (response * 10 >= b.bound * 7) ++tight;
    }
  }
  EXPECT_GE(workloads, 200);
  EXPECT_GT(jobs, 3000);
  EXPECT_GT(tight, 0);  // the bound is not vacuous: some responses come within 70 % of it
}

}  // namespace
}  // namespace red
