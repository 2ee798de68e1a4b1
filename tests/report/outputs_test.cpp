// What `red compare|simulate|sweep --out DIR` leaves for a person: summary.json, jobs.csv,
// units.csv, trace.json, plots and index.html, run as a real process. Progress stays quiet
// when stderr is not a terminal (here it is a file).

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "red/report/plots.hpp"

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using test::quote;
using test::read_text;
using test::scenario;

class Outputs : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        fs::temp_directory_path() / fmt::format("red_outputs_test_{}_{}", ::getpid(), info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  // Runs `env red ARGS`; returns the exit code, stdout and stderr in out_, err_.
  int red(const std::string& args, const std::string& env = "") {
    const std::string cmd = env + (env.empty() ? "" : " ") + quote(RED_CLI) + " " + args + " >" +
                            quote((dir_ / "stdout.txt").string()) + " 2>" +
                            quote((dir_ / "stderr.txt").string()) + " </dev/null";
    const int status = std::system(cmd.c_str());
    out_ = read_text(dir_ / "stdout.txt");
    err_ = read_text(dir_ / "stderr.txt");
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  fs::path dir_;
  std::string out_, err_;
};

TEST_F(Outputs, CompareWritesEverythingAPersonLooksAt) {
  const fs::path out = dir_ / "x";
  ASSERT_EQ(red("compare " + scenario("case-dynamic.yaml") + " --policies edf,red --out " +
                quote(out.string())),
            0)
      << err_;
  for (const char* f : {"summary.json", "jobs.csv", "units.csv", "trace.json", "index.html"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_NE(out_.find("trace.json"), std::string::npos) << out_;
  EXPECT_NE(out_.find("index.html"), std::string::npos) << out_;
  EXPECT_EQ(err_.find('\r'), std::string::npos) << "progress drawn on a non-terminal";

  // trace.json: one process per policy.
  const json trace = json::parse(read_text(out / "trace.json"));
  std::set<std::string> processes;
  for (const json& e : trace.at("traceEvents"))
    if (e.at("ph") == "M" && e.at("name") == "process_name")
      processes.insert(e.at("args").at("name").get<std::string>());
  EXPECT_EQ(processes, (std::set<std::string>{"policy edf", "policy red"}));

  // index.html: a row per policy, and every local file it references exists.
  const std::string html = read_text(out / "index.html");
  EXPECT_NE(html.find("<tr><td>edf</td>"), std::string::npos);
  EXPECT_NE(html.find("<tr><td>red</td>"), std::string::npos);
  const std::regex ref("(?:src|href)=\"([^\"]+)\"");
  int refs = 0;
  for (auto it = std::sregex_iterator(html.begin(), html.end(), ref); it != std::sregex_iterator();
       ++it) {
    const std::string target = (*it)[1];
    ASSERT_EQ(target.find("://"), std::string::npos) << "remote reference " << target;
    EXPECT_TRUE(fs::exists(out / target)) << target;
    ++refs;
  }
  EXPECT_GE(refs, 4);  // summary.json, jobs.csv, units.csv, trace.json (+ plots)
  if (!gnuplot_png_terminal("gnuplot").empty()) {
    for (const char* p : {"response_hist", "response_cdf", "metrics_bars", "miss_over_time"}) {
      EXPECT_GT(fs::file_size(out / "plots" / (std::string(p) + ".png")), 0u) << p;
      EXPECT_NE(html.find(std::string("plots/") + p + ".png"), std::string::npos) << p;
    }
  }
}

TEST_F(Outputs, SimulateWritesTraceAndPlotsButNoIndex) {
  const fs::path out = dir_ / "sim";
  ASSERT_EQ(
      red("simulate " + scenario("case-async.yaml") + " --policy red --out " + quote(out.string())),
      0)
      << err_;
  EXPECT_TRUE(fs::exists(out / "trace.json"));
  EXPECT_TRUE(fs::exists(out / "plots" / "metrics_bars.gp"));
  EXPECT_FALSE(fs::exists(out / "index.html"));
  EXPECT_NE(out_.find("wrote " + out.string() + "/summary.json, jobs.csv, units.csv"),
            std::string::npos)
      << out_;
}

TEST_F(Outputs, TraceCanBeTurnedOffAndGnuplotMissingIsNotAnError) {
  const fs::path out = dir_ / "quiet";
  ASSERT_EQ(red("compare " + scenario("case-async.yaml") + " --policies red --trace-events 0 " +
                    "--out " + quote(out.string()),
                "RED_GNUPLOT=" + quote((dir_ / "no-gnuplot").string())),
            0)
      << err_;
  EXPECT_FALSE(fs::exists(out / "trace.json"));
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "plots" / "metrics_bars.png"));
  EXPECT_NE(err_.find("gnuplot not found"), std::string::npos) << err_;
  const std::string html = read_text(out / "index.html");
  EXPECT_NE(html.find("gnuplot not found"), std::string::npos);
  EXPECT_EQ(html.find("trace.json\""), std::string::npos);  // no link to a missing file
}

TEST_F(Outputs, SweepWritesCurvesAndIndex) {
  const fs::path out = dir_ / "sweep";
  ASSERT_EQ(red("sweep " + scenario("case-async.yaml") +
                " --set deadline_scale=0.8,1.2 --policies edf,red --out " + quote(out.string())),
            0)
      << err_;
  EXPECT_TRUE(fs::exists(out / "sweep.csv"));
  const std::string html = read_text(out / "index.html");
  EXPECT_NE(html.find("<caption>miss rate (%) by deadline_scale</caption>"), std::string::npos);
  EXPECT_NE(html.find("href=\"sweep.csv\""), std::string::npos);
  if (!gnuplot_png_terminal("gnuplot").empty()) {
    for (const char* p : {"sweep_miss_rate", "sweep_latency", "sweep_qoe"})
      EXPECT_GT(fs::file_size(out / "plots" / (std::string(p) + ".png")), 0u) << p;
  }
}

}  // namespace
}  // namespace red
