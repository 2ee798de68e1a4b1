// The np-schedulability-analysis export (red/analysis/nptest.hpp): headers, one row per
// unit of every job in the window, precedence edges between existing jobs, times in μs.

#include "red/analysis/nptest.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "red/scenario/builder.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

std::vector<std::vector<long long>> rows_of(const std::string& csv, std::string& header) {
  std::istringstream in(csv);
  std::getline(in, header);
  std::vector<std::vector<long long>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<long long> r;
    std::istringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) r.push_back(std::stoll(cell));
    rows.push_back(r);
  }
  return rows;
}

Scenario two_ops() {
  ScenarioBuilder b("np");
  b.duration(std::chrono::seconds{1}).sensor("camera", 20, Duration{0}, milliseconds{2});
  b.operation("drive")
      .trigger("camera")
      .deadline(milliseconds{45})
      .inference("L", "lane", "camera")
      .inference("S", "seg", "camera")
      .inference("C", "steer", "camera")
      .edge("L", "S")
      .edge("S", "C");
  b.operation("post")
      .rate(10)
      .deadline(milliseconds{30})
      .plain("P", milliseconds{3}, milliseconds{4});
  auto s = b.build();
  EXPECT_TRUE(s) << (s ? "" : s.error().to_string());
  return std::move(s).value();
}

void check_files(const NptestExport& x, std::size_t expect_jobs, std::size_t expect_edges) {
  std::string h;
  const auto jobs = rows_of(x.jobs_csv, h);
  EXPECT_EQ(h, "Task ID, Job ID, Arrival min, Arrival max, Cost min, Cost max, Deadline, Priority");
  EXPECT_EQ(jobs.size(), expect_jobs);
  EXPECT_EQ(x.jobs, expect_jobs);
  std::set<std::pair<long long, long long>> ids;
  std::set<long long> job_ids;
  for (const auto& r : jobs) {
    ASSERT_EQ(r.size(), 8u);
    EXPECT_TRUE(ids.emplace(r[0], r[1]).second);
    EXPECT_TRUE(job_ids.insert(r[1]).second);  // job IDs are unique
    EXPECT_LE(r[2], r[3]);                     // arrival min <= max
    EXPECT_LE(r[4], r[5]);                     // cost min <= max
    EXPECT_GT(r[5], 0);
    EXPECT_GT(r[6], r[2]);  // deadline after arrival
  }
  const auto edges = rows_of(x.prec_csv, h);
  EXPECT_EQ(h, "Predecessor TID, Predecessor JID, Successor TID, Successor JID");
  EXPECT_EQ(edges.size(), expect_edges);
  for (const auto& e : edges) {
    ASSERT_EQ(e.size(), 4u);
    EXPECT_TRUE(ids.count({e[0], e[1]})) << "edge from a missing job";
    EXPECT_TRUE(ids.count({e[2], e[3]})) << "edge to a missing job";
  }
  const auto tasks = rows_of(x.tasks_csv.substr(0, x.tasks_csv.find('\n') + 1), h);
  EXPECT_EQ(h, "Task ID, Kind, Operation, Node");
}

TEST(NptestExport, CoarseEdfOneHyperperiod) {
  const Scenario s = two_ops();
  const Profile p = default_profile();
  auto x = export_nptest(s, p, *policy_options(s, "edf"));
  ASSERT_TRUE(x) << x.error().to_string();
  // Periods 50 ms and 100 ms: one hyperperiod is 100 ms: 2 drive jobs (3 units, 2 edges)
  // and 1 post job.
  EXPECT_TRUE(x->hyperperiod);
  EXPECT_EQ(x->window, milliseconds{100});
  check_files(*x, 2 * 3 + 1, 2 * 2);
  std::string h;
  const auto jobs = rows_of(x->jobs_csv, h);
  // EDF: priority = absolute deadline; the camera's jitter widens the arrival window.
  for (const auto& r : jobs) EXPECT_EQ(r[7], r[6]);
  EXPECT_EQ(jobs.front()[3] - jobs.front()[2], 2000);  // 2 ms of jitter, in μs
  // Costs in μs: a coarse lane node costs encoder + head, between min and max.
  const UnitProfile* enc = p.find("encoder");
  const UnitProfile* lane = p.find("head/lane");
  const long long lo = (enc->at(1).min + lane->at(1).min).count() / 1000;
  EXPECT_GE(jobs.front()[4], lo - 1);
}

TEST(NptestExport, FineGraphSharesTheFramesEncoderRun) {
  const Scenario s = two_ops();
  auto x = export_nptest(s, default_profile(), *policy_options(s, "red"));
  ASSERT_TRUE(x) << x.error().to_string();
  // Fine graph under DynamicMerge: per drive job one encoder run (shared by L, S, C), three
  // heads; edges e→L, e→S, e→C, L→S, S→C.
  check_files(*x, 2 * 4 + 1, 2 * 5);
  EXPECT_NE(x->tasks_csv.find("encoder, drive, camera"), std::string::npos) << x->tasks_csv;
}

TEST(NptestExport, WindowFlagAndErrors) {
  const Scenario s = two_ops();
  auto x = export_nptest(s, default_profile(), *policy_options(s, "mono"), milliseconds{300});
  ASSERT_TRUE(x) << x.error().to_string();
  EXPECT_FALSE(x->hyperperiod);
  check_files(*x, 6 + 3, 0);  // mono: one job per release, no edges
  EXPECT_FALSE(export_nptest(s, default_profile(), *policy_options(s, "edf"), Duration{0}));
}

}  // namespace
}  // namespace red
