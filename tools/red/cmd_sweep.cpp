/// \file
/// `red sweep S.yaml --set key=a:b:step | key=v1,v2,...`: the paper's Tables 4 and 5.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "red/analysis/workload.hpp"
#include "red/core/clock.hpp"
#include "red/observe/progress.hpp"
#include "red/report/html.hpp"
#include "red/report/plots.hpp"
#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"
#include "signals.hpp"

namespace red::cli {

namespace {

struct SweepArgs {
  ScenarioArgs scenario;
  std::string sweep;
  std::string policies;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
};

// The most values one sweep runs (each a simulation of every policy).
constexpr std::size_t kMaxSweepValues = 10000;

// Parses "key=a:b:step" or "key=v1,v2,..." into key and values.
Expected<std::pair<std::string, std::vector<double>>> parse_sweep(const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0)
    return Error{"", 0, "--set '" + spec + "': expected key=a:b:step or key=v1,v2"};
  const std::string key = spec.substr(0, eq);
  const std::string rest = spec.substr(eq + 1);
  std::vector<double> values;
  auto number = [&](const std::string& t, double& v) {
    const std::optional<double> x = decimal_number(t);
    if (x) v = *x;
    return x.has_value();
  };
  if (rest.find(':') != std::string::npos) {
    std::vector<std::string> parts;
    std::size_t from = 0;
    for (std::size_t i = 0; i <= rest.size(); ++i)
      if (i == rest.size() || rest[i] == ':') {
        parts.push_back(rest.substr(from, i - from));
        from = i + 1;
      }
    double a = 0, b = 0, step = 0;
    if (parts.size() != 3 || !number(parts[0], a) || !number(parts[1], b) ||
        !number(parts[2], step) || step <= 0 || b < a)
      return Error{"", 0,
                   "--set " + key +
                       ": expected a:b:step, finite decimal numbers with a <= b and "
                       "step > 0"};
    if ((b - a) / step + 1 > kMaxSweepValues)
      return Error{"", 0,
                   fmt::format("--set {}: {}:{}:{} gives more than {} values", key, parts[0],
                               parts[1], parts[2], kMaxSweepValues)};
    for (int i = 0;; ++i) {
      const double v = a + step * i;
      if (v > b + step * 1e-9) break;
      values.push_back(std::round(v * 1e9) / 1e9);
    }
  } else {
    for (const std::string& t : split_list(rest)) {
      double v = 0;
      if (!number(t, v)) return Error{"", 0, "--set " + key + ": '" + t + "' is not a number"};
      values.push_back(v);
    }
    if (values.size() > kMaxSweepValues)
      return Error{"", 0, fmt::format("--set {}: more than {} values", key, kMaxSweepValues)};
  }
  if (values.empty()) return Error{"", 0, "--set " + key + ": no values"};
  return std::pair{key, values};
}

// docs/DESIGN.md, "Performance targets"'s breakdown rate of one policy over a rate_scale sweep: the
// largest swept scale up to which (every smaller swept scale included) the miss rate stays within
// the limit.
struct Breakdown {
  std::optional<double> scale;  // none: the smallest swept scale already misses more
  bool censored = false;        // no swept scale missed more: the rate is at least `scale`
  double first_over = 0;        // the first scale past it, and its miss rate
  double first_over_miss = 0;
};

constexpr double kBreakdownMiss = 0.01;

Breakdown breakdown_of(const std::vector<double>& values, const std::vector<PolicyMetrics>& m) {
  std::vector<std::size_t> order(values.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](auto x, auto y) { return values[x] < values[y]; });
  Breakdown b;
  for (std::size_t k : order) {
    if (m[k].miss_rate > kBreakdownMiss) {
      b.first_over = values[k];
      b.first_over_miss = m[k].miss_rate;
      return b;
    }
    b.scale = values[k];
  }
  b.censored = b.scale.has_value();
  return b;
}

}  // namespace

void register_sweep(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<SweepArgs>();
  CLI::App* cmd =
      app.add_subcommand("sweep", "Run policies over a range of one parameter (paper Tables 4, 5)");
  cmd->add_option("scenario", a->scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--set", a->sweep,
                  "key=a:b:step or key=v1,v2,... (deadline_scale, qoe_lambda, rate_scale, ...)")
      ->required();
  cmd->add_option("--policies", a->policies, "Comma-separated presets (default: all)");
  cmd->add_option("--profile", a->scenario.profile, "Profile JSON");
  cmd->add_option("--seed", a->seed, "Random seed (default: the scenario's)")
      ->check(whole_number());
  cmd->add_option("--out", a->out, "Directory for sweep.json, sweep.csv, plots and index.html");
  add_with_option(cmd, a->scenario);
  cmd->callback([a, &exit_code] {
    install_stop_signals();
    auto sw = parse_sweep(a->sweep);
    if (!sw) {
      print_error(sw.error());
      exit_code = kBadInput;
      return;
    }
    auto loaded = load_with_profile(a->scenario);
    if (!loaded) {
      exit_code = kBadInput;
      return;
    }
    Scenario& base = loaded->scenario;
    const Profile& p = loaded->profile;
    const auto names = a->policies.empty() ? default_presets() : split_list(a->policies);
    for (const std::string& n : names)
      if (!make_policy(n)) {
        print_error(Error{"", 0, unknown_policy_message(n)});
        exit_code = kBadInput;
        return;
      }
    const auto& [key, all_values] = sw.value();
    std::vector<double> values;  // the values every policy ran at (all, unless stopped)
    const std::uint64_t seed = a->seed ? *a->seed : base.seed;
    // results[policy][value]
    std::vector<std::vector<PolicyMetrics>> results(names.size());
    const SteadyClock clock;
    ProgressReporter progress(clock, std::cerr, ProgressReporter::stderr_is_terminal());
    const std::size_t total = all_values.size() * names.size();
    std::size_t done = 0;
    std::cerr << fmt::format(
        "red: sweep of {} over {} value(s) x {} policies (SIGINT or SIGTERM stops it; the "
        "values done are written)\n",
        key, all_values.size(), names.size());
    for (double v : all_values) {
      // A stop signal: no further value starts; the finished values are written (a
      // simulation in progress ends at once, its value is left out).
      if (stop_signal() != 0) break;
      Scenario s = base;
      std::vector<std::string> warnings;
      if (auto e = apply_override(s, key, v, &warnings)) {
        progress.finish();
        print_error(*e);
        exit_code = kBadInput;
        return;
      }
      if (!warnings.empty()) progress.finish();  // a warning on a line of its own
      for (const std::string& w : warnings) std::cerr << "red: warning: " << w << '\n';
      for (std::size_t i = 0; i < names.size() && stop_signal() == 0; ++i) {
        progress.begin_run(fmt::format("{}={:g} {} [{}/{}]", key, v, names[i], ++done, total),
                           s.duration);
        auto r = simulate_policy(s, p, names[i], seed, {&progress}, false);
        if (!r && stop_signal() != 0) break;  // ended by the signal: this value is left out
        if (!r) {
          progress.finish();
          print_error(r.error());
          exit_code = kBadInput;
          return;
        }
        results[i].push_back(r->metrics);
      }
      if (results.back().size() == values.size() + 1) values.push_back(v);
    }
    progress.finish();  // the line stays up across the sweep's runs
    for (auto& per_policy : results) per_policy.resize(values.size());
    if (stop_signal() != 0) {
      std::cerr << fmt::format("red: stopped by {} after {} of {} value(s)\n", stop_signal_name(),
                               values.size(), all_values.size());
      if (values.empty()) {
        exit_code = stop_exit_code();
        return;
      }
    }
    // One table per figure: a row per policy, a column per value, the first column as wide
    // as the longest policy name. Miss rates in percent, as `red compare` prints them.
    std::size_t name_width = 10;
    for (const std::string& n : names) name_width = std::max(name_width, n.size() + 1);
    auto table = [&](const char* title, int decimals, auto get) {
      std::string out = fmt::format("{} by {}\n{:<{}}", title, key, "policy", name_width);
      for (double v : values) out += fmt::format(" {:>9g}", v);
      out += '\n';
      for (std::size_t i = 0; i < names.size(); ++i) {
        out += fmt::format("{:<{}}", names[i], name_width);
        for (const PolicyMetrics& m : results[i])
          out += fmt::format(" {:>9.{}f}", get(m), decimals);
        out += '\n';
      }
      return out;
    };
    std::string text =
        table("miss rate (%)", 2, [](const PolicyMetrics& m) { return 100.0 * m.miss_rate; });
    text += table("mean latency (ms)", 3, [](const PolicyMetrics& m) { return m.latency.mean; });
    text += table("QoE", 3, [](const PolicyMetrics& m) { return m.qoe; });
    // docs/DESIGN.md, "Performance targets": over rate_scale, each policy's breakdown rate beside
    // the physical limit.
    std::vector<Breakdown> breakdowns;
    NecessaryLoad need;
    double limit = 0;
    bool has_limit = false;  // a finite, positive limit: fractions of it are shown
    std::string limit_text;  // what follows "physical limit: "
    std::vector<std::vector<std::string>> bd_rows;  // policy, breakdown, fraction, next
    if (key == "rate_scale") {
      need = necessary_load(base, p);
      limit = need.limit_scale();
      has_limit = std::isfinite(limit) && limit > 0;
      limit_text = fmt::format(
          "{} (above it no policy meets every deadline: the necessary work, one encoder run per "
          "frame shared by the operations reading it, runs batched as the deadlines let them "
          "gather at the profile's cost per batch size, plain nodes, at mean costs, overloads a "
          "phase; it takes {:.1f} % of the lanes at rate_scale 1)",
          has_limit ? fmt::format("rate_scale {:.3f}", limit) : "none", 100 * need.total());
      for (std::size_t i = 0; i < names.size(); ++i) {
        const Breakdown b = breakdown_of(values, results[i]);
        breakdowns.push_back(b);
        const std::string past = b.censored ? "no swept value missed more"
                                            : fmt::format("{:g}: {:.1f} % missed", b.first_over,
                                                          100 * b.first_over_miss);
        const std::string ge = b.censored ? ">= " : "";
        bd_rows.push_back(
            {names[i], b.scale ? fmt::format("{}{:g}", ge, *b.scale) : "none",
             b.scale && has_limit ? fmt::format("{}{:.3f}", ge, *b.scale / limit) : "-", past});
      }
      text += fmt::format(
          "breakdown rate (miss rate of all the policy's jobs, every operation pooled, <= {:g} % "
          "at every swept rate_scale up to it; `red analyze`'s headroom asks instead that each "
          "operation's own miss rate stay within the limit; see docs/DESIGN.md#targets)\n"
          "physical limit: {}\n{:<{}} {:>9} {:>12}\n",
          100 * kBreakdownMiss, limit_text, "policy", name_width, "breakdown", "of the limit");
      for (const auto& r : bd_rows)
        text += fmt::format("{:<{}} {:>9} {:>12}   ({})\n", r[0], name_width, r[1], r[2], r[3]);
    }
    fmt::print("scenario {} (backend sim, seed {})\n{}", base.name, seed, text);
    if (a->out) {
      nlohmann::ordered_json j;
      j["schema"] = 1;
      j["scenario"] = base.name;
      j["parameter"] = key;
      j["values"] = values;
      j["seed"] = seed;
      if (!breakdowns.empty()) {
        nlohmann::ordered_json bd;
        bd["miss_limit"] = kBreakdownMiss;
        bd["necessary_load"] = need.total();
        bd["limit_scale"] = std::isfinite(limit) ? nlohmann::ordered_json(limit) : nullptr;
        for (std::size_t i = 0; i < names.size(); ++i) {
          const Breakdown& b = breakdowns[i];
          nlohmann::ordered_json row;
          row["name"] = names[i];
          row["rate_scale"] = b.scale ? nlohmann::ordered_json(*b.scale) : nullptr;
          row["fraction"] =
              b.scale && has_limit ? nlohmann::ordered_json(*b.scale / limit) : nullptr;
          row["censored"] = b.censored;
          bd["policies"].push_back(row);
        }
        j["breakdown"] = bd;
      }
      std::string csv =
          "policy," + key + ",jobs,miss_rate,drop_rate,latency_mean_ms,latency_p99_ms,qoe\n";
      for (std::size_t i = 0; i < names.size(); ++i) {
        nlohmann::ordered_json row;
        row["name"] = names[i];
        for (std::size_t k = 0; k < values.size(); ++k) {
          const PolicyMetrics& m = results[i][k];
          row["miss_rate"].push_back(m.miss_rate);
          row["drop_rate"].push_back(m.drop_rate);
          row["latency_mean_ms"].push_back(m.latency.mean);
          row["latency_p99_ms"].push_back(m.latency.p99);
          row["qoe"].push_back(m.qoe);
          csv += fmt::format("{},{:g},{},{},{},{},{},{}\n", names[i], values[k], m.jobs,
                             m.miss_rate, m.drop_rate, m.latency.mean, m.latency.p99, m.qoe);
        }
        j["policies"].push_back(row);
      }
      // The files are one set: the old manifest goes first, the new one comes last
      // (docs/REPORTS.md, "The output directory").
      auto set = OutputSet::begin(*a->out, "sweep");
      if (!set) {
        print_error(set.error());
        exit_code = kRunFailure;
        return;
      }
      j["run_id"] = set->run_id();
      if (auto e = write_file(
              *a->out, "sweep.json",
              j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n")) {
        print_error(*e);
        exit_code = kRunFailure;
        return;
      }
      set->add("sweep.json");
      if (auto e = write_file(*a->out, "sweep.csv", csv)) {
        print_error(*e);
        exit_code = kRunFailure;
        return;
      }
      set->add("sweep.csv");
      std::vector<SweepSeries> series;
      for (std::size_t i = 0; i < names.size(); ++i) series.push_back({names[i], results[i]});
      PlotOptions po;
      po.gnuplot = gnuplot_command();
      const PlotReport plots = write_sweep_plots(*a->out, base.name, key, values, series, po);
      if (!plots.note.empty()) std::cerr << "red: " << plots.note << '\n';
      for (const Error& e : plots.errors) {
        print_error(e);
        set->fail(e);
      }
      const std::vector<HtmlLink> links = {{"sweep.csv", "one row per (policy, value)"},
                                           {"sweep.json", "the same numbers as JSON"}};
      HtmlPage page = sweep_page(base.name, seed, key, values, series, plots, links);
      if (!bd_rows.empty()) {
        HtmlSection sec;
        sec.id = "breakdown";
        sec.heading = "Breakdown rate";
        sec.paragraphs = {
            fmt::format(
                "The largest swept rate_scale up to which each policy misses at most "
                "{:g} % of all its jobs (every operation pooled) at every swept value, and its "
                "fraction of the physical limit (docs/DESIGN.md, \"Performance targets\"). "
                "`red analyze`'s headroom asks instead that each operation's own miss rate "
                "stay within the limit: a rarely released operation can miss every job here.",
                100 * kBreakdownMiss),
            "Physical limit: " + limit_text + "."};
        HtmlTable t;
        t.header = {"policy", "breakdown rate_scale", "fraction of the limit",
                    "first swept value past it"};
        t.rows = bd_rows;
        sec.tables.push_back(std::move(t));
        page.sections.push_back(std::move(sec));
      }
      page.run_id = set->run_id();
      if (auto e = write_file(*a->out, "index.html", render_html(page))) {
        print_error(*e);
        exit_code = kRunFailure;
        return;
      }
      for (const std::string& f : plots.files) set->add(f);
      for (const PlotFile& f : plots.plots) {
        set->add(f.png);
        if (!f.svg.empty()) set->add(f.svg);
      }
      set->add("index.html");
      if (auto e = set->finish()) {
        print_error(*e);
        exit_code = kRunFailure;
        return;
      }
      std::size_t images = 0;
      for (const PlotFile& f : plots.plots) images += f.svg.empty() ? 1 : 2;
      fmt::print("wrote {}/sweep.json, sweep.csv, index.html{}\n", *a->out,
                 images > 0 ? fmt::format(", plots/ ({} images)", images) : std::string());
      if (!plots.errors.empty()) {
        // A plot that could not be drawn is a lost output (the errors are above).
        exit_code = stop_signal() != 0 ? stop_exit_code() : kRunFailure;
        return;
      }
    }
    exit_code = stop_signal() != 0 ? stop_exit_code() : kOk;
  });
}

}  // namespace red::cli
