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

#include "commands.hpp"
#include "common.hpp"
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

// A calibration of one policy's run from its own units (docs/FIDELITY.md, "The run's own
// costs"): what every unit of that policy cost in this run, the machine's stretches and the
// hand-offs the runtime timed. The simulator drawing from it predicts the run without the
// machine's drift between the calibration and the run, so the two predictions side by side
// tell the simulator's own error from the machine's. nullopt where the run kept no units
// (no --out) or completed too few model units to fit (plain nodes cost what the scenario says).
std::optional<Profile> run_costs(const Scenario& s, const Profile& p, const PolicyRun& r,
                                 const Handoffs& handoffs, std::optional<SyncMode> sync) {
  CalibrationRun run = calibration_run(s, r.metrics.name, r.units, handoffs.handoff_us, sync);
  run.queued_gap_us = handoffs.queued_gap_us;
  if (run.units.empty()) return std::nullopt;
  auto c = calibrate_profile(p, s, {std::move(run)});
  if (!c) return std::nullopt;
  return std::move(c).value();
}

// The simulator's prediction of a real run, side by side with it (same scenario, same
// profile): how well the simulator, fed the measured profile, predicts reality. With a
// calibrated profile the prediction is random like the run (the machine's slow stretches
// are replayed from the calibration), so it is given over several seeds: the median and
// the range. Where the runs kept their units (--out), a second table predicts each policy
// from the costs its own units met in the run (run_costs). Returns prediction.json's text;
// `html` gets the same tables for index.html.
std::string print_prediction(const Scenario& s, const Profile& p, std::uint64_t seed,
                             const std::vector<PolicyRun>& real,
                             const std::vector<Handoffs>& handoffs, std::optional<SyncMode> sync,
                             std::vector<HtmlTable>& html) {
  constexpr int kCalibratedSeeds = 5;
  const int seeds = p.calibration ? kCalibratedSeeds : 1;
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 == 1 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  // Miss %, mean latency and QoE of `n` seeds of the simulator, costs drawn from `costs`
  // (nullptr: the profile the scheduler plans with).
  struct Predicted {
    std::vector<double> miss, mean, qoe;
  };
  auto predict = [&](const std::string& policy, int n, const Profile* costs) {
    Predicted out;
    for (int k = 0; k < n; ++k) {
      auto sim = simulate_policy(s, p, policy, seed + static_cast<std::uint64_t>(k), {}, false,
                                 sync, costs);
      if (!sim) break;
      out.miss.push_back(100 * sim->metrics.miss_rate);
      out.mean.push_back(sim->metrics.latency.mean);
      out.qoe.push_back(sim->metrics.qoe);
    }
    return out;
  };
  auto range = [&](const std::vector<double>& v, int n, const char* f) {
    const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
    return n > 1 ? fmt::format(fmt::runtime(std::string(f) + " [" + f + "-" + f + "]"), median(v),
                               *lo, *hi)
                 : fmt::format(fmt::runtime(f), v.front());
  };
  auto to_json = [&](const Predicted& x) {
    const auto [mlo, mhi] = std::minmax_element(x.miss.begin(), x.miss.end());
    const auto [llo, lhi] = std::minmax_element(x.mean.begin(), x.mean.end());
    return nlohmann::ordered_json{{"miss_pct", median(x.miss)}, {"miss_pct_min", *mlo},
                                  {"miss_pct_max", *mhi},       {"mean_ms", median(x.mean)},
                                  {"mean_ms_min", *llo},        {"mean_ms_max", *lhi},
                                  {"qoe", median(x.qoe)}};
  };
  auto print_header = [] {
    fmt::print("{:<10} {:>10} {:>20} {:>12} {:>22} {:>8} {:>8}\n", "policy", "miss% real",
               "miss% sim", "mean ms real", "mean ms sim", "QoE real", "QoE sim");
  };
  // One row, printed and kept for index.html: the same cells in both.
  auto print_row = [&](const PolicyRun& r, const Predicted& x, int n, HtmlTable& t) {
    std::vector<std::string> c{r.metrics.name,
                               fmt::format("{:.2f}", 100 * r.metrics.miss_rate),
                               range(x.miss, n, "{:.2f}"),
                               fmt::format("{:.2f}", r.metrics.latency.mean),
                               range(x.mean, n, "{:.2f}"),
                               fmt::format("{:.3f}", r.metrics.qoe),
                               fmt::format("{:.3f}", median(x.qoe))};
    fmt::print("{:<10} {:>10} {:>20} {:>12} {:>22} {:>8} {:>8}\n", c[0], c[1], c[2], c[3], c[4],
               c[5], c[6]);
    t.rows.push_back(std::move(c));
  };
  auto table = [](std::string caption) {
    return HtmlTable{std::move(caption),
                     {"policy", "miss % real", "miss % sim", "mean ms real", "mean ms sim",
                      "QoE real", "QoE sim"},
                     {}};
  };

  const std::string over = seeds > 1 ? fmt::format(", median [min-max] of {} seeds", seeds) : "";
  fmt::print("simulator prediction with the same profile ({}{}):\n", p.source, over);
  print_header();
  HtmlTable ahead = table(fmt::format(
      "Simulator's prediction of these runs with the same profile ({}{}; docs/FIDELITY.md)",
      p.source, over));
  nlohmann::ordered_json doc;
  doc["scenario"] = s.name;
  doc["profile"] = p.source;
  doc["seeds"] = seeds;
  nlohmann::ordered_json policies = nlohmann::ordered_json::array();
  std::vector<std::optional<Predicted>> own(real.size());
  for (std::size_t i = 0; i < real.size(); ++i) {
    const PolicyRun& r = real[i];
    const Predicted x = predict(r.metrics.name, seeds, nullptr);
    if (x.miss.empty()) continue;
    print_row(r, x, seeds, ahead);
    nlohmann::ordered_json row{{"policy", r.metrics.name},
                               {"real",
                                {{"miss_pct", 100 * r.metrics.miss_rate},
                                 {"mean_ms", r.metrics.latency.mean},
                                 {"qoe", r.metrics.qoe}}},
                               {"sim", to_json(x)}};
    static const Handoffs kNone;
    if (const auto c = run_costs(s, p, r, i < handoffs.size() ? handoffs[i] : kNone, sync)) {
      Predicted y = predict(r.metrics.name, kCalibratedSeeds, &*c);
      if (!y.miss.empty()) {
        row["sim_run_costs"] = to_json(y);
        own[i] = std::move(y);
      }
    }
    policies.push_back(std::move(row));
  }
  html.push_back(std::move(ahead));
  if (std::any_of(own.begin(), own.end(), [](const auto& x) { return x.has_value(); })) {
    HtmlTable t = table(fmt::format(
        "Simulator fed the costs each policy's units met in this run: the model apart from the "
        "machine's drift since the profile was measured (median [min-max] of {} seeds; "
        "docs/FIDELITY.md, \"The run's own costs\")",
        kCalibratedSeeds));
    fmt::print(
        "simulator with the costs each policy's units met in this run (the model without the "
        "machine's drift, median [min-max] of {} seeds):\n",
        kCalibratedSeeds);
    print_header();
    for (std::size_t i = 0; i < real.size(); ++i)
      if (own[i]) print_row(real[i], *own[i], kCalibratedSeeds, t);
    html.push_back(std::move(t));
  }
  doc["policies"] = std::move(policies);
  return doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

// What differs between running the policies in the simulator and on a real backend (the
// real-time runtime); run_policies chooses one of the two once (make_driver) and does the rest
// the same way for both.
class Driver {
 public:
  virtual ~Driver() = default;
  /// The lanes are asynchronous (they hold a queue of units).
  [[nodiscard]] virtual bool asynchronous() const { return false; }
  /// Rows are streamed to jobs.csv and units.csv as jobs end (set_rows), not kept in memory.
  [[nodiscard]] virtual bool streams_rows() const { return false; }
  virtual void set_rows(RowSink* /*rows*/) {}
  /// The backend in the table's heading, and in summary.json.
  [[nodiscard]] virtual std::string heading_name() const = 0;
  [[nodiscard]] virtual std::string summary_name() const = 0;
  /// Said on stderr before policy `i` of `count` starts.
  virtual void announce(const std::string& /*policy*/, std::size_t /*i*/, std::size_t /*count*/) {}
  virtual Expected<PolicyRun> run(const std::string& policy, const std::vector<Observer*>& extra,
                                  bool keep_units) = 0;
  /// The exit code when a run fails.
  [[nodiscard]] virtual int failure_code() const = 0;
  /// After `policy` ran: its line on stderr, and what is kept of it for later.
  virtual void finished(const std::string& policy, const PolicyRun& r) = 0;
  /// The simulator's prediction of the runs, printed (prediction.json's text; "": none).
  virtual std::string predict(const std::vector<PolicyRun>& /*runs*/,
                              std::vector<HtmlTable>& /*html*/) {
    return {};
  }
  /// The files write_more writes (index.html links them).
  virtual void more_files(OutputOptions& /*o*/, const std::string& /*prediction*/) const {}
  /// Writes the files besides write_outputs' through `put(name, text)`.
  virtual void write_more(
      const std::vector<std::string>& /*names*/, const std::string& /*prediction*/,
      const std::string& /*run_id*/,
      const std::function<void(const std::string&, const std::string&)>& /*put*/) const {}
};

// The simulator: the same releases and the same sampled unit times for every policy.
class SimDriver final : public Driver {
 public:
  SimDriver(const Scenario& s, const Profile& p, std::uint64_t seed, std::optional<SyncMode> sync,
            std::optional<Profile> costs)
      : s_(s), p_(p), seed_(seed), sync_(sync), costs_(std::move(costs)) {}
  [[nodiscard]] std::string heading_name() const override { return "sim"; }
  [[nodiscard]] std::string summary_name() const override { return "sim"; }
  Expected<PolicyRun> run(const std::string& policy, const std::vector<Observer*>& extra,
                          bool keep_units) override {
    return simulate_policy(s_, p_, policy, seed_, extra, keep_units, sync_,
                           costs_ ? &*costs_ : nullptr);
  }
  [[nodiscard]] int failure_code() const override { return kBadInput; }
  void finished(const std::string& policy, const PolicyRun& r) override {
    std::cerr << fmt::format(
        "red: simulated {} on {} in {:.3f} s ({:.2f} M unit events/s)\n", policy, s_.name, r.wall_s,
        static_cast<double>(r.result.unit_events) / std::max(r.wall_s, 1e-9) / 1e6);
  }

 private:
  const Scenario& s_;
  const Profile& p_;
  std::uint64_t seed_;
  std::optional<SyncMode> sync_;
  std::optional<Profile> costs_;  ///< --costs: the unit costs drawn from
};

// A real backend: one backend (one loaded model) serves every policy, each in turn for the
// scenario's duration, on the same releases.
class RealDriver final : public Driver {
 public:
  RealDriver(const Scenario& s, const Profile& p, std::uint64_t seed, std::string backend_name,
             RealRunOptions real, std::unique_ptr<Backend> backend)
      : s_(s),
        p_(p),
        seed_(seed),
        backend_name_(std::move(backend_name)),
        real_(std::move(real)),
        backend_(std::move(backend)) {}
  [[nodiscard]] bool asynchronous() const override { return backend_->asynchronous(); }
  [[nodiscard]] bool streams_rows() const override { return true; }
  void set_rows(RowSink* rows) override { real_.rows = rows; }
  [[nodiscard]] std::string heading_name() const override { return std::string(backend_->name()); }
  [[nodiscard]] std::string summary_name() const override { return backend_name_; }
  void announce(const std::string& policy, std::size_t i, std::size_t count) override {
    if (count <= 1) return;
    // A real compare takes the scenario's duration per policy: say which one runs, also
    // off a terminal (where the progress line is not drawn).
    real_.label = fmt::format("{} ({} of {})", policy, i + 1, count);
    std::cerr << fmt::format("red: policy {}: running for {:g} s (warm-up {:g} s)\n", real_.label,
                             to_s(s_.duration), to_s(s_.warmup));
  }
  Expected<PolicyRun> run(const std::string& policy, const std::vector<Observer*>& extra,
                          bool /*keep_units*/) override {
    report_ = {};
    return run_real(s_, p_, policy, *backend_, real_, extra, &report_);
  }
  [[nodiscard]] int failure_code() const override { return kRunFailure; }
  void finished(const std::string& policy, const PolicyRun& /*r*/) override {
    print_runtime_report(policy, report_);
    // Only the samples are needed later (rss.csv): the timing samples go now, so a
    // compare of many policies does not keep them all; the hand-offs feed the prediction
    // from the run's own costs.
    report_.decision_us = {};
    handoffs_.push_back({std::move(report_.handoff_us), std::move(report_.queued_gap_us)});
    report_.handoff_us = {};
    report_.queued_gap_us = {};
    report_.frame_release_us = {};
    report_.release_late_us = {};
    reports_.push_back(std::move(report_));
  }
  std::string predict(const std::vector<PolicyRun>& runs, std::vector<HtmlTable>& html) override {
    return print_prediction(s_, p_, seed_, runs, handoffs_, real_.sync, html);
  }
  void more_files(OutputOptions& o, const std::string& prediction) const override {
    o.more_files.emplace_back("rss.csv");
    if (!prediction.empty()) o.more_files.emplace_back("prediction.json");
  }
  void write_more(
      const std::vector<std::string>& names, const std::string& prediction,
      const std::string& run_id,
      const std::function<void(const std::string&, const std::string&)>& put) const override {
    put("rss.csv", samples_csv(names, reports_));
    if (!prediction.empty()) {
      // The run id, where the format has room for it (docs/REPORTS.md).
      auto doc = nlohmann::ordered_json::parse(prediction);
      doc["run_id"] = run_id;
      put("prediction.json",
          doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
    }
  }

 private:
  const Scenario& s_;
  const Profile& p_;
  std::uint64_t seed_;
  std::string backend_name_;  ///< as asked (--backend), for summary.json
  RealRunOptions real_;
  std::unique_ptr<Backend> backend_;
  RuntimeReport report_;                // the run in progress: what the runtime measured
  std::vector<RuntimeReport> reports_;  // what the runtime measured, per policy
  std::vector<Handoffs> handoffs_;      // the hand-offs timed (a bounded sample), per policy
};

// The driver for `a.backend`, or the error that stops the command before any run (exit 2).
Expected<std::unique_ptr<Driver>> make_driver(const RunArgs& a, const Scenario& s, const Profile& p,
                                              std::uint64_t seed, RealRunOptions real) {
  if (a.backend == "sim") {
    std::optional<Profile> costs;
    if (a.costs) {
      auto c = load_profile(*a.costs);
      if (!c) return c.error();
      if (auto e = check_profile_covers(*c, s)) return *e;
      costs = std::move(*c);
    }
    return std::unique_ptr<Driver>(
        std::make_unique<SimDriver>(s, p, seed, real.sync, std::move(costs)));
  }
  if (a.costs)
    return Error{"", 0,
                 "--costs is for the simulator (--backend sim); a real run's costs "
                 "are the machine's"};
  if (real.watchdog_x > 0 && p.source == "builtin-default")
    std::cerr << "red: warning: watchdog limits come from the built-in profile, not one "
                 "measured here; measure one (red profile) or turn it off (--watchdog-x 0)\n";
  auto b = make_backend(s, p, real);
  if (!b) return b.error();
  return std::unique_ptr<Driver>(
      std::make_unique<RealDriver>(s, p, seed, a.backend, std::move(real), std::move(b.value())));
}

}  // namespace

// Runs the given policies on one scenario and prints and writes the results. In the
// simulator every policy sees the same releases and the same sampled unit times (common
// random numbers, docs/DESIGN.md, "Metrics"); on a real backend the same releases. Returns the
// exit code.
int run_policies(const RunArgs& a, const std::vector<std::string>& names, bool table,
                 const char* command) {
  install_stop_signals();
  {
    // The device first: a device that is not there is an error, never a CPU run.
    RealRunOptions asked = a.real;
    asked.backend = a.backend;
    if (auto e = check_device(asked)) {
      print_error(*e);
      return kBadInput;
    }
  }
  auto loaded = load_with_profile(a.scenario);
  if (!loaded) return kBadInput;
  Scenario& s = loaded->scenario;
  const Profile& p = loaded->profile;
  for (const std::string& n : names) {
    if (!make_policy(n)) {
      std::string known;
      for (const std::string& k : known_policies()) known += (known.empty() ? "" : ", ") + k;
      print_error(Error{"", 0, "unknown policy '" + n + "' (known: " + known + ")"});
      return kBadInput;
    }
  }
  std::optional<std::pair<Duration, Duration>> timeline;
  if (a.timeline) {
    auto w = parse_timeline_window(*a.timeline);
    if (!w) {
      print_error(w.error());
      return kBadInput;
    }
    if (!a.out) {
      print_error(Error{"", 0, "--timeline: the timeline is drawn into --out DIR; give --out"});
      return kBadInput;
    }
    if (w->first >= s.duration) {
      print_error(Error{"", 0,
                        fmt::format("--timeline: FROM ({:g} s) is not before the end of the run "
                                    "({:g} s, duration_s)",
                                    to_s(w->first), to_s(s.duration))});
      return kBadInput;
    }
    timeline = *w;
  }
  const std::uint64_t seed = a.seed ? *a.seed : s.seed;
  RealRunOptions real = a.real;
  real.backend = a.backend;
  real.realtime = !a.no_realtime;
  real.seed = seed;
  real.sync = parse_sync(a.sync);
  real.keep_units = a.out.has_value();  // units.csv and the plots are written only with --out
  // A real run streams its rows to jobs.csv and units.csv as jobs end, so that its memory
  // does not grow with its length (docs/REPORTS.md, "Streamed rows"); without --out only
  // the summary's bounded state is kept (the rows too for --phases).
  real.keep_rows = !a.out && a.phases;
  auto made = make_driver(a, s, p, seed, real);
  if (!made) {
    print_error(made.error());
    return kBadInput;
  }
  Driver& driver = *made.value();
  // Asynchronous lanes (--async, or a GPU) hold the scenario's queue depth, 2 unless it sets
  // one: the scheduler, the simulator and the prediction beside a real run all plan so.
  if ((a.real.asynchronous || driver.asynchronous()) && !s.device.queue_depth)
    s.device.queue_depth = 2;
  // The output directory's old manifest goes before anything else is written, so that the
  // files of an earlier run are never taken for this run's (docs/REPORTS.md).
  std::optional<OutputSet> set;
  if (a.out) {
    auto begun = OutputSet::begin(*a.out, command);
    if (!begun) {
      print_error(begun.error());
      return kRunFailure;
    }
    set = std::move(begun.value());
  }
  // A file that fails is reported as it fails and at the end; the run and the other files
  // go on, and the exit code is 1.
  bool write_failed = false;
  auto failed = [&](const Error& e) {
    print_error(e);
    if (set) set->fail(e);
    write_failed = true;
  };
  std::unique_ptr<CsvRowStream> stream;
  std::optional<RowQueue> queue;
  if (driver.streams_rows() && a.out) {
    auto st = CsvRowStream::open(*a.out, s, true);
    if (!st) {
      failed(st.error());
      return kRunFailure;
    }
    stream = std::move(st.value());
    if (auto e = stream->flush()) {
      // No room even for the headers (a full disk): said now, and the runs go on.
      failed(*e);
      std::cerr << "red: the runs go on; the table and summary.json follow at the end\n";
    }
    // Rows are formatted and written on the queue's thread, not on the lane that reports
    // them between one unit and the next (the hand-off, docs/BENCHMARKS.md).
    queue.emplace(*stream);
    driver.set_rows(&*queue);
  }
  std::vector<PolicyRun> runs;
  // Observers beside the metrics: the timeline (only when it will be written) and the
  // progress line (only on a terminal, only for runs longer than a few seconds).
  std::vector<std::unique_ptr<TraceObserver>> traces;
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
    if (stream) stream->begin_policy(n);
    auto r = driver.run(n, extra, a.out.has_value());
    progress.finish();
    if (!r && stop_signal() != 0) break;  // a simulation ended by the signal: left out
    if (!r) {
      print_error(r.error());
      return driver.failure_code();
    }
    if (queue) queue->drain();
    if (stream && !write_failed)
      if (auto e = stream->flush()) {
        // The file stops there; the runs go on, and the table and the summary are still
        // given at the end.
        failed(*e);
        std::cerr << "red: the runs go on; the table and summary.json follow at the end\n";
      }
    driver.finished(n, *r);
    if (traces.back() && traces.back()->truncated())
      std::cerr << fmt::format(
          "red: trace of {} stops at {:.3f} s (limit of {} events; see --trace-events)\n", n,
          to_s(traces.back()->truncated_at()), traces.back()->events());
    runs.push_back(std::move(r.value()));
  }
  if (stop_signal() != 0) {
    // A run stopped during its warm-up measured nothing: say so rather than show 0 jobs.
    const bool measured = std::any_of(runs.begin(), runs.end(),
                                      [](const PolicyRun& r) { return r.metrics.jobs > 0; });
    std::cerr << fmt::format("red: stopped by {} after {} of {} run(s){}\n", stop_signal_name(),
                             runs.size(), names.size(),
                             runs.empty() ? ""
                             : !measured  ? "; nothing was measured (stopped during the warm-up)"
                             : a.out      ? "; writing what they measured"
                                          : "");
    if (runs.empty()) return stop_exit_code();
  }
  std::vector<std::string> streamed;  // the streamed files renamed into place
  if (stream) {
    // The report's rows: the window kept in memory, or read back from the streamed files.
    // Without them (a file failed) the summary and the table still come from the metrics.
    auto rows = stream->rows();
    if (!rows) {
      if (!write_failed)
        failed(rows.error());
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
    const bool before = write_failed;
    if (auto e = stream->finish(); e && !before) failed(*e);
    streamed = stream->finished();
  }
  std::vector<PolicyMetrics> metrics;
  for (const PolicyRun& r : runs) metrics.push_back(r.metrics);
  apply_ratios(metrics, "edf");
  fmt::print("scenario {} (backend {}, seed {}, profile {}, {} lane(s), {:g} s measured)\n", s.name,
             driver.heading_name(), seed, p.source, s.device.lanes, metrics.front().measured_s);
  fmt::print("{}", comparison_table(metrics, "edf"));
  fmt::print("{}", releases_table(metrics));
  std::string prediction;
  std::vector<HtmlTable> prediction_html;
  if (stop_signal() == 0) prediction = driver.predict(runs, prediction_html);
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
    const PolicyMetrics& m = metrics.front();
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
  if (a.out) {
    OutputOptions o;
    for (const auto& t : traces) o.traces.push_back(t.get());
    o.index_html = table;  // red compare
    if (table) {
      // The verdicts of `red analyze` (without its headroom search) at the top of the page.
      std::vector<Analysis> verdicts;
      for (const PolicyRun& r : runs) {
        AnalysisOptions ao;
        ao.policy = r.metrics.name;
        ao.headroom = false;
        if (auto an = analyze(s, p, ao)) verdicts.push_back(std::move(an).value());
      }
      o.verdicts = verdict_html_table(verdicts);
      o.prediction = std::move(prediction_html);
    }
    o.timeline = timeline;
    driver.more_files(o, prediction);
    o.rows_written = stream != nullptr;
    o.rows_files = streamed;
    o.set = &*set;
    OutputReport written;
    (void)write_outputs(*a.out, s, p, driver.summary_name(), seed, runs, o, &written);
    for (const Error& e : written.errors) print_error(e);
    write_failed = write_failed || !written.errors.empty();
    auto put = [&](const std::string& name, const std::string& text) {
      if (auto e = write_file(*a.out, name, text))
        failed(*e);
      else
        set->add(name);
    };
    driver.write_more(names, prediction, set->run_id(), put);
    if (stop_signal() != 0) set->stopped(stop_signal_name());
    // Last: the manifest that marks the files as this run's complete set.
    const std::optional<Error> manifest = set->finish();
    if (manifest) failed(*manifest);
    fmt::print("{}{}\n", wrote_message(*a.out, written), manifest ? "" : ", manifest.json");
    if (write_failed)
      std::cerr << fmt::format(
          "red: not every file could be written into {} (errors above): the result there is "
          "not complete\n",
          *a.out);
  }
  if (stop_signal() != 0) return stop_exit_code();
  return write_failed ? kRunFailure : kOk;
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
}

}  // namespace red::cli
