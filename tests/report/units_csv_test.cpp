// units.csv and jobs.csv: one row per unit execution / per job, with the columns that
// docs/REPORTS.md documents.

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line) {
    if (c == ',')
      out.emplace_back();
    else
      out.back().push_back(c);
  }
  return out;
}

// Unit executions as the scheduler reported them, counted the way units.csv counts them:
// those that started after the warm-up window and ended.
struct UnitCounter final : Observer {
  explicit UnitCounter(TimePoint warmup) : warmup_(warmup) {}
  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus) override {
    if (d.start < warmup_) return;
    ++units;
    members += static_cast<std::int64_t>(d.members.size());
    starts.push_back(d.start);
    ends.push_back(end);
  }
  TimePoint warmup_;
  std::int64_t units = 0, members = 0;
  std::vector<TimePoint> starts, ends;
};

const char* kUnitColumns[] = {"policy",     "dispatch", "lane", "decided_ms", "start_ms",
                              "end_ms",     "kind",     "head", "batch",      "members",
                              "round_trip", "status",   "jobs", "expected_ms"};
const char* kJobColumns[] = {"policy",    "operation",    "job",     "release_ms",
                             "finish_ms", "deadline_ms",  "outcome", "response_ms",
                             "qoe",       "frame_age_ms", "reason",  "ended_ms",
                             "cause",     "cause_ms"};

TEST(UnitsCsv, OneRowPerUnitExecutionWithTheDocumentedColumns) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/case-dynamic.yaml");
  ASSERT_TRUE(s.has_value());
  for (const std::string policy : {"edf", "red"}) {
    SCOPED_TRACE(policy);
    UnitCounter count(s->warmup);
    auto r = simulate_policy(*s, default_profile(), policy, s->seed, {&count});
    ASSERT_TRUE(r.has_value());
    const auto lines = lines_of(units_csv(*s, {{policy, &r->units}}));
    ASSERT_FALSE(lines.empty());
    const auto header = split_csv(lines[0]);
    ASSERT_EQ(header.size(), std::size(kUnitColumns));
    for (std::size_t i = 0; i < header.size(); ++i) EXPECT_EQ(header[i], kUnitColumns[i]);
    ASSERT_EQ(static_cast<std::int64_t>(lines.size()) - 1, count.units);
    std::int64_t members = 0;
    for (std::size_t i = 1; i < lines.size(); ++i) {
      const auto f = split_csv(lines[i]);
      ASSERT_EQ(f.size(), header.size()) << lines[i];
      EXPECT_EQ(f[0], policy);
      EXPECT_LE(std::stod(f[4]), std::stod(f[5])) << lines[i];  // start <= end
      EXPECT_GE(std::stoi(f[8]), 1);                            // batch
      const int m = std::stoi(f[9]);
      members += m;
      // `jobs` lists every member, space-separated.
      int listed = f[12].empty() ? 0 : 1;
      for (char c : f[12]) listed += c == ' ' ? 1 : 0;
      EXPECT_EQ(listed, m) << lines[i];
      EXPECT_NEAR(std::stod(f[4]), to_ms(count.starts[i - 1]), 1e-6);
      EXPECT_NEAR(std::stod(f[5]), to_ms(count.ends[i - 1]), 1e-6);
    }
    EXPECT_EQ(members, count.members);
  }
}

TEST(JobsCsv, HeaderIsTheDocumentedOne) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/case-async.yaml");
  ASSERT_TRUE(s.has_value());
  auto r = simulate_policy(*s, default_profile(), "red", s->seed);
  ASSERT_TRUE(r.has_value());
  const auto lines = lines_of(jobs_csv(*s, {{"red", &r->jobs}}));
  ASSERT_EQ(static_cast<std::int64_t>(lines.size()) - 1, r->metrics.jobs);
  const auto header = split_csv(lines[0]);
  ASSERT_EQ(header.size(), std::size(kJobColumns));
  for (std::size_t i = 0; i < header.size(); ++i) EXPECT_EQ(header[i], kJobColumns[i]);
}

TEST(ReportsDoc, DocumentsEveryCsvColumn) {
  std::ifstream in(std::string(RED_SOURCE_DIR) + "/docs/REPORTS.md");
  ASSERT_TRUE(in) << "docs/REPORTS.md is missing";
  std::ostringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  for (const char* c : kUnitColumns)
    EXPECT_NE(doc.find("`" + std::string(c) + "`"), std::string::npos) << "units.csv " << c;
  for (const char* c : kJobColumns)
    EXPECT_NE(doc.find("`" + std::string(c) + "`"), std::string::npos) << "jobs.csv " << c;
}

}  // namespace
}  // namespace red
