#include "red/report/schedule_html.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "red/metrics/why.hpp"
#include "red/report/report.hpp"

namespace red {

namespace {

std::string num(double v, int decimals) {
  return fmt::format("{:.{}f}", v, decimals);
}

std::string span_text(const PhaseSpan& p) {
  return fmt::format("{:.3f} to {:.3f}", to_s(p.from), to_s(p.to));
}

}  // namespace

Expected<TimelineReport> write_timelines(const std::string& dir, const Scenario& s,
                                         const std::vector<TimelineRun>& runs,
                                         const std::vector<TimelineWindow>& windows,
                                         const std::string& subdir) {
  TimelineReport r;
  r.section.id = "timeline";
  r.section.heading = "Timeline";
  r.section.paragraphs = {
      "Each policy is a block of rows on one shared time axis: one row per lane with every unit "
      "execution as a box coloured by the operation it served (several colours when a merged run "
      "served several) and labelled with what it ran (enc, a head's name, enc+head for a coarse "
      "unit), with \u00d7N for a merged encoder run or a batch of N members. A dark mark before a "
      "box is the round trip to the synchronizer it paid; empty stretches are idle time. Below, "
      "merge waits (hatched) and one row per operation: each job is a light bar from its release "
      "to its deadline with a dark line up to its finish (red when late), and a red cross marks "
      "every miss. Dashed lines are workload events. Hover a box or a job for its details. The "
      "drawing scrolls sideways."};
  const std::string plots = (std::filesystem::path(dir) / subdir).string();
  for (const TimelineWindow& w : windows) {
    std::vector<TimelineRun> shown;
    for (const TimelineRun& run : runs)
      if (w.policy.empty() || run.policy == w.policy) shown.push_back(run);
    const std::string svg = timeline_svg(s, shown, w);
    if (auto e = write_file(plots, w.name + ".svg", svg)) return *e;
    const std::string rel = subdir + "/" + w.name + ".svg";
    r.files.push_back(rel);
    r.section.raw_html.push_back(fmt::format(
        "<figure>\n<div class=\"timeline\">\n{}</div>\n<figcaption>{} ({:.3f} to {:.3f} s; "
        "<a href=\"{}\">SVG</a>)</figcaption>\n</figure>\n",
        svg, html_escape(w.title), to_s(w.from), to_s(w.to), html_escape(rel)));
  }
  return r;
}

HtmlSection phase_section(const Scenario& s, const std::vector<std::string>& policies,
                          const std::vector<std::vector<PhaseMetrics>>& phases) {
  HtmlSection sec;
  sec.id = "phases";
  sec.heading = "Per workload phase";
  sec.paragraphs = {
      s.events.empty()
          ? "The scenario has no workload events: one phase, the whole measured window."
          : "The measured window is split at each workload event (the scenario's events:); a job "
            "belongs to the phase in which it was released. Rates, QoE and latency are computed "
            "as in the results table, over the jobs of the phase."};
  const std::size_t n = std::min(policies.size(), phases.size());
  if (n == 0) return sec;
  // Side by side: the miss rate of every policy per (phase, operation).
  HtmlTable side;
  side.caption = "miss rate (%) per phase and operation";
  side.header = {"phase", "from s to s", "operation"};
  for (std::size_t i = 0; i < n; ++i) side.header.push_back(policies[i]);
  const std::vector<PhaseMetrics>& first = phases.front();
  for (std::size_t p = 0; p < first.size(); ++p) {
    std::vector<std::string> ops;
    for (const auto& [op, f] : first[p].operations) ops.push_back(op);
    for (std::size_t i = 1; i < n; ++i)  // runs may differ (an operation without jobs)
      if (p < phases[i].size())
        for (const auto& [op, f] : phases[i][p].operations)
          if (std::find(ops.begin(), ops.end(), op) == ops.end()) ops.push_back(op);
    if (ops.size() != 1) ops.emplace_back("all");
    for (const std::string& op : ops) {
      std::vector<std::string> row{phase_label(s, first[p].span), span_text(first[p].span), op};
      for (std::size_t i = 0; i < n; ++i) {
        const PhaseFigures* f = nullptr;
        if (p < phases[i].size()) {
          if (op == "all") f = &phases[i][p].all;
          for (const auto& [name, g] : phases[i][p].operations)
            if (name == op && op != "all") f = &g;
        }
        row.push_back(f == nullptr ? "-" : num(100.0 * f->miss_rate, 2));
      }
      side.rows.push_back(std::move(row));
    }
  }
  sec.tables.push_back(std::move(side));
  for (std::size_t i = 0; i < n; ++i) {
    HtmlTable t;
    t.caption = policies[i] + ": jobs, miss rate, drop rate, QoE and latency per phase";
    t.header = {"phase",  "from s to s", "operation", "jobs",  "miss %",
                "drop %", "QoE",         "p50 ms",    "p99 ms"};
    auto add = [&](const PhaseMetrics& ph, const std::string& op, const PhaseFigures& f) {
      t.rows.push_back({phase_label(s, ph.span), span_text(ph.span), op, std::to_string(f.jobs),
                        num(100.0 * f.miss_rate, 2), num(100.0 * f.drop_rate, 2), num(f.qoe, 3),
                        f.completed > 0 ? num(f.latency_p50_ms, 2) : "-",
                        f.completed > 0 ? num(f.latency_p99_ms, 2) : "-"});
    };
    for (const PhaseMetrics& ph : phases[i]) {
      for (const auto& [op, f] : ph.operations) add(ph, op, f);
      if (ph.operations.size() != 1) add(ph, "all", ph.all);
    }
    sec.tables.push_back(std::move(t));
  }
  return sec;
}

std::optional<HtmlSection> costs_section(const std::vector<PolicyMetrics>& runs) {
  HtmlSection sec;
  sec.id = "costs";
  sec.heading = "Costs: the profile against this run";
  sec.paragraphs = {
      "What each unit cost in this run against the profile the scheduler was given, per batch "
      "size that ran (summary.json's costs). A ratio far from 1 means the profile is not this "
      "machine's, or not under this load: measure one here (red profile), or calibrate it in a "
      "run (red profile --from PROFILE --calibrate SCENARIO). With online estimates "
      "(scheduler.online_costs, on by default in real runs) the plan followed the run's costs: "
      "the planned factor is what the profile's figures were multiplied by at the end."};
  for (const PolicyMetrics& m : runs) {
    if (m.costs.empty()) continue;
    HtmlTable t;
    t.caption = fmt::format("{}: online estimates {}, the plan changed {} time(s)", m.name,
                            m.online_costs ? "on" : "off", m.plan_changes);
    t.header = {"unit",        "batch", "runs",          "profile mean ms",
                "run mean ms", "ratio", "planned factor"};
    for (const UnitCostFigures& f : m.costs) {
      if (f.runs == 0) continue;
      t.rows.push_back({f.unit, std::to_string(f.batch), std::to_string(f.runs),
                        num(to_ms(f.profile_mean), 2), num(to_ms(f.run_mean), 2), num(f.ratio(), 2),
                        num(f.factor, 2)});
    }
    if (!t.rows.empty()) sec.tables.push_back(std::move(t));
  }
  if (sec.tables.empty()) return std::nullopt;
  return sec;
}

HtmlSection why_section(const Scenario& s, const std::vector<std::string>& policies,
                        const std::vector<std::vector<PhaseMetrics>>& phases) {
  HtmlSection sec;
  sec.id = "causes";
  sec.heading = "Why jobs missed";
  sec.paragraphs = {
      "Every job that did not meet its deadline has a cause (jobs.csv's cause column; red report "
      "DIR --why OPERATION#JOB tells one job's story): the rule that shed it (admission, "
      "hopeless, max_inflight, a failure), or what took the most lane time between its release "
      "and its deadline: its own work, a cost overrun past the scheduler's estimate, its work "
      "held back while a lane was idle (a merge or a batch forming), or other operations' work "
      "of higher, equal or lower criticality, or its operation's earlier jobs. One row per "
      "phase and operation with a miss: the jobs not met, the top cause and its share, then the "
      "next causes with their numbers of jobs."};
  const std::size_t n = std::min(policies.size(), phases.size());
  bool any = false;
  for (std::size_t i = 0; i < n; ++i) {
    HtmlTable t;
    t.caption = policies[i] + ": why jobs missed, per phase and operation";
    t.header = {"phase", "operation", "not met", "top cause", "share %", "next causes"};
    for (const PhaseMetrics& ph : phases[i])
      for (const auto& [op, f] : ph.operations) {
        const auto top = top_causes(f.causes);
        if (top.empty()) continue;
        std::int64_t all = 0;
        for (const auto& [cause, k] : top) all += k;
        std::string next;
        for (std::size_t c = 1; c < top.size() && c < 4; ++c)
          next += fmt::format("{}{} ({})", next.empty() ? "" : "; ", top[c].first, top[c].second);
        if (top.size() > 4) next += fmt::format("; {} more", top.size() - 4);
        t.rows.push_back(
            {phase_label(s, ph.span), op, std::to_string(all), top.front().first,
             num(100.0 * static_cast<double>(top.front().second) / static_cast<double>(all), 1),
             next.empty() ? "-" : next});
      }
    if (t.rows.empty()) continue;
    any = true;
    sec.tables.push_back(std::move(t));
  }
  if (!any)
    sec.paragraphs.emplace_back(
        "No job with a cause: every job met its deadline (or the run's files were written by an "
        "older red, without causes).");
  return sec;
}

}  // namespace red
