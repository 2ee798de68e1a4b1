// `red analyze` run as a real process (docs/CLI.md, docs/ANALYSIS.md): the report, analysis.json,
// --check's exit codes (0 all ok, 1 otherwise), bad input (2), and --export-nptest's files.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;
using test::scenario;

using Result = test::RunResult;

class AnalyzeCli : public test::ScratchTest {
 protected:
  Result red(const std::string& args, const std::string& command = "analyze") {
    return test::run_red(command + " " + args, dir_);
  }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return quote(p.string());
  }
};

// A plain chain of 2 × 10 ms under a 15 ms deadline: infeasible.
const char* const kInfeasible = R"(name: infeasible
duration_s: 3
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
operations:
  - name: chain
    rate_hz: 10
    deadline_ms: 15
    nodes:
      A: {cost_ms: 10}
      B: {cost_ms: 10}
    edges: [[A, B]]
)";

TEST_F(AnalyzeCli, ReportAndAnalysisJson) {
  const fs::path out = dir_ / "out";
  const Result r = red(scenario("case-dynamic.yaml") + " --check --out " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  for (const char* s : {"phase", "navigate", "headroom", "rate_scale", "response-time bound",
                        "on-time fraction bound", "verdict: ok"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s << "\n" << r.out;
  const auto j = nlohmann::json::parse(read_text(out / "analysis.json"));
  EXPECT_EQ(j["schema"], 1);
  EXPECT_EQ(j["policy"], "red");
  EXPECT_EQ(j["verdict"], "ok");
  ASSERT_EQ(j["phases"].size(), 3u);
  const auto& op = j["phases"][1]["operations"][0];
  EXPECT_EQ(op["name"], "navigate");
  for (const char* k : {"rate_hz", "deadline_ms", "critical_path_ms", "alone_ms", "work_ms",
                        "utilization", "simulated", "verdict", "reason"})
    EXPECT_TRUE(op.contains(k)) << k;
  EXPECT_TRUE(j["device"].contains("on_time_bound"));
  ASSERT_EQ(j["device"]["lane_busy"].size(), 1u);  // one lane
  EXPECT_GT(j["device"]["lane_busy"][0].get<double>(), 0.0);
  ASSERT_EQ(j["headroom"].size(), 4u);  // red and edf, profiled and worst-case
  EXPECT_EQ(j["headroom"][2]["policy"], "edf");
  EXPECT_EQ(j["headroom"][1]["costs"], "worst-case");
  EXPECT_FALSE(j["response_bound"]["applies"]);
  EXPECT_NE(j["response_bound"]["why_not"].get<std::string>().find("no analysis applies"),
            std::string::npos);
}

TEST_F(AnalyzeCli, CheckExitsOneWhenAnOperationIsNotOk) {
  const std::string f = write("infeasible.yaml", kInfeasible);
  const Result checked = red(f + " --check --no-headroom --policy edf");
  EXPECT_EQ(checked.code, 1) << checked.err;
  EXPECT_NE(checked.out.find("infeasible"), std::string::npos) << checked.out;
  // Without --check the report is a success.
  EXPECT_EQ(red(f + " --no-headroom --policy edf").code, 0);
  // One lane, coarse EDF: the busy-period bound applies.
  EXPECT_NE(checked.out.find("busy period"), std::string::npos) << checked.out;
}

TEST_F(AnalyzeCli, BadInputExitsTwo) {
  Result r = red(quote((dir_ / "missing.yaml").string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("missing.yaml"), std::string::npos) << r.err;
  r = red(scenario("case-dynamic.yaml") + " --policy nope");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown policy 'nope'"), std::string::npos) << r.err;
  r = red(write("bad.yaml", "name: x\nduration_s: -1\n"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.yaml"), std::string::npos) << r.err;
  r = red(scenario("case-dynamic.yaml") + " --export-nptest " + quote(dir_.string()) +
          " --nptest-window-ms -5");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--nptest-window-ms"), std::string::npos) << r.err;
}

TEST_F(AnalyzeCli, ExportNptest) {
  const fs::path np = dir_ / "np";
  const Result r = red(scenario("case-dynamic.yaml") +
                       " --no-headroom --policy edf --export-nptest " + quote(np.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("jobs.csv"), std::string::npos) << r.out;
  const std::string jobs = read_text(np / "jobs.csv");
  EXPECT_EQ(jobs.substr(0, jobs.find('\n')),
            "Task ID, Job ID, Arrival min, Arrival max, Cost min, Cost max, Deadline, Priority");
  const std::string prec = read_text(np / "jobs.prec.csv");
  EXPECT_EQ(prec.substr(0, prec.find('\n')),
            "Predecessor TID, Predecessor JID, Successor TID, Successor JID");
  // 9 s at 30 Hz: the period is 33 333 333 ns, so 271 frames fall before 9 s; 2 coarse
  // nodes each, 3 for the 90 frames while detection is in (frames 91 to 180, 3 s to 6 s).
  std::size_t rows = 0;
  for (char c : jobs) rows += c == '\n';
  EXPECT_EQ(rows - 1, 181u * 2 + 90u * 3);
  EXPECT_TRUE(fs::exists(np / "tasks.csv"));
}

TEST_F(AnalyzeCli, CompareShowsTheVerdictTableFirst) {
  const fs::path out = dir_ / "cmp";
  const Result r = red(scenario("case-dynamic.yaml") +
                           " --policies edf,red --trace-events 0 --out " + quote(out.string()),
                       "compare");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string html = read_text(out / "index.html");
  const auto verdicts = html.find("Verdicts (red analyze");
  const auto results = html.find("Policies on the identical workload");
  ASSERT_NE(verdicts, std::string::npos);
  ASSERT_NE(results, std::string::npos);
  EXPECT_LT(verdicts, results);
  // edf misses once detection joins although the necessary work fits (at risk: another policy
  // fits it); red keeps up.
  EXPECT_NE(html.find("<td>at risk</td>"), std::string::npos);
  EXPECT_EQ(html.find("<td>overloaded</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>ok</td>"), std::string::npos);
}

}  // namespace
}  // namespace red
