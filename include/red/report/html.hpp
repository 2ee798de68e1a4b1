#pragma once
/// \file
/// index.html for `red compare` and `red sweep` (docs/REPORTS.md, "index.html"): one static
/// page with the results table, the plots and links to every file of the run. No scripts,
/// no network, no external assets: it opens from disk.
///
///     HtmlPage page = compare_page(header, metrics, plots, files);
///     write_file(dir, "index.html", render_html(page));

#include <string>
#include <utility>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/report/plots.hpp"
#include "red/report/report.hpp"

namespace red {

/// A table; cells are plain text (escaped when rendered).
struct HtmlTable {
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

/// A link to a file of the run (relative to index.html).
struct HtmlLink {
  std::string href;
  std::string note;  ///< what the file holds
};

/// A section of its own after the results: a heading, an introduction, tables and HTML
/// made by RED itself (inline SVG), inserted as it is.
struct HtmlSection {
  std::string id;  ///< anchor
  std::string heading;
  std::vector<std::string> paragraphs;  ///< plain text
  std::vector<HtmlTable> tables;
  std::vector<std::string> raw_html;  ///< trusted markup written by RED (never user text)
};

/// Everything a page shows.
struct HtmlPage {
  std::string title;
  std::vector<std::pair<std::string, std::string>> facts;  ///< scenario, backend, seed, ...
  /// The pictures that open the page, under "Which policy, and why jobs missed": plots,
  /// then sections (the timeline); the tables follow them.
  std::vector<PlotFile> lead_plots;
  std::vector<HtmlSection> lead_sections;
  std::vector<HtmlTable> tables;
  std::vector<HtmlSection> sections;  ///< after the results, before the plots
  std::vector<PlotFile> plots;
  std::string plots_note;  ///< why plots are missing, if they are
  std::vector<HtmlLink> files;
  std::vector<std::string> how_to_read;  ///< paragraphs (plain text)
  /// The run id of the output set, as <meta name="red-run-id">; empty: none.
  std::string run_id;
};

/// The page as HTML text: deterministic for the same page.
std::string render_html(const HtmlPage& page);

/// The comparison table of report::comparison_table as an HtmlTable: policy, jobs, miss %,
/// drop %, mean ms, p99 ms, QoE, encoder runs and the ratios vs `baseline`.
HtmlTable comparison_html_table(const std::vector<PolicyMetrics>& policies,
                                const std::string& baseline);

/// The page of `red compare` (and `red simulate`): header facts, the comparison table, the
/// plots, the files and how to read them.
HtmlPage compare_page(const SummaryHeader& header, const std::vector<PolicyMetrics>& policies,
                      const PlotReport& plots, const std::vector<HtmlLink>& files);

/// The page of `red sweep`: one table per metric (policy × swept value) and the curves.
HtmlPage sweep_page(const std::string& scenario, std::uint64_t seed, const std::string& parameter,
                    const std::vector<double>& values, const std::vector<SweepSeries>& series,
                    const PlotReport& plots, const std::vector<HtmlLink>& files);

/// `text` with &, <, >, " and ' escaped for HTML.
std::string html_escape(const std::string& text);

}  // namespace red
