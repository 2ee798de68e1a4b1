#pragma once
/// \file
/// Plots with gnuplot, PNG and SVG, for a person to look at (docs/REPORTS.md, "Plots"):
/// the response-time histogram per policy (the paper's Fig. 7) and its CDF, bars of miss
/// rate, latency and QoE per policy (Fig. 6), the miss rate over time for scenarios with
/// workload events (Fig. 1), and sweep curves (Tables 4 and 5).
///
/// Every plot leaves its data (`plots/NAME.dat`) and script (`plots/NAME.gp`) next to the
/// images, so a person can re-run `gnuplot NAME.gp` after editing a label. gnuplot is an
/// edge tool: when it is missing or fails, the report says why and the run goes on.
///
///     PlotReport r = write_run_plots("out/x", scenario, {{"red", &metrics, &jobs}});
///     if (!r.note.empty()) std::cerr << "red: " << r.note << '\n';

#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// One policy's run, as the plots read it. Pointers are not owned.
struct PlotRun {
  std::string policy;
  const PolicyMetrics* metrics = nullptr;
  const std::vector<JobRow>* jobs = nullptr;
};

/// One policy's sweep results: one PolicyMetrics per swept value, in value order.
struct SweepSeries {
  std::string policy;
  std::vector<PolicyMetrics> points;
};

/// How plots are made.
struct PlotOptions {
  std::string gnuplot = "gnuplot";  ///< command or path; empty: write data and scripts only
  std::string subdir = "plots";     ///< under the output directory
  bool svg = true;                  ///< an SVG beside every PNG
};

/// One plot: image paths relative to the output directory.
struct PlotFile {
  std::string name;   ///< e.g. "response_hist"
  std::string title;  ///< what it shows, for captions
  std::string png;    ///< e.g. "plots/response_hist.png"
  std::string svg;    ///< empty without SVG
};

/// What was made.
struct PlotReport {
  std::vector<PlotFile> plots;  ///< images that exist and are non-empty
  /// One line on what was skipped by choice or for want of gnuplot (data and scripts are
  /// written all the same); empty when gnuplot drew.
  std::string note;
  /// The data and scripts written (e.g. "plots/response_hist.dat", ".gp"), besides the images.
  std::vector<std::string> files;
  /// Outputs lost: a file that could not be written, an image gnuplot failed to draw (path,
  /// and the system's reason or gnuplot's first line of complaint). A caller treats each as
  /// a failed output (`red` exits 1).
  std::vector<Error> errors;
};

/// The PNG terminal gnuplot offers ("pngcairo" or "png"), or empty when `gnuplot` cannot
/// be run. Runs gnuplot once per distinct command (the answer is cached).
std::string gnuplot_png_terminal(const std::string& gnuplot = "gnuplot");

/// Plots of one or more policies' runs of scenario `s` into `dir/subdir`: response_hist,
/// response_cdf, metrics_bars, and (when `s` has workload events) miss_over_time. Never
/// throws for a tool problem; errors writing files go to `note` too.
PlotReport write_run_plots(const std::string& dir, const Scenario& s,
                           const std::vector<PlotRun>& runs, const PlotOptions& options = {});

/// Sweep curves into `dir/subdir`: sweep_miss_rate, sweep_latency, sweep_qoe (x: the swept
/// parameter, one line per policy).
PlotReport write_sweep_plots(const std::string& dir, const std::string& scenario,
                             const std::string& parameter, const std::vector<double>& values,
                             const std::vector<SweepSeries>& series,
                             const PlotOptions& options = {});

/// The colour (`#rrggbb`) a policy's curves and bars are drawn in: each preset its own, the
/// same in every plot; another name the palette's colour at `index` (its place in the run).
std::string policy_color(const std::string& policy, std::size_t index);

/// A label for a sweep parameter with its unit ("deadline scale (× the scenario's)").
std::string parameter_label(const std::string& parameter);

}  // namespace red
