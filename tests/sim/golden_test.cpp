// Golden files for seeded simulations (as SimGrid's expected-output files): the
// summary.json of a few scenario × policy runs at seed 1 is checked in under
// tests/data/golden/, so any change in schedule shows up in review as a diff.
//
// To regenerate after an intended change:
//   RED_UPDATE_GOLDEN=1 red_tests --gtest_filter='Golden/*'
// then review and commit the diff of tests/data/golden/.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <tuple>

#include "red/metrics/policy_run.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

const std::string kGoldenDir = std::string(RED_TEST_DATA) + "/golden";
constexpr std::uint64_t kSeed = 1;

bool updating() {
  const char* v = std::getenv("RED_UPDATE_GOLDEN");
  return v != nullptr && std::string(v) == "1";
}

using Param = std::tuple<std::string, std::string>;  // scenario, policy

class Golden : public testing::TestWithParam<Param> {};

TEST_P(Golden, SummaryJsonMatchesCheckedInFile) {
  const auto& [scenario, policy] = GetParam();
  const auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + scenario + ".yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const auto p = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const auto run = simulate_policy(*s, *p, policy, kSeed, {}, false);
  ASSERT_TRUE(run.has_value()) << run.error().to_string();
  const SummaryHeader h{s->name, "sim", "edf", kSeed, p->source, {}, {}};  // no run id
  const std::string actual = summary_json(h, {run->metrics});

  const std::string file = scenario + "-" + policy + ".json";
  const std::string path = kGoldenDir + "/" + file;
  if (updating()) {
    const auto err = write_file(kGoldenDir, file, actual);
    ASSERT_FALSE(err.has_value()) << err->to_string();
    std::cout << "[ golden   ] wrote " << path << "\n";
    return;
  }
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in.good()) << "missing golden file " << path
                         << "; generate it with RED_UPDATE_GOLDEN=1 red_tests "
                            "--gtest_filter='Golden/*'";
  std::ostringstream expected;
  expected << in.rdbuf();
  EXPECT_EQ(actual, expected.str())
      << "summary.json of " << scenario << " under " << policy << " (seed " << kSeed
      << ") differs from " << path
      << ".\nIf the change in schedule is intended, regenerate with\n  RED_UPDATE_GOLDEN=1 "
         "red_tests --gtest_filter='Golden/*'\nand review the diff of tests/data/golden/ "
         "before committing it.";
}

std::string golden_name(const testing::TestParamInfo<Param>& p) {
  std::string n = std::get<0>(p.param) + "_" + std::get<1>(p.param);
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Golden, Golden,
                         testing::Combine(testing::Values("minibench-tight", "case-async"),
                                          testing::Values("edf", "red")),
                         golden_name);

}  // namespace
}  // namespace red
