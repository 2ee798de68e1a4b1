#include "red/report/report.hpp"

#include "red/core/output_file.hpp"
#include "red/metrics/why.hpp"

#include "job_columns.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string_view>

#include <fmt/format.h>

namespace red {

namespace {

using report_detail::csv;

nlohmann::json opt(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

// Why the jobs missed, most first: [{"cause", "jobs", "share"}], the share of the jobs
// with a cause.
nlohmann::ordered_json causes_json(const std::map<std::string, std::int64_t>& causes) {
  std::int64_t all = 0;
  for (const auto& [cause, n] : causes) all += n;
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const auto& [cause, n] : top_causes(causes))
    out.push_back(
        {{"cause", cause},
         {"jobs", n},
         {"share", std::round(static_cast<double>(n) / static_cast<double>(all) * 1e6) / 1e6}});
  return out;
}

nlohmann::ordered_json phase_figures(const PhaseFigures& f) {
  return {{"jobs", f.jobs},
          {"completed", f.completed},
          {"missed", f.missed},
          {"dropped", f.dropped},
          {"unfinished", f.unfinished},
          {"miss_rate", f.miss_rate},
          {"drop_rate", f.drop_rate},
          {"qoe", f.qoe},
          {"latency_ms", {{"p50", f.latency_p50_ms}, {"p99", f.latency_p99_ms}}},
          {"causes", causes_json(f.causes)}};
}

nlohmann::ordered_json phases_json(const std::vector<PhaseMetrics>& phases) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const PhaseMetrics& ph : phases) {
    nlohmann::ordered_json p = {{"from_s", std::round(to_s(ph.span.from) * 1e6) / 1e6},
                                {"to_s", std::round(to_s(ph.span.to) * 1e6) / 1e6},
                                {"events", ph.span.events}};
    p.update(phase_figures(ph.all));
    nlohmann::ordered_json ops = nlohmann::ordered_json::object();
    for (const auto& [name, f] : ph.operations) ops[name] = phase_figures(f);
    p["operations"] = ops;
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace

std::string summary_json(const SummaryHeader& h, const std::vector<PolicyMetrics>& policies,
                         const std::vector<std::vector<PhaseMetrics>>& phases) {
  nlohmann::ordered_json j;
  j["schema"] = 1;
  j["scenario"] = h.scenario;
  j["backend"] = h.backend;
  j["baseline"] = h.baseline;
  j["seed"] = h.seed;
  j["profile"] = h.profile_source;
  if (!h.run_id.empty()) j["run_id"] = h.run_id;
  j["policies"] = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < policies.size(); ++i) {
    const PolicyMetrics& m = policies[i];
    nlohmann::ordered_json p;
    p["name"] = m.name;
    p["jobs"] = m.jobs;
    p["completed"] = m.completed;
    p["missed"] = m.missed;
    p["dropped"] = m.dropped;
    p["skipped"] = m.skipped;
    p["failed"] = m.failed;
    p["unfinished"] = m.unfinished;
    p["miss_rate"] = m.miss_rate;
    p["drop_rate"] = m.drop_rate;
    p["qoe"] = m.qoe;
    p["on_time"] = m.on_time;
    nlohmann::ordered_json why = nlohmann::ordered_json::object();
    for (const auto& [reason, n] : m.drop_reasons) why[reason] = n;
    p["drop_reasons"] = why;
    p["wasted_lane_fraction"] = m.wasted_lane_fraction;
    p["latency_ms"] = {{"mean", m.latency.mean},
                       {"p50", m.latency.p50},
                       {"p90", m.latency.p90},
                       {"p99", m.latency.p99},
                       {"max", m.latency.max}};
    p["encoder_runs"] = m.encoder_runs;
    p["encoder_runs_saved"] = m.encoder_runs_saved;
    p["sync_round_trips"] = m.sync_round_trips;
    p["dispatches"] = m.dispatches;
    p["merge_waits"] = m.merge_waits;
    nlohmann::ordered_json b = nlohmann::ordered_json::object();
    for (const auto& [size, n] : m.batch_sizes) b[std::to_string(size)] = n;
    p["batch_sizes"] = b;
    p["lane_utilization"] = m.lane_utilization;
    nlohmann::ordered_json t = nlohmann::ordered_json::object();
    for (const auto& [head, hz] : m.throughput_hz) t[head] = hz;
    p["throughput_hz"] = t;
    p["frame_age_ms"] = {{"mean", m.frame_age_mean_ms}, {"p99", m.frame_age_p99_ms}};
    p["measured_s"] = m.measured_s;
    // Only when the run completed more jobs than are kept exactly, so that the summaries
    // of shorter runs stay as they were (docs/REPORTS.md).
    if (m.percentile_error)
      p["percentiles"] = {{"exact", false},
                          {"exact_up_to", m.percentile_exact_up_to},
                          {"relative_error", *m.percentile_error}};
    if (m.online_costs || !m.costs.empty()) {
      nlohmann::ordered_json units = nlohmann::ordered_json::array();
      for (const UnitCostFigures& f : m.costs)
        units.push_back({{"unit", f.unit},
                         {"batch", f.batch},
                         {"runs", f.runs},
                         {"profile_mean_ms", to_ms(f.profile_mean)},
                         {"run_mean_ms", to_ms(f.run_mean)},
                         {"run_p50_ms", to_ms(f.run_p50)},
                         {"ratio", std::round(f.ratio() * 1000) / 1000},
                         // Unrounded: index.html shows it, and `red report` redraws it from here.
                         {"planned_factor", f.factor}});
      p["costs"] = {{"online", m.online_costs}, {"plan_changes", m.plan_changes}, {"units", units}};
    }
    if (m.decision_p50_us)
      p["decision_us"] = {{"p50", *m.decision_p50_us}, {"p99", opt(m.decision_p99_us)}};
    if (!m.failure_reasons.empty()) {
      nlohmann::ordered_json f = nlohmann::ordered_json::object();
      for (const auto& [reason, n] : m.failure_reasons) f[reason] = n;
      p["failure_reasons"] = f;
    }
    if (m.peak_rss_mb) p["peak_rss_mb"] = *m.peak_rss_mb;
    if (m.releases)
      p["frames"] = {{"offered", m.releases->offered},
                     {"released", m.releases->released},
                     {"released_late_ms",
                      {{"p50", m.releases->late_p50_ms},
                       {"p99", m.releases->late_p99_ms},
                       {"max", m.releases->late_max_ms}}},
                     {"behind_a_period", m.releases->behind}};
    p["ratios"] = {{"miss_rate", opt(m.ratio_miss)},
                   {"latency_mean", opt(m.ratio_latency)},
                   {"qoe", opt(m.ratio_qoe)}};
    if (i < phases.size()) p["phases"] = phases_json(phases[i]);
    j["policies"].push_back(std::move(p));
  }
  if (!h.page.empty()) j["page"] = nlohmann::ordered_json::parse(h.page);
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

std::string jobs_csv_header() {
  std::string out;
  for (const auto& c : report_detail::kJobColumns) {
    if (!out.empty()) out += ',';
    out += c.name;
  }
  return out + "\n";
}

void append_job_row(std::string& out, const Scenario& s, const std::string& policy,
                    const JobRow& j) {
  bool first = true;
  for (const auto& c : report_detail::kJobColumns) {
    if (!first) out += ',';
    first = false;
    c.write(out, s, policy, j);
  }
  out += '\n';
}

std::string jobs_csv(const Scenario& s, const std::vector<PolicyRows<JobRow>>& runs) {
  std::string out = jobs_csv_header();
  for (const auto& run : runs)
    for (const JobRow& j : *run.rows) append_job_row(out, s, run.policy, j);
  return out;
}

std::string units_csv_header() {
  return "policy,dispatch,lane,decided_ms,start_ms,end_ms,kind,head,batch,members,round_trip,"
         "status,jobs,expected_ms\n";
}

void append_unit_row(std::string& out, const Scenario& s, const std::string& policy,
                     const UnitRow& u) {
  out += fmt::format(
      "{},{},{},{:.6f},{:.6f},{:.6f},{},{},{},{},{},{},{},{:.6f}\n", csv(policy), u.dispatch,
      u.lane, to_ms(u.decided), to_ms(u.start), to_ms(u.end), to_string(u.kind),
      u.head >= 0 ? s.model.heads[static_cast<std::size_t>(u.head)] : "", u.batch, u.members,
      u.round_trip ? 1 : 0, to_string(u.status), csv(u.jobs), to_ms(u.expected));
}

std::string units_csv(const Scenario& s, const std::vector<PolicyRows<UnitRow>>& runs) {
  std::string out = units_csv_header();
  for (const auto& run : runs)
    for (const UnitRow& u : *run.rows) append_unit_row(out, s, run.policy, u);
  return out;
}

std::string comparison_table(const std::vector<PolicyMetrics>& policies,
                             const std::string& baseline) {
  auto r = [](const std::optional<double>& v) {
    return v ? fmt::format("{:.3f}", *v) : std::string("-");
  };
  std::string out = fmt::format(
      "{:<10} {:>6} {:>7} {:>7} {:>9} {:>9} {:>6} {:>8}  {:>6} {:>6} {:>6}\n", "policy", "jobs",
      "miss%", "drop%", "mean ms", "p99 ms", "QoE", "enc runs", "miss/", "lat/", "QoE/");
  out += fmt::format("{:<10} {:>6} {:>7} {:>7} {:>9} {:>9} {:>6} {:>8}  {:>6} {:>6} {:>6}\n", "",
                     "", "", "", "", "", "", "", baseline, baseline, baseline);
  for (const PolicyMetrics& m : policies) {
    if (m.jobs == 0) {
      // Nothing measured (a run stopped during its warm-up): no rate is 0 %, there is none.
      out += fmt::format("{:<10} {:>6} {:>7} {:>7} {:>9} {:>9} {:>6} {:>8}  {:>6} {:>6} {:>6}\n",
                         m.name, 0, "-", "-", "-", "-", "-", m.encoder_runs, "-", "-", "-");
      continue;
    }
    out += fmt::format(
        "{:<10} {:>6} {:>7.2f} {:>7.2f} {:>9.2f} {:>9.2f} {:>6.3f} {:>8}  {:>6} {:>6} {:>6}\n",
        m.name, m.jobs, 100.0 * m.miss_rate, 100.0 * m.drop_rate, m.latency.mean, m.latency.p99,
        m.qoe, m.encoder_runs, r(m.ratio_miss), r(m.ratio_latency), r(m.ratio_qoe));
  }
  return out;
}

std::string releases_table(const std::vector<PolicyMetrics>& policies) {
  bool any = false;
  for (const PolicyMetrics& m : policies) any = any || m.releases.has_value();
  if (!any) return {};
  std::string out = fmt::format("\nframes    {:>8} {:>8} {:>13} {:>13} {:>13} {:>7}\n", "offered",
                                "released", "late p50 ms", "late p99 ms", "late max ms", "behind");
  for (const PolicyMetrics& m : policies) {
    if (!m.releases) continue;
    const PolicyMetrics::Releases& r = *m.releases;
    out += fmt::format("{:<10}{:>8} {:>8} {:>13.3f} {:>13.3f} {:>13.3f} {:>7}\n", m.name, r.offered,
                       r.released, r.late_p50_ms, r.late_p99_ms, r.late_max_ms, r.behind);
  }
  return out;
}

std::optional<std::string> releases_warning(const PolicyMetrics& m) {
  if (!m.releases) return std::nullopt;
  const PolicyMetrics::Releases& r = *m.releases;
  if (r.released >= r.offered && r.behind == 0) return std::nullopt;
  return fmt::format(
      "policy {}: releases fell behind the sensors: {} of {} frames released, {} more than a "
      "period late (late by p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms); the policies did not "
      "all see the same workload",
      m.name, r.released, r.offered, r.behind, r.late_p50_ms, r.late_p99_ms, r.late_max_ms);
}

std::optional<Error> write_file(const std::string& dir, const std::string& name,
                                const std::string& text) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{dir, 0, "cannot create directory: " + ec.message()};
  return write_file_atomically((std::filesystem::path(dir) / name).string(), text);
}

}  // namespace red
