#include "red/report/html.hpp"

#include <fmt/format.h>

namespace red {

namespace {

constexpr const char* kStyle =
    R"(body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:2em auto;max-width:1400px;padding:0 1em;color:#222}
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
dl.facts{display:grid;grid-template-columns:max-content auto;gap:.2em 1em;margin:.5em 0}
dl.facts dt{font-weight:600}dl.facts dd{margin:0}
table{border-collapse:collapse;margin:.6em 0;font-variant-numeric:tabular-nums}
caption{text-align:left;font-weight:600;padding:.3em 0}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
tbody tr:nth-child(even){background:#fafafa}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.9em;color:#555}
.note{background:#fff8e1;border-left:4px solid #f0c36d;padding:.4em .8em}
code{background:#f3f3f3;padding:0 .2em}
.timeline{overflow-x:auto;border:1px solid #ddd;margin:.4em 0}.timeline svg{display:block})";

std::string num(double v, int decimals) {
  return fmt::format("{:.{}f}", v, decimals);
}

std::string ratio(const std::optional<double>& v) {
  return v ? fmt::format("{:.3f}", *v) : std::string("-");
}

std::string render_table(const HtmlTable& t) {
  std::string out = "<table>\n";
  if (!t.caption.empty()) out += "<caption>" + html_escape(t.caption) + "</caption>\n";
  out += "<thead><tr>";
  for (const std::string& h : t.header) out += "<th>" + html_escape(h) + "</th>";
  out += "</tr></thead>\n<tbody>\n";
  for (const auto& row : t.rows) {
    out += "<tr>";
    for (const std::string& c : row) out += "<td>" + html_escape(c) + "</td>";
    out += "</tr>\n";
  }
  return out + "</tbody>\n</table>\n";
}

std::vector<std::string> common_notes() {
  return {
      "Miss rate counts jobs that finished after their deadline or were dropped (skipped and "
      "failed jobs count as dropped), over the jobs released after the warm-up window. QoE is "
      "the mean per job of 1 / (1 + e^lambda * max(0, R - D)); a dropped job scores 0.",
      "The Timeline section at the top draws the schedule offline (plots/timeline*.svg hold the "
      "same drawings). The full trace (trace.json) opens in the Perfetto UI: go to "
      "https://ui.perfetto.dev and "
      "drag the file in (the file stays on this computer), or open chrome://tracing in "
      "Chrome and load it. Each policy is one process; its tracks are the lanes (every unit "
      "execution, click one for its jobs, batch and merged members), per operation the "
      "release, deadline and miss instants and the jobs from release to finish, and counters "
      "of the ready queue.",
      "jobs.csv has one row per job and units.csv one row per unit execution; their columns "
      "are described in docs/REPORTS.md. The plots' data (plots/*.dat) and gnuplot scripts "
      "(plots/*.gp) are beside the images: edit a script and run gnuplot on it to redraw.",
  };
}

}  // namespace

std::string html_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string render_html(const HtmlPage& page) {
  std::string out = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  if (!page.run_id.empty())
    out += "<meta name=\"red-run-id\" content=\"" + html_escape(page.run_id) + "\">\n";
  out += "<title>" + html_escape(page.title) + "</title>\n";
  out += std::string("<style>\n") + kStyle + "\n</style>\n</head>\n<body>\n";
  out += "<h1>" + html_escape(page.title) + "</h1>\n";
  if (!page.facts.empty()) {
    out += "<dl class=\"facts\">\n";
    for (const auto& [k, v] : page.facts)
      out += "<dt>" + html_escape(k) + "</dt><dd>" + html_escape(v) + "</dd>\n";
    out += "</dl>\n";
  }
  auto figure = [&](const PlotFile& p) {
    out += "<figure>\n";
    out += "<img src=\"" + html_escape(p.png) + "\" alt=\"" + html_escape(p.title) + "\">\n";
    out += "<figcaption>" + html_escape(p.title);
    if (!p.svg.empty()) out += " (<a href=\"" + html_escape(p.svg) + "\">SVG</a>)";
    out += "</figcaption>\n</figure>\n";
  };
  auto section = [&](const HtmlSection& s) {
    out += "<section id=\"" + html_escape(s.id) + "\">\n<h2>" + html_escape(s.heading) + "</h2>\n";
    for (const std::string& p : s.paragraphs) out += "<p>" + html_escape(p) + "</p>\n";
    for (const HtmlTable& t : s.tables) out += render_table(t);
    for (const std::string& h : s.raw_html) out += h;
    out += "</section>\n";
  };
  if (!page.lead_plots.empty() || !page.lead_sections.empty()) {
    out += "<h2 id=\"why\">Which policy, and why jobs missed</h2>\n";
    for (const PlotFile& p : page.lead_plots) figure(p);
    for (const HtmlSection& s : page.lead_sections) section(s);
  }
  if (!page.tables.empty()) {
    out += "<h2>Results</h2>\n";
    for (const HtmlTable& t : page.tables) out += render_table(t);
  }
  for (const HtmlSection& s : page.sections) section(s);
  out += "<h2>Plots</h2>\n";
  if (!page.plots_note.empty())
    out += "<p class=\"note\">" + html_escape(page.plots_note) + "</p>\n";
  if (page.plots.empty() && page.lead_plots.empty() && page.plots_note.empty())
    out += "<p>No plots.</p>\n";
  for (const PlotFile& p : page.plots) figure(p);
  if (!page.files.empty()) {
    out += "<h2>Files</h2>\n<ul>\n";
    for (const HtmlLink& f : page.files) {
      out += "<li><a href=\"" + html_escape(f.href) + "\">" + html_escape(f.href) + "</a>";
      if (!f.note.empty()) out += ": " + html_escape(f.note);
      out += "</li>\n";
    }
    out += "</ul>\n";
  }
  if (!page.how_to_read.empty()) {
    out += "<h2>How to read this</h2>\n";
    for (const std::string& p : page.how_to_read) out += "<p>" + html_escape(p) + "</p>\n";
  }
  out += "</body>\n</html>\n";
  return out;
}

HtmlTable comparison_html_table(const std::vector<PolicyMetrics>& policies,
                                const std::string& baseline) {
  HtmlTable t;
  t.caption = "Policies on the identical workload (ratios vs " + baseline + ")";
  t.header = {"policy",         "jobs", "miss %",   "drop %",           "mean ms",
              "p99 ms",         "QoE",  "enc runs", "miss/" + baseline, "lat/" + baseline,
              "QoE/" + baseline};
  for (const PolicyMetrics& m : policies)
    t.rows.push_back({m.name, std::to_string(m.jobs), num(100.0 * m.miss_rate, 2),
                      num(100.0 * m.drop_rate, 2), num(m.latency.mean, 2), num(m.latency.p99, 2),
                      num(m.qoe, 3), std::to_string(m.encoder_runs), ratio(m.ratio_miss),
                      ratio(m.ratio_latency), ratio(m.ratio_qoe)});
  return t;
}

HtmlPage compare_page(const SummaryHeader& header, const std::vector<PolicyMetrics>& policies,
                      const PlotReport& plots, const std::vector<HtmlLink>& files) {
  HtmlPage page;
  page.title = "RED: " + header.scenario;
  page.run_id = header.run_id;
  page.facts = {{"scenario", header.scenario},
                {"backend", header.backend},
                {"seed", std::to_string(header.seed)},
                {"profile", header.profile_source},
                {"baseline", header.baseline}};
  if (!policies.empty())
    page.facts.emplace_back("measured",
                            fmt::format("{:g} s after warm-up", policies.front().measured_s));
  page.tables.push_back(comparison_html_table(policies, header.baseline));
  HtmlTable frames;
  frames.caption =
      "Frames of the sensors (real runs): offered in the measured window, released, and how "
      "late (release - nominal capture time)";
  frames.header = {"policy",
                   "offered",
                   "released",
                   "late p50 ms",
                   "late p99 ms",
                   "late max ms",
                   "more than a period late",
                   "note"};
  for (const PolicyMetrics& m : policies) {
    if (!m.releases) continue;
    const PolicyMetrics::Releases& r = *m.releases;
    frames.rows.push_back({m.name, std::to_string(r.offered), std::to_string(r.released),
                           num(r.late_p50_ms, 3), num(r.late_p99_ms, 3), num(r.late_max_ms, 3),
                           std::to_string(r.behind),
                           releases_warning(m) ? "fell behind the sensors" : "kept up"});
  }
  if (!frames.rows.empty()) page.tables.push_back(std::move(frames));
  page.plots = plots.plots;
  page.plots_note = plots.note;
  page.files = files;
  page.how_to_read = common_notes();
  return page;
}

HtmlPage sweep_page(const std::string& scenario, std::uint64_t seed, const std::string& parameter,
                    const std::vector<double>& values, const std::vector<SweepSeries>& series,
                    const PlotReport& plots, const std::vector<HtmlLink>& files) {
  HtmlPage page;
  page.title = "RED sweep: " + scenario + " by " + parameter;
  page.facts = {{"scenario", scenario},
                {"backend", "sim"},
                {"seed", std::to_string(seed)},
                {"parameter", parameter_label(parameter)}};
  struct Metric {
    const char* caption;
    double (*get)(const PolicyMetrics&);
    int decimals;
  };
  const Metric metrics[] = {
      {"miss rate (%)", [](const PolicyMetrics& m) { return 100.0 * m.miss_rate; }, 2},
      {"mean latency (ms)", [](const PolicyMetrics& m) { return m.latency.mean; }, 2},
      {"QoE", [](const PolicyMetrics& m) { return m.qoe; }, 3},
  };
  for (const Metric& mt : metrics) {
    HtmlTable t;
    t.caption = std::string(mt.caption) + " by " + parameter;
    t.header.push_back("policy");
    for (double v : values) t.header.push_back(fmt::format("{:g}", v));
    for (const SweepSeries& s : series) {
      std::vector<std::string> row{s.policy};
      for (const PolicyMetrics& m : s.points) row.push_back(num(mt.get(m), mt.decimals));
      t.rows.push_back(std::move(row));
    }
    page.tables.push_back(std::move(t));
  }
  page.plots = plots.plots;
  page.plots_note = plots.note;
  page.files = files;
  page.how_to_read = {
      "Each point is one simulated run of the policy with the parameter set to that value, "
      "on the same seed (the same releases and sampled execution times for every policy).",
      common_notes().front(),
      "sweep.csv has one row per (policy, value); sweep.json holds the same numbers. The "
      "plots' data and gnuplot scripts are in plots/."};
  return page;
}

}  // namespace red
