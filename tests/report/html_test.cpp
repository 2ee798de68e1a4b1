// index.html: a static page with the comparison table, the plots and links; escaped text.

#include "red/report/html.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace red {
namespace {

PolicyMetrics metrics(const std::string& name, double miss, double mean, double qoe) {
  PolicyMetrics m;
  m.name = name;
  m.jobs = 100;
  m.miss_rate = miss;
  m.latency.mean = mean;
  m.latency.p99 = mean * 2;
  m.qoe = qoe;
  m.encoder_runs = 42;
  m.measured_s = 9.5;
  return m;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(Html, ComparePageHasARowPerPolicyAndThePlots) {
  std::vector<PolicyMetrics> all{metrics("edf", 0.3, 30, 0.6), metrics("red", 0.0, 18.45, 1.0)};
  apply_ratios(all, "edf");
  SummaryHeader h;
  h.scenario = "case-dynamic";
  h.seed = 11;
  h.profile_source = "builtin-default";
  PlotReport plots;
  plots.plots.push_back({"metrics_bars", "Miss rate, latency and QoE per policy",
                         "plots/metrics_bars.png", "plots/metrics_bars.svg"});
  const std::string html = render_html(
      compare_page(h, all, plots, {{"summary.json", "summary"}, {"trace.json", "timeline"}}));
  EXPECT_TRUE(contains(html, "<!DOCTYPE html>"));
  EXPECT_TRUE(contains(html, "<tr><td>edf</td><td>100</td><td>30.00</td>")) << html;
  EXPECT_TRUE(contains(html, "<tr><td>red</td><td>100</td><td>0.00</td>")) << html;
  EXPECT_TRUE(contains(html, "<th>miss/edf</th>"));
  EXPECT_TRUE(contains(html, "<td>0.615</td>"));  // red's latency ratio vs edf
  EXPECT_TRUE(contains(html, "<img src=\"plots/metrics_bars.png\""));
  EXPECT_TRUE(contains(html, "href=\"plots/metrics_bars.svg\""));
  EXPECT_TRUE(contains(html, "href=\"trace.json\""));
  EXPECT_TRUE(contains(html, "<dd>builtin-default</dd>"));
  EXPECT_TRUE(contains(html, "ui.perfetto.dev"));
  EXPECT_TRUE(contains(html, "How to read this"));
  // Static and offline: no scripts, no remote assets.
  EXPECT_FALSE(contains(html, "<script"));
  EXPECT_FALSE(contains(html, "src=\"http"));
  EXPECT_FALSE(contains(html, "<link"));
}

TEST(Html, PlotsNoteShownWhenThereAreNone) {
  PlotReport plots;
  plots.note = "plots skipped: gnuplot not found";
  const std::string html =
      render_html(compare_page(SummaryHeader{}, {metrics("red", 0, 1, 1)}, plots, {}));
  EXPECT_TRUE(contains(html, "plots skipped: gnuplot not found"));
  EXPECT_FALSE(contains(html, "<img"));
}

TEST(Html, TextIsEscaped) {
  SummaryHeader h;
  h.scenario = "<script>alert('x')</script> & co";
  const std::string html =
      render_html(compare_page(h, {metrics("a<b", 0, 1, 1)}, PlotReport{}, {}));
  EXPECT_FALSE(contains(html, "<script>"));
  EXPECT_TRUE(contains(html, "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; co"));
  EXPECT_TRUE(contains(html, "<td>a&lt;b</td>"));
}

TEST(Html, SweepPageHasATablePerMetric) {
  std::vector<SweepSeries> series{
      {"edf", {metrics("edf", 0.5, 40, 0.5), metrics("edf", 0.25, 45, 0.75)}},
      {"red", {metrics("red", 0.0, 20, 1.0), metrics("red", 0.0, 21, 1.0)}}};
  const std::string html = render_html(
      sweep_page("minibench-tight", 7, "deadline_scale", {0.8, 1.2}, series, PlotReport{}, {}));
  EXPECT_TRUE(contains(html, "<caption>miss rate (%) by deadline_scale</caption>"));
  EXPECT_TRUE(contains(html, "<caption>mean latency (ms) by deadline_scale</caption>"));
  EXPECT_TRUE(contains(html, "<caption>QoE by deadline_scale</caption>"));
  EXPECT_TRUE(contains(html, "<th>0.8</th><th>1.2</th>"));
  EXPECT_TRUE(contains(html, "<tr><td>edf</td><td>50.00</td><td>25.00</td></tr>"));
  EXPECT_TRUE(contains(html, "<tr><td>red</td><td>20.00</td><td>21.00</td></tr>"));
}

}  // namespace
}  // namespace red
