#pragma once
/// \file
/// What the `red` subcommands share: loading a scenario with overrides and its profile,
/// printing located errors, writing a run's outputs.

#include <cstddef>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "red/core/expected.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/observe/progress.hpp"
#include "red/observe/trace.hpp"
#include "red/profile/profile.hpp"
#include "red/report/html.hpp"
#include "red/report/manifest.hpp"
#include "red/scenario/manifest.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sim/run.hpp"

namespace red::cli {

/// Options shared by the commands that read a scenario.
struct ScenarioArgs {
  std::string path;
  std::optional<std::string> profile;
  std::vector<std::string> sets;  ///< key=value overrides
  std::vector<std::string> with;  ///< policy options "key=value,…" (--with), after the scenario's
};

/// Adds --with to a command that reads a scenario.
void add_with_option(CLI::App* cmd, ScenarioArgs& a);

/// Prints `file:line: message` on stderr.
inline void print_error(const Error& e) {
  std::cerr << "red: " << e.to_string() << '\n';
}

/// When the profile a command loaded says its figures are suspect (its `quality` field,
/// docs/CLI.md "Profile quality"), one `red: warning:` line per finding on stderr, at most
/// `cap`. Changes no other output and no exit code. `path`: the profile's file.
void warn_suspect_profile(const Profile& p, const std::string& path, std::size_t cap = 5);

/// Loads the scenario, checks its model (check_model(): manifest, files, heads, input),
/// applies overrides; Error on bad input.
/// `manifest`, when given, gets the manifest check_model() read (empty for a built-in model).
Expected<Scenario> load(const ScenarioArgs& a, std::optional<ModelManifest>* manifest = nullptr);

/// resolve_profile(), printing its warnings on stderr ("red: warning: ...").
Expected<Profile> cli_profile(const Scenario& s, const std::optional<std::string>& cli_path);

/// A scenario as a command runs it: loaded with its overrides (load()) and its profile
/// (cli_profile()).
struct LoadedScenario {
  Scenario scenario;
  Profile profile;
};

/// load(), then cli_profile() with `a.profile`, as every command that reads a scenario and a
/// profile starts. The first error is printed (print_error) and gives nullopt: the caller
/// exits with kBadInput (commands.hpp).
std::optional<LoadedScenario> load_with_profile(const ScenarioArgs& a);

/// Splits "a,b,c".
std::vector<std::string> split_list(const std::string& s);

/// A finite decimal number ("0.5", "1e-3", "-2"), or nullopt: no hex ("0x10"), no "nan" or
/// "inf", nothing before or after the number. What --set values and sweep ranges accept.
std::optional<double> decimal_number(const std::string& text);

/// CLI11 checks of a finite decimal number > 0, or >= 0 (CLI11's PositiveNumber and
/// NonNegativeNumber let "nan" through).
CLI::Validator finite_positive();
CLI::Validator finite_non_negative();

/// A CLI11 check of a whole number in [0, max] (CLI11 clamps a seed past 2^64 - 1, and its
/// NonNegativeNumber prints a 309-digit bound).
CLI::Validator whole_number(std::uint64_t max = std::numeric_limits<std::uint64_t>::max());

/// What write_outputs writes besides summary.json, jobs.csv, units.csv and the plots.
struct OutputOptions {
  /// The timeline of each run, in the order of `runs` (null entries are left out); empty:
  /// no trace.json.
  std::vector<const TraceObserver*> traces;
  bool index_html = false;  ///< index.html (red compare)
  /// gnuplot command; empty: $RED_GNUPLOT, else "gnuplot" ("none" writes no images).
  std::string gnuplot;
  /// The timeline's window (`--timeline FROM:TO`); none: the default windows.
  std::optional<std::pair<Duration, Duration>> timeline;
  /// The verdict table shown first in index.html (red compare; red/analysis), if any.
  std::optional<HtmlTable> verdicts;
  /// Tables shown after the comparison in index.html: the simulator's prediction of a real
  /// comparison (red compare on a real backend), if any.
  std::vector<HtmlTable> prediction;
  /// jobs.csv and units.csv are in `dir` already (streamed during the run,
  /// report/stream.hpp): not written again; the runs' rows still feed the plots.
  bool rows_written = false;
  /// With rows_written: the files they are in (relative to the directory), for the manifest.
  std::vector<std::string> rows_files;
  /// Files the caller writes after write_outputs (rss.csv, prediction.json): index.html
  /// links them.
  std::vector<std::string> more_files;
  /// The run's output set: its run id goes into summary.json, trace.json and index.html, and
  /// every file written is added to it (failures too). Null: no run id, no manifest.
  OutputSet* set = nullptr;
};

/// What write_outputs wrote, relative to its directory.
struct OutputReport {
  std::vector<std::string> files;
  std::size_t images = 0;     ///< PNG and SVG files among them
  std::vector<Error> errors;  ///< every file that could not be written (the first returned)
};

/// Writes everything a set of runs of one scenario leaves in `dir`: summary.json, jobs.csv,
/// units.csv, trace.json (one process per run, when traces are given), the plots (PNG and
/// SVG with their data and scripts, under plots/) and, if asked, index.html, each atomically
/// (core/output_file.hpp). A missing or failing gnuplot gives a note on stderr, never an
/// error. A file that cannot be written does not stop the others (OutputReport::errors);
/// when it is summary.json, the summary goes to stderr instead. Error: the first file that
/// could not be written (names the path and the system's reason). Sets the cause of every
/// job row of `runs` (metrics/why.hpp) first; with OutputOptions::rows_written, writes
/// jobs.csv again with the causes when every run's rows are there.
std::optional<Error> write_outputs(const std::string& dir, const Scenario& s, const Profile& p,
                                   const std::string& backend, std::uint64_t seed,
                                   std::vector<PolicyRun>& runs, const OutputOptions& options = {},
                                   OutputReport* report = nullptr);

/// "wrote DIR/summary.json, jobs.csv, units.csv, trace.json, index.html, plots/ (N images)".
std::string wrote_message(const std::string& dir, const OutputReport& r);

/// The gnuplot command to use: `configured` if set, else $RED_GNUPLOT, else "gnuplot";
/// "none" gives an empty command (no images).
std::string gnuplot_command(const std::string& configured = {});

/// The default limit on trace events per file (spread over its processes).
inline constexpr std::size_t kDefaultTraceEvents = 1'000'000;

/// A trace observer for one of `runs` runs sharing a file of at most `total_events` events
/// (0: no trace, returns null).
std::unique_ptr<TraceObserver> make_trace(const Scenario& s, std::size_t total_events,
                                          std::size_t runs);

}  // namespace red::cli
