#pragma once
/// \file
/// The page of a run (index.html, the plots and the timeline), written from what the run
/// keeps, and redrawn later from its saved files (docs/REPORTS.md, "red report"): `red
/// compare` and `red run` write the page through write_report_page() from the rows in
/// memory; `red report DIR` reads summary.json, jobs.csv, units.csv and trace.json back
/// (read_saved_run) and calls the same function, so that the same window gives the same
/// page. No scenario is read and nothing is simulated: what the page needs besides the
/// rows is in summary.json's "page" object (page_json).
///
///     auto saved = read_saved_run("out/x");          // Error: file, line, problem
///     PageOptions o; o.phase = 1;
///     PageReport r = write_report_page("out/x", saved->input(), o);

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/phases.hpp"
#include "red/report/html.hpp"
#include "red/report/report.hpp"
#include "red/report/timeline.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// One policy's run as the page reads it. Pointers are not owned; null: not kept.
struct PageRun {
  const PolicyMetrics* metrics = nullptr;  ///< with the ratios vs the baseline applied
  const std::vector<JobRow>* jobs = nullptr;
  const std::vector<UnitRow>* units = nullptr;
  const std::vector<PhaseMetrics>* phases = nullptr;  ///< empty: no figures per phase
  const std::vector<TimelineWait>* waits = nullptr;   ///< merge waits (trace.json), if any
  std::optional<TimePoint> waits_cut;                 ///< trace.json stopped there
  TimePoint end{0};                                   ///< end of the run
};

/// Everything the page shows.
struct PageInput {
  SummaryHeader header;
  /// Names, warm-up, duration, events, heads and sensors of the scenario (all the page uses).
  const Scenario* scenario = nullptr;
  std::vector<PageRun> runs;
  std::optional<HtmlTable> verdicts;    ///< red analyze's verdicts (red compare)
  std::vector<HtmlTable> prediction;    ///< the simulator's prediction of a real run
  std::vector<std::string> data_files;  ///< the run's other files (summary.json, jobs.csv, ...)
  bool index_html = true;               ///< write index.html (red compare), not only the plots
};

/// What to draw.
struct PageOptions {
  std::string gnuplot = "gnuplot";  ///< command; empty: data and scripts only, no images
  /// One timeline window (FROM, TO); none: report_timeline_windows.
  std::optional<std::pair<Duration, Duration>> timeline;
  std::optional<std::size_t> phase;   ///< only this workload phase (0-based)
  std::optional<std::string> policy;  ///< only this policy in the timeline
};

/// What write_report_page wrote (relative to its directory).
struct PageReport {
  std::vector<std::string> files;  ///< in the order written (index.html last)
  std::size_t images = 0;          ///< PNG and SVG files among them
  std::vector<Error> errors;       ///< files that could not be written
  std::string plots_note;          ///< why images are missing, if they are
};

/// The default timeline windows (docs/REPORTS.md, "The timeline"): the first 2 s of each
/// workload phase (at most 8) with every run, then for each run with a miss the 2 s around
/// its worst miss (the most critical job at its release, then the one that ended latest past
/// its deadline, then the earliest release), that run alone. With `phase`: that phase's start, and
/// the worst misses among the jobs released in it.
std::vector<TimelineWindow> report_timeline_windows(const Scenario& s,
                                                    const std::vector<TimelineRun>& runs,
                                                    std::optional<std::size_t> phase = {});

/// Writes the plots, the timeline SVGs and (PageInput::index_html) index.html into `dir`,
/// each atomically. index.html links every file of the run: `data_files`, manifest.json
/// and what this call writes.
PageReport write_report_page(const std::string& dir, const PageInput& in, const PageOptions& o);

/// summary.json's "page" object: what the page needs besides the policies' figures and the
/// rows (the scenario's names, warm-up, duration, events; each run's end; the verdicts and
/// the prediction).
std::string page_json(const PageInput& in);

/// A run read back from its directory; input() points into it.
struct SavedRun {
  Scenario scenario;
  SummaryHeader header;
  std::string command;  ///< manifest.json's
  std::vector<PolicyMetrics> metrics;
  std::vector<std::vector<JobRow>> jobs;
  std::vector<std::vector<UnitRow>> units;
  std::vector<std::vector<PhaseMetrics>> phases;
  std::vector<std::vector<TimelineWait>> waits;
  std::vector<bool> has_waits;
  std::vector<std::optional<TimePoint>> waits_cut;
  std::vector<TimePoint> ends;
  std::optional<HtmlTable> verdicts;
  std::vector<HtmlTable> prediction;
  std::vector<std::string> data_files;
  std::vector<std::string> files;  ///< manifest.json's list
  bool index_html = true;

  [[nodiscard]] PageInput input() const;
};

/// Reads the saved files of a run in `dir`: manifest.json (the run must be complete),
/// summary.json (with its "page" object: written by this version of red), jobs.csv,
/// units.csv and trace.json when listed. Error: the file, the line and the problem.
Expected<SavedRun> read_saved_run(const std::string& dir);

}  // namespace red
