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

// A sweep's inputs, checked: the scenario and profile, the presets, the swept key and its
// values, the seed.
struct SweepPlan {
  LoadedScenario loaded;
  std::vector<std::string> names;
  std::string key;
  std::vector<double> all_values;
  std::uint64_t seed = 0;
};

// What the sweep ran: the values every policy ran at (all, unless stopped), and
// results[policy][value].
struct SweepResults {
  std::vector<double> values;
  std::vector<std::vector<PolicyMetrics>> results;
};

// docs/DESIGN.md, "Performance targets": over rate_scale, each policy's breakdown rate beside the
// physical limit (empty for any other key).
struct BreakdownReport {
  std::vector<Breakdown> breakdowns;
  NecessaryLoad need;
  double limit = 0;
  bool has_limit = false;  // a finite, positive limit: fractions of it are shown
  std::string limit_text;  // what follows "physical limit: "
  std::vector<std::vector<std::string>> rows;  // policy, breakdown, fraction, next
};

// The sweep's values, scenario, profile and presets; nullopt (bad input) once an error is
// printed.
std::optional<SweepPlan> plan_sweep(const SweepArgs& a) {
  auto sw = parse_sweep(a.sweep);
  if (!sw) {
    print_error(sw.error());
    return std::nullopt;
  }
  auto loaded = load_with_profile(a.scenario);
  if (!loaded) return std::nullopt;
  SweepPlan plan;
  plan.names = a.policies.empty() ? default_presets() : split_list(a.policies);
  for (const std::string& n : plan.names)
    if (!make_policy(n)) {
      print_error(Error{"", 0, unknown_policy_message(n)});
      return std::nullopt;
    }
  plan.key = sw->first;
  plan.all_values = sw->second;
  plan.seed = a.seed ? *a.seed : loaded->scenario.seed;
  plan.loaded = std::move(*loaded);
  return plan;
}

// Every policy at every value, in the simulator, until a stop signal; the exit code when the
// sweep ends without a result to show.
std::optional<int> run_sweep_values(const SweepPlan& plan, SweepResults& out) {
  const Scenario& base = plan.loaded.scenario;
  const std::vector<std::string>& names = plan.names;
  const std::string& key = plan.key;
  std::vector<double>& values = out.values;
  std::vector<std::vector<PolicyMetrics>>& results = out.results;
  results.resize(names.size());
  const SteadyClock clock;
  ProgressReporter progress(clock, std::cerr, ProgressReporter::stderr_is_terminal());
  const std::size_t total = plan.all_values.size() * names.size();
  std::size_t done = 0;
  std::cerr << fmt::format(
      "red: sweep of {} over {} value(s) x {} policies (SIGINT or SIGTERM stops it; the "
      "values done are written)\n",
      key, plan.all_values.size(), names.size());
  for (double v : plan.all_values) {
    // A stop signal: no further value starts; the finished values are written (a
    // simulation in progress ends at once, its value is left out).
    if (stop_signal() != 0) break;
    Scenario s = base;
    std::vector<std::string> warnings;
    if (auto e = apply_override(s, key, v, &warnings)) {
      progress.finish();
      print_error(*e);
      return kBadInput;
    }
    if (!warnings.empty()) progress.finish();  // a warning on a line of its own
    for (const std::string& w : warnings) std::cerr << "red: warning: " << w << '\n';
    for (std::size_t i = 0; i < names.size() && stop_signal() == 0; ++i) {
      progress.begin_run(fmt::format("{}={:g} {} [{}/{}]", key, v, names[i], ++done, total),
                         s.duration);
      auto r = simulate_policy(s, plan.loaded.profile, names[i], plan.seed, {&progress}, false);
      if (!r && stop_signal() != 0) break;  // ended by the signal: this value is left out
      if (!r) {
        progress.finish();
        print_error(r.error());
        return kBadInput;
      }
      results[i].push_back(r->metrics);
    }
    if (results.back().size() == values.size() + 1) values.push_back(v);
  }
  progress.finish();  // the line stays up across the sweep's runs
  for (auto& per_policy : results) per_policy.resize(values.size());
  if (stop_signal() != 0) {
    std::cerr << fmt::format("red: stopped by {} after {} of {} value(s)\n", stop_signal_name(),
                             values.size(), plan.all_values.size());
    if (values.empty()) return stop_exit_code();
  }
  return std::nullopt;
}

// The first column's width: as wide as the longest policy name.
std::size_t name_width_of(const std::vector<std::string>& names) {
  std::size_t name_width = 10;
  for (const std::string& n : names) name_width = std::max(name_width, n.size() + 1);
  return name_width;
}

// One table per figure: a row per policy, a column per value. Miss rates in percent, as `red
// compare` prints them.
std::string sweep_tables(const SweepPlan& plan, const SweepResults& r) {
  const std::size_t name_width = name_width_of(plan.names);
  auto table = [&](const char* title, int decimals, auto get) {
    std::string out = fmt::format("{} by {}\n{:<{}}", title, plan.key, "policy", name_width);
    for (double v : r.values) out += fmt::format(" {:>9g}", v);
    out += '\n';
    for (std::size_t i = 0; i < plan.names.size(); ++i) {
      out += fmt::format("{:<{}}", plan.names[i], name_width);
      for (const PolicyMetrics& m : r.results[i])
        out += fmt::format(" {:>9.{}f}", get(m), decimals);
      out += '\n';
    }
    return out;
  };
  std::string text =
      table("miss rate (%)", 2, [](const PolicyMetrics& m) { return 100.0 * m.miss_rate; });
  text += table("mean latency (ms)", 3, [](const PolicyMetrics& m) { return m.latency.mean; });
  text += table("QoE", 3, [](const PolicyMetrics& m) { return m.qoe; });
  return text;
}

// Each policy's breakdown rate and the physical limit, over rate_scale only.
BreakdownReport breakdown_report(const SweepPlan& plan, const SweepResults& r) {
  BreakdownReport bd;
  if (plan.key != "rate_scale") return bd;
  bd.need = necessary_load(plan.loaded.scenario, plan.loaded.profile);
  bd.limit = bd.need.limit_scale();
  bd.has_limit = std::isfinite(bd.limit) && bd.limit > 0;
  bd.limit_text = fmt::format(
      "{} (above it no policy meets every deadline: the necessary work, one encoder run per "
      "frame shared by the operations reading it, runs batched as the deadlines let them "
      "gather at the profile's cost per batch size, plain nodes, at mean costs, overloads a "
      "phase; it takes {:.1f} % of the lanes at rate_scale 1)",
      bd.has_limit ? fmt::format("rate_scale {:.3f}", bd.limit) : "none", 100 * bd.need.total());
  for (std::size_t i = 0; i < plan.names.size(); ++i) {
    const Breakdown b = breakdown_of(r.values, r.results[i]);
    bd.breakdowns.push_back(b);
    const std::string past =
        b.censored ? "no swept value missed more"
                   : fmt::format("{:g}: {:.1f} % missed", b.first_over, 100 * b.first_over_miss);
    const std::string ge = b.censored ? ">= " : "";
    bd.rows.push_back(
        {plan.names[i], b.scale ? fmt::format("{}{:g}", ge, *b.scale) : "none",
         b.scale && bd.has_limit ? fmt::format("{}{:.3f}", ge, *b.scale / bd.limit) : "-", past});
  }
  return bd;
}

std::string breakdown_text(const BreakdownReport& bd, std::size_t name_width) {
  std::string text = fmt::format(
      "breakdown rate (miss rate of all the policy's jobs, every operation pooled, <= {:g} % "
      "at every swept rate_scale up to it; `red analyze`'s headroom asks instead that each "
      "operation's own miss rate stay within the limit; see docs/DESIGN.md#targets)\n"
      "physical limit: {}\n{:<{}} {:>9} {:>12}\n",
      100 * kBreakdownMiss, bd.limit_text, "policy", name_width, "breakdown", "of the limit");
  for (const auto& r : bd.rows)
    text += fmt::format("{:<{}} {:>9} {:>12}   ({})\n", r[0], name_width, r[1], r[2], r[3]);
  return text;
}

// sweep.json without its run id.
nlohmann::ordered_json sweep_json(const SweepPlan& plan, const SweepResults& r,
                                  const BreakdownReport& bd) {
  nlohmann::ordered_json j;
  j["schema"] = 1;
  j["scenario"] = plan.loaded.scenario.name;
  j["parameter"] = plan.key;
  j["values"] = r.values;
  j["seed"] = plan.seed;
  if (!bd.breakdowns.empty()) {
    nlohmann::ordered_json b_json;
    b_json["miss_limit"] = kBreakdownMiss;
    b_json["necessary_load"] = bd.need.total();
    b_json["limit_scale"] = std::isfinite(bd.limit) ? nlohmann::ordered_json(bd.limit) : nullptr;
    for (std::size_t i = 0; i < plan.names.size(); ++i) {
      const Breakdown& b = bd.breakdowns[i];
      nlohmann::ordered_json row;
      row["name"] = plan.names[i];
      row["rate_scale"] = b.scale ? nlohmann::ordered_json(*b.scale) : nullptr;
      row["fraction"] =
          b.scale && bd.has_limit ? nlohmann::ordered_json(*b.scale / bd.limit) : nullptr;
      row["censored"] = b.censored;
      b_json["policies"].push_back(row);
    }
    j["breakdown"] = b_json;
  }
  for (std::size_t i = 0; i < plan.names.size(); ++i) {
    nlohmann::ordered_json row;
    row["name"] = plan.names[i];
    for (std::size_t k = 0; k < r.values.size(); ++k) {
      const PolicyMetrics& m = r.results[i][k];
      row["miss_rate"].push_back(m.miss_rate);
      row["drop_rate"].push_back(m.drop_rate);
      row["latency_mean_ms"].push_back(m.latency.mean);
      row["latency_p99_ms"].push_back(m.latency.p99);
      row["qoe"].push_back(m.qoe);
    }
    j["policies"].push_back(row);
  }
  return j;
}

// sweep.csv: one row per (policy, value).
std::string sweep_csv(const SweepPlan& plan, const SweepResults& r) {
  std::string csv =
      "policy," + plan.key + ",jobs,miss_rate,drop_rate,latency_mean_ms,latency_p99_ms,qoe\n";
  for (std::size_t i = 0; i < plan.names.size(); ++i)
    for (std::size_t k = 0; k < r.values.size(); ++k) {
      const PolicyMetrics& m = r.results[i][k];
      csv += fmt::format("{},{:g},{},{},{},{},{},{}\n", plan.names[i], r.values[k], m.jobs,
                         m.miss_rate, m.drop_rate, m.latency.mean, m.latency.p99, m.qoe);
    }
  return csv;
}

// The breakdown rates as a section of index.html.
HtmlSection breakdown_section(const BreakdownReport& bd) {
  HtmlSection sec;
  sec.id = "breakdown";
  sec.heading = "Breakdown rate";
  sec.paragraphs = {
      fmt::format("The largest swept rate_scale up to which each policy misses at most "
                  "{:g} % of all its jobs (every operation pooled) at every swept value, and its "
                  "fraction of the physical limit (docs/DESIGN.md, \"Performance targets\"). "
                  "`red analyze`'s headroom asks instead that each operation's own miss rate "
                  "stay within the limit: a rarely released operation can miss every job here.",
                  100 * kBreakdownMiss),
      "Physical limit: " + bd.limit_text + "."};
  HtmlTable t;
  t.header = {"policy", "breakdown rate_scale", "fraction of the limit",
              "first swept value past it"};
  t.rows = bd.rows;
  sec.tables.push_back(std::move(t));
  return sec;
}

// sweep.json, sweep.csv, the plots and index.html into `dir`, ended by the manifest; the exit
// code.
int write_sweep(const std::string& dir, const SweepPlan& plan, const SweepResults& r,
                const BreakdownReport& bd) {
  const std::string& name = plan.loaded.scenario.name;
  nlohmann::ordered_json j = sweep_json(plan, r, bd);
  const std::string csv = sweep_csv(plan, r);
  // The files are one set: the old manifest goes first, the new one comes last
  // (docs/REPORTS.md, "The output directory").
  auto set = OutputSet::begin(dir, "sweep");
  if (!set) {
    print_error(set.error());
    return kRunFailure;
  }
  j["run_id"] = set->run_id();
  if (auto e = write_file(
          dir, "sweep.json",
          j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n")) {
    print_error(*e);
    return kRunFailure;
  }
  set->add("sweep.json");
  if (auto e = write_file(dir, "sweep.csv", csv)) {
    print_error(*e);
    return kRunFailure;
  }
  set->add("sweep.csv");
  std::vector<SweepSeries> series;
  for (std::size_t i = 0; i < plan.names.size(); ++i)
    series.push_back({plan.names[i], r.results[i]});
  PlotOptions po;
  po.gnuplot = gnuplot_command();
  const PlotReport plots = write_sweep_plots(dir, name, plan.key, r.values, series, po);
  if (!plots.note.empty()) std::cerr << "red: " << plots.note << '\n';
  for (const Error& e : plots.errors) {
    print_error(e);
    set->fail(e);
  }
  const std::vector<HtmlLink> links = {{"sweep.csv", "one row per (policy, value)"},
                                       {"sweep.json", "the same numbers as JSON"}};
  HtmlPage page = sweep_page(name, plan.seed, plan.key, r.values, series, plots, links);
  if (!bd.rows.empty()) page.sections.push_back(breakdown_section(bd));
  page.run_id = set->run_id();
  if (auto e = write_file(dir, "index.html", render_html(page))) {
    print_error(*e);
    return kRunFailure;
  }
  for (const std::string& f : plots.files) set->add(f);
  for (const PlotFile& f : plots.plots) {
    set->add(f.png);
    if (!f.svg.empty()) set->add(f.svg);
  }
  set->add("index.html");
  if (auto e = set->finish()) {
    print_error(*e);
    return kRunFailure;
  }
  std::size_t images = 0;
  for (const PlotFile& f : plots.plots) images += f.svg.empty() ? 1 : 2;
  fmt::print("wrote {}/sweep.json, sweep.csv, index.html{}\n", dir,
             images > 0 ? fmt::format(", plots/ ({} images)", images) : std::string());
  // A plot that could not be drawn is a lost output (the errors are above).
  if (!plots.errors.empty()) return stop_signal() != 0 ? stop_exit_code() : kRunFailure;
  return kOk;
}

// `red sweep`: parse, run every policy at every value, print the tables, write the files.
int run_sweep(const SweepArgs& a) {
  install_stop_signals();
  const std::optional<SweepPlan> plan = plan_sweep(a);
  if (!plan) return kBadInput;
  SweepResults r;
  if (const std::optional<int> stopped = run_sweep_values(*plan, r)) return *stopped;
  std::string text = sweep_tables(*plan, r);
  const BreakdownReport bd = breakdown_report(*plan, r);
  if (plan->key == "rate_scale") text += breakdown_text(bd, name_width_of(plan->names));
  fmt::print("scenario {} (backend sim, seed {})\n{}", plan->loaded.scenario.name, plan->seed,
             text);
  if (a.out)
    if (const int code = write_sweep(*a.out, *plan, r, bd); code != kOk) return code;
  return stop_signal() != 0 ? stop_exit_code() : kOk;
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
  cmd->callback([a, &exit_code] { exit_code = run_sweep(*a); });
}

}  // namespace red::cli
