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
#include "red/metrics/why.hpp"
#include "red/profile/quality.hpp"
#include "red/report/html.hpp"
#include "red/report/plots.hpp"
#include "red/report/redraw.hpp"
#include "red/report/report.hpp"
#include "red/report/schedule_html.hpp"
#include "red/scenario/loader.hpp"
#include "red/scenario/manifest.hpp"
#include "red/sched/policy.hpp"

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

Expected<Scenario> load(const ScenarioArgs& a, std::optional<ModelManifest>* manifest) {
  auto s = load_scenario(a.path);
  if (!s) return s.error();
  if (auto e = check_policy_options(*s)) return *e;  // the scheduler section's policy options
  if (auto e = check_model(*s, manifest)) return *e;
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

std::optional<LoadedScenario> load_with_profile(const ScenarioArgs& a) {
  auto s = load(a);
  if (!s) {
    print_error(s.error());
    return std::nullopt;
  }
  auto p = cli_profile(*s, a.profile);
  if (!p) {
    print_error(p.error());
    return std::nullopt;
  }
  return LoadedScenario{std::move(s).value(), std::move(p).value()};
}

void add_with_option(CLI::App* cmd, ScenarioArgs& a) {
  std::string keys;  // every option, as set_option() spells it
  for (const std::string& k : option_keys()) keys += (keys.empty() ? "" : ", ") + k;
  cmd->add_option("--with", a.with,
                  "Policy options key=value,… for every policy run (" + keys + "; docs/CLI.md)");
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

namespace {

// The files write_outputs writes, one by one: a file that cannot be written is recorded and
// the others are still tried (on a full disk a small summary.json may still fit where a
// large units.csv did not).
struct OutputWriter {
  const std::string& dir;
  OutputReport& r;
  OutputSet* set;

  void failed(const Error& e) {
    r.errors.push_back(e);
    if (set != nullptr) set->fail(e);
  }
  void wrote(const std::string& name) {
    r.files.push_back(name);
    if (set != nullptr) set->add(name);
  }
  bool put(const std::string& name, const std::string& text) {
    if (auto e = write_file(dir, name, text)) {
      failed(*e);
      return false;
    }
    wrote(name);
    return true;
  }
};

// The figures per workload phase of each run.
std::vector<std::vector<PhaseMetrics>> phases_of(const Scenario& s,
                                                 const std::vector<PolicyRun>& runs) {
  std::vector<std::vector<PhaseMetrics>> phases;
  for (const PolicyRun& run : runs)
    // A run whose rows were lost (a streamed file that could not be written) has no figures
    // per phase: an empty list, not phases of no jobs.
    phases.push_back(run.jobs.empty() && run.metrics.jobs > 0
                         ? std::vector<PhaseMetrics>{}
                         : phase_metrics(s, run.jobs, run.result.end));
  return phases;
}

// What the page is drawn from, as summary.json keeps it. The merge waits the traces recorded
// go into `waits`, to the microsecond trace.json keeps, so that `red report` redraws the same
// timeline from trace.json.
PageInput page_input(const Scenario& s, std::vector<PolicyRun>& runs,
                     const std::vector<PolicyMetrics>& metrics,
                     const std::vector<std::vector<PhaseMetrics>>& phases,
                     const OutputOptions& options, std::vector<std::vector<TimelineWait>>& waits) {
  PageInput in;
  in.scenario = &s;
  in.verdicts = options.verdicts;
  in.prediction = options.prediction;
  in.index_html = options.index_html;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    PageRun pr{&metrics[i], &runs[i].jobs, &runs[i].units,    &phases[i],
               nullptr,     std::nullopt,  runs[i].result.end};
    if (i < options.traces.size() && options.traces[i] != nullptr) {
      for (const auto& w : options.traces[i]->waits())
        waits[i].push_back(
            {w.at, from_ms(std::stod(fmt::format("{:.3f}", to_ms(w.until)))), w.sensor});
      pr.waits = &waits[i];
      if (options.traces[i]->truncated()) pr.waits_cut = options.traces[i]->truncated_at();
    }
    in.runs.push_back(pr);
  }
  return in;
}

// jobs.csv and units.csv, or, streamed during the run, their files for the manifest.
void write_rows(OutputWriter& out, const Scenario& s, const std::vector<PolicyRun>& runs,
                const OutputOptions& options) {
  std::vector<PolicyRows<JobRow>> jobs;
  std::vector<PolicyRows<UnitRow>> units;
  for (const PolicyRun& run : runs) {
    jobs.push_back({run.metrics.name, &run.jobs});
    units.push_back({run.metrics.name, &run.units});
  }
  if (!options.rows_written) {
    out.put("jobs.csv", jobs_csv(s, jobs));
    out.put("units.csv", units_csv(s, units));
    return;
  }
  // The streamed jobs.csv has no causes (a job's cause needs the units that ran up to its
  // deadline, which end after it): written again with them when every row is here.
  const bool whole = std::find(options.rows_files.begin(), options.rows_files.end(), "jobs.csv") !=
                         options.rows_files.end() &&
                     std::all_of(runs.begin(), runs.end(), [](const PolicyRun& run) {
                       return static_cast<std::int64_t>(run.jobs.size()) == run.metrics.jobs;
                     });
  for (const std::string& f : options.rows_files)
    if (f != "jobs.csv" || !whole) out.wrote(f);
  if (whole) out.put("jobs.csv", jobs_csv(s, jobs));
}

// trace.json: one process per policy, so Perfetto shows the policies on one time axis.
void write_trace(OutputWriter& out, const Scenario& s, const Profile& p, const SummaryHeader& h,
                 const std::vector<PolicyRun>& runs, const OutputOptions& options) {
  std::vector<TraceProcess> processes;
  for (std::size_t i = 0; i < runs.size() && i < options.traces.size(); ++i)
    if (options.traces[i] != nullptr)
      processes.push_back({"policy " + runs[i].metrics.name, options.traces[i]});
  if (processes.empty()) return;
  AtomicFile f((std::filesystem::path(out.dir) / "trace.json").string());
  std::vector<std::pair<std::string, std::string>> meta = {
      {"backend", h.backend},
      {"seed", std::to_string(h.seed)},
      {"profile", p.source},
      {"time", h.backend == "sim" ? "simulated" : "real (from the run's start)"}};
  if (!h.run_id.empty()) meta.emplace_back("run_id", h.run_id);
  write_chrome_trace(f.stream(), s, processes, meta);
  if (auto e = f.commit())
    out.failed(*e);
  else
    out.wrote("trace.json");
}

// The plots, the timeline (plots/timeline*.svg) and index.html: the same function `red
// report` redraws them with from the saved files (report/redraw.hpp).
void write_page(OutputWriter& out, PageInput& in, const OutputOptions& options) {
  in.data_files = out.r.files;
  for (const std::string& f : options.more_files) in.data_files.push_back(f);
  PageOptions po;
  po.gnuplot = gnuplot_command(options.gnuplot);
  po.timeline = options.timeline;
  const PageReport page = write_report_page(out.dir, in, po);
  if (!page.plots_note.empty()) std::cerr << "red: " << page.plots_note << '\n';
  for (const std::string& f : page.files) {
    const bool data = f.size() > 3 && (f.ends_with(".dat") || f.ends_with(".gp"));
    if (data) {
      if (out.set != nullptr) out.set->add(f);
    } else {
      out.wrote(f);
    }
  }
  out.r.images += page.images;
  for (const Error& e : page.errors) out.failed(e);
}

}  // namespace

std::optional<Error> write_outputs(const std::string& dir, const Scenario& s, const Profile& p,
                                   const std::string& backend, std::uint64_t seed,
                                   std::vector<PolicyRun>& runs, const OutputOptions& options,
                                   OutputReport* report) {
  OutputReport local;
  OutputReport& r = report != nullptr ? *report : local;
  r = {};
  // Why each job missed (metrics/why.hpp): before the phases and jobs.csv, which show it.
  for (PolicyRun& run : runs) annotate_causes(s, run.jobs, run.units);
  std::vector<PolicyMetrics> metrics;
  for (const PolicyRun& run : runs) metrics.push_back(run.metrics);
  apply_ratios(metrics, "edf");
  SummaryHeader h;
  h.scenario = s.name;
  h.backend = backend;
  h.seed = seed;
  h.profile_source = p.source;
  if (options.set != nullptr) h.run_id = options.set->run_id();
  OutputWriter out{dir, r, options.set};
  const std::vector<std::vector<PhaseMetrics>> phases = phases_of(s, runs);
  std::vector<std::vector<TimelineWait>> waits(runs.size());
  PageInput in = page_input(s, runs, metrics, phases, options, waits);
  h.page = page_json(in);
  const std::string summary = summary_json(h, metrics, phases);
  if (!out.put("summary.json", summary))
    // The run's figures are not lost with the file: the summary goes to stderr instead.
    std::cerr << "red: " << r.errors.back().to_string()
              << "; summary.json follows on stderr instead:\n"
              << summary;
  write_rows(out, s, runs, options);
  write_trace(out, s, p, h, runs, options);
  in.header = h;
  write_page(out, in, options);
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
