/// \file
/// `red analyze S.yaml [--profile F.json] [--policy P] [--out DIR] [--check]
/// [--export-nptest DIR]`: will this robot meet its deadlines, and with how much headroom?
/// (docs/ANALYSIS.md).

#include <fmt/format.h>

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "red/analysis/analyze.hpp"
#include "red/analysis/nptest.hpp"
#include "red/report/report.hpp"

namespace red::cli {

namespace {

struct AnalyzeArgs {
  ScenarioArgs scenario;
  std::string policy = "red";
  std::optional<std::string> out;
  std::optional<std::string> nptest;
  std::optional<double> nptest_window_ms;
  bool check = false;
  bool no_headroom = false;
};

// analysis.json, marked with the run id and ended by the manifest (docs/REPORTS.md); the exit
// code.
int write_analysis(const std::string& dir, const Analysis& an) {
  auto set = OutputSet::begin(dir, "analyze");
  if (!set) {
    print_error(set.error());
    return kRunFailure;
  }
  auto doc = nlohmann::ordered_json::parse(analysis_json(an));
  doc["run_id"] = set->run_id();
  if (auto e = write_file(
          dir, "analysis.json",
          doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n")) {
    print_error(*e);
    return kRunFailure;
  }
  set->add("analysis.json");
  if (auto e = set->finish()) {
    print_error(*e);
    return kRunFailure;
  }
  fmt::print("wrote {}/analysis.json, manifest.json\n", dir);
  return kOk;
}

// --export-nptest: the job set in np-schedulability-analysis CSV formats; the exit code.
int write_nptest(const AnalyzeArgs& a, const Scenario& s, const Profile& p,
                 const PolicyOptions& opts) {
  std::optional<Duration> window;
  if (a.nptest_window_ms) window = from_ms(*a.nptest_window_ms);
  auto x = export_nptest(s, p, opts, window);
  if (!x) {
    print_error(x.error());
    return kBadInput;
  }
  for (const auto& [name, text] :
       {std::pair{"jobs.csv", &x->jobs_csv}, std::pair{"jobs.prec.csv", &x->prec_csv},
        std::pair{"tasks.csv", &x->tasks_csv}})
    if (auto e = write_file(*a.nptest, name, *text)) {
      print_error(*e);
      return kRunFailure;
    }
  fmt::print(
      "wrote {}/jobs.csv ({} jobs), jobs.prec.csv ({} edges), tasks.csv: window {:g} ms, {}; "
      "times in μs (nptest {}/jobs.csv -p {}/jobs.prec.csv{})\n",
      *a.nptest, x->jobs, x->edges, to_ms(x->window), x->note, *a.nptest, *a.nptest,
      s.device.lanes > 1 ? fmt::format(" -m {}", s.device.lanes) : std::string());
  return kOk;
}

int run_analyze(const AnalyzeArgs& a) {
  auto loaded = load_with_profile(a.scenario);
  if (!loaded) return kBadInput;
  Scenario& s = loaded->scenario;
  const Profile& p = loaded->profile;
  warn_suspect_profile(p, a.scenario.profile.value_or(s.profile));
  const auto opts = policy_options(s, a.policy);
  if (!opts) {
    print_error(Error{"", 0, "--policy: " + unknown_policy_message(a.policy)});
    return kBadInput;
  }
  if (a.nptest_window_ms && !(*a.nptest_window_ms > 0)) {
    print_error(Error{"", 0, "--nptest-window-ms: must be > 0"});
    return kBadInput;
  }
  AnalysisOptions o;
  o.policy = a.policy;
  o.headroom = !a.no_headroom;
  auto an = analyze(s, p, o);
  if (!an) {
    print_error(an.error());
    return kRunFailure;
  }
  fmt::print("{}", analysis_text(*an));
  if (a.out)
    if (const int code = write_analysis(*a.out, *an); code != kOk) return code;
  if (a.nptest)
    if (const int code = write_nptest(a, s, p, *opts); code != kOk) return code;
  return a.check && an->verdict != Verdict::Ok ? kRunFailure : kOk;
}

}  // namespace

void register_analyze(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<AnalyzeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "analyze", "Verdict per operation, headroom and response-time bound (docs/ANALYSIS.md)");
  cmd->add_option("scenario", a->scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--profile", a->scenario.profile,
                  "Profile JSON (default: the scenario's, else built-in)");
  cmd->add_option("--set", a->scenario.sets,
                  "Override key=value (deadline_scale, rate_scale, lanes, ...)");
  cmd->add_option("--policy", a->policy, "The policy to judge (a preset)")->capture_default_str();
  cmd->add_option("--out", a->out, "Directory for analysis.json");
  cmd->add_flag("--check", a->check, "Exit 1 when any operation's verdict is not ok");
  cmd->add_flag("--no-headroom", a->no_headroom, "Skip the headroom search");
  cmd->add_option("--export-nptest", a->nptest,
                  "Directory for the job set in np-schedulability-analysis CSV formats");
  cmd->add_option("--nptest-window-ms", a->nptest_window_ms,
                  "Export the releases of [0, W) ms (default: one hyperperiod, else the "
                  "scenario's duration)");
  add_with_option(cmd, a->scenario);
  cmd->callback([a, &exit_code] { exit_code = run_analyze(*a); });
}

}  // namespace red::cli
