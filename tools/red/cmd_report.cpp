/// \file
/// `red report DIR`: index.html, the plots and the timeline of a run redrawn from the files
/// it saved (summary.json, jobs.csv, units.csv, trace.json), with another timeline window
/// or phase; no scenario is read and nothing is simulated (docs/REPORTS.md, "red report").

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.hpp"
#include "common.hpp"
#include "red/report/manifest.hpp"
#include "red/report/redraw.hpp"
#include "red/report/timeline.hpp"
#include "red/report/why_text.hpp"

namespace red::cli {

namespace {

struct ReportArgs {
  std::string dir;
  std::optional<std::string> timeline;
  std::optional<std::size_t> phase;
  std::optional<std::string> policy;
  std::optional<std::string> why;
};

// `--why OPERATION#JOB`: one job's story, printed; nothing is redrawn.
int run_why(const ReportArgs& a, const SavedRun& saved) {
  auto ref = parse_job_ref(*a.why, saved.scenario);
  if (!ref) {
    print_error(ref.error());
    return kBadInput;
  }
  std::size_t run = 0;
  if (a.policy) {
    while (run < saved.metrics.size() && saved.metrics[run].name != *a.policy) ++run;
  } else if (saved.metrics.size() > 1) {
    std::string known;
    for (const PolicyMetrics& m : saved.metrics) known += (known.empty() ? "" : ", ") + m.name;
    print_error(Error{"", 0,
                      "--why " + *a.why + ": the run has several policies (" + known +
                          "); say which with --policy"});
    return kBadInput;
  }
  const std::vector<JobRow>& jobs = saved.jobs[run];
  const auto it = std::find_if(jobs.begin(), jobs.end(), [&](const JobRow& j) {
    return j.operation == ref->first && j.seq == ref->second;
  });
  if (it == jobs.end()) {
    std::uint64_t lo = 0, hi = 0;
    bool any = false;
    for (const JobRow& j : jobs)
      if (j.operation == ref->first) {
        lo = any ? std::min(lo, j.seq) : j.seq;
        hi = any ? std::max(hi, j.seq) : j.seq;
        any = true;
      }
    print_error(Error{
        "", 0,
        fmt::format("--why {}: no such job in {}'s jobs.csv ({})", *a.why, saved.metrics[run].name,
                    any ? fmt::format("its jobs of {} counted after the warm-up: {} to {}",
                                      saved.scenario.operation_name(ref->first), lo, hi)
                        : "it has no job of that operation after the warm-up")});
    return kBadInput;
  }
  fmt::print("{}", why_story(saved.scenario, saved.metrics[run].name, *it, saved.units[run]));
  return kOk;
}

// --policy names a policy of the run (or is not given); false once an error is printed.
bool policy_in_run(const ReportArgs& a, const SavedRun& saved) {
  if (!a.policy) return true;
  std::string known;
  bool found = false;
  for (const PolicyMetrics& m : saved.metrics) {
    known += (known.empty() ? "" : ", ") + m.name;
    found = found || m.name == *a.policy;
  }
  if (!found) {
    print_error(
        Error{"", 0, "--policy " + *a.policy + ": not in this run (its policies: " + known + ")"});
    return false;
  }
  return true;
}

// What to draw: --timeline and --phase checked against the run, --policy; nullopt once an error
// is printed.
std::optional<PageOptions> page_options(const ReportArgs& a, const SavedRun& saved) {
  PageOptions o;
  o.gnuplot = gnuplot_command();
  if (a.timeline) {
    auto w = parse_timeline_window(*a.timeline);
    if (!w) {
      print_error(w.error());
      return std::nullopt;
    }
    if (w->first >= saved.scenario.duration) {
      print_error(Error{"", 0,
                        fmt::format("--timeline: FROM ({:g} s) is not before the end of the run "
                                    "({:g} s)",
                                    to_s(w->first), to_s(saved.scenario.duration))});
      return std::nullopt;
    }
    o.timeline = *w;
  }
  if (a.phase) {
    TimePoint end = saved.scenario.warmup;
    for (TimePoint e : saved.ends) end = std::max(end, e);
    const std::size_t n = workload_phases(saved.scenario, end).size();
    if (*a.phase >= n) {
      print_error(Error{
          "", 0, fmt::format("--phase {}: the run has {} phase(s), 0 to {}", *a.phase, n, n - 1)});
      return std::nullopt;
    }
    o.phase = a.phase;
  }
  o.policy = a.policy;
  return o;
}

// The page and its plots redrawn into the run's directory, ended by its manifest; the exit code.
int redraw(const std::string& dir, const SavedRun& saved, const PageOptions& o) {
  // The directory is marked unfinished (same run id) until the new page and its manifest
  // are written, as a run's own files are.
  auto set =
      OutputSet::reopen(dir, saved.command.empty() ? "report" : saved.command, saved.header.run_id);
  if (!set) {
    print_error(set.error());
    return kRunFailure;
  }
  for (const std::string& f : saved.data_files) set->add(f);
  const PageReport page = write_report_page(dir, saved.input(), o);
  if (!page.plots_note.empty()) std::cerr << "red: " << page.plots_note << '\n';
  for (const std::string& f : page.files) set->add(f);
  for (const Error& e : page.errors) {
    print_error(e);
    set->fail(e);
  }
  // The previous page's drawings that this one does not use are not the run's any more.
  for (const std::string& f : saved.files) {
    const bool kept = std::find(page.files.begin(), page.files.end(), f) != page.files.end();
    if (!kept && f.rfind("plots/", 0) == 0) {
      std::error_code ec;
      std::filesystem::remove(std::filesystem::path(dir) / f, ec);
    }
  }
  const std::optional<Error> manifest = set->finish();
  if (manifest) print_error(*manifest);
  fmt::print("redrew {}/{} ({} images){}\n", dir,
             saved.index_html ? "index.html and plots/" : "plots/", page.images,
             manifest ? "" : ", manifest.json");
  return page.errors.empty() && !manifest ? kOk : kRunFailure;
}

int run_report(const ReportArgs& a) {
  auto saved = read_saved_run(a.dir);
  if (!saved) {
    print_error(saved.error());
    return kBadInput;
  }
  if (!policy_in_run(a, *saved)) return kBadInput;
  if (a.why) return run_why(a, *saved);
  const std::optional<PageOptions> o = page_options(a, *saved);
  if (!o) return kBadInput;
  return redraw(a.dir, *saved, *o);
}

}  // namespace

void register_report(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report",
      "Redraw a run's index.html, plots and timeline from its saved files (no simulation)");
  cmd->add_option("dir", a->dir, "Output directory of red compare or red run")->required();
  auto* t = cmd->add_option("--timeline", a->timeline,
                            "Timeline window FROM:TO in seconds (default: each workload "
                            "phase's start and each policy's worst miss)");
  auto* ph =
      cmd->add_option("--phase", a->phase,
                      "Timeline of one workload phase (0-based, as in the page's phase table): "
                      "its start and each policy's worst miss in it")
          ->check(whole_number(1000))
          ->excludes(t);
  cmd->add_option("--policy", a->policy,
                  "Draw only this policy in the timeline; with --why, the policy whose job");
  cmd->add_option("--why", a->why,
                  "Print why job OPERATION#JOB (e.g. navigate#42) did not meet its deadline: its "
                  "units, what ran meanwhile and its cause; nothing is redrawn")
      ->excludes(t)
      ->excludes(ph);
  cmd->callback([a, &exit_code] { exit_code = run_report(*a); });
}

}  // namespace red::cli
