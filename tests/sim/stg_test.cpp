// Standard Task Graph Set check: on the 180 random 50-task graphs of the STG set, every
// work-conserving policy's makespan on m identical lanes lies between the published
// optimum and Graham's bound cp + (work − cp) / m. A simulator that finishes below the
// optimum or above Graham's bound has a bug (lost precedence, idle lanes, wrong costs).

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "../support/stg.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

const std::string kStgDir = std::string(RED_TEST_DATA) + "/stg";
constexpr int kLaneCounts[] = {2, 4, 8, 16};

/// Every graph of the set, sorted, as paths relative to kStgDir ("50/randNNNN.stg").
const std::vector<std::string>& stg_graphs() {
  static const std::vector<std::string> graphs = [] {
    std::vector<std::string> v;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(kStgDir + "/50", ec))
      if (e.path().extension() == ".stg") v.push_back("50/" + e.path().filename().string());
    std::sort(v.begin(), v.end());
    return v;
  }();
  return graphs;
}

constexpr const char* kPolicies[] = {"edf", "fifo", "red", "red-ida"};

std::string case_name(const testing::TestParamInfo<int>& info) {
  return "m" + std::to_string(info.param);
}

// One case per lane count; each graph is parsed once and run under every policy (the YAML
// parse costs more than the simulation).
class StgMakespan : public testing::TestWithParam<int> {};

TEST_P(StgMakespan, BetweenOptimumAndGrahamBound) {
  const int lanes = GetParam();
  const auto optima =
      test::read_stg_optima(kStgDir + "/Case50_" + std::to_string(lanes) + "_OPT.csv");
  ASSERT_EQ(stg_graphs().size(), 180U) << "expected the 180 graphs under " << kStgDir;
  ASSERT_EQ(optima.size(), 180U) << "expected 180 optima for m = " << lanes;
  const Profile profile = default_profile();
  int checks = 0;
  for (const std::string& rel : stg_graphs()) {
    std::string error;
    const auto g = test::read_stg(kStgDir + "/" + rel, error);
    ASSERT_TRUE(g.has_value()) << error;
    const auto opt = optima.find(rel);
    ASSERT_NE(opt, optima.end()) << rel << ": no published optimum";
    const auto parsed = parse_scenario(test::stg_scenario_yaml(*g, lanes, "stg"), rel);
    ASSERT_TRUE(parsed.has_value()) << parsed.error().to_string();
    const std::int64_t ms = 1'000'000;  // times in the file are read as milliseconds
    const std::int64_t cp = g->critical_path();
    const std::int64_t work = g->work();
    const std::int64_t m = lanes;
    for (const char* policy : kPolicies) {
      SCOPED_TRACE(rel + " on " + std::to_string(lanes) + " lanes, policy " + policy);
      const auto run = simulate_policy(*parsed, profile, policy, 1, {}, false);
      ASSERT_TRUE(run.has_value()) << run.error().to_string();
      ASSERT_EQ(run->jobs.size(), 1U);
      const JobRow& job = run->jobs.front();
      ASSERT_EQ(job.outcome, JobOutcome::Met) << to_string(job.outcome);
      // Exact comparison in nanoseconds.
      const std::int64_t makespan = (job.finish - job.release).count();
      EXPECT_GE(makespan, opt->second * ms) << "below the published optimum " << opt->second;
      // makespan <= cp + (work - cp) / m, multiplied through by m to stay in integers.
      EXPECT_LE(makespan * m, (cp * m + work - cp) * ms)
          << "above Graham's bound: cp " << cp << ", work " << work << ", makespan "
          << static_cast<double>(makespan) / 1e6 << " ms";
      ++checks;
    }
  }
  RecordProperty("checks", checks);
  EXPECT_EQ(checks, 180 * 4);
}

INSTANTIATE_TEST_SUITE_P(Stg, StgMakespan, testing::ValuesIn(kLaneCounts), case_name);

// The converter itself: the dummy entry/exit tasks and their edges are left out.
TEST(StgConverter, SkipsDummyTasksAndKeepsEdges) {
  std::string error;
  const auto g = test::read_stg(kStgDir + "/50/rand0000.stg", error);
  ASSERT_TRUE(g.has_value()) << error;
  EXPECT_EQ(g->n, 50);
  EXPECT_EQ(g->critical_path(), 55);  // the file's own "CP Length" comment
  const auto s = parse_scenario(test::stg_scenario_yaml(*g, 4, "stg"), "rand0000.stg");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  ASSERT_EQ(s->operation_count(), 1);
  const OperationSpec& op = *s->initial.front();
  EXPECT_EQ(op.nodes.size(), 50U);
  std::size_t real_edges = 0;
  for (int t = 1; t <= g->n; ++t)
    for (int p : g->preds[static_cast<std::size_t>(t)]) real_edges += p != 0 ? 1 : 0;
  EXPECT_EQ(op.edges.size(), real_edges);
  EXPECT_EQ(op.edges.size(), 96U);  // "Edges: 96 / 1225 (+dummy edges : 23)"
  EXPECT_EQ(s->device.lanes, 4);
  EXPECT_EQ(op.release_count, 1);
}

}  // namespace
}  // namespace red
