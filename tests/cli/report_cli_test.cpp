// `red report DIR` run as a real process (docs/REPORTS.md, "red report"): the page redrawn
// from a run's saved files is the one compare wrote (round trip), --timeline, --phase and
// --policy change the timeline, the default timeline shows every policy's worst miss and
// every phase's start, every file is linked, and bad directories are refused (exit 2)
// with the file and the line.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "../support/cli.hpp"
#include "red/profile/profile.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;

using Result = test::RunResult;

// The delivery robot: two cameras, an operation added at 4 s and removed at 7 s.
// The built-in profile with every figure doubled, written under `dir`: units that cost twice
// what the plan's profile says (--costs).
fs::path slow_profile(const fs::path& dir) {
  Profile slow = default_profile();
  for (auto& [name, u] : slow.units)
    for (LatencyStats& st : u.by_batch) st = st.scaled(2.0);
  const fs::path costs = dir / "slow.json";
  std::ofstream(costs) << profile_to_json(slow);
  return costs;
}

std::string delivery() {
  return quote(std::string(RED_TEST_DATA) + "/scenarios/delivery-robot.yaml");
}

class ReportCli : public test::ScratchTest {
 protected:
  Result red(const std::string& args) { return test::run_red(args, dir_); }
  // A comparison of the delivery robot into dir_/name; its directory.
  fs::path compare(const std::string& name, const std::string& more = "") {
    const fs::path out = dir_ / name;
    const Result r = red("compare " + delivery() + " --policies edf,fifo,red --out " +
                         quote(out.string()) + " " + more);
    EXPECT_EQ(r.code, 0) << r.err;
    return out;
  }
};

// The captions of the timeline figures, in page order.
std::vector<std::string> timeline_titles(const std::string& html) {
  std::vector<std::string> out;
  const std::regex re("<figcaption>(Timeline[^<]*)");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), re); it != std::sregex_iterator();
       ++it)
    out.push_back((*it)[1].str());
  return out;
}

TEST_F(ReportCli, RedrawsTheSamePageFromTheSavedFiles) {
  const fs::path out = compare("run");
  const std::string page = read_text(out / "index.html");
  const std::string svg = read_text(out / "plots" / "timeline_phase0.svg");
  ASSERT_FALSE(page.empty());
  const Result r = red("report " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  // Byte for byte: the run id is kept, and nothing on the page is a time of day.
  EXPECT_EQ(read_text(out / "index.html"), page);
  EXPECT_EQ(read_text(out / "plots" / "timeline_phase0.svg"), svg);
  const auto manifest = nlohmann::json::parse(read_text(out / "manifest.json"));
  EXPECT_TRUE(manifest.at("complete").get<bool>());
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(manifest.at("run_id"), summary.at("run_id"));
}

TEST_F(ReportCli, TheSameWindowGivesTheSamePageAsCompare) {
  const fs::path a = compare("a", "--timeline 4.5:5.5");
  const fs::path b = compare("b");
  const Result r = red("report " + quote(b.string()) + " --timeline 4.5:5.5");
  ASSERT_EQ(r.code, 0) << r.err;
  // The run ids differ (two runs); the rest is the same page.
  const std::regex id("<meta name=\"red-run-id\" content=\"[0-9a-f]+\">");
  const std::string pa = std::regex_replace(read_text(a / "index.html"), id, "");
  const std::string pb = std::regex_replace(read_text(b / "index.html"), id, "");
  ASSERT_NE(pa.find("Timeline: 4.5 to 5.5 s"), std::string::npos);
  EXPECT_EQ(pa, pb);
  // The default drawings are gone, and so is their place in the manifest.
  EXPECT_FALSE(fs::exists(b / "plots" / "timeline_phase0.svg"));
  EXPECT_EQ(read_text(b / "manifest.json").find("timeline_phase0"), std::string::npos);
}

TEST_F(ReportCli, DefaultTimelineShowsEveryPhaseStartAndEveryPolicysWorstMiss) {
  const fs::path out = compare("run");
  const std::string html = read_text(out / "index.html");
  const auto titles = timeline_titles(html);
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  // One drawing per phase (the events at 4 s and 7 s make three).
  const std::size_t phases = summary.at("policies")[0].at("phases").size();
  ASSERT_EQ(phases, 3u);
  for (std::size_t k = 0; k < phases; ++k) {
    EXPECT_TRUE(fs::exists(out / "plots" / fmt::format("timeline_phase{}.svg", k))) << k;
    EXPECT_NE(html.find(fmt::format("Timeline: phase {} (", k)), std::string::npos) << k;
  }
  // Every policy that missed has its own drawing around its worst miss.
  int missed = 0;
  for (const auto& p : summary.at("policies")) {
    const std::string name = p.at("name").get<std::string>();
    const bool drawn =
        html.find("Timeline of " + name + ": 2 s around its worst miss") != std::string::npos;
    EXPECT_EQ(drawn, p.at("missed").get<int>() > 0) << name;
    missed += p.at("missed").get<int>() > 0 ? 1 : 0;
  }
  EXPECT_GT(missed, 0) << "the delivery robot should make some policy miss";
  EXPECT_EQ(titles.size(), phases + static_cast<std::size_t>(missed));
}

TEST_F(ReportCli, PhaseAndPolicyChooseWhatTheTimelineShows) {
  const fs::path out = compare("run");
  Result r = red("report " + quote(out.string()) + " --phase 1");
  ASSERT_EQ(r.code, 0) << r.err;
  std::string html = read_text(out / "index.html");
  auto titles = timeline_titles(html);
  ASSERT_FALSE(titles.empty());
  EXPECT_NE(titles.front().find("Timeline: phase 1 (after add_operation"), std::string::npos)
      << titles.front();
  for (std::size_t i = 1; i < titles.size(); ++i)
    EXPECT_NE(titles[i].find("worst miss in phase 1"), std::string::npos) << titles[i];
  // Only one policy's runs in the drawings.
  r = red("report " + quote(out.string()) + " --policy fifo");
  ASSERT_EQ(r.code, 0) << r.err;
  html = read_text(out / "index.html");
  EXPECT_EQ(html.find("data-policy=\"edf\""), std::string::npos);
  EXPECT_NE(html.find("data-policy=\"fifo\""), std::string::npos);
}

TEST_F(ReportCli, EveryFileIsLinkedAndThePicturesComeFirst) {
  const fs::path out = compare("run");
  const std::string html = read_text(out / "index.html");
  const auto manifest = nlohmann::json::parse(read_text(out / "manifest.json"));
  for (const auto& f : manifest.at("files")) {
    const std::string path = f.at("path").get<std::string>();
    if (path == "index.html") continue;
    EXPECT_NE(html.find("href=\"" + path + "\""), std::string::npos) << path;
  }
  EXPECT_NE(html.find("href=\"manifest.json\""), std::string::npos);
  const auto why = html.find("Which policy, and why jobs missed");
  const auto timeline = html.find("<section id=\"timeline\"");
  const auto tables = html.find("<h2>Results</h2>");
  ASSERT_NE(why, std::string::npos);
  ASSERT_NE(timeline, std::string::npos);
  ASSERT_NE(tables, std::string::npos);
  EXPECT_LT(why, timeline);
  EXPECT_LT(timeline, tables);
}

TEST_F(ReportCli, TheVerdictExplainsEveryPolicy) {
  const fs::path out = compare("run");
  const std::string html = read_text(out / "index.html");
  const auto at = html.find("Verdicts (red analyze");
  ASSERT_NE(at, std::string::npos);
  const std::string table = html.substr(at, html.find("</table>", at) - at);
  EXPECT_NE(table.find("<th>why</th>"), std::string::npos);
  // Each row's why names every policy ("edf, fifo: ...; red: ..."), or "all: " when they
  // agree: a group of names that starts the cell or follows "; ".
  const std::regex row("<td>([^<]*)</td></tr>");
  int rows = 0;
  for (auto it = std::sregex_iterator(table.begin(), table.end(), row);
       it != std::sregex_iterator(); ++it, ++rows) {
    const std::string why = (*it)[1].str();
    if (why.rfind("all: ", 0) == 0) continue;
    for (const std::string p : {"edf", "fifo", "red"}) {
      const std::regex group("(^|; )([a-z-]+, )*" + p + "(, [a-z-]+)*: ");
      EXPECT_TRUE(std::regex_search(why, group)) << p << " in " << why;
    }
  }
  EXPECT_GT(rows, 0);
}

TEST_F(ReportCli, BadDirectoriesAreRefusedWithTheFileAndLine) {
  Result r = red("report " + quote((dir_ / "none").string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("no such directory"), std::string::npos) << r.err;

  const fs::path out = compare("run");
  // A malformed row: the file and its line.
  {
    std::string jobs = read_text(out / "jobs.csv");
    const auto second = jobs.find('\n', jobs.find('\n') + 1);
    jobs.insert(second + 1, "edf,drive,x,not-a-number\n");
    std::ofstream(out / "jobs.csv", std::ios::binary) << jobs;
  }
  r = red("report " + quote(out.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("jobs.csv:3:"), std::string::npos) << r.err;

  // An incomplete run (stopped, or a file lost).
  const fs::path inc = compare("inc");
  {
    std::string m = read_text(inc / "manifest.json");
    m.replace(m.find("\"complete\": true"), 16, "\"complete\": false");
    std::ofstream(inc / "manifest.json", std::ios::binary) << m;
  }
  r = red("report " + quote(inc.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("manifest.json:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not complete"), std::string::npos) << r.err;

  // A summary of an older red (no "page"): refused with what to do.
  const fs::path old = compare("old");
  {
    auto s = nlohmann::ordered_json::parse(read_text(old / "summary.json"));
    s.erase("page");
    std::ofstream(old / "summary.json", std::ios::binary) << s.dump(2);
  }
  r = red("report " + quote(old.string()));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("summary.json:1: has no \"page\""), std::string::npos) << r.err;

  // Options that do not fit the run.
  const fs::path ok = compare("ok");
  EXPECT_EQ(red("report " + quote(ok.string()) + " --phase 9").code, 2);
  EXPECT_EQ(red("report " + quote(ok.string()) + " --policy lst").code, 2);
  EXPECT_EQ(red("report " + quote(ok.string()) + " --timeline 99:100").code, 2);
}

// `red report DIR --why OPERATION#JOB`: one job's story with the cause jobs.csv gives it;
// bad input is refused with exit code 2 and a message that says what to give.
TEST_F(ReportCli, WhyTellsOneJobsStory) {
  const fs::path out = compare("why");
  // The first job not met, with its policy, name and cause (jobs.csv's columns 0, 1, 2, 6, 12).
  std::istringstream rows(read_text(out / "jobs.csv"));
  std::string line;
  std::getline(rows, line);
  std::vector<std::string> f;
  while (std::getline(rows, line)) {
    if (line.find('"') != std::string::npos) continue;  // a quoted field: not needed here
    f.clear();
    std::istringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) f.push_back(c);
    if (f.size() >= 13 && f[6] != "met") break;
    f.clear();
  }
  ASSERT_GE(f.size(), 13u) << "no job missed in the delivery robot";
  EXPECT_FALSE(f[12].empty()) << line;
  const std::string job = f[1] + "#" + f[2];
  Result r = red("report " + quote(out.string()) + " --why " + job + " --policy " + f[0]);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(job + " under " + f[0]), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cause: " + f[12]), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("its units"), std::string::npos) << r.out;
  // The page's why table and the summary's causes of the same policy.
  EXPECT_NE(read_text(out / "index.html").find(f[0] + ": why jobs missed"), std::string::npos);
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  bool counted = false;
  for (const auto& p : summary.at("policies"))
    if (p.at("name") == f[0])
      for (const auto& ph : p.at("phases"))
        if (ph.at("operations").contains(f[1]))
          for (const auto& c : ph.at("operations").at(f[1]).at("causes"))
            counted = counted || c.at("cause") == f[12];
  EXPECT_TRUE(counted) << "summary.json has no count of " << f[12];

  // Several policies and none named; a name that is not a job; an unknown operation; a job
  // not in the run.
  r = red("report " + quote(out.string()) + " --why " + job);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--policy"), std::string::npos) << r.err;
  r = red("report " + quote(out.string()) + " --why " + f[1] + " --policy " + f[0]);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("OPERATION#JOB"), std::string::npos) << r.err;
  r = red("report " + quote(out.string()) + " --why nosuch#1 --policy " + f[0]);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("no operation 'nosuch'"), std::string::npos) << r.err;
  r = red("report " + quote(out.string()) + " --why " + f[1] + "#999999999 --policy " + f[0]);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("no such job"), std::string::npos) << r.err;
  EXPECT_EQ(red("report " + quote(out.string()) + " --why " + job + " --policy lst").code, 2);
}

// Issue 53: a run whose units cost twice the profile's (the simulator drawing from another
// profile, --costs) follows them with online estimates, and says so: summary.json's costs
// per unit and batch size, index.html's costs table, both kept by `red report DIR`.
TEST_F(ReportCli, TheCostsARunMetAreSavedShownAndRedrawn) {
  const fs::path costs = slow_profile(dir_);
  const fs::path out = compare("costs", "--costs " + quote(costs.string()));
  const auto summary = nlohmann::json::parse(read_text(out / "summary.json"));
  for (const auto& p : summary.at("policies")) {
    ASSERT_TRUE(p.contains("costs")) << p.at("name");
    const auto& c = p.at("costs");
    EXPECT_TRUE(c.at("online").get<bool>());
    EXPECT_GE(c.at("plan_changes").get<int>(), 1) << p.at("name");
    // red runs the encoder as its own unit; edf and fifo run coarse units (encoder and
    // head back to back), measured against the profile's coarse figures.
    int measured = 0;
    for (const auto& u : c.at("units")) {
      const std::string unit = u.at("unit").get<std::string>();
      if (u.at("runs").get<int>() < 10 || (unit != "encoder" && unit.rfind("coarse/", 0) != 0))
        continue;
      ++measured;
      EXPECT_NEAR(u.at("ratio").get<double>(), 2.0, 0.25) << p.at("name") << " " << unit;
    }
    EXPECT_GE(measured, 1) << p.at("name");
    // The plan follows: the encoder's figures doubled.
    for (const auto& u : c.at("units"))
      if (u.at("unit") == "encoder" && u.at("batch") == 1) {
        EXPECT_NEAR(u.at("planned_factor").get<double>(), 2.0, 0.25) << p.at("name");
      }
  }
  const std::string page = read_text(out / "index.html");
  EXPECT_NE(page.find("Costs: the profile against this run"), std::string::npos);
  const Result r = red("report " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(read_text(out / "index.html"), page);
}

// A run whose trace holds tasks waiting (merge waits, or the criticality guard's holds, counted
// by the trace's "merge wait" counter) is redrawn: the counter, a "C" event of the same name as
// the waits' instants, once aborted `red report` on its missing until_ms.
TEST_F(ReportCli, RedrawsARunWhoseTraceCountsWaitingTasks) {
  const fs::path costs = slow_profile(dir_);
  const fs::path out = dir_ / "warehouse";
  const Result run = red(
      "compare " + quote(std::string(RED_TEST_DATA) + "/workloads/warehouse/warehouse.yaml") +
      " --policies red-robust --costs " + quote(costs.string()) + " --out " + quote(out.string()));
  ASSERT_EQ(run.code, 0) << run.err;
  const std::string trace = read_text(out / "trace.json");
  EXPECT_NE(trace.find(R"("name":"merge wait","ph":"C")"), std::string::npos)
      << "no waiting tasks counted: the run no longer exercises the counter";
  const std::string page = read_text(out / "index.html");
  const Result r = red("report " + quote(out.string()));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(read_text(out / "index.html"), page);
}

}  // namespace
}  // namespace red
