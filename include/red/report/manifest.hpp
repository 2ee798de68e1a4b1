#pragma once
/// \file
/// The files one run writes into an output directory, marked as one set (docs/REPORTS.md,
/// "The output directory"): every run gets a run id (16 random hex digits), written into
/// the files whose format has room for it (summary.json, trace.json, index.html, ...), and
/// the set ends with manifest.json, written last, listing each file with its size:
///
///     auto set = OutputSet::begin(dir, "compare");   // the old manifest.json is replaced
///     ... write the files, set->add("summary.json") for each ...
///     set->finish();                                 // manifest.json, "complete": true
///
/// A directory is a complete result when its manifest.json says "complete": true and each
/// file it lists has the size it gives. A run killed before finish() leaves the manifest
/// begin() wrote: "complete": false and no files.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"

namespace red {

/// The name of the manifest in an output directory.
inline constexpr const char* kManifestName = "manifest.json";

/// One run's set of files in one directory. Not thread-safe.
class OutputSet {
 public:
  /// Creates `dir` and marks it as holding an unfinished run: a manifest.json with the new
  /// run id, "complete": false and no files replaces any there (or, if it cannot be
  /// written, the old one is removed). `command` is the red subcommand, for the reader.
  /// Error: the directory cannot be created, or an old manifest cannot be replaced or
  /// removed (names the path and the system's reason).
  static Expected<OutputSet> begin(const std::string& dir, std::string command);

  /// As begin(), for a run whose id is known: `red report` rewriting part of a run's files
  /// marks the directory unfinished under the same run id until its finish().
  static Expected<OutputSet> reopen(const std::string& dir, std::string command,
                                    std::string run_id);

  /// A set whose run id is given (tests); nothing is written until finish().
  OutputSet(std::string dir, std::string command, std::string run_id);

  /// 16 lower-case hex digits, random for each run.
  [[nodiscard]] const std::string& run_id() const noexcept { return run_id_; }
  /// The run's start, UTC, as "2026-11-28T00:38:23Z".
  [[nodiscard]] const std::string& started() const noexcept { return started_; }
  [[nodiscard]] const std::string& dir() const noexcept { return dir_; }

  /// `relative` (to dir()) was written whole. Listed once, in the order first added.
  void add(const std::string& relative);
  /// A file that could not be written: the set is not complete.
  void fail(const Error& e);
  /// The run was stopped early by `signal_name` (its files are whole, but hold less).
  void stopped(std::string signal_name) { stopped_ = std::move(signal_name); }
  [[nodiscard]] const std::vector<Error>& failures() const noexcept { return failures_; }

  /// manifest.json's text: run id, start, command, "complete" (no failure), the files
  /// added with their sizes now (a file gone since is left out and the set is incomplete).
  [[nodiscard]] std::string manifest_json() const;
  /// Writes manifest.json (atomically), last. Error names its path and the reason.
  [[nodiscard]] std::optional<Error> finish();

 private:
  std::string dir_;
  std::string command_;
  std::string run_id_;
  std::string started_;
  std::vector<std::string> files_;
  std::vector<Error> failures_;
  std::optional<std::string> stopped_;
};

/// A new run id: 16 lower-case hex digits from std::random_device.
std::string new_run_id();

}  // namespace red
