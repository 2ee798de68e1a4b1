#pragma once
/// \file
/// The schedule itself, drawn offline (docs/REPORTS.md, "The timeline in index.html"): for
/// each policy one row per lane with every unit execution as a box coloured by operation
/// and labelled with its node, round trips, merge waits and idle gaps, and one row per
/// operation with each job from release to deadline (its response drawn over it) and its
/// miss. The policies are stacked on one time axis. Inline SVG written directly: no
/// scripts, no fonts or styles fetched, so it renders from disk in any browser.
///
///     std::vector<TimelineWindow> w = default_timeline_windows(s, runs);
///     for (const TimelineWindow& x : w) svg = timeline_svg(s, runs, x);

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// A merge wait (docs/DESIGN.md, "DynamicMerge"): an encoder run of `sensor` held from `at` to
/// `until`.
struct TimelineWait {
  TimePoint at{0};
  TimePoint until{0};
  int sensor = -1;
};

/// One policy's run, as the timeline reads it. Pointers are not owned.
struct TimelineRun {
  std::string policy;
  const std::vector<UnitRow>* units = nullptr;  ///< units.csv rows (after the warm-up)
  const std::vector<JobRow>* jobs = nullptr;    ///< jobs.csv rows (after the warm-up)
  /// Merge waits; null when they were not recorded (no trace.json).
  const std::vector<TimelineWait>* waits = nullptr;
  /// Merge waits after this time were not recorded (trace.json cut at --trace-events).
  std::optional<TimePoint> waits_cut;
  TimePoint end{0};  ///< end of the run
};

/// A span of the run to draw, [from, to).
struct TimelineWindow {
  TimePoint from{0};
  TimePoint to{0};
  std::string name;    ///< file stem under plots/: timeline, timeline_start, timeline_worst_miss
  std::string title;   ///< what it shows, for captions
  std::string policy;  ///< draw only this policy's run; empty: every run
};

/// Parses `--timeline FROM:TO` (seconds, FROM ≥ 0, FROM < TO ≤ FROM + 60, e.g. "2.5:4"). Error:
/// what is wrong with the text.
Expected<std::pair<Duration, Duration>> parse_timeline_window(const std::string& text);

/// The default windows: the first 2 s after the warm-up and the 2 s around the worst miss
/// of any run (the miss with the lowest QoE, a job without a result scoring 0; the
/// earliest on ties), from 0.3 s before it; one window when both start at the warm-up's
/// end. No miss: the first only.
std::vector<TimelineWindow> default_timeline_windows(const Scenario& s,
                                                     const std::vector<TimelineRun>& runs);

/// The timeline of `runs` over `window` as a standalone SVG document (also valid inline
/// in HTML). Deterministic for the same inputs. Every unit that overlaps the window is a
/// `<g class="unit">` with data-policy, data-dispatch, data-lane, data-start-ms and
/// data-end-ms (units.csv's values), so tests and tools can check it; the root carries
/// data-from-ms, data-to-ms, data-left and data-px-per-ms (x = left + (t − from) · scale).
std::string timeline_svg(const Scenario& s, const std::vector<TimelineRun>& runs,
                         const TimelineWindow& window);

}  // namespace red
