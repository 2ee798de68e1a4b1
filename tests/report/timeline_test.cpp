// The timeline SVG (docs/REPORTS.md, "The timeline in index.html") checked against
// units.csv and jobs.csv: every unit execution in the window is drawn once, on its lane,
// at its times; merged runs show their members; round trips, misses, merge waits and
// workload events are marked. The SVG is parsed here, not compared to a golden file.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/report/report.hpp"
#include "red/report/timeline.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

Scenario load(const std::string& name) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
  EXPECT_TRUE(s.has_value()) << name;
  return std::move(s.value());
}

struct Runs {
  Scenario scenario;
  std::vector<PolicyRun> runs;
  std::vector<TimelineRun> timeline;
};

// Every policy of `policies` simulated on the scenario, as the timeline reads them.
Runs simulate(const std::string& name, const std::vector<std::string>& policies) {
  Runs r{load(name), {}, {}};
  auto p = resolve_profile(r.scenario, std::nullopt);
  EXPECT_TRUE(p.has_value());
  for (const std::string& policy : policies) {
    auto run = simulate_policy(r.scenario, *p, policy, r.scenario.seed);
    EXPECT_TRUE(run.has_value()) << policy;
    r.runs.push_back(std::move(run.value()));
  }
  for (const PolicyRun& run : r.runs)
    r.timeline.push_back(
        {run.metrics.name, &run.units, &run.jobs, nullptr, std::nullopt, run.result.end});
  return r;
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

// One unit as units.csv gives it and as the SVG draws it.
struct UnitKey {
  std::string policy;
  std::string dispatch;
  std::string lane;
  std::string start_ms;
  std::string end_ms;
  auto operator<=>(const UnitKey&) const = default;
};

// units.csv rows that overlap [from, to) ms, with their round-trip flag and members.
std::map<UnitKey, std::pair<bool, std::string>> csv_units(const std::string& csv, double from,
                                                          double to) {
  std::map<UnitKey, std::pair<bool, std::string>> out;
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("policy,dispatch,lane,decided_ms,start_ms,end_ms", 0), 0u);
  while (std::getline(in, line)) {
    const auto f = split(line, ',');
    if (f.size() < 13) {
      ADD_FAILURE() << line;
      continue;
    }
    if (std::stod(f[4]) < to && std::stod(f[5]) > from)
      out[{f[0], f[1], f[2], f[4], f[5]}] = {f[10] == "1", f[12]};
  }
  return out;
}

// One `<g class="unit">` of the SVG with the policy and lane groups it is drawn in.
struct DrawnUnit {
  UnitKey key;
  std::string in_policy, in_lane;
  std::string body;  // its markup up to its closing tag
};

std::string attr(const std::string& tag, const std::string& name) {
  const std::regex re(" " + name + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(tag, m, re) ? m[1].str() : std::string();
}

std::vector<DrawnUnit> drawn_units(const std::string& svg) {
  std::vector<DrawnUnit> out;
  std::string policy, lane;
  const std::regex open("<g class=\"(policy|lane|unit|operation)\"[^>]*>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), open); it != std::sregex_iterator();
       ++it) {
    const std::string tag = it->str();
    const std::string cls = (*it)[1].str();
    if (cls == "policy") {
      policy = attr(tag, "data-policy");
      lane.clear();
    } else if (cls == "lane") {
      lane = attr(tag, "data-lane");
    } else if (cls == "operation") {
      lane.clear();
    } else {
      const auto begin = static_cast<std::size_t>(it->position());
      const std::size_t end = svg.find("</g>", begin);
      out.push_back({{attr(tag, "data-policy"), attr(tag, "data-dispatch"), attr(tag, "data-lane"),
                      attr(tag, "data-start-ms"), attr(tag, "data-end-ms")},
                     policy,
                     lane,
                     svg.substr(begin, end - begin)});
    }
  }
  return out;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t i = text.find(what); i != std::string::npos; i = text.find(what, i + 1)) ++n;
  return n;
}

// Checks the drawing of `window` against units.csv of the same runs.
void check_against_units_csv(const Runs& r, const TimelineWindow& window) {
  std::vector<PolicyRows<UnitRow>> rows;
  for (const PolicyRun& run : r.runs) rows.push_back({run.metrics.name, &run.units});
  const std::string csv = units_csv(r.scenario, rows);
  const std::string svg = timeline_svg(r.scenario, r.timeline, window);
  const double from = to_ms(window.from), to = to_ms(window.to);
  const auto expected = csv_units(csv, from, to);
  ASSERT_FALSE(expected.empty()) << "no unit in the window: the test checks nothing";
  const std::vector<DrawnUnit> drawn = drawn_units(svg);

  const double left = std::stod(attr(svg.substr(0, 600), "data-left"));
  const double scale = std::stod(attr(svg.substr(0, 600), "data-px-per-ms"));
  std::set<UnitKey> seen;
  for (const DrawnUnit& d : drawn) {
    EXPECT_TRUE(seen.insert(d.key).second) << "drawn twice: dispatch " << d.key.dispatch;
    auto it = expected.find(d.key);
    ASSERT_NE(it, expected.end()) << "drawn but not in units.csv (or not in the window): "
                                  << d.key.policy << " dispatch " << d.key.dispatch;
    // In its policy's block, on its lane's row.
    EXPECT_EQ(d.in_policy, d.key.policy);
    EXPECT_EQ(d.in_lane, d.key.lane);
    // The box at its times: x = left + (start − from) · scale, clipped to the window.
    std::smatch m;
    ASSERT_TRUE(std::regex_search(d.body, m,
                                  std::regex("<rect x=\"([0-9.]+)\" y=\"[0-9.]+\" "
                                             "width=\"([0-9.]+)\"")))
        << d.body;
    const double start = std::clamp(std::stod(d.key.start_ms), from, to);
    const double end = std::clamp(std::stod(d.key.end_ms), from, to);
    EXPECT_NEAR(std::stod(m[1].str()), left + (start - from) * scale, 0.006) << d.body;
    EXPECT_NEAR(std::stod(m[2].str()), std::max(1.0, (end - start) * scale), 0.011) << d.body;
    // A round trip is marked before exactly the units that paid one (and started in the
    // window: the mark sits before the box).
    const bool mark = it->second.first && std::stod(d.key.start_ms) >= from;
    EXPECT_EQ(count(d.body, "class=\"round-trip\""), mark ? 1u : 0u) << d.body;
    // The tooltip lists every member job.
    for (const std::string& member : split(it->second.second, ' '))
      EXPECT_NE(d.body.find(member.substr(0, member.find(':'))), std::string::npos)
          << member << " missing from " << d.body;
  }
  EXPECT_EQ(seen.size(), expected.size()) << "units of units.csv in the window not drawn";
}

TEST(Timeline, EveryUnitInTheWindowIsDrawnOnItsLaneAtItsTimes) {
  // Two lanes, merged encoder runs (red) and coarse units (edf).
  const Runs r = simulate("case-async.yaml", {"edf", "red"});
  const std::vector<TimelineWindow> windows = default_timeline_windows(r.scenario, r.timeline);
  ASSERT_FALSE(windows.empty());
  check_against_units_csv(r, windows.front());
  // A window that cuts units at both ends.
  check_against_units_csv(r, {from_ms(1234.5), from_ms(1567.25), "timeline", "cut", ""});
}

TEST(Timeline, MergedRunsShowTheirMembers) {
  const Runs r = simulate("case-async.yaml", {"red"});
  const TimelineWindow w{r.scenario.warmup, r.scenario.warmup + from_s(2.0), "t", "t", ""};
  const std::string svg = timeline_svg(r.scenario, r.timeline, w);
  int merged = 0;
  for (const DrawnUnit& d : drawn_units(svg)) {
    if (attr(d.body.substr(0, d.body.find('>') + 1), "data-members") != "2") continue;
    ++merged;
    // Two operations served: two colour bands; its label says how many members.
    EXPECT_NE(d.body.find("\u00d72"), std::string::npos) << d.body;
    EXPECT_NE(d.body.find("cruise#"), std::string::npos) << d.body;
    EXPECT_NE(d.body.find("detect#"), std::string::npos) << d.body;
  }
  EXPECT_GT(merged, 0) << "case-async under red merges encoder runs";
}

TEST(Timeline, JobsReleasesDeadlinesAndMissesAreMarked) {
  const Runs r = simulate("minibench-tight.yaml", {"edf"});
  const TimelineWindow w{from_s(3.0), from_s(5.0), "t", "t", ""};
  const std::string svg = timeline_svg(r.scenario, r.timeline, w);
  std::size_t jobs = 0, misses = 0;
  for (const JobRow& j : r.runs.front().jobs) {
    if (std::max(j.deadline, j.finish) < w.from || j.release >= w.to) continue;
    ++jobs;
    const bool miss = j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished;
    if (miss && j.finish >= w.from && j.finish <= w.to) ++misses;
  }
  ASSERT_GT(misses, 0u) << "edf misses in minibench-tight: the test needs some";
  EXPECT_EQ(count(svg, "<g class=\"job\""), jobs);
  EXPECT_EQ(count(svg, "class=\"deadline\""), jobs);
  EXPECT_EQ(count(svg, "<path class=\"miss\""), misses);
  // Workload events at 3, 4 and 5 s: the window [3, 5] s holds all three.
  EXPECT_EQ(count(svg, "<g class=\"event\""), 3u);
  EXPECT_NE(svg.find("data-at-ms=\"4000.000000\""), std::string::npos);
}

// A text's extent along x, as the writer estimates it (5.6 px a character at font-size 10, bold
// 15 % wider): [x, x + width).
struct TextBox {
  double x0 = 0, x1 = 0;
  std::string text;
};

std::vector<TextBox> text_boxes(const std::string& svg, const std::regex& re, double char_w) {
  std::vector<TextBox> out;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    const std::string text = (*it)[2];
    std::size_t glyphs = 0;
    for (char c : text) glyphs += (static_cast<unsigned char>(c) & 0xC0U) != 0x80U ? 1 : 0;
    const double x = std::stod((*it)[1]);
    out.push_back({x, x + char_w * static_cast<double>(glyphs), text});
  }
  return out;
}

// The event labels and "N jobs released in this window" share the title row of each policy: an
// event at the window's start (3 s here) draws its label where that text used to start, so the
// text moves right of it.
TEST(Timeline, EventLabelsDoNotOverlapTheJobsReleasedLabel) {
  const Runs r = simulate("minibench-tight.yaml", {"edf", "red"});
  const TimelineWindow w{from_s(3.0), from_s(5.0), "t", "t", ""};
  const std::string svg = timeline_svg(r.scenario, r.timeline, w);
  const auto released = text_boxes(
      svg, std::regex("<text class=\"released\" x=\"([0-9.]+)\"[^>]*>([^<]*)</text>"), 5.6);
  const auto events = text_boxes(
      svg, std::regex("<text x=\"([0-9.]+)\"[^>]*font-weight=\"bold\">(event [^<]*)</text>"),
      5.6 * 1.15);
  ASSERT_EQ(released.size(), 2u);       // one per policy
  ASSERT_EQ(events.size(), 2u * 3);     // events at 3, 4 and 5 s, in each policy's block
  EXPECT_LT(events.front().x0, 160.0);  // the first lies at the window's start
  for (const TextBox& j : released) {
    EXPECT_NE(j.text.find("jobs released in this window"), std::string::npos);
    for (const TextBox& e : events)
      EXPECT_TRUE(j.x1 <= e.x0 || e.x1 <= j.x0)
          << "'" << j.text << "' [" << j.x0 << ", " << j.x1 << ") overlaps '" << e.text << "' ["
          << e.x0 << ", " << e.x1 << ")";
  }
}

TEST(Timeline, MergeWaitsAreDrawnWhenRecorded) {
  Runs r = simulate("case-async.yaml", {"red"});
  const TimelineWindow w{from_ms(1000), from_ms(1100), "t", "t", ""};
  EXPECT_NE(timeline_svg(r.scenario, r.timeline, w).find("merge waits not recorded"),
            std::string::npos);
  const std::vector<TimelineWait> waits = {{from_ms(990), from_ms(1005), 0},
                                           {from_ms(1050), from_ms(1060), 0},
                                           {from_ms(1200), from_ms(1210), 0}};
  r.timeline.front().waits = &waits;
  const std::string svg = timeline_svg(r.scenario, r.timeline, w);
  EXPECT_EQ(count(svg, "class=\"merge-wait\""), 2u);  // the third is after the window
  EXPECT_EQ(svg.find("merge waits not recorded"), std::string::npos);
}

// The moment the worst miss of the runs missed: lowest QoE (no result: 0), earliest on ties.
TimePoint worst_miss(const Runs& r) {
  const JobRow* worst = nullptr;
  auto score = [](const JobRow& j) { return j.outcome == JobOutcome::Missed ? j.qoe : 0.0; };
  for (const PolicyRun& run : r.runs)
    for (const JobRow& j : run.jobs) {
      if (j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Unfinished) continue;
      if (worst == nullptr || score(j) < score(*worst) ||
          (score(j) == score(*worst) && j.release < worst->release))
        worst = &j;
    }
  EXPECT_NE(worst, nullptr);
  return worst == nullptr ? TimePoint{0} : std::min(worst->deadline, worst->finish);
}

TEST(Timeline, DefaultWindowsAreTheStartAndTheWorstMiss) {
  // edf misses once detection joins at 3 s: a second window, from 0.3 s before the miss.
  const Runs r = simulate("case-dynamic.yaml", {"edf", "red"});
  const auto w = default_timeline_windows(r.scenario, r.timeline);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].from, r.scenario.warmup);
  EXPECT_EQ(w[0].to, r.scenario.warmup + std::chrono::seconds{2});
  EXPECT_EQ(w[1].to - w[1].from, std::chrono::seconds{2});
  const TimePoint at = worst_miss(r);
  EXPECT_EQ(w[1].from, at - std::chrono::milliseconds{300});
  EXPECT_EQ(w[1].name, "timeline_worst_miss");

  // edf misses from the start of minibench-tight: one window shows both.
  const Runs tight = simulate("minibench-tight.yaml", {"edf"});
  const auto one = default_timeline_windows(tight.scenario, tight.timeline);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].from, tight.scenario.warmup);
  EXPECT_LE(worst_miss(tight), one[0].to);

  // Without a miss: the start only.
  const Runs calm = simulate("case-async.yaml", {"red"});
  ASSERT_EQ(calm.runs.front().metrics.missed, 0);
  EXPECT_EQ(default_timeline_windows(calm.scenario, calm.timeline).size(), 1u);
}

TEST(Timeline, IsDeterministic) {
  const Runs a = simulate("case-dynamic.yaml", {"edf", "red"});
  const Runs b = simulate("case-dynamic.yaml", {"edf", "red"});
  const TimelineWindow w{from_s(2.5), from_s(3.5), "t", "t", ""};
  EXPECT_EQ(timeline_svg(a.scenario, a.timeline, w), timeline_svg(b.scenario, b.timeline, w));
}

TEST(Timeline, ParsesWindows) {
  auto w = parse_timeline_window("2:4.5");
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(w->first, std::chrono::seconds{2});
  EXPECT_EQ(w->second, std::chrono::milliseconds{4500});
  EXPECT_TRUE(parse_timeline_window("0:0.001").has_value());
  for (const char* bad : {"", "2", ":", "2:", ":4", "4:2", "2:2", "-1:2", "a:b", "1:2:3", "1 :2",
                          "nan:1", "1:inf", "1e400:1e401", "0:60.5"}) {
    auto e = parse_timeline_window(bad);
    ASSERT_FALSE(e.has_value()) << bad;
    EXPECT_NE(e.error().message.find("--timeline"), std::string::npos) << bad;
  }
}

}  // namespace
}  // namespace red
