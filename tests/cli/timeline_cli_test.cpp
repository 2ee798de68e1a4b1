// `--timeline FROM:TO` and `--phases` on `red simulate`, `red compare` and `red run`, run
// as a real process: the timeline drawn into plots/ and index.html, the phase table, and
// exit code 2 with a message for bad values (before anything runs).

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;
using test::scenario;

class TimelineCli : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           fmt::format("red_timeline_cli_test_{}_{}", ::getpid(), info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  // Runs `red ARGS`; returns the exit code, stdout and stderr in out_, err_.
  int red(const std::string& args) {
    const std::string cmd = quote(RED_CLI) + " " + args + " >" +
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

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t i = text.find(what); i != std::string::npos; i = text.find(what, i + 1)) ++n;
  return n;
}

TEST_F(TimelineCli, SimulateDrawsTheChosenWindowIntoPlots) {
  const fs::path out = dir_ / "sim";
  ASSERT_EQ(red("simulate " + scenario("case-dynamic.yaml") +
                " --policy edf --timeline 2.5:3.5 --out " + quote(out.string())),
            0)
      << err_;
  const std::string svg = read_text(out / "plots" / "timeline.svg");
  ASSERT_FALSE(svg.empty());
  EXPECT_FALSE(fs::exists(out / "plots" / "timeline_start.svg"));
  EXPECT_NE(svg.find("data-from-ms=\"2500.000000\" data-to-ms=\"3500.000000\""), std::string::npos);
  // One box per units.csv row overlapping the window.
  std::istringstream units(read_text(out / "units.csv"));
  std::string line;
  std::getline(units, line);
  std::size_t in_window = 0;
  while (std::getline(units, line)) {
    std::vector<std::string> f;
    std::stringstream ls(line);
    for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
    ASSERT_GE(f.size(), 6u);
    if (std::stod(f[4]) < 3500 && std::stod(f[5]) > 2500) ++in_window;
  }
  EXPECT_GT(in_window, 0u);
  EXPECT_EQ(count(svg, "<g class=\"unit\""), in_window);
  // The workload event at 3 s is in the window.
  EXPECT_NE(svg.find("event 0: add_nodes"), std::string::npos);
  // summary.json: the phases of the run.
  const auto j = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(j.at("policies")[0].at("phases").size(), 3u);
}

TEST_F(TimelineCli, CompareEmbedsTheTimelineAndThePhasesInIndexHtml) {
  const fs::path out = dir_ / "cmp";
  ASSERT_EQ(red("compare " + scenario("case-dynamic.yaml") + " --policies edf,red --out " +
                quote(out.string())),
            0)
      << err_;
  const std::string html = read_text(out / "index.html");
  EXPECT_EQ(html.find("<script"), std::string::npos);  // offline, static
  EXPECT_NE(html.find("class=\"red-timeline\""), std::string::npos);
  EXPECT_NE(html.find("<section id=\"phases\">"), std::string::npos);
  EXPECT_NE(html.find("after add_nodes (event 0)"), std::string::npos);
  EXPECT_NE(html.find("data-policy=\"edf\""), std::string::npos);
  EXPECT_NE(html.find("data-policy=\"red\""), std::string::npos);
  // Default windows: each phase's start (three phases) and, edf missing after 3 s, edf's
  // worst miss (red's too if it missed).
  const auto j = nlohmann::json::parse(read_text(out / "summary.json"));
  std::size_t missed = 0;
  for (const auto& p : j.at("policies")) missed += p.at("missed").get<int>() > 0 ? 1 : 0;
  for (int k = 0; k < 3; ++k)
    EXPECT_TRUE(fs::exists(out / "plots" / ("timeline_phase" + std::to_string(k) + ".svg"))) << k;
  EXPECT_TRUE(fs::exists(out / "plots" / "timeline_worst_edf.svg"));
  EXPECT_EQ(count(html, "class=\"red-timeline\""), 3u + missed);
  EXPECT_NE(out_.find("plots/ ("), std::string::npos);
}

TEST_F(TimelineCli, BadTimelineValuesExitTwoBeforeRunning) {
  const fs::path out = dir_ / "bad";
  const std::string sc = scenario("case-dynamic.yaml");
  for (const std::string& cmd : {"simulate " + sc, "compare " + sc + " --policies edf,red",
                                 "run " + sc + " --backend synthetic --no-realtime"}) {
    for (const char* bad : {"abc", "3:1", "2:2", "=-1:2", "1:2:3", "=", "=:4", "1:x", "50:60"}) {
      const std::string arg =
          bad[0] == '=' ? std::string("--timeline") + bad : std::string("--timeline ") + bad;
      EXPECT_EQ(red(cmd + " " + arg + " --out " + quote(out.string())), 2) << cmd << " " << arg;
      EXPECT_NE(err_.find("timeline"), std::string::npos) << cmd << " " << arg << ": " << err_;
      EXPECT_FALSE(fs::exists(out)) << "wrote output for " << cmd << " " << arg;
    }
    // A window but nowhere to draw it.
    EXPECT_EQ(red(cmd + " --timeline 1:2"), 2) << cmd;
    EXPECT_NE(err_.find("--out"), std::string::npos) << err_;
  }
}

TEST_F(TimelineCli, PhasesPrintsEachPolicysFiguresPerPhase) {
  ASSERT_EQ(red("compare " + scenario("case-dynamic.yaml") + " --policies edf,red --phases"), 0)
      << err_;
  for (const char* policy : {"edf", "red"}) {
    const std::size_t at = out_.find(std::string("phases of ") + policy);
    ASSERT_NE(at, std::string::npos) << out_;
    // Three phases of one operation; their jobs add up to the comparison table's.
    const std::regex row(R"(\n\s*[0-9.]+\s+[0-9.]+\s+navigate\s+([0-9]+)\s)");
    const std::string block = out_.substr(at, out_.find("phases of", at + 1) - at);
    int rows = 0, jobs = 0;
    for (auto it = std::sregex_iterator(block.begin(), block.end(), row);
         it != std::sregex_iterator(); ++it) {
      ++rows;
      jobs += std::stoi((*it)[1].str());
    }
    EXPECT_EQ(rows, 3) << block;
    std::smatch m;
    ASSERT_TRUE(
        std::regex_search(out_, m, std::regex(std::string("\n") + policy + R"(\s+([0-9]+))")));
    EXPECT_EQ(jobs, std::stoi(m[1].str())) << out_;
  }
  EXPECT_NE(out_.find("after remove_nodes (event 1)"), std::string::npos);
  // Without --phases, no phase table.
  ASSERT_EQ(red("simulate " + scenario("case-dynamic.yaml") + " --policy red"), 0) << err_;
  EXPECT_EQ(out_.find("phases of"), std::string::npos);
}

}  // namespace
}  // namespace red
