// The `red` command line (docs/CLI.md), run as a real process: exit codes, messages on stderr,
// and the files --out writes (summary.json schema, jobs.csv, units.csv, sweep.json/csv).

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "../support/cli.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using test::column_index;
using test::quote;
using test::read_text;
using test::RunResult;
using test::scenario;

std::string data(const std::string& name) {
  return std::string(RED_TEST_DATA) + "/cli/" + name;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           fmt::format("red_cli_test_{}_{}_{}", ::getpid(), info->test_suite_name(), info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  /// Runs `red ARGS`, capturing stdout and stderr. `wrapper` (e.g. "timeout 120") runs the
  /// binary under another command, so a hang shows as a failure instead of stalling the suite.
  RunResult red(const std::string& args, const std::string& wrapper = "") {
    return test::run_red(args, dir_, wrapper);
  }

  /// Expects exit code exactly 2 (bad input), a message on stderr, and no crash.
  void expect_bad_input(const std::string& args, const std::string& fragment,
                        const std::string& wrapper = "") {
    SCOPED_TRACE("red " + args);
    const RunResult r = red(args, wrapper);
    ASSERT_TRUE(r.exited) << "terminated abnormally\nstderr: " << r.err;
    EXPECT_EQ(r.code, 2) << "stderr: " << r.err << "\nstdout: " << r.out;
    EXPECT_FALSE(r.err.empty());
    EXPECT_TRUE(contains(r.err, fragment)) << "stderr: " << r.err << "\nexpected: " << fragment;
    EXPECT_FALSE(contains(r.err, "RED_ASSERT"));
    EXPECT_FALSE(contains(r.err, "terminate called"));
  }

  fs::path dir_;
};

// ---- red validate ---------------------------------------------------------------------------

TEST_F(Cli, ValidatePrintsNodesWithHeightsAndDeadlines) {
  const RunResult r = red("validate " + scenario("minibench-tight.yaml"));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "scenario minibench-tight"));
  EXPECT_TRUE(contains(r.out, "operation cruise"));
  // 1.125 × coarse critical path (17.6 + 18.8 + 14.75 ms p99, default profile).
  EXPECT_TRUE(contains(r.out, "deadline 57.544 ms")) << r.out;
  EXPECT_TRUE(contains(r.out, "coarse H")) << r.out;
  EXPECT_TRUE(contains(r.out, "fine H")) << r.out;
  // Node rows: name, what it runs, coarse height, coarse deadline, fine height, fine deadline.
  std::map<std::string, std::tuple<int, double, int, double>> rows;
  bool first_op = true;
  for (const std::string& line : lines_of(r.out)) {
    if (contains(line, "event 0")) first_op = false;  // rows after this belong to events
    std::istringstream in(line);
    std::string name, head, on, sensor;
    int ch = -1, fh = -1;
    double cd = 0, fd = 0;
    if (!(in >> name >> head >> on >> sensor >> ch >> cd >> fh >> fd) || on != "on") continue;
    if (first_op) rows[name] = {ch, cd, fh, fd};
  }
  ASSERT_EQ(rows.size(), 3u) << r.out;
  EXPECT_EQ(std::get<0>(rows["L"]), 0);
  EXPECT_EQ(std::get<0>(rows["S"]), 1);
  EXPECT_EQ(std::get<0>(rows["C"]), 2);
  EXPECT_EQ(std::get<2>(rows["L"]), 1);  // fine: encoders at height 0
  EXPECT_EQ(std::get<2>(rows["S"]), 2);
  EXPECT_EQ(std::get<2>(rows["C"]), 3);
  EXPECT_NEAR(std::get<1>(rows["C"]), 57.544, 1e-3);  // the last level ends at D
  EXPECT_NEAR(std::get<3>(rows["C"]), 57.544, 1e-3);
  EXPECT_LT(std::get<1>(rows["L"]), std::get<1>(rows["S"]));
  EXPECT_LT(std::get<1>(rows["S"]), std::get<1>(rows["C"]));
  // The events' node O is shown too.
  EXPECT_TRUE(contains(r.out, "add_nodes"));
  EXPECT_TRUE(contains(r.out, "det on camera"));
  EXPECT_TRUE(contains(r.out, "ok"));
}

TEST_F(Cli, ValidateWarnsOfADeadlineShorterThanTheCriticalPath) {
  const std::string path = data("infeasible_deadline.yaml");
  const RunResult r = red("validate " + quote(path));
  ASSERT_TRUE(r.exited);
  EXPECT_EQ(r.code, 0) << r.err;  // a warning, not an error
  // Named by file and the line of the deadline: 5 + 8 ms at mean costs, at least.
  EXPECT_TRUE(contains(r.err, "red: warning: " + path +
                                  ":11: operation 'chain': deadline 0.050 ms is shorter than its "
                                  "least critical path 13.000 ms"))
      << r.err;
  // An event's set_deadline is named by its own line and the time it takes effect.
  EXPECT_TRUE(contains(r.err, path + ":23: operation 'side' from 1 s (event 0): deadline 1.000 ms "
                                     "is shorter than its least critical path 2.000 ms"))
      << r.err;
  EXPECT_FALSE(contains(r.err, "operation 'side': deadline")) << r.err;  // 50 ms at t = 0 fits
  EXPECT_TRUE(contains(r.out, "ok, with 2 warning(s) on stderr")) << r.out;
}

TEST_F(Cli, ValidatePrintsEachOperationsCriticality) {
  const RunResult r = red("validate " + quote(data("infeasible_deadline.yaml")));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out,
                       "operation chain: every frame of camera; deadline 0.050 ms; coarse "
                       "critical path 15.000 ms; criticality 3; max_inflight 2"))
      << r.out;
  EXPECT_TRUE(contains(r.out,
                       "operation side: 10 Hz, newest frames; deadline 50.000 ms; coarse "
                       "critical path 2.000 ms; criticality 0;"))
      << r.out;
}

// Every column of a node table ends where its heading does, however long a node's name or a
// plain node's "mean / p99" cost.
TEST_F(Cli, ValidateNodeTableColumnsFitTheirContent) {
  for (const char* file : {"tiny.yaml", "infeasible_deadline.yaml"}) {
    SCOPED_TRACE(file);
    const RunResult r = red("validate " + quote(data(file)));
    ASSERT_TRUE(r.exited);
    ASSERT_EQ(r.code, 0) << r.err;
    std::string header;
    int rows = 0;
    for (const std::string& line : lines_of(r.out)) {
      if (contains(line, "    node ")) {
        header = line;
        continue;
      }
      if (header.empty() || !contains(line, " plain ")) continue;
      ++rows;
      // The row is as long as its heading and has a blank wherever the heading does between
      // columns (after "runs", "coarse H", "coarse d ms", "fine H"), so no cell runs into the next.
      EXPECT_EQ(line.size(), header.size()) << header << '\n' << line;
      for (const char* heading : {"coarse H", "coarse d ms", "fine H", "fine d ms"}) {
        const std::size_t at = header.find(heading);
        ASSERT_NE(at, std::string::npos);
        ASSERT_LT(at, line.size());
        EXPECT_EQ(line[at - 1], ' ') << heading << '\n' << header << '\n' << line;
      }
    }
    EXPECT_GE(rows, 2) << r.out;
  }
  const RunResult r = red("validate " + quote(data("tiny.yaml")));
  EXPECT_TRUE(contains(r.out, "plain mean 8.000 / p99 10.000 ms")) << r.out;
}

// ---- red simulate ---------------------------------------------------------------------------

TEST_F(Cli, SimulateWritesSummaryJobsAndUnits) {
  const fs::path out = dir_ / "sim";
  const RunResult r = red("simulate " + scenario("minibench-tight.yaml") +
                          " --policy red --seed 1 --out " + quote(out.string()));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out / "summary.json"));
  ASSERT_TRUE(fs::exists(out / "jobs.csv"));
  ASSERT_TRUE(fs::exists(out / "units.csv"));

  const json j = json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(j.at("schema"), 1);
  EXPECT_EQ(j.at("scenario"), "minibench-tight");
  EXPECT_EQ(j.at("backend"), "sim");
  EXPECT_EQ(j.at("baseline"), "edf");
  ASSERT_EQ(j.at("policies").size(), 1u);
  const json& p = j.at("policies")[0];
  EXPECT_EQ(p.at("name"), "red");
  for (const char* key : {"jobs", "completed", "missed", "dropped", "encoder_runs",
                          "encoder_runs_saved", "sync_round_trips"})
    EXPECT_TRUE(p.at(key).is_number_integer()) << key;
  for (const char* key : {"miss_rate", "drop_rate", "qoe"}) {
    ASSERT_TRUE(p.at(key).is_number()) << key;
    EXPECT_GE(p.at(key).get<double>(), 0.0) << key;
    EXPECT_LE(p.at(key).get<double>(), 1.0) << key;
  }
  for (const char* key : {"mean", "p50", "p90", "p99", "max"})
    EXPECT_TRUE(p.at("latency_ms").at(key).is_number()) << key;
  EXPECT_LE(p.at("latency_ms").at("p50").get<double>(), p.at("latency_ms").at("p99").get<double>());
  EXPECT_LE(p.at("latency_ms").at("p99").get<double>(), p.at("latency_ms").at("max").get<double>());
  for (const char* key : {"miss_rate", "latency_mean", "qoe"})
    EXPECT_TRUE(p.at("ratios").contains(key)) << key;
  const auto jobs = p.at("jobs").get<std::int64_t>();
  EXPECT_GE(jobs, p.at("completed").get<std::int64_t>());
  // 20 Hz camera, 20 s, frames at k · 50 ms; warm-up 1 s excluded: frames 20..399.
  EXPECT_EQ(jobs, 380);
  EXPECT_GT(p.at("encoder_runs_saved").get<std::int64_t>(), 0);  // red merges encoders

  const auto job_lines = lines_of(read_text(out / "jobs.csv"));
  ASSERT_FALSE(job_lines.empty());
  EXPECT_EQ(job_lines[0],
            "policy,operation,job,release_ms,finish_ms,deadline_ms,outcome,response_ms,qoe,"
            "frame_age_ms,reason,ended_ms,cause,cause_ms");
  EXPECT_EQ(static_cast<std::int64_t>(job_lines.size()) - 1, jobs);
  std::map<std::string, std::int64_t> outcomes;
  for (std::size_t i = 1; i < job_lines.size(); ++i) {
    const auto f = split_csv(job_lines[i]);
    ASSERT_EQ(f.size(), 14u) << job_lines[i];
    EXPECT_EQ(f[0], "red");
    EXPECT_EQ(f[1], "cruise");
    EXPECT_GE(std::stod(f[3]), 1000.0) << "a warm-up job was counted: " << job_lines[i];
    ++outcomes[f[6]];
    // A cause for every job not met, none for a met one (docs/REPORTS.md, "Why jobs missed").
    EXPECT_EQ(f[12].empty(), f[6] == "met") << job_lines[i];
  }
  EXPECT_EQ(outcomes["met"] + outcomes["missed"], p.at("completed").get<std::int64_t>());

  const auto unit_lines = lines_of(read_text(out / "units.csv"));
  ASSERT_GT(unit_lines.size(), 1u);
  EXPECT_EQ(unit_lines[0],
            "policy,dispatch,lane,decided_ms,start_ms,end_ms,kind,head,batch,members,round_trip,"
            "status,jobs,expected_ms");
  EXPECT_EQ(split_csv(unit_lines[1]).size(), 14u);

  // Same seed, same summary, byte for byte but for the run's id (docs/REPORTS.md).
  const fs::path again = dir_ / "again";
  const RunResult r2 = red("simulate " + scenario("minibench-tight.yaml") +
                           " --policy red --seed 1 --out " + quote(again.string()));
  ASSERT_EQ(r2.code, 0) << r2.err;
  auto without_run_id = [](const fs::path& file) {
    std::string text;
    for (const std::string& line : lines_of(read_text(file)))
      if (line.find("\"run_id\": ") == std::string::npos) text += line + "\n";
    return text;
  };
  EXPECT_NE(json::parse(read_text(out / "summary.json"))["run_id"],
            json::parse(read_text(again / "summary.json"))["run_id"]);
  EXPECT_EQ(without_run_id(out / "summary.json"), without_run_id(again / "summary.json"));
  EXPECT_EQ(read_text(out / "jobs.csv"), read_text(again / "jobs.csv"));
}

TEST_F(Cli, SimulatePrintsASummaryWithoutOut) {
  const RunResult r = red("simulate " + quote(data("tiny.yaml")) + " --policy edf");
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "scenario tiny")) << r.out;
  EXPECT_TRUE(contains(r.out, "edf")) << r.out;
  EXPECT_TRUE(contains(r.out, "latency ms")) << r.out;
}

// ---- red compare ----------------------------------------------------------------------------

TEST_F(Cli, CompareRunsEveryPresetOnTheSameReleases) {
  const fs::path out = dir_ / "cmp";
  const RunResult r = red("compare " + scenario("minibench-tight.yaml") + " --backend sim --out " +
                          quote(out.string()));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<std::string> presets{"fifo",    "mono", "edf",       "red-fg",
                                         "red-ida", "red",  "red-robust"};
  // The table: a row per preset, and ratio columns against edf.
  const auto rows = lines_of(r.out);
  for (const std::string& name : presets) {
    bool found = false;
    for (const std::string& line : rows) found = found || line.rfind(name + " ", 0) == 0;
    EXPECT_TRUE(found) << "no row for " << name << "\n" << r.out;
  }
  EXPECT_TRUE(contains(r.out, "miss/")) << r.out;
  EXPECT_TRUE(contains(r.out, "QoE/")) << r.out;
  for (const std::string& line : rows) {
    if (line.rfind("edf ", 0) == 0) {
      EXPECT_TRUE(contains(line, "1.000")) << line;
    }
  }

  const json j = json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(j.at("schema"), 1);
  EXPECT_EQ(j.at("baseline"), "edf");
  ASSERT_EQ(j.at("policies").size(), presets.size());
  for (std::size_t i = 0; i < presets.size(); ++i) {
    const json& p = j.at("policies")[i];
    EXPECT_EQ(p.at("name"), presets[i]);
    EXPECT_EQ(p.at("jobs"), j.at("policies")[0].at("jobs"));  // identical workload
    if (presets[i] == "edf") {
      EXPECT_EQ(p.at("ratios").at("miss_rate"), 1.0);
      EXPECT_EQ(p.at("ratios").at("latency_mean"), 1.0);
      EXPECT_EQ(p.at("ratios").at("qoe"), 1.0);
    }
  }

  // Common random numbers: every policy saw the same (operation, job, release) set.
  std::map<std::string, std::set<std::tuple<std::string, std::string, std::string>>> releases;
  const auto job_lines = lines_of(read_text(out / "jobs.csv"));
  ASSERT_GT(job_lines.size(), 1u);
  for (std::size_t i = 1; i < job_lines.size(); ++i) {
    const auto f = split_csv(job_lines[i]);
    ASSERT_GE(f.size(), 4u);
    releases[f[0]].insert({f[1], f[2], f[3]});
  }
  ASSERT_EQ(releases.size(), presets.size());
  for (const std::string& name : presets) {
    EXPECT_EQ(releases[name].size(), j.at("policies")[0].at("jobs").get<std::size_t>()) << name;
    EXPECT_EQ(releases[name], releases["edf"]) << name;
  }
}

// A real comparison (synthetic backend) is followed by the simulator's prediction with the
// profile and, where the runs kept their units (--out), by a second prediction from the
// costs each policy's own units met in the run; prediction.json holds both.
TEST_F(Cli, RealComparePredictsFromTheProfileAndFromTheRunsOwnCosts) {
  const fs::path out = dir_ / "real";
  const std::string args = "compare " + scenario("case-async.yaml") +
                           " --backend synthetic --no-realtime --set duration_s=2 "
                           "--policies edf,red";
  const RunResult r = red(args + " --out " + quote(out.string()), "timeout 300");
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string own_costs = "simulator with the costs each policy's units met in this run";
  EXPECT_TRUE(contains(r.out, "simulator prediction with the same profile")) << r.out;
  ASSERT_TRUE(contains(r.out, own_costs)) << r.out;
  // A row per policy in the second table.
  const std::string second = r.out.substr(r.out.find(own_costs));
  for (const char* name : {"edf ", "red "}) {
    bool found = false;
    for (const std::string& line : lines_of(second)) found = found || line.rfind(name, 0) == 0;
    EXPECT_TRUE(found) << name << "\n" << second;
  }

  const json j = json::parse(read_text(out / "prediction.json"));
  ASSERT_EQ(j.at("policies").size(), 2u);
  const json summary = json::parse(read_text(out / "summary.json"));
  for (std::size_t i = 0; i < 2; ++i) {
    const json& p = j.at("policies")[i];
    SCOPED_TRACE(p.at("policy").get<std::string>());
    EXPECT_EQ(p.at("policy"), summary.at("policies")[i].at("name"));
    for (const char* which : {"sim", "sim_run_costs"}) {
      const json& x = p.at(which);
      EXPECT_LE(x.at("miss_pct_min").get<double>(), x.at("miss_pct").get<double>()) << which;
      EXPECT_LE(x.at("miss_pct").get<double>(), x.at("miss_pct_max").get<double>()) << which;
      EXPECT_LE(x.at("mean_ms_min").get<double>(), x.at("mean_ms").get<double>()) << which;
      EXPECT_LE(x.at("mean_ms").get<double>(), x.at("mean_ms_max").get<double>()) << which;
      EXPECT_GT(x.at("mean_ms").get<double>(), 0.0) << which;  // jobs completed
    }
  }

  // Issue 53: a real run measures what its units cost (the synthetic backend spins the
  // profile's draws: near the profile), and every job it did not meet has a cause.
  for (const json& p : summary.at("policies")) {
    SCOPED_TRACE(p.at("name").get<std::string>());
    ASSERT_TRUE(p.contains("costs"));
    EXPECT_TRUE(p.at("costs").at("online").get<bool>());
    int measured = 0;
    for (const json& u : p.at("costs").at("units")) measured += u.at("runs").get<int>();
    EXPECT_GT(measured, 0);
  }
  const std::vector<std::string> rows = lines_of(read_text(out / "jobs.csv"));
  ASSERT_GT(rows.size(), 1u);
  const std::vector<std::string> jobs_header = split_csv(rows.front());
  const std::size_t outcome = column_index(jobs_header, "outcome");
  const std::size_t cause = column_index(jobs_header, "cause");
  ASSERT_LT(std::max(outcome, cause), jobs_header.size()) << rows.front();
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (rows[i].empty()) continue;
    const std::vector<std::string> f = split_csv(rows[i]);
    ASSERT_GT(f.size(), std::max(outcome, cause)) << rows[i];
    if (f[outcome] != "met" && f[outcome] != "unfinished") {
      EXPECT_FALSE(f[cause].empty()) << rows[i];
    }
  }

  // index.html shows both predictions after the comparison.
  const std::string html = read_text(out / "index.html");
  EXPECT_TRUE(contains(html, "Simulator&#39;s prediction of these runs") ||
              contains(html, "Simulator's prediction of these runs"));
  EXPECT_TRUE(contains(html, "Simulator fed the costs each policy")) << html.substr(0, 2000);

  // Without --out the runs keep no units: only the prediction from the profile.
  const RunResult plain = red(args, "timeout 300");
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_TRUE(contains(plain.out, "simulator prediction with the same profile")) << plain.out;
  EXPECT_FALSE(contains(plain.out, own_costs)) << plain.out;
}

// A device that is asked for and is not there is an error naming it (exit 2), before
// anything runs: never a silent run somewhere else.
TEST_F(Cli, ADeviceThatIsNotThereIsAnErrorNeverACpuRun) {
  const std::string tiny = quote(data("tiny.yaml"));
  expect_bad_input("compare " + tiny + " --device cuda", "--device cuda: the sim backend");
  expect_bad_input("run " + tiny + " --backend synthetic --device cuda:1",
                   "--device cuda:1: the synthetic backend");
  expect_bad_input("compare " + tiny + " --backend synthetic --policies edf --device gpu",
                   "--device gpu");
}

// --debug-sync sets LibTorch's CUDA sync debug mode: with a backend that has no device it is
// bad usage (exit 2, naming the option), before anything runs.
TEST_F(Cli, DebugSyncWithoutTheTorchBackendIsBadUsage) {
  const std::string tiny = quote(data("tiny.yaml"));
  expect_bad_input("run " + tiny + " --backend synthetic --debug-sync",
                   "--debug-sync: the synthetic backend has no device");
  expect_bad_input("compare " + tiny + " --debug-sync", "--debug-sync: the sim backend");
}

// A real run says how many frames its sensors offered, how many it released and how late:
// in summary.json (frames) and in a table after the comparison.
TEST_F(Cli, RealRunCountsFramesOfferedAndReleased) {
  const fs::path out = dir_ / "frames";
  const RunResult r = red("compare " + scenario("case-async.yaml") +
                              " --backend synthetic --no-realtime --set duration_s=2 "
                              "--policies edf,red --out " +
                              quote(out.string()),
                          "timeout 300");
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "late p99 ms")) << r.out;
  const json j = json::parse(read_text(out / "summary.json"));
  for (const json& p : j.at("policies")) {
    SCOPED_TRACE(p.at("name").get<std::string>());
    const json& f = p.at("frames");
    EXPECT_GT(f.at("offered").get<std::int64_t>(), 0);
    EXPECT_LE(f.at("released").get<std::int64_t>(), f.at("offered").get<std::int64_t>());
    EXPECT_LE(f.at("released_late_ms").at("p50").get<double>(),
              f.at("released_late_ms").at("p99").get<double>());
    EXPECT_LE(f.at("behind_a_period").get<std::int64_t>(), f.at("released").get<std::int64_t>());
  }
  // Both policies were offered the same frames: the workload is the scenario's, not the run's.
  EXPECT_EQ(j.at("policies")[0].at("frames").at("offered"),
            j.at("policies")[1].at("frames").at("offered"));
  // A simulation has no such figures (it releases every frame at its capture time).
  const fs::path sim = dir_ / "frames-sim";
  ASSERT_EQ(red("simulate " + quote(data("tiny.yaml")) + " --out " + quote(sim.string())).code, 0);
  EXPECT_FALSE(json::parse(read_text(sim / "summary.json")).at("policies")[0].contains("frames"));
}

// Issue 57: a real run checks the prediction it was given. The check's gaps are the
// simulated figures minus the real ones (points of miss rate, percent of mean latency), each
// held to the target (5 points, 10 %), and counted; --write-profile writes the costs the run's
// units met as a calibrated profile that the next run (or the simulator) takes as --profile.
TEST_F(Cli, RealRunChecksItsPredictionAndWritesItsOwnCostsAsTheNextProfile) {
  const fs::path out = dir_ / "check";
  const fs::path own = dir_ / "own-costs.json";
  const RunResult r = red("compare " + scenario("case-async.yaml") +
                              " --backend synthetic --no-realtime --set duration_s=2 "
                              "--policies edf,red --out " +
                              quote(out.string()) + " --write-profile " + quote(own.string()),
                          "timeout 300");
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "prediction check")) << r.out;
  EXPECT_TRUE(contains(r.out, "within the target")) << r.out;
  EXPECT_TRUE(contains(r.out, "reading: ")) << r.out;
  EXPECT_TRUE(contains(r.out, "wrote " + own.string())) << r.out;

  const json j = json::parse(read_text(out / "prediction.json"));
  const json& check = j.at("check");
  EXPECT_EQ(check.at("policies").get<int>(), 2);
  int ahead_within = 0, own_within = 0;
  const auto expect_gap = [](const json& real, const json& sim, const json& gap) -> int {
    const double miss = sim.at("miss_pct").get<double>() - real.at("miss_pct").get<double>();
    EXPECT_NEAR(gap.at("miss_pts").get<double>(), miss, 1e-9);
    const double real_mean = real.at("mean_ms").get<double>();
    EXPECT_GT(real_mean, 0.0);  // jobs completed
    if (real_mean <= 0.0) return 0;
    if (sim.at("mean_ms").get<double>() <= 0.0) {
      // The prediction completed no job: no mean to compare, the miss rate alone counts.
      EXPECT_TRUE(gap.at("mean_pct").is_null());
      EXPECT_EQ(gap.at("within_target").get<bool>(), std::abs(miss) <= 5.0);
      return gap.at("within_target").get<bool>() ? 1 : 0;
    }
    const double pct = 100.0 * (sim.at("mean_ms").get<double>() - real_mean) / real_mean;
    EXPECT_NEAR(gap.at("mean_pct").get<double>(), pct, 1e-9);
    EXPECT_EQ(gap.at("within_target").get<bool>(), std::abs(miss) <= 5.0 && std::abs(pct) <= 10.0);
    return gap.at("within_target").get<bool>() ? 1 : 0;
  };
  for (const json& p : j.at("policies")) {
    SCOPED_TRACE(p.at("policy").get<std::string>());
    ahead_within += expect_gap(p.at("real"), p.at("sim"), p.at("gap").at("ahead"));
    own_within += expect_gap(p.at("real"), p.at("sim_run_costs"), p.at("gap").at("own"));
  }
  EXPECT_EQ(check.at("ahead_within").get<int>(), ahead_within);
  EXPECT_EQ(check.at("own_within").get<int>(), own_within);
  EXPECT_GT(check.at("unit_cost_ratio").get<double>(), 0.0);
  EXPECT_TRUE(check.at("unit_cost_ratio_by_kind").contains("encoder"));

  // The written profile holds what the units cost in this run: the encoder's in-run mean at
  // batch 1 is the mean of the run's encoder rows after the warm-up (0.5 s), over both
  // policies' units.
  const json prof = json::parse(read_text(own));
  ASSERT_TRUE(prof.contains("calibration"));
  EXPECT_EQ(prof.at("calibration").at("policies"), json::array({"edf", "red"}));
  const std::vector<std::string> rows = lines_of(read_text(out / "units.csv"));
  ASSERT_GT(rows.size(), 1u);
  const std::vector<std::string> header = split_csv(rows.front());
  const std::size_t kind = column_index(header, "kind");
  const std::size_t batch = column_index(header, "batch");
  const std::size_t status = column_index(header, "status");
  const std::size_t start_ms = column_index(header, "start_ms");
  const std::size_t end_ms = column_index(header, "end_ms");
  const std::size_t last = std::max({kind, batch, status, start_ms, end_ms});
  ASSERT_LT(last, header.size()) << rows.front();
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (rows[i].empty()) continue;
    const std::vector<std::string> f = split_csv(rows[i]);
    ASSERT_GT(f.size(), last) << rows[i];
    if (f[kind] != "encoder" || f[batch] != "1" || f[status] != "completed") continue;
    const double start = std::stod(f[start_ms]);
    if (start < 500.0) continue;
    sum += std::stod(f[end_ms]) - start;
    ++n;
  }
  ASSERT_GT(n, 0);
  double written = -1.0;
  for (const json& u : prof.at("units").at("encoder"))
    if (u.at("batch").get<int>() == 1) written = u.at("mean_us").get<double>() / 1000.0;
  EXPECT_NEAR(written, sum / n, 1e-3 * (sum / n)) << n << " encoder runs";

  // It is a profile the simulator (and the next real run) takes.
  const RunResult next = red("compare " + scenario("case-async.yaml") + " --profile " +
                             quote(own.string()) + " --policies red --set duration_s=2");
  ASSERT_EQ(next.code, 0) << next.err;
  EXPECT_TRUE(contains(next.out, "profile calibrated")) << next.out;
  // `red run` without --out keeps the units it needs for the fit.
  const fs::path alone = dir_ / "run-own-costs.json";
  const RunResult single = red("run " + scenario("case-async.yaml") +
                                   " --policy red --backend synthetic --no-realtime "
                                   "--set duration_s=2 --write-profile " +
                                   quote(alone.string()),
                               "timeout 300");
  ASSERT_EQ(single.code, 0) << single.err;
  EXPECT_EQ(json::parse(read_text(alone)).at("calibration").at("policies"), json::array({"red"}));
  // The simulator's costs are the profile's: nothing to write.
  expect_bad_input("compare " + scenario("case-async.yaml") + " --write-profile " +
                       quote((dir_ / "sim.json").string()),
                   "--write-profile");
  EXPECT_FALSE(fs::exists(dir_ / "sim.json"));
}

// Plain nodes cost what the scenario says: there is nothing to fit from the run's units, so
// the run still succeeds with the prediction from the profile alone.
TEST_F(Cli, RealCompareOfPlainNodesHasNoPredictionFromTheRunsCosts) {
  const fs::path out = dir_ / "plain";
  const RunResult r =
      red("compare " + quote(data("tiny.yaml")) +
              " --backend synthetic --no-realtime --policies edf --out " + quote(out.string()),
          "timeout 300");
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "simulator prediction with the same profile")) << r.out;
  EXPECT_FALSE(contains(r.out, "costs each policy's units met")) << r.out;
  const json j = json::parse(read_text(out / "prediction.json"));
  ASSERT_EQ(j.at("policies").size(), 1u);
  EXPECT_TRUE(j.at("policies")[0].contains("sim"));
  EXPECT_FALSE(j.at("policies")[0].contains("sim_run_costs"));
}

// ---- red sweep ------------------------------------------------------------------------------

TEST_F(Cli, SweepWritesOneColumnPerValue) {
  const fs::path out = dir_ / "sweep";
  const RunResult r =
      red("sweep " + scenario("minibench-tight.yaml") +
          " --set deadline_scale=0.8:1.2:0.2 --policies edf,red --out " + quote(out.string()));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(out / "sweep.json"));
  ASSERT_TRUE(fs::exists(out / "sweep.csv"));
  const json j = json::parse(read_text(out / "sweep.json"));
  EXPECT_EQ(j.at("parameter"), "deadline_scale");
  ASSERT_EQ(j.at("values").size(), 3u);
  EXPECT_NEAR(j.at("values")[0].get<double>(), 0.8, 1e-9);
  EXPECT_NEAR(j.at("values")[1].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j.at("values")[2].get<double>(), 1.2, 1e-9);
  ASSERT_EQ(j.at("policies").size(), 2u);
  EXPECT_EQ(j.at("policies")[0].at("name"), "edf");
  EXPECT_EQ(j.at("policies")[1].at("name"), "red");
  for (const json& p : j.at("policies")) {
    EXPECT_EQ(p.at("miss_rate").size(), 3u);
    EXPECT_EQ(p.at("qoe").size(), 3u);
  }
  // The printed miss rates are percentages, as `red compare` prints them (sweep.json keeps
  // fractions): edf's at deadline_scale 1, to two decimals.
  EXPECT_TRUE(contains(r.out, "miss rate (%) by deadline_scale")) << r.out;
  const double edf_miss = j.at("policies")[0].at("miss_rate")[1].get<double>();
  EXPECT_GT(edf_miss, 0.0);
  EXPECT_TRUE(contains(r.out, fmt::format(" {:>9.2f}", 100 * edf_miss))) << r.out;
  // Looser deadlines never make edf miss more on the identical workload... at least the
  // loosest is no worse than the tightest.
  const json& edf = j.at("policies")[0].at("miss_rate");
  EXPECT_LE(edf[2].get<double>(), edf[0].get<double>());

  const auto csv = lines_of(read_text(out / "sweep.csv"));
  ASSERT_EQ(csv.size(), 7u);  // header + 2 policies × 3 values
  EXPECT_EQ(split_csv(csv[0]).at(1), "deadline_scale");
  std::set<std::string> values;
  for (std::size_t i = 1; i < csv.size(); ++i) values.insert(split_csv(csv[i]).at(1));
  EXPECT_EQ(values, (std::set<std::string>{"0.8", "1", "1.2"}));
}

// docs/DESIGN.md, "Performance targets": a sweep over rate_scale reports each policy's breakdown
// rate beside the physical limit, and every swept value up to a policy's breakdown rate keeps its
// misses within 1 %, the next one does not.
TEST_F(Cli, SweepOverRateScaleReportsTheBreakdownRate) {
  const fs::path out = dir_ / "sweep-rate";
  const RunResult r =
      red("sweep " + scenario("minibench-tight.yaml") +
          " --set rate_scale=2.2,1.6,2.0,2.1 --policies edf,red,mono --out " + quote(out.string()));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("breakdown rate"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("physical limit: rate_scale"), std::string::npos) << r.out;
  const json j = json::parse(read_text(out / "sweep.json"));
  const json& bd = j.at("breakdown");
  EXPECT_DOUBLE_EQ(bd.at("miss_limit").get<double>(), 0.01);
  const double limit = bd.at("limit_scale").get<double>();
  // Not 1: the load is not linear in the rate (faster frames gather into larger batches, which
  // cost less per run), and the phases with detection need more than the run's mean.
  EXPECT_GT(limit * bd.at("necessary_load").get<double>(), 0.5);
  EXPECT_LT(limit * bd.at("necessary_load").get<double>(), 1.5);
  const json& values = j.at("values");
  ASSERT_EQ(bd.at("policies").size(), 3u);
  int found = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    const json& row = bd.at("policies")[i];
    const json& miss = j.at("policies")[i].at("miss_rate");
    ASSERT_EQ(row.at("name"), j.at("policies")[i].at("name"));
    SCOPED_TRACE(row.at("name").get<std::string>());
    if (row.at("rate_scale").is_null()) {
      // None: the smallest swept value (1.6) already misses more than 1 %.
      EXPECT_GT(miss[1].get<double>(), 0.01);
      continue;
    }
    ++found;
    const double b = row.at("rate_scale").get<double>();
    EXPECT_NEAR(row.at("fraction").get<double>(), b / limit, 1e-9);
    for (std::size_t k = 0; k < values.size(); ++k) {
      const double v = values[k].get<double>();
      if (v <= b) {
        EXPECT_LE(miss[k].get<double>(), 0.01) << v;
      }
    }
    if (!row.at("censored").get<bool>()) {
      // The next swept value above it misses more than 1 %.
      double next = 1e9;
      std::size_t at = 0;
      for (std::size_t k = 0; k < values.size(); ++k)
        if (values[k].get<double>() > b && values[k].get<double>() < next) {
          next = values[k].get<double>();
          at = k;
        }
      ASSERT_LT(next, 1e9);
      EXPECT_GT(miss[at].get<double>(), 0.01);
    }
    // No policy keeps up past the physical limit by much: the limit is the work itself.
    EXPECT_LE(b, limit * 1.05);
  }
  EXPECT_GE(found, 2);  // red and mono hold at 1.6 on the built-in profile; edf does not
  const std::string html = read_text(out / "index.html");
  EXPECT_NE(html.find("Breakdown rate"), std::string::npos);
  EXPECT_NE(html.find("fraction of the limit"), std::string::npos);
  EXPECT_TRUE(bd.at("policies")[0].at("rate_scale").is_null());
}

// A policy that misses at most 1 % at every swept scale has a breakdown rate of at least the
// largest (censored); a sweep over another key reports none.
TEST_F(Cli, SweepBreakdownRateIsCensoredWhenNoSweptScaleMissesMore) {
  const fs::path out = dir_ / "sweep-censored";
  const RunResult r = red("sweep " + scenario("minibench-tight.yaml") +
                          " --set rate_scale=0.5,1 --policies red --out " + quote(out.string()));
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("no swept value missed more"), std::string::npos) << r.out;
  const json j = json::parse(read_text(out / "sweep.json"));
  const json& row = j.at("breakdown").at("policies").at(0);
  EXPECT_TRUE(row.at("censored").get<bool>());
  EXPECT_DOUBLE_EQ(row.at("rate_scale").get<double>(), 1.0);
  for (const json& m : j.at("policies").at(0).at("miss_rate")) EXPECT_LE(m.get<double>(), 0.01);

  const RunResult other =
      red("sweep " + scenario("minibench-tight.yaml") + " --set deadline_scale=1 --policies red");
  ASSERT_EQ(other.code, 0) << other.err;
  EXPECT_EQ(other.out.find("breakdown rate"), std::string::npos) << other.out;
}

// ---- bad input: exit code 2 and a located message, never a crash -----------------------------

// Every command says the same: the name and every known one (unknown_policy_message).
TEST_F(Cli, UnknownPolicy) {
  const std::string message = unknown_policy_message("bogus");
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --policy bogus", message);
  expect_bad_input("compare " + quote(data("tiny.yaml")) + " --policies edf,bogus", message);
  expect_bad_input(
      "sweep " + quote(data("tiny.yaml")) + " --set deadline_scale=1,2 --policies bogus", message);
  expect_bad_input("analyze " + quote(data("tiny.yaml")) + " --policy bogus", message);
}

TEST_F(Cli, MissingScenarioFile) {
  const std::string path = (dir_ / "no-such-scenario.yaml").string();
  for (const char* cmd : {"validate", "simulate", "compare"})
    expect_bad_input(std::string(cmd) + " " + quote(path), path + ": cannot open");
  expect_bad_input("sweep " + quote(path) + " --set deadline_scale=1", path + ": cannot open");
}

TEST_F(Cli, YamlSyntaxError) {
  const std::string path = data("syntax_error.yaml");
  for (const char* cmd : {"validate", "simulate"})
    expect_bad_input(std::string(cmd) + " " + quote(path), path + ":5:");
  expect_bad_input("validate " + quote(path), "YAML syntax error");
}

TEST_F(Cli, EmptyFile) {
  const std::string path = data("empty.yaml");
  for (const char* cmd : {"validate", "simulate", "compare"})
    expect_bad_input(std::string(cmd) + " " + quote(path), path + ": the file is empty");
}

TEST_F(Cli, UnknownKeyNamesFileAndLine) {
  const std::string path = data("unknown_key.yaml");
  for (const char* cmd : {"validate", "simulate", "compare"})
    expect_bad_input(std::string(cmd) + " " + quote(path), path + ":5: ");
  expect_bad_input("validate " + quote(path), "unknown key 'colour'");
}

TEST_F(Cli, UnknownSubcommand) {
  expect_bad_input("frobnicate " + quote(data("tiny.yaml")), "subcommand");
  expect_bad_input("", "subcommand");  // no subcommand at all
}

TEST_F(Cli, UnknownSubcommandIsNamed) {
  expect_bad_input("frobnicate " + quote(data("tiny.yaml")), "frobnicate");
}

TEST_F(Cli, BadSetValue) {
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --set deadline_scale=abc",
                   "not a number");
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --set deadline_scale", "key=value");
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --set deadline_scale=-1",
                   "deadline_scale");
  expect_bad_input("validate " + quote(data("tiny.yaml")) + " --set lanes=0", "lanes");
  expect_bad_input("sweep " + quote(data("tiny.yaml")) + " --set deadline_scale=1.2:0.8:0.1",
                   "deadline_scale");
  expect_bad_input("sweep " + quote(data("tiny.yaml")) + " --set deadline_scale=0.5,x",
                   "not a number");
}

// Numbers and lists the command line once accepted silently (issue 39): hex, NaN, a negative
// count, a policy listed twice, an empty list, a sweep of NaN steps or of a billion values.
TEST_F(Cli, NumbersAndListsThatMeantNothingAreRefused) {
  const std::string tiny = quote(data("tiny.yaml"));
  expect_bad_input("simulate " + tiny + " --set rate_scale=0x10", "not a number");
  expect_bad_input("simulate " + tiny + " --set rate_scale=nan", "not a number");
  expect_bad_input("sweep " + tiny + " --set rate_scale=1:2:nan", "finite decimal numbers");
  expect_bad_input("sweep " + tiny + " --set rate_scale=1:2:1e-9", "more than 10000 values");
  expect_bad_input("run " + tiny + " --backend synthetic --watchdog-x nan", "--watchdog-x");
  expect_bad_input("simulate " + tiny + " --trace-events -1", "--trace-events");
  expect_bad_input("compare " + tiny + " --policies red,red", "'red' is listed twice");
  expect_bad_input("compare " + tiny + " --policies ''", "--policies: empty list");
}

// Output that cannot be written is a failure naming the reason (exit 1), never an exit 0
// with the table gone: standard output on a full device.
TEST_F(Cli, AStandardOutputThatCannotBeWrittenIsAnError) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  const std::string to_full = R"(sh -c 'exec "$0" "$@" >/dev/full')";
  for (const std::string& args : {"validate " + quote(data("tiny.yaml")),
                                  "compare " + quote(data("tiny.yaml")) + " --policies edf,red"}) {
    SCOPED_TRACE(args);
    const RunResult r = red(args, to_full);
    ASSERT_TRUE(r.exited) << r.err;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_TRUE(contains(r.err, "standard output: No space left on device")) << r.err;
  }
  // --help and --version too (they exited 0 with nothing written).
  for (const std::string args : {"--help", "validate --help", "--version"}) {
    SCOPED_TRACE(args);
    const RunResult r = red(args, to_full);
    ASSERT_TRUE(r.exited) << r.err;
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_TRUE(contains(r.err, "red: standard output: ")) << r.err;
  }
}

TEST_F(Cli, NegativeSeedIsRejected) {
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --seed -1", "--seed");
  expect_bad_input("sweep " + quote(data("tiny.yaml")) + " --set deadline_scale=1 --seed -1",
                   "--seed");
}

// A seed past 2^64 - 1 was clamped to it; a seed that is not a number printed a range
// ending in a 309-digit bound.
TEST_F(Cli, SeedMustFitSixtyFourBits) {
  const std::string tiny = quote(data("tiny.yaml"));
  expect_bad_input("simulate " + tiny + " --seed 18446744073709551616",
                   "--seed: must be a whole number from 0 to 18446744073709551615, not "
                   "'18446744073709551616'");
  const RunResult r = red("simulate " + tiny + " --seed abc");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(contains(r.err, "not 'abc'")) << r.err;
  EXPECT_FALSE(contains(r.err, "000000000000000000")) << r.err;
  EXPECT_EQ(red("simulate " + tiny + " --seed 18446744073709551615").code, 0);
}

TEST_F(Cli, MisspeltOptionGetsTheClosestOne) {
  expect_bad_input("compare " + quote(data("tiny.yaml")) + " --polices edf,red",
                   "red compare: unknown option '--polices' (did you mean --policies?)");
  // Nothing close: no suggestion, CLI11's message alone.
  const RunResult r = red("compare " + quote(data("tiny.yaml")) + " --zzzzzzzzzz 1");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(contains(r.err, "did you mean")) << r.err;
}

// Shortening a run leaves out the events past its end, with a warning (it was refused).
TEST_F(Cli, ShorterDurationLeavesOutLaterEvents) {
  const std::string tight = scenario("minibench-tight.yaml");
  const RunResult r = red("simulate " + tight + " --policy red --set duration_s=2.5");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "red: warning: --set duration_s=2.5 leaves out")) << r.err;
  const RunResult sweep = red("sweep " + tight + " --policies red --set duration_s=2.5,4 --out " +
                              quote((dir_ / "sw").string()));
  EXPECT_EQ(sweep.code, 0) << sweep.err;
  EXPECT_TRUE(contains(sweep.err, "red: warning: duration_s=2.5 leaves out")) << sweep.err;
}

TEST_F(Cli, TooLargeOverrideSaysTooLarge) {
  const RunResult r = red("simulate " + quote(data("tiny.yaml")) + " --set duration_s=1e10");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(contains(r.err, "must be > 0")) << r.err;
}

TEST_F(Cli, SensorRateWhosePeriodOverflowsIsRejected) {
  // `timeout` turns the hang into exit 124 (a failure) instead of stalling the suite.
  expect_bad_input("simulate " + quote(data("tiny_rate.yaml")), "rate_hz", "timeout 120");
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --set rate_scale=1e-12", "rate_scale",
                   "timeout 120");
}

TEST_F(Cli, UnknownSetKey) {
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --set bogus_key=1",
                   "unknown key 'bogus_key'");
  expect_bad_input("sweep " + quote(data("tiny.yaml")) + " --set bogus_key=1,2",
                   "unknown key 'bogus_key'");
}

TEST_F(Cli, MissingRequiredArgument) {
  expect_bad_input("validate", "scenario");
  expect_bad_input("simulate", "scenario");
  expect_bad_input("sweep " + quote(data("tiny.yaml")), "--set");  // the swept parameter
  expect_bad_input("simulate " + quote(data("tiny.yaml")) + " --policy", "--policy");
  expect_bad_input("compare " + quote(data("tiny.yaml")) + " --backend gpu", "backend");
}

TEST_F(Cli, BadInputWritesNoOutputs) {
  const fs::path out = dir_ / "never";
  expect_bad_input("simulate " + quote(data("unknown_key.yaml")) + " --out " + quote(out.string()),
                   "unknown key");
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

}  // namespace
}  // namespace red

namespace red {
namespace {

// --sync overrides a preset's synchronization: per-edge pays a round trip for every
// dispatch, on-demand continues a job's chain on the same lane without one.
TEST_F(Cli, SyncOptionSelectsPerEdgeOrOnDemand) {
  auto trips = [&](const std::string& sync) {
    const fs::path out = dir_ / ("sync-" + sync);
    const RunResult r =
        red("simulate " + scenario("minibench-tight.yaml") + " --policy red --sync " + sync +
            " --trace-events 0 --out " + quote(out.string()));
    EXPECT_EQ(r.code, 0) << r.err;
    const json p = json::parse(read_text(out / "summary.json")).at("policies")[0];
    return std::pair{p.at("sync_round_trips").get<long>(), p.at("dispatches").get<long>()};
  };
  const auto [edge_trips, edge_dispatches] = trips("per-edge");
  const auto [demand_trips, demand_dispatches] = trips("on-demand");
  EXPECT_EQ(edge_trips, edge_dispatches);
  EXPECT_GT(demand_dispatches, 0);
  EXPECT_LT(demand_trips, demand_dispatches);
  expect_bad_input("simulate " + scenario("minibench-tight.yaml") + " --sync sometimes", "--sync");
}

TEST_F(Cli, WithSetsPolicyOptionsForAblations) {
  auto summary = [&](const std::string& args) {
    const fs::path out = dir_ / "with";
    fs::remove_all(out);
    const RunResult r =
        red("simulate " + scenario("minibench-tight.yaml") + " --set rate_scale=2 " + args +
            " --trace-events 0 --out " + quote(out.string()));
    EXPECT_EQ(r.code, 0) << r.err;
    return json::parse(read_text(out / "summary.json")).at("policies")[0];
  };
  // red with red-robust's mechanisms is red-robust, figure for figure.
  const json robust = summary("--policy red-robust");
  const json red_with =
      summary("--policy red --with drop=hopeless,admission=shed,rank=overload,drop_estimate=mean");
  EXPECT_EQ(robust.at("on_time"), red_with.at("on_time"));
  EXPECT_EQ(robust.at("drop_reasons"), red_with.at("drop_reasons"));
  // ... and red-robust without them is red.
  const json red = summary("--policy red");
  const json robust_without =
      summary("--policy red-robust --with drop=strict --with admission=none,rank=policy");
  EXPECT_EQ(red.at("on_time"), robust_without.at("on_time"));
  EXPECT_EQ(red.at("latency_ms"), robust_without.at("latency_ms"));

  expect_bad_input("simulate " + scenario("minibench-tight.yaml") + " --with drop=sometimes",
                   "'sometimes' is not one of: none, strict, hopeless");
  expect_bad_input("compare " + scenario("minibench-tight.yaml") + " --with colour=red",
                   "unknown policy option 'colour'");
  expect_bad_input("simulate " + scenario("minibench-tight.yaml") + " --with merge", "key=value");
}

TEST_F(Cli, ScenarioSchedulerSectionSetsPolicyOptions) {
  const fs::path path = dir_ / "opts.yaml";
  std::ofstream(path) << "name: opts\nduration_s: 1\nscheduler:\n  gamma_ms: 10\n"
                         "  admission: sideways\noperations:\n  - name: a\n    rate_hz: 10\n"
                         "    deadline_ms: 50\n    nodes: {A: {cost_ms: 1}}\n";
  expect_bad_input("validate " + quote(path.string()), path.string() + ":5: ");
  expect_bad_input("simulate " + quote(path.string()), "'sideways' is not one of: none, shed");
}

TEST_F(Cli, RunDefaultsToRedRobust) {
  const RunResult r = red("run --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(contains(r.out, "--policy TEXT=red-robust")) << r.out;
}

}  // namespace
}  // namespace red

namespace red {
namespace {

// --watchdog-x (red run, red compare on a real backend): a multiple of a unit's p99, 0 off.
TEST_F(Cli, WatchdogMultipleMustNotBeNegative) {
  expect_bad_input("run " + quote(data("tiny.yaml")) + " --backend synthetic --watchdog-x -1",
                   "--watchdog-x");
  expect_bad_input("compare " + quote(data("tiny.yaml")) +
                       " --backend synthetic --policies red --watchdog-x often",
                   "--watchdog-x");
}

}  // namespace
}  // namespace red
