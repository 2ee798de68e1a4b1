/// \file
/// The two drivers of run_policies (drivers.hpp): the simulator, and a real backend with the
/// simulator's prediction of its runs beside them.

#include "drivers.hpp"

#include "commands.hpp"
#include "prediction_check.hpp"

#include <algorithm>
#include <iostream>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "red/calibrate/calibrate.hpp"

namespace red::cli {

namespace {

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

constexpr int kCalibratedSeeds = 5;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 == 1 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Miss %, mean latency and QoE of seeds of the simulator.
struct Predicted {
  std::vector<double> miss, mean, qoe;
};

// What the simulator predicts the runs with: the scenario and the profile the scheduler plans
// with, the first seed, the synchronization.
struct PredictionInput {
  const Scenario& s;
  const Profile& p;
  std::uint64_t seed;
  std::optional<SyncMode> sync;
};

// `n` seeds of the simulator running `policy`, costs drawn from `costs` (nullptr: the profile the
// scheduler plans with).
Predicted predict(const PredictionInput& in, const std::string& policy, int n,
                  const Profile* costs) {
  Predicted out;
  for (int k = 0; k < n; ++k) {
    auto sim = simulate_policy(in.s, in.p, policy, in.seed + static_cast<std::uint64_t>(k), {},
                               false, in.sync, costs);
    if (!sim) break;
    out.miss.push_back(100 * sim->metrics.miss_rate);
    out.mean.push_back(sim->metrics.latency.mean);
    out.qoe.push_back(sim->metrics.qoe);
  }
  return out;
}

// The median [min-max] of `v` over n > 1 seeds, else its one value; each in format `f`.
std::string range(const std::vector<double>& v, int n, const char* f) {
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return n > 1 ? fmt::format(fmt::runtime(std::string(f) + " [" + f + "-" + f + "]"), median(v),
                             *lo, *hi)
               : fmt::format(fmt::runtime(f), v.front());
}

nlohmann::ordered_json predicted_json(const Predicted& x) {
  const auto [mlo, mhi] = std::minmax_element(x.miss.begin(), x.miss.end());
  const auto [llo, lhi] = std::minmax_element(x.mean.begin(), x.mean.end());
  return nlohmann::ordered_json{{"miss_pct", median(x.miss)}, {"miss_pct_min", *mlo},
                                {"miss_pct_max", *mhi},       {"mean_ms", median(x.mean)},
                                {"mean_ms_min", *llo},        {"mean_ms_max", *lhi},
                                {"qoe", median(x.qoe)}};
}

void print_header() {
  fmt::print("{:<10} {:>10} {:>20} {:>12} {:>22} {:>8} {:>8}\n", "policy", "miss% real",
             "miss% sim", "mean ms real", "mean ms sim", "QoE real", "QoE sim");
}

// One row, printed and kept for index.html: the same cells in both.
void print_row(const PolicyRun& r, const Predicted& x, int n, HtmlTable& t) {
  std::vector<std::string> c{r.metrics.name,
                             fmt::format("{:.2f}", 100 * r.metrics.miss_rate),
                             range(x.miss, n, "{:.2f}"),
                             fmt::format("{:.2f}", r.metrics.latency.mean),
                             range(x.mean, n, "{:.2f}"),
                             fmt::format("{:.3f}", r.metrics.qoe),
                             fmt::format("{:.3f}", median(x.qoe))};
  fmt::print("{:<10} {:>10} {:>20} {:>12} {:>22} {:>8} {:>8}\n", c[0], c[1], c[2], c[3], c[4], c[5],
             c[6]);
  t.rows.push_back(std::move(c));
}

HtmlTable prediction_table(std::string caption) {
  return HtmlTable{
      std::move(caption),
      {"policy", "miss % real", "miss % sim", "mean ms real", "mean ms sim", "QoE real", "QoE sim"},
      {}};
}

// The second table: each policy predicted from the costs its own units met in the run (`own`,
// none where the run kept too few units), printed and into `html`.
void print_own_costs(const std::vector<PolicyRun>& real,
                     const std::vector<std::optional<Predicted>>& own,
                     std::vector<HtmlTable>& html) {
  HtmlTable t = prediction_table(fmt::format(
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
  const PredictionInput in{s, p, seed, sync};
  const int seeds = p.calibration ? kCalibratedSeeds : 1;
  const std::string over = seeds > 1 ? fmt::format(", median [min-max] of {} seeds", seeds) : "";
  fmt::print("simulator prediction with the same profile ({}{}):\n", p.source, over);
  print_header();
  HtmlTable ahead = prediction_table(fmt::format(
      "Simulator's prediction of these runs with the same profile ({}{}; docs/FIDELITY.md)",
      p.source, over));
  nlohmann::ordered_json doc;
  doc["scenario"] = s.name;
  doc["profile"] = p.source;
  doc["seeds"] = seeds;
  nlohmann::ordered_json policies = nlohmann::ordered_json::array();
  std::vector<std::optional<Predicted>> own(real.size());
  std::vector<PredictionCheck> checks;
  for (std::size_t i = 0; i < real.size(); ++i) {
    const PolicyRun& r = real[i];
    const Predicted x = predict(in, r.metrics.name, seeds, nullptr);
    if (x.miss.empty()) continue;
    print_row(r, x, seeds, ahead);
    checks.push_back({r.metrics.name,
                      prediction_gap(100 * r.metrics.miss_rate, r.metrics.latency.mean,
                                     median(x.miss), median(x.mean)),
                      std::nullopt, std::nullopt});
    if (const CostDrift d = cost_drift({&r.metrics}); d.runs > 0)
      checks.back().unit_ratio = d.ratio;
    nlohmann::ordered_json row{{"policy", r.metrics.name},
                               {"real",
                                {{"miss_pct", 100 * r.metrics.miss_rate},
                                 {"mean_ms", r.metrics.latency.mean},
                                 {"qoe", r.metrics.qoe}}},
                               {"sim", predicted_json(x)}};
    static const Handoffs kNone;
    if (const auto c = run_costs(s, p, r, i < handoffs.size() ? handoffs[i] : kNone, sync)) {
      Predicted y = predict(in, r.metrics.name, kCalibratedSeeds, &*c);
      if (!y.miss.empty()) {
        row["sim_run_costs"] = predicted_json(y);
        checks.back().own = prediction_gap(100 * r.metrics.miss_rate, r.metrics.latency.mean,
                                           median(y.miss), median(y.mean));
        own[i] = std::move(y);
      }
    }
    policies.push_back(std::move(row));
  }
  html.push_back(std::move(ahead));
  if (std::any_of(own.begin(), own.end(), [](const auto& x) { return x.has_value(); }))
    print_own_costs(real, own, html);
  doc["policies"] = std::move(policies);
  std::vector<const PolicyMetrics*> all;
  for (const PolicyRun& r : real) all.push_back(&r.metrics);
  fmt::print("{}", prediction_check(checks, cost_drift(all), html, doc));
  return doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

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
  [[nodiscard]] Expected<Profile> own_costs_profile(
      const std::vector<PolicyRun>& runs) const override {
    return run_profile(s_, p_, runs, handoffs_, real_.sync);
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

}  // namespace

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
  if (auto note = profile_origin_note(s, p, real)) std::cerr << "red: note: " << *note << '\n';
  return std::unique_ptr<Driver>(
      std::make_unique<RealDriver>(s, p, seed, a.backend, std::move(real), std::move(b.value())));
}

}  // namespace red::cli
