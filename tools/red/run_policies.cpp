/// \file
/// run_policies (run_policies.hpp): one or more policies on one scenario, in the simulator or
/// on a real backend, printed as a table and written as a report; and the options of
/// `red simulate`, `red compare` and `red run`.

#include "run_policies.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <nlohmann/json.hpp>

#include <iostream>
#include <memory>
#include <optional>

#include "red/core/clock.hpp"
#include "red/core/output_file.hpp"

#include "commands.hpp"
#include "common.hpp"
#include "drivers.hpp"
#include "real_run.hpp"
#include "red/analysis/analyze.hpp"
#include "red/calibrate/calibrate.hpp"
#include "red/metrics/phases.hpp"
#include "red/report/report.hpp"
#include "red/report/row_queue.hpp"
#include "red/report/stream.hpp"
#include "red/report/timeline.hpp"
#include "signals.hpp"

namespace red::cli {

namespace {

std::optional<SyncMode> parse_sync(const std::string& v) {
  if (v == "per-edge") return SyncMode::PerEdge;
  if (v == "on-demand") return SyncMode::OnDemand;
  return std::nullopt;  // CLI11 has checked the value
}

// The inputs of a run, checked: the scenario and profile, the timeline's window, the seed and
// the real backend's options.
struct RunPlan {
  LoadedScenario loaded;
  std::optional<std::pair<Duration, Duration>> timeline;
  std::uint64_t seed = 0;
  RealRunOptions real;
};

// --timeline's window, checked against the run's length; nullopt once an error is printed.
std::optional<std::pair<Duration, Duration>> timeline_window(const RunArgs& a, const Scenario& s) {
  auto w = parse_timeline_window(*a.timeline);
  if (!w) {
    print_error(w.error());
    return std::nullopt;
  }
  if (!a.out) {
    print_error(Error{"", 0, "--timeline: the timeline is drawn into --out DIR; give --out"});
    return std::nullopt;
  }
  if (w->first >= s.duration) {
    print_error(Error{"", 0,
                      fmt::format("--timeline: FROM ({:g} s) is not before the end of the run "
                                  "({:g} s, duration_s)",
                                  to_s(w->first), to_s(s.duration))});
    return std::nullopt;
  }
  return *w;
}

// The device, the scenario and profile, the presets and --timeline, checked; nullopt (bad
// input) once an error is printed.
std::optional<RunPlan> plan_runs(const RunArgs& a, const std::vector<std::string>& names) {
  {
    // The device first: a device that is not there is an error, never a CPU run.
    RealRunOptions asked = a.real;
    asked.backend = a.backend;
    if (auto e = check_device(asked)) {
      print_error(*e);
      return std::nullopt;
    }
  }
  auto loaded = load_with_profile(a.scenario);
  if (!loaded) return std::nullopt;
  const Scenario& s = loaded->scenario;
  for (const std::string& n : names) {
    if (!make_policy(n)) {
      print_error(Error{"", 0, unknown_policy_message(n)});
      return std::nullopt;
    }
  }
  RunPlan plan;
  if (a.timeline) {
    plan.timeline = timeline_window(a, s);
    if (!plan.timeline) return std::nullopt;
  }
  if (a.write_profile && a.backend == "sim") {
    print_error(Error{"", 0,
                      "--write-profile writes the costs a real run's units met: it needs a real "
                      "backend (--backend torch or synthetic); the simulator's are the profile's"});
    return std::nullopt;
  }
  plan.seed = a.seed ? *a.seed : s.seed;
  plan.real = a.real;
  plan.real.backend = a.backend;
  plan.real.realtime = !a.no_realtime;
  plan.real.seed = plan.seed;
  plan.real.sync = parse_sync(a.sync);
  // units.csv and the plots are written only with --out; --write-profile fits the units.
  plan.real.keep_units = a.out.has_value() || a.write_profile.has_value();
  // A real run streams its rows to jobs.csv and units.csv as jobs end, so that its memory
  // does not grow with its length (docs/REPORTS.md, "Streamed rows"); without --out only
  // the summary's bounded state is kept (the rows too for --phases, and for --write-profile,
  // which fits the units).
  plan.real.keep_rows = !a.out && (a.phases || a.write_profile);
  plan.loaded = std::move(*loaded);
  return plan;
}

// Where the files go: the output set, the rows streamed to jobs.csv and units.csv, and whether
// a file failed.
struct RunFiles {
  std::optional<OutputSet> set;
  bool write_failed = false;
  std::unique_ptr<CsvRowStream> stream;
  std::optional<RowQueue> queue;

  // A file that fails is reported as it fails and at the end; the run and the other files
  // go on, and the exit code is 1.
  void failed(const Error& e) {
    print_error(e);
    if (set) set->fail(e);
    write_failed = true;
  }
};

// Opens the streamed jobs.csv and units.csv and hands their queue to the driver; false when
// they cannot be opened (the error is printed).
bool stream_rows(const std::string& dir, const Scenario& s, Driver& driver, RunFiles& files) {
  auto st = CsvRowStream::open(dir, s, true);
  if (!st) {
    files.failed(st.error());
    return false;
  }
  files.stream = std::move(st.value());
  if (auto e = files.stream->flush()) {
    // No room even for the headers (a full disk): said now, and the runs go on.
    files.failed(*e);
    std::cerr << "red: the runs go on; the table and summary.json follow at the end\n";
  }
  // Rows are formatted and written on the queue's thread, not on the lane that reports
  // them between one unit and the next (the hand-off, docs/BENCHMARKS.md).
  files.queue.emplace(*files.stream);
  driver.set_rows(&*files.queue);
  return true;
}

// The runs of the policies, each with its timeline's trace (null when none is written).
struct Runs {
  std::vector<PolicyRun> runs;
  std::vector<std::unique_ptr<TraceObserver>> traces;
};

// Each policy in turn, until a stop signal; the exit code when a run failed.
std::optional<int> run_each(const RunArgs& a, const std::vector<std::string>& names,
                            const Scenario& s, Driver& driver, RunFiles& files, Runs& out) {
  // Observers beside the metrics: the timeline (only when it will be written) and the
  // progress line (only on a terminal, only for runs longer than a few seconds).
  std::vector<std::unique_ptr<TraceObserver>>& traces = out.traces;
  const SteadyClock clock;
  ProgressReporter progress(clock, std::cerr, ProgressReporter::stderr_is_terminal());
  for (std::size_t i = 0; i < names.size(); ++i) {
    // A stop signal: no further policy starts (a simulation in progress ends at once and is
    // left out; a real run ends as at its duration and is kept).
    if (stop_signal() != 0) break;
    const std::string& n = names[i];
    traces.push_back(a.out ? make_trace(s, a.trace_events, names.size()) : nullptr);
    std::vector<Observer*> extra{&progress};
    if (traces.back()) extra.push_back(traces.back().get());
    progress.begin_run(names.size() == 1 ? n : fmt::format("{} [{}/{}]", n, i + 1, names.size()),
                       s.duration);
    driver.announce(n, i, names.size());
    if (files.stream) files.stream->begin_policy(n);
    auto r = driver.run(n, extra, a.out.has_value());
    progress.finish();
    if (!r && stop_signal() != 0) break;  // a simulation ended by the signal: left out
    if (!r) {
      print_error(r.error());
      return driver.failure_code();
    }
    if (files.queue) files.queue->drain();
    if (files.stream && !files.write_failed)
      if (auto e = files.stream->flush()) {
        // The file stops there; the runs go on, and the table and the summary are still
        // given at the end.
        files.failed(*e);
        std::cerr << "red: the runs go on; the table and summary.json follow at the end\n";
      }
    driver.finished(n, *r);
    if (traces.back() && traces.back()->truncated())
      std::cerr << fmt::format(
          "red: trace of {} stops at {:.3f} s (limit of {} events; see --trace-events)\n", n,
          to_s(traces.back()->truncated_at()), traces.back()->events());
    out.runs.push_back(std::move(r.value()));
  }
  return std::nullopt;
}

// After a stop signal: what was run, and whether anything is left to show.
bool report_stop(const RunArgs& a, const std::vector<std::string>& names,
                 const std::vector<PolicyRun>& runs) {
  // A run stopped during its warm-up measured nothing: say so rather than show 0 jobs.
  const bool measured =
      std::any_of(runs.begin(), runs.end(), [](const PolicyRun& r) { return r.metrics.jobs > 0; });
  std::cerr << fmt::format("red: stopped by {} after {} of {} run(s){}\n", stop_signal_name(),
                           runs.size(), names.size(),
                           runs.empty() ? ""
                           : !measured  ? "; nothing was measured (stopped during the warm-up)"
                           : a.out      ? "; writing what they measured"
                                        : "");
  return !runs.empty();
}

// The report's rows: the window kept in memory, or read back from the streamed files; returns
// the streamed files renamed into place. Without the rows (a file failed) the summary and the
// table still come from the metrics.
std::vector<std::string> finish_stream(RunFiles& files, std::vector<PolicyRun>& runs) {
  auto rows = files.stream->rows();
  if (!rows) {
    if (!files.write_failed)
      files.failed(rows.error());
    else
      std::cerr << "red: " << rows.error().to_string()
                << "; summary.json has no figures per phase, and the plots and the "
                   "timeline no rows\n";
  } else {
    for (std::size_t i = 0; i < runs.size() && i < rows->size(); ++i) {
      runs[i].jobs = std::move((*rows)[i].jobs);
      runs[i].units = std::move((*rows)[i].units);
    }
  }
  const bool before = files.write_failed;
  if (auto e = files.stream->finish(); e && !before) files.failed(*e);
  return files.stream->finished();
}

// The prediction beside the runs (Driver::predict): text and the page's tables.
struct Prediction {
  std::string text;
  std::vector<HtmlTable> html;
};

// The comparison and release tables on stdout; returns the runs' metrics, with their ratios to
// edf.
std::vector<PolicyMetrics> print_comparison(const RunPlan& plan, const Driver& driver,
                                            const std::vector<PolicyRun>& runs) {
  const Scenario& s = plan.loaded.scenario;
  std::vector<PolicyMetrics> metrics;
  for (const PolicyRun& r : runs) metrics.push_back(r.metrics);
  apply_ratios(metrics, "edf");
  fmt::print("scenario {} (backend {}, seed {}, profile {}, {} lane(s), {:g} s measured)\n", s.name,
             driver.heading_name(), plan.seed, plan.loaded.profile.source, s.device.lanes,
             metrics.front().measured_s);
  fmt::print("{}", comparison_table(metrics, "edf"));
  fmt::print("{}", releases_table(metrics));
  return metrics;
}

// --write-profile: the run's own costs, the next run's profile (docs/FIDELITY.md, "The check at
// the end of a run").
void write_own_profile(const std::string& path, const Driver& driver,
                       const std::vector<PolicyRun>& runs, RunFiles& files) {
  auto own = driver.own_costs_profile(runs);
  if (!own) {
    files.failed(own.error());
  } else if (auto e = write_file_atomically(path, profile_to_json(*own))) {
    files.failed(*e);
  } else {
    fmt::print(
        "wrote {}: this run's own unit costs as a calibrated profile (--profile for the "
        "next run)\n",
        path);
  }
}

// The figures per phase (--phases) and, for one policy (`table` false), its summary, on stdout.
void print_details(const RunArgs& a, const Scenario& s, const std::vector<PolicyRun>& runs,
                   const PolicyMetrics& m, bool table) {
  if (a.phases) {
    std::vector<std::string> names_run;
    std::vector<std::vector<PhaseMetrics>> phases;
    for (const PolicyRun& r : runs) {
      names_run.push_back(r.metrics.name);
      phases.push_back(phase_metrics(s, r.jobs, r.result.end));
    }
    fmt::print("{}", phase_table(s, names_run, phases));
  }
  if (!table) {
    fmt::print(
        "completed {}, met {}, missed {} (dropped {}, skipped {}, failed {}), unfinished {}\n",
        m.completed, m.completed - (m.missed - m.dropped), m.missed, m.dropped, m.skipped, m.failed,
        m.unfinished);
    fmt::print("latency ms: mean {:.2f}, p50 {:.2f}, p90 {:.2f}, p99 {:.2f}, max {:.2f}\n",
               m.latency.mean, m.latency.p50, m.latency.p90, m.latency.p99, m.latency.max);
    fmt::print("encoder runs {} (saved {}), dispatches {}, sync round trips {}, merge waits {}\n",
               m.encoder_runs, m.encoder_runs_saved, m.dispatches, m.sync_round_trips,
               m.merge_waits);
    std::string util;
    for (double u : m.lane_utilization) util += fmt::format(" {:.1f}%", 100 * u);
    fmt::print("lane utilization:{}; frame age mean {:.2f} ms\n", util, m.frame_age_mean_ms);
  }
}

// The verdicts of `red analyze` (without its headroom search) for each policy run, for the top
// of the page.
HtmlTable verdicts_of(const RunPlan& plan, const std::vector<PolicyRun>& runs) {
  std::vector<Analysis> verdicts;
  for (const PolicyRun& r : runs) {
    AnalysisOptions ao;
    ao.policy = r.metrics.name;
    ao.headroom = false;
    if (auto an = analyze(plan.loaded.scenario, plan.loaded.profile, ao))
      verdicts.push_back(std::move(an).value());
  }
  return verdict_html_table(verdicts);
}

// The report (write_outputs) and the driver's own files into --out, ended by the manifest.
void write_run_files(const RunArgs& a, const std::vector<std::string>& names, bool table,
                     const RunPlan& plan, Driver& driver, Runs& done, Prediction& prediction,
                     const std::vector<std::string>& streamed, RunFiles& files) {
  const std::string& dir = *a.out;
  OutputOptions o;
  for (const auto& t : done.traces) o.traces.push_back(t.get());
  o.index_html = table;  // red compare
  if (table) {
    o.verdicts = verdicts_of(plan, done.runs);
    o.prediction = std::move(prediction.html);
  }
  o.timeline = plan.timeline;
  driver.more_files(o, prediction.text);
  o.rows_written = files.stream != nullptr;
  o.rows_files = streamed;
  o.set = &*files.set;
  OutputReport written;
  (void)write_outputs(dir, plan.loaded.scenario, plan.loaded.profile, driver.summary_name(),
                      plan.seed, done.runs, o, &written);
  for (const Error& e : written.errors) print_error(e);
  files.write_failed = files.write_failed || !written.errors.empty();
  auto put = [&](const std::string& name, const std::string& text) {
    if (auto e = write_file(dir, name, text))
      files.failed(*e);
    else
      files.set->add(name);
  };
  driver.write_more(names, prediction.text, files.set->run_id(), put);
  if (stop_signal() != 0) files.set->stopped(stop_signal_name());
  // Last: the manifest that marks the files as this run's complete set.
  const std::optional<Error> manifest = files.set->finish();
  if (manifest) files.failed(*manifest);
  fmt::print("{}{}\n", wrote_message(dir, written), manifest ? "" : ", manifest.json");
  if (files.write_failed)
    std::cerr << fmt::format(
        "red: not every file could be written into {} (errors above): the result there is "
        "not complete\n",
        dir);
}

}  // namespace

// Runs the given policies on one scenario and prints and writes the results. In the
// simulator every policy sees the same releases and the same sampled unit times (common
// random numbers, docs/DESIGN.md, "Metrics"); on a real backend the same releases. Returns the
// exit code.
int run_policies(const RunArgs& a, const std::vector<std::string>& names, bool table,
                 const char* command) {
  install_stop_signals();
  std::optional<RunPlan> plan = plan_runs(a, names);
  if (!plan) return kBadInput;
  Scenario& s = plan->loaded.scenario;
  auto made = make_driver(a, s, plan->loaded.profile, plan->seed, plan->real);
  if (!made) {
    print_error(made.error());
    return kBadInput;
  }
  Driver& driver = *made.value();
  // Asynchronous lanes (--async, or a GPU) hold the scenario's queue depth, 2 unless it sets
  // one: the scheduler, the simulator and the prediction beside a real run all plan so.
  if ((a.real.asynchronous || driver.asynchronous()) && !s.device.queue_depth)
    s.device.queue_depth = 2;
  RunFiles files;
  if (a.out) {
    // The output directory's old manifest goes before anything else is written, so that the
    // files of an earlier run are never taken for this run's (docs/REPORTS.md).
    auto begun = OutputSet::begin(*a.out, command);
    if (!begun) {
      print_error(begun.error());
      return kRunFailure;
    }
    files.set = std::move(begun.value());
  }
  if (driver.streams_rows() && a.out && !stream_rows(*a.out, s, driver, files)) return kRunFailure;
  Runs done;
  if (const std::optional<int> code = run_each(a, names, s, driver, files, done)) return *code;
  if (stop_signal() != 0 && !report_stop(a, names, done.runs)) return stop_exit_code();
  std::vector<std::string> streamed;  // the streamed files renamed into place
  if (files.stream) streamed = finish_stream(files, done.runs);
  const std::vector<PolicyMetrics> metrics = print_comparison(*plan, driver, done.runs);
  Prediction prediction;
  if (stop_signal() == 0) prediction.text = driver.predict(done.runs, prediction.html);
  if (a.write_profile && stop_signal() == 0)
    write_own_profile(*a.write_profile, driver, done.runs, files);
  print_details(a, plan->loaded.scenario, done.runs, metrics.front(), table);
  if (a.out) write_run_files(a, names, table, *plan, driver, done, prediction, streamed, files);
  if (stop_signal() != 0) return stop_exit_code();
  return files.write_failed ? kRunFailure : kOk;
}

void add_common(CLI::App* cmd, RunArgs& a) {
  cmd->add_option("scenario", a.scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--profile", a.scenario.profile,
                  "Profile JSON (default: the scenario's, else built-in)");
  cmd->add_option("--set", a.scenario.sets,
                  "Override key=value (deadline_scale, rate_scale, qoe_lambda, ...)");
  cmd->add_option("--seed", a.seed, "Random seed (default: the scenario's)")->check(whole_number());
  cmd->add_option("--out", a.out,
                  "Directory for summary.json, jobs.csv, units.csv, trace.json and plots");
  add_with_option(cmd, a.scenario);
  cmd->add_option("--costs", a.costs,
                  "Simulator only: draw unit costs from this profile (e.g. a calibration, "
                  "docs/FIDELITY.md) while the scheduler plans with --profile");
  cmd->add_option("--sync", a.sync,
                  "Synchronization: per-edge or on-demand (default: each policy's own; "
                  "docs/DESIGN.md#synchronization)")
      ->check(CLI::IsMember({"per-edge", "on-demand"}));
  cmd->add_option("--trace-events", a.trace_events,
                  "Most events in trace.json, over all policies (0: no trace.json)")
      ->check(whole_number())
      ->capture_default_str();
  cmd->add_option("--timeline", a.timeline,
                  "Window of the timeline drawn under --out, FROM:TO in seconds (default: the "
                  "first 2 s after the warm-up and the 2 s around the worst miss)");
  cmd->add_flag("--phases", a.phases,
                "Print jobs, miss and drop rate, QoE and latency per workload phase");
}

void add_real(CLI::App* cmd, RunArgs& a) {
  add_device_options(cmd, a.real);
  cmd->add_flag("--no-realtime", a.no_realtime, "Do not try SCHED_FIFO, CPU affinity, mlockall");
  cmd->add_option("--watchdog-x", a.real.watchdog_x,
                  "Fail a unit running past this many times its profiled p99 with the reason "
                  "'timeout' (0: no watchdog)")
      ->check(finite_non_negative())
      ->capture_default_str();
  cmd->add_option("--write-profile", a.write_profile,
                  "Write the costs this run's units met (after the warm-up) as a calibrated "
                  "profile, the next run's --profile: the run's profile with their in-run "
                  "figures and the simulator's model of the run (docs/FIDELITY.md)");
}

}  // namespace red::cli
