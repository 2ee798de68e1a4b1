// Why each job missed (docs/REPORTS.md, "Why jobs missed"): the rule that shed a job, or
// the share of lane time between its release and its deadline, on hand-built rows; every
// job of every bundled scenario under every preset that did not meet its deadline has a
// cause; the cause columns and units.csv's expected_ms are read back, and files written
// before them still read.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include <nlohmann/json.hpp>

#include "red/metrics/phases.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/metrics/why.hpp"
#include "red/report/report.hpp"
#include "red/report/stream.hpp"
#include "red/report/why_text.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

std::shared_ptr<const OperationSpec> op(const std::string& name, int criticality) {
  auto o = std::make_shared<OperationSpec>();
  o->name = name;
  o->criticality = criticality;
  return o;
}

// Three operations: hi (criticality 2), mid (1), lo (0); one lane unless told.
Scenario three(int lanes = 1) {
  Scenario s;
  s.names_ = {"hi", "mid", "lo"};
  s.initial = {op("hi", 2), op("mid", 1), op("lo", 0)};
  s.device.lanes = lanes;
  return s;
}

constexpr int kHi = 0, kMid = 1, kLo = 2;

JobRow job(int operation, std::uint64_t seq, int release_ms, int deadline_ms, int end_ms,
           JobOutcome o, const std::string& reason = "") {
  JobRow j;
  j.operation = operation;
  j.seq = seq;
  j.release = milliseconds{release_ms};
  j.deadline = milliseconds{deadline_ms};
  j.finish = milliseconds{end_ms};
  j.outcome = o;
  j.reason = reason;
  return j;
}

UnitRow unit(int lane, int start_ms, int end_ms, const std::string& jobs, int expected_ms = 0) {
  UnitRow u;
  u.lane = lane;
  u.decided = milliseconds{start_ms};
  u.start = milliseconds{start_ms};
  u.end = milliseconds{end_ms};
  u.jobs = jobs;
  u.expected = milliseconds{expected_ms};
  return u;
}

Duration share(const JobWhy& w, WhyShare k) {
  return w.shares[static_cast<std::size_t>(k)];
}

TEST(Why, AMetJobHasNoCause) {
  const Scenario s = three();
  const std::vector<UnitRow> units = {unit(0, 0, 5, "mid#1:a")};
  JobRow j = job(kMid, 1, 0, 10, 5, JobOutcome::Met);
  WhyIndex(s, units).annotate(j);
  EXPECT_EQ(j.cause, "");
  EXPECT_EQ(j.cause_ms, "");
}

TEST(Why, AJobShedByARuleHasTheRule) {
  const Scenario s = three();
  const std::vector<UnitRow> units;
  const WhyIndex why(s, units);
  auto cause = [&](JobOutcome o, const std::string& reason) {
    const JobWhy w = why.explain(job(kMid, 1, 0, 10, 0, o, reason));
    EXPECT_TRUE(w.by_rule) << reason;
    EXPECT_EQ(w.breakdown(), "") << reason;
    return w.cause;
  };
  EXPECT_EQ(cause(JobOutcome::Dropped, "rejected at release"), "admission: rejected at release");
  EXPECT_EQ(cause(JobOutcome::Dropped, "hopeless"), "hopeless: shed at dispatch");
  EXPECT_EQ(cause(JobOutcome::Skipped, "max_inflight"), "max_inflight: release skipped");
  EXPECT_EQ(cause(JobOutcome::Failed, "timeout"), "failed: timeout");
  EXPECT_EQ(cause(JobOutcome::Unfinished, ""), "unfinished at the end of the run");
}

TEST(Why, LowerCriticalityWorkAheadOfALateJob) {
  const Scenario s = three();
  // lo#3 holds the only lane for 8 of mid#1's 10 ms; mid#1 then runs 8 to 15 ms.
  const std::vector<UnitRow> units = {unit(0, 0, 8, "lo#3:a"), unit(0, 8, 15, "mid#1:a")};
  const JobWhy w = WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 15, JobOutcome::Missed));
  EXPECT_FALSE(w.by_rule);
  EXPECT_EQ(w.cause, "lower-criticality work ahead");
  EXPECT_EQ(share(w, WhyShare::Lower), milliseconds{8});
  EXPECT_EQ(share(w, WhyShare::Own), milliseconds{2});  // up to its deadline only
  EXPECT_EQ(share(w, WhyShare::Held), Duration{0});
  EXPECT_EQ(w.breakdown(), "own 2.000; lower 8.000");
  ASSERT_EQ(w.units.size(), 1u);
  ASSERT_EQ(w.others.size(), 1u);
  EXPECT_EQ(w.others[0].operation, kLo);
  EXPECT_EQ(w.others[0].criticality, 0);
}

TEST(Why, HigherEqualAndSameOperationWork) {
  const Scenario s = three();
  // hi 0-3, an earlier job of mid 3-4, hi again 4-9, then mid#1 9-12.
  const std::vector<UnitRow> units = {unit(0, 0, 3, "hi#7:a"), unit(0, 3, 4, "mid#0:a"),
                                      unit(0, 4, 9, "hi#8:a"), unit(0, 9, 12, "mid#1:a")};
  const JobWhy w = WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed));
  EXPECT_EQ(w.cause, "higher-criticality work ahead");
  EXPECT_EQ(share(w, WhyShare::Higher), milliseconds{8});
  EXPECT_EQ(share(w, WhyShare::SameOperation), milliseconds{1});
  EXPECT_EQ(share(w, WhyShare::Own), milliseconds{1});
}

TEST(Why, AUnitOfSeveralJobsIsSplitAmongThem) {
  Scenario s = three();
  s.names_.push_back("peer");
  s.initial.push_back(op("peer", 1));
  // A batch of lo#1 and hi#2 takes 0-8; peer (criticality 1, as mid) 8-9; mid#1 9-12.
  const std::vector<UnitRow> units = {unit(0, 0, 8, "lo#1:a hi#2:a"), unit(0, 8, 9, "peer#0:x"),
                                      unit(0, 9, 12, "mid#1:a")};
  const JobWhy w = WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed));
  EXPECT_EQ(share(w, WhyShare::Lower), milliseconds{4});
  EXPECT_EQ(share(w, WhyShare::Higher), milliseconds{4});
  EXPECT_EQ(share(w, WhyShare::Equal), milliseconds{1});
  // A tie goes to the share listed first (WhyShare order): higher before lower.
  EXPECT_EQ(w.cause, "higher-criticality work ahead");
}

TEST(Why, AnIdleLaneWhileItWaitedIsHeldWork) {
  const Scenario s = three(2);
  // Nothing ran until 6 ms on either lane (a merge wait), then mid#1 ran 6-12 on lane 0 while
  // lo ran on lane 1 (beside it: not ahead of it).
  const std::vector<UnitRow> units = {unit(0, 6, 12, "mid#1:a"), unit(1, 6, 12, "lo#5:a")};
  const JobWhy w = WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed));
  EXPECT_EQ(w.cause, "held back by the scheduler");
  EXPECT_EQ(share(w, WhyShare::Held), milliseconds{12});  // 6 ms × 2 lanes
  EXPECT_EQ(share(w, WhyShare::Own), milliseconds{4});
  EXPECT_EQ(share(w, WhyShare::Lower), Duration{0});
}

TEST(Why, ARunPastItsEstimateIsACostOverrun) {
  const Scenario s = three();
  // Expected 3 ms, ran 0-12: 3 ms own, 7 ms overrun before the deadline at 10.
  const std::vector<UnitRow> units = {unit(0, 0, 12, "mid#1:a", 3)};
  const JobWhy w = WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed));
  EXPECT_EQ(w.cause, "cost overrun");
  EXPECT_EQ(share(w, WhyShare::Own), milliseconds{3});
  EXPECT_EQ(share(w, WhyShare::Overrun), milliseconds{7});
  ASSERT_EQ(w.units.size(), 1u);
  EXPECT_EQ(w.units[0].overrun, milliseconds{9});
  // Without an estimate (0: unknown) the same run is its own work.
  const std::vector<UnitRow> unknown = {unit(0, 0, 12, "mid#1:a")};
  EXPECT_EQ(WhyIndex(s, unknown).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed)).cause,
            "its own work");
}

TEST(Why, ADropAtItsDeadlineIsExplainedByItsWindow) {
  const Scenario s = three();
  const std::vector<UnitRow> units = {unit(0, 0, 20, "hi#1:a")};
  const JobWhy w =
      WhyIndex(s, units).explain(job(kLo, 4, 2, 10, 10, JobOutcome::Dropped, "deadline passed"));
  EXPECT_FALSE(w.by_rule);
  EXPECT_EQ(w.cause, "higher-criticality work ahead");
  EXPECT_EQ(share(w, WhyShare::Higher), milliseconds{8});
}

TEST(Why, WithoutUnitsTheCauseSaysSo) {
  const Scenario s = three();
  const std::vector<UnitRow> units;
  // No unit at all: the lane was idle throughout, which is held time.
  EXPECT_EQ(WhyIndex(s, units).explain(job(kMid, 1, 0, 10, 12, JobOutcome::Missed)).cause,
            "held back by the scheduler");
  // An empty window (a deadline at its release) has no lane time.
  EXPECT_EQ(WhyIndex(s, units).explain(job(kMid, 1, 5, 5, 5, JobOutcome::Dropped)).cause,
            "no lane time recorded");
}

TEST(Why, CriticalityFollowsTheEvents) {
  Scenario s = three();
  EventSpec e;
  e.at = milliseconds{100};
  e.kind = "set_deadline";
  e.changes = {{kLo, op("lo", 5)}};
  s.events.push_back(e);
  EXPECT_EQ(criticality_at(s, kLo, milliseconds{99}), 0);
  EXPECT_EQ(criticality_at(s, kLo, milliseconds{100}), 5);
  // After the event lo outranks mid: its work ahead of mid is higher-criticality work.
  const std::vector<UnitRow> units = {unit(0, 100, 108, "lo#9:a"), unit(0, 108, 115, "mid#3:a")};
  EXPECT_EQ(WhyIndex(s, units).explain(job(kMid, 3, 100, 110, 115, JobOutcome::Missed)).cause,
            "higher-criticality work ahead");
}

TEST(Why, TheStoryOfOneJob) {
  const Scenario s = three();
  const std::vector<UnitRow> units = {unit(0, 0, 8, "lo#3:a"), unit(0, 8, 15, "mid#1:a", 5)};
  const JobRow j = job(kMid, 1, 0, 10, 15, JobOutcome::Missed);
  const std::string text = why_story(s, "red", j, units);
  EXPECT_NE(text.find("mid#1 under red"), std::string::npos) << text;
  EXPECT_NE(text.find("cause: lower-criticality work ahead"), std::string::npos) << text;
  EXPECT_NE(text.find("lo "), std::string::npos) << text;  // the other work, by operation
  auto ref = parse_job_ref("mid#1", s);
  ASSERT_TRUE(ref.has_value());
  EXPECT_EQ(ref->first, kMid);
  EXPECT_EQ(ref->second, 1u);
  EXPECT_FALSE(parse_job_ref("mid", s).has_value());
  EXPECT_FALSE(parse_job_ref("mid#x", s).has_value());
  EXPECT_FALSE(parse_job_ref("#3", s).has_value());
  const auto unknown = parse_job_ref("nosuch#3", s);
  ASSERT_FALSE(unknown.has_value());
  EXPECT_NE(unknown.error().message.find("hi, mid, lo"), std::string::npos);
}

TEST(Why, CausesGoToThePhasesAndTheSummary) {
  const Scenario s = three();
  std::vector<JobRow> jobs = {job(kMid, 1, 0, 10, 15, JobOutcome::Missed),
                              job(kMid, 2, 0, 10, 0, JobOutcome::Skipped, "max_inflight"),
                              job(kMid, 3, 0, 10, 0, JobOutcome::Skipped, "max_inflight"),
                              job(kHi, 1, 0, 10, 5, JobOutcome::Met)};
  const std::vector<UnitRow> units = {unit(0, 0, 8, "lo#3:a"), unit(0, 8, 15, "mid#1:a")};
  annotate_causes(s, jobs, units);
  const auto phases = phase_metrics(s, jobs, milliseconds{20});
  ASSERT_EQ(phases.size(), 1u);
  ASSERT_EQ(phases[0].operations.size(), 2u);
  const auto& mid = phases[0].operations[1].second;
  EXPECT_EQ(mid.causes.at("max_inflight: release skipped"), 2);
  EXPECT_EQ(mid.causes.at("lower-criticality work ahead"), 1);
  EXPECT_TRUE(phases[0].operations[0].second.causes.empty());
  const auto j = nlohmann::json::parse(summary_json({}, {PolicyMetrics{}}, {phases}));
  const auto& c = j.at("policies")[0].at("phases")[0].at("operations").at("mid").at("causes");
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].at("cause"), "max_inflight: release skipped");  // most first
  EXPECT_EQ(c[0].at("jobs"), 2);
  EXPECT_NEAR(c[0].at("share").get<double>(), 2.0 / 3.0, 1e-6);
}

class WhyFiles : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("red_why_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const auto p = dir_ / name;
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  std::filesystem::path dir_;
};

TEST_F(WhyFiles, CausesAndEstimatesAreReadBack) {
  const Scenario s = three();
  std::vector<JobRow> jobs = {job(kMid, 1, 0, 10, 15, JobOutcome::Missed)};
  const std::vector<UnitRow> units = {unit(0, 0, 8, "lo#3:a", 6), unit(0, 8, 15, "mid#1:a", 5)};
  annotate_causes(s, jobs, units);
  const auto j = read_job_rows(write("jobs.csv", jobs_csv(s, {{"red", &jobs}})), s);
  ASSERT_TRUE(j.has_value()) << j.error().to_string();
  ASSERT_EQ(j->size(), 1u);
  EXPECT_EQ(j->front().second.at(0).cause, "lower-criticality work ahead");
  EXPECT_EQ(j->front().second.at(0).cause_ms, jobs[0].cause_ms);
  const auto u = read_unit_rows(write("units.csv", units_csv(s, {{"red", &units}})), s);
  ASSERT_TRUE(u.has_value()) << u.error().to_string();
  EXPECT_EQ(u->front().second.at(1).expected, milliseconds{5});
}

TEST_F(WhyFiles, FilesWrittenBeforeTheCausesStillRead) {
  const Scenario s = three();
  const auto j = read_job_rows(
      write("jobs.csv",
            "policy,operation,job,release_ms,finish_ms,deadline_ms,outcome,response_ms,qoe,"
            "frame_age_ms,reason,ended_ms\n"
            "red,mid,1,0.000000,,10.000000,dropped,,0,,hopeless,4.000000\n"),
      s);
  ASSERT_TRUE(j.has_value()) << j.error().to_string();
  EXPECT_EQ(j->front().second.at(0).reason, "hopeless");
  EXPECT_EQ(j->front().second.at(0).cause, "");
  const auto u = read_unit_rows(
      write("units.csv",
            "policy,dispatch,lane,decided_ms,start_ms,end_ms,kind,head,batch,members,round_trip,"
            "status,jobs\n"
            "red,1,0,0.000000,0.000000,8.000000,plain,,1,1,0,completed,lo#3:a\n"),
      s);
  ASSERT_TRUE(u.has_value()) << u.error().to_string();
  EXPECT_EQ(u->front().second.at(0).expected, Duration{0});
  // A header that is not a prefix of the columns is still refused.
  EXPECT_FALSE(read_job_rows(write("bad.csv", "policy,operation,job\n"), s).has_value());
}

// Every bundled scenario under every preset: each job counted that did not meet its deadline
// has a cause, and each met job none.
class WhyScenarios : public testing::TestWithParam<std::string> {};

TEST_P(WhyScenarios, EveryJobNotMetHasACause) {
  auto s = load_scenario(GetParam());
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  auto p = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  for (const std::string& policy : known_policies()) {
    SCOPED_TRACE(policy);
    auto run = simulate_policy(*s, *p, policy, s->seed, {}, true);
    ASSERT_TRUE(run.has_value()) << run.error().to_string();
    ASSERT_FALSE(run->jobs.empty());
    annotate_causes(*s, run->jobs, run->units);
    for (const JobRow& j : run->jobs) {
      const std::string name = s->operation_name(j.operation) + "#" + std::to_string(j.seq);
      if (j.outcome == JobOutcome::Met) {
        EXPECT_EQ(j.cause, "") << name;
      } else {
        EXPECT_NE(j.cause, "") << name << " " << to_string(j.outcome);
        // A late job is explained by lane time: its breakdown has some.
        if (j.outcome == JobOutcome::Missed) {
          EXPECT_NE(j.cause_ms, "") << name;
        }
      }
    }
  }
}

std::vector<std::string> bundled() {
  std::vector<std::string> out;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(RED_SOURCE_DIR) + "/scenarios"))
    if (e.path().extension() == ".yaml") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

INSTANTIATE_TEST_SUITE_P(Bundled, WhyScenarios, testing::ValuesIn(bundled()),
                         [](const testing::TestParamInfo<std::string>& i) {
                           std::string n = std::filesystem::path(i.param).stem().string();
                           for (char& c : n)
                             if (std::isalnum(static_cast<unsigned char>(c)) == 0) c = '_';
                           return n;
                         });

}  // namespace
}  // namespace red
