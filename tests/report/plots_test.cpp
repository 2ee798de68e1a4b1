// Plots: data and gnuplot scripts always; PNG and SVG images when gnuplot is installed
// (skipped otherwise); a missing gnuplot is a note, never a failure.

#include "red/report/plots.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Scenario load(const std::string& name) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
  EXPECT_TRUE(s.has_value());
  return std::move(s.value());
}

class Plots : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ =
        fs::temp_directory_path() / fmt::format("red_plots_test_{}_{}", ::getpid(), info->name());
    fs::remove_all(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  // Simulates `policies` on scenario `name`; the runs stay alive in runs_.
  std::vector<PlotRun> simulate(const Scenario& s, const std::vector<std::string>& policies) {
    runs_.clear();
    runs_.reserve(policies.size());
    for (const std::string& p : policies) {
      auto r = simulate_policy(s, default_profile(), p, s.seed);
      EXPECT_TRUE(r.has_value());
      runs_.push_back(std::move(r.value()));
    }
    std::vector<PlotRun> out;
    for (const PolicyRun& r : runs_) out.push_back({r.metrics.name, &r.metrics, &r.jobs});
    return out;
  }

  static bool have_gnuplot() { return !gnuplot_png_terminal("gnuplot").empty(); }

  void expect_image(const std::string& rel, const char* magic) {
    const fs::path p = dir_ / rel;
    ASSERT_TRUE(fs::exists(p)) << p;
    EXPECT_GT(fs::file_size(p), 1000u) << p;
    EXPECT_EQ(read_text(p).substr(0, std::string(magic).size()), magic) << p;
  }

  fs::path dir_;
  std::vector<PolicyRun> runs_;
};

TEST_F(Plots, DataAndScriptsWithoutGnuplot) {
  const Scenario s = load("case-dynamic.yaml");
  PlotOptions o;
  o.gnuplot = "";  // write data and scripts only
  const PlotReport r = write_run_plots(dir_.string(), s, simulate(s, {"edf", "red"}), o);
  EXPECT_TRUE(r.plots.empty());
  EXPECT_FALSE(r.note.empty());
  for (const char* name : {"response_hist", "response_cdf", "metrics_bars", "miss_over_time"}) {
    EXPECT_TRUE(fs::exists(dir_ / "plots" / (std::string(name) + ".dat"))) << name;
    const std::string gp = read_text(dir_ / "plots" / (std::string(name) + ".gp"));
    // Every plot is titled and labelled, for both images.
    EXPECT_NE(gp.find("set title"), std::string::npos) << name;
    EXPECT_NE(gp.find(name + std::string(".png")), std::string::npos) << name;
    EXPECT_NE(gp.find(name + std::string(".svg")), std::string::npos) << name;
    if (std::string(name) != "metrics_bars") {
      EXPECT_NE(gp.find("set xlabel"), std::string::npos) << name;
    }
    EXPECT_NE(gp.find("set ylabel"), std::string::npos) << name;
  }
}

TEST_F(Plots, MissingGnuplotIsANoteNotAFailure) {
  const Scenario s = load("case-async.yaml");
  PlotOptions o;
  o.gnuplot = (dir_ / "no-such-gnuplot").string();
  const PlotReport r = write_run_plots(dir_.string(), s, simulate(s, {"red"}), o);
  EXPECT_TRUE(r.plots.empty());
  EXPECT_NE(r.note.find("gnuplot not found"), std::string::npos) << r.note;
  EXPECT_TRUE(fs::exists(dir_ / "plots" / "metrics_bars.gp"));
}

TEST_F(Plots, HistogramCountsEveryCompletedJob) {
  const Scenario s = load("case-dynamic.yaml");
  PlotOptions o;
  o.gnuplot = "";
  const auto runs = simulate(s, {"fifo", "red"});
  write_run_plots(dir_.string(), s, runs, o);
  std::istringstream in(read_text(dir_ / "plots" / "response_hist.dat"));
  std::vector<std::int64_t> totals;
  bool new_block = true;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) {
      new_block = true;
      continue;
    }
    if (line[0] == '#') {
      if (line.find("response-time") == std::string::npos && new_block) {
        totals.push_back(0);
        new_block = false;
      }
      continue;
    }
    double centre = 0;
    std::int64_t count = 0;
    std::istringstream(line) >> centre >> count;
    totals.back() += count;
  }
  ASSERT_EQ(totals.size(), 2u);
  EXPECT_EQ(totals[0], runs[0].metrics->completed);
  EXPECT_EQ(totals[1], runs[1].metrics->completed);
}

TEST_F(Plots, RunPlotsArePngAndSvg) {
  if (!have_gnuplot()) GTEST_SKIP() << "gnuplot is not installed";
  const Scenario s = load("case-dynamic.yaml");
  const PlotReport r = write_run_plots(dir_.string(), s, simulate(s, {"fifo", "edf", "red"}));
  EXPECT_TRUE(r.note.empty()) << r.note;
  std::vector<std::string> names;
  for (const PlotFile& f : r.plots) {
    names.push_back(f.name);
    EXPECT_FALSE(f.title.empty());
    expect_image(f.png, "\x89PNG");
    expect_image(f.svg, "<?xml");
  }
  EXPECT_EQ(names, (std::vector<std::string>{"response_hist", "response_cdf", "metrics_bars",
                                             "miss_over_time"}));
  EXPECT_FALSE(fs::exists(dir_ / "plots" / "response_hist.log"));  // logs only on failure
}

TEST_F(Plots, NoMissOverTimeWithoutWorkloadEvents) {
  if (!have_gnuplot()) GTEST_SKIP() << "gnuplot is not installed";
  const Scenario s = load("case-async.yaml");
  ASSERT_TRUE(s.events.empty());
  const PlotReport r = write_run_plots(dir_.string(), s, simulate(s, {"red"}));
  EXPECT_TRUE(r.note.empty()) << r.note;
  EXPECT_EQ(r.plots.size(), 3u);
  EXPECT_FALSE(fs::exists(dir_ / "plots" / "miss_over_time.png"));
}

TEST_F(Plots, SweepCurves) {
  if (!have_gnuplot()) GTEST_SKIP() << "gnuplot is not installed";
  const Scenario base = load("case-async.yaml");
  const std::vector<double> values{0.001, 0.1, 10};
  std::vector<SweepSeries> series{{"edf", {}}, {"red", {}}};
  for (double v : values) {
    Scenario s = base;
    ASSERT_FALSE(apply_override(s, "qoe_lambda", v).has_value());
    for (SweepSeries& ser : series) {
      auto r = simulate_policy(s, default_profile(), ser.policy, s.seed, {}, false);
      ASSERT_TRUE(r.has_value());
      ser.points.push_back(r->metrics);
    }
  }
  const PlotReport r = write_sweep_plots(dir_.string(), base.name, "qoe_lambda", values, series);
  EXPECT_TRUE(r.note.empty()) << r.note;
  ASSERT_EQ(r.plots.size(), 3u);
  for (const PlotFile& f : r.plots) {
    expect_image(f.png, "\x89PNG");
    expect_image(f.svg, "<?xml");
  }
  // λ spans four decades: a log axis.
  EXPECT_NE(read_text(dir_ / "plots" / "sweep_qoe.gp").find("set logscale x"), std::string::npos);
}

TEST(PlotColors, EveryPresetHasItsOwnColorWhereverItRuns) {
  // red-robust, the default, once took the palette's colour at its place in the run, so its
  // curves changed colour between commands.
  std::set<std::string> seen;
  for (const std::string& p : known_policies()) {
    const std::string c = policy_color(p, 0);
    for (std::size_t i = 1; i < 10; ++i) EXPECT_EQ(policy_color(p, i), c) << p;
    EXPECT_TRUE(seen.insert(c).second) << p << " shares " << c;
  }
  EXPECT_EQ(seen.size(), known_policies().size());
  // Another name takes the palette by its place.
  EXPECT_NE(policy_color("mine", 0), policy_color("mine", 1));
}

TEST(PlotLabels, SweepParametersHaveUnits) {
  EXPECT_NE(parameter_label("gamma_ms").find("(ms)"), std::string::npos);
  EXPECT_NE(parameter_label("deadline_scale").find("deadline"), std::string::npos);
  EXPECT_EQ(parameter_label("something_else"), "something_else");
}

}  // namespace
}  // namespace red
