#include "common.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>

#include "red/core/output_file.hpp"
#include "red/profile/quality.hpp"
#include "red/report/html.hpp"
#include "red/report/plots.hpp"
#include "red/report/report.hpp"
#include "red/report/schedule_html.hpp"
#include "red/scenario/loader.hpp"
#include "red/scenario/manifest.hpp"

namespace red::cli {

std::optional<double> decimal_number(const std::string& text) {
  double v = 0;
  const char* last = text.data() + text.size();
  // Plain decimal notation only (std::chars_format::general: no "0x", no leading '+').
  const auto [ptr, ec] = std::from_chars(text.data(), last, v, std::chars_format::general);
  if (text.empty() || ec != std::errc{} || ptr != last || !std::isfinite(v)) return std::nullopt;
  return v;
}

namespace {

// A CLI11 check that the text is a finite decimal number for which `ok` holds.
CLI::Validator finite_number(bool (*ok)(double), const std::string& what) {
  return CLI::Validator(
      [ok, what](std::string& text) {
        const auto v = decimal_number(text);
        return v && ok(*v) ? std::string()
                           : "must be a finite number " + what + ", not '" + text + "'";
      },
      "NUMBER " + what);
}

}  // namespace

CLI::Validator finite_positive() {
  return finite_number([](double v) { return v > 0; }, "> 0");
}

CLI::Validator finite_non_negative() {
  return finite_number([](double v) { return v >= 0; }, ">= 0");
}

CLI::Validator whole_number(std::uint64_t max) {
  return CLI::Validator(
      [max](std::string& text) {
        std::uint64_t v = 0;
        const char* last = text.data() + text.size();
        const auto [ptr, ec] = std::from_chars(text.data(), last, v);
        if (!text.empty() && ec == std::errc{} && ptr == last && v <= max) return std::string();
        return fmt::format("must be a whole number from 0 to {}, not '{}'", max, text);
      },
      "INTEGER");
}

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ' ') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

Expected<Scenario> load(const ScenarioArgs& a) {
  auto s = load_scenario(a.path);
  if (!s) return s.error();
  if (auto e = check_model(*s)) return *e;
  for (const std::string& kv : a.sets) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) return Error{"", 0, "--set '" + kv + "': expected key=value"};
    const std::string key = kv.substr(0, eq);
    const std::string val = kv.substr(eq + 1);
    const std::optional<double> v = decimal_number(val);
    if (!v)
      return Error{"", 0,
                   "--set " + key + ": '" + val +
                       "' is not a number (a finite decimal such as 1.5 or 2e-3)"};
    std::vector<std::string> warnings;
    if (auto err = apply_override(s.value(), key, *v, &warnings)) return *err;
    for (const std::string& w : warnings) std::cerr << "red: warning: --set " << w << '\n';
  }
  for (const std::string& w : a.with) {
    PolicyOptions check;
    if (std::string err = apply_options(check, w); !err.empty())
      return Error{"", 0, "--with " + w + ": " + err};
    std::string& all = s.value().scheduler.policy_with;
    all += (all.empty() || w.empty() ? "" : ",") + w;
  }
  return s;
}

Expected<Profile> cli_profile(const Scenario& s, const std::optional<std::string>& cli_path) {
  std::vector<std::string> warnings;
  auto p = resolve_profile(s, cli_path, &warnings);
  if (p)
    for (const std::string& w : warnings) std::cerr << "red: warning: " << w << '\n';
  return p;
}

void add_with_option(CLI::App* cmd, ScenarioArgs& a) {
  cmd->add_option("--with", a.with,
                  "Policy options key=value,… for every policy run (graph, deadlines, reassign, "
                  "merge, batching, sync, drop, drop_estimate, admission, admit_margin, rank, "
                  "shed_rate, lookahead, shed_lone, batch_by_job, path_rank; "
                  "docs/CLI.md)");
}

std::string gnuplot_command(const std::string& configured) {
  std::string cmd = configured;
  if (cmd.empty()) {
    const char* env = std::getenv("RED_GNUPLOT");
    cmd = env != nullptr && *env != '\0' ? env : "gnuplot";
  }
  return cmd == "none" ? std::string() : cmd;
}

std::unique_ptr<TraceObserver> make_trace(const Scenario& s, std::size_t total_events,
                                          std::size_t runs) {
  if (total_events == 0) return nullptr;
  TraceOptions o;
  o.max_events = std::max<std::size_t>(1, total_events / std::max<std::size_t>(1, runs));
  return std::make_unique<TraceObserver>(s, o);
}

std::optional<Error> write_outputs(const std::string& dir, const Scenario& s, const Profile& p,
                                   const std::string& backend, std::uint64_t seed,
                                   const std::vector<PolicyRun>& runs, const OutputOptions& options,
                                   OutputReport* report) {
  OutputReport local;
  OutputReport& r = report != nullptr ? *report : local;
  r = {};
  std::vector<PolicyMetrics> metrics;
  std::vector<PolicyRows<JobRow>> jobs;
  std::vector<PolicyRows<UnitRow>> units;
  for (const PolicyRun& run : runs) {
    metrics.push_back(run.metrics);
    jobs.push_back({run.metrics.name, &run.jobs});
    units.push_back({run.metrics.name, &run.units});
  }
  apply_ratios(metrics, "edf");
  SummaryHeader h;
  h.scenario = s.name;
  h.backend = backend;
  h.seed = seed;
  h.profile_source = p.source;
  if (options.set != nullptr) h.run_id = options.set->run_id();
  // A file that cannot be written is recorded and the others are still tried: on a full
  // disk a small summary.json may still fit where a large units.csv did not.
  auto failed = [&](const Error& e) {
    r.errors.push_back(e);
    if (options.set != nullptr) options.set->fail(e);
  };
  auto wrote = [&](const std::string& name) {
    r.files.push_back(name);
    if (options.set != nullptr) options.set->add(name);
  };
  auto put = [&](const std::string& name, const std::string& text) {
    if (auto e = write_file(dir, name, text)) {
      failed(*e);
      return false;
    }
    wrote(name);
    return true;
  };
  std::vector<std::vector<PhaseMetrics>> phases;
  for (const PolicyRun& run : runs)
    // A run whose rows were lost (a streamed file that could not be written) has no figures
    // per phase: an empty list, not phases of no jobs.
    phases.push_back(run.jobs.empty() && run.metrics.jobs > 0
                         ? std::vector<PhaseMetrics>{}
                         : phase_metrics(s, run.jobs, run.result.end));
  const std::string summary = summary_json(h, metrics, phases);
  if (!put("summary.json", summary))
    // The run's figures are not lost with the file: the summary goes to stderr instead.
    std::cerr << "red: " << r.errors.back().to_string()
              << "; summary.json follows on stderr instead:\n"
              << summary;
  if (!options.rows_written) {
    put("jobs.csv", jobs_csv(s, jobs));
    put("units.csv", units_csv(s, units));
  } else {
    for (const std::string& f : options.rows_files) wrote(f);
  }

  // trace.json: one process per policy, so Perfetto shows the policies on one time axis.
  std::vector<TraceProcess> processes;
  for (std::size_t i = 0; i < runs.size() && i < options.traces.size(); ++i)
    if (options.traces[i] != nullptr)
      processes.push_back({"policy " + runs[i].metrics.name, options.traces[i]});
  if (!processes.empty()) {
    AtomicFile f((std::filesystem::path(dir) / "trace.json").string());
    std::vector<std::pair<std::string, std::string>> meta = {
        {"backend", backend},
        {"seed", std::to_string(seed)},
        {"profile", p.source},
        {"time", backend == "sim" ? "simulated" : "real (from the run's start)"}};
    if (!h.run_id.empty()) meta.emplace_back("run_id", h.run_id);
    write_chrome_trace(f.stream(), s, processes, meta);
    if (auto e = f.commit())
      failed(*e);
    else
      wrote("trace.json");
  }

  PlotOptions po;
  po.gnuplot = gnuplot_command(options.gnuplot);
  std::vector<PlotRun> plot_runs;
  for (std::size_t i = 0; i < runs.size(); ++i)
    plot_runs.push_back({runs[i].metrics.name, &metrics[i], &runs[i].jobs});
  const PlotReport plots = write_run_plots(dir, s, plot_runs, po);
  if (!plots.note.empty()) std::cerr << "red: " << plots.note << '\n';
  for (const Error& e : plots.errors) failed(e);
  for (const std::string& f : plots.files)
    if (options.set != nullptr) options.set->add(f);
  for (const PlotFile& f : plots.plots) {
    wrote(f.png);
    ++r.images;
    if (!f.svg.empty()) {
      wrote(f.svg);
      ++r.images;
    }
  }

  // The schedule itself (plots/timeline*.svg), drawn from units.csv and jobs.csv, with the
  // merge waits the traces recorded.
  std::vector<std::vector<TimelineWait>> waits(runs.size());
  std::vector<TimelineRun> timeline_runs;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    TimelineRun t{runs[i].metrics.name, &runs[i].units,    &runs[i].jobs, nullptr,
                  std::nullopt,         runs[i].result.end};
    if (i < options.traces.size() && options.traces[i] != nullptr) {
      for (const auto& w : options.traces[i]->waits())
        waits[i].push_back({w.at, w.until, w.sensor});
      t.waits = &waits[i];
      if (options.traces[i]->truncated()) t.waits_cut = options.traces[i]->truncated_at();
    }
    timeline_runs.push_back(std::move(t));
  }
  std::vector<TimelineWindow> windows;
  if (options.timeline)
    windows.push_back({options.timeline->first, options.timeline->second, "timeline",
                       fmt::format("Timeline: {:g} to {:g} s", to_s(options.timeline->first),
                                   to_s(options.timeline->second))});
  else
    windows = default_timeline_windows(s, timeline_runs);
  auto timelines = write_timelines(dir, s, timeline_runs, windows);
  if (!timelines)
    failed(timelines.error());
  else
    for (const std::string& f : timelines->files) {
      wrote(f);
      ++r.images;
    }

  if (options.index_html) {
    std::vector<HtmlLink> links = {
        {"summary.json", "the summary of every policy (schema in docs/REPORTS.md)"},
        {"jobs.csv", "one row per job"},
        {"units.csv", "one row per unit execution"}};
    if (!processes.empty())
      links.push_back({"trace.json", "the timeline: drag into https://ui.perfetto.dev"});
    HtmlPage page = compare_page(h, metrics, plots, links);
    if (options.verdicts) page.tables.insert(page.tables.begin(), *options.verdicts);
    for (const HtmlTable& t : options.prediction) page.tables.push_back(t);
    std::vector<std::string> names;
    for (const PolicyMetrics& m : metrics) names.push_back(m.name);
    page.sections.push_back(phase_section(s, names, phases));
    if (timelines) page.sections.push_back(timelines->section);
    put("index.html", render_html(page));
  }
  if (!r.errors.empty()) return r.errors.front();
  return std::nullopt;
}

std::string wrote_message(const std::string& dir, const OutputReport& r) {
  std::string out = "wrote " + dir + "/";
  bool first = true;
  for (const std::string& f : r.files) {
    if (f.rfind("plots/", 0) == 0) continue;  // images are counted below
    out += (first ? "" : ", ") + f;
    first = false;
  }
  if (r.images > 0) out += fmt::format(", plots/ ({} images)", r.images);
  return out;
}

void warn_suspect_profile(const Profile& p, const std::string& path, std::size_t cap) {
  if (!p.quality || p.quality->verdict != "suspect") return;
  std::cerr << fmt::format(
      "red: warning: profile {} was measured with suspect figures ({} finding(s); its "
      "'quality' field has them all); costs from it may be too high:\n",
      path, p.quality->findings.size());
  for (const std::string& line : quality_lines(*p.quality, cap))
    std::cerr << "red: warning: " << line << '\n';
}

}  // namespace red::cli
