#pragma once
/// \file
/// jobs.csv and units.csv written as a real run goes (docs/REPORTS.md, "Streamed rows"):
/// a run of any length keeps only a bounded buffer and a bounded window of rows. While the
/// run goes the rows go to jobs.csv.partial and units.csv.partial, renamed to jobs.csv and
/// units.csv by finish(): a run killed before leaves only the .partial files. Rows are
/// appended in whole lines (a write never ends inside a row), so the files are valid CSV
/// at any moment, and no row waits in memory longer than kFlushInterval (checked at each
/// row and at each poll()); the bytes are those jobs_csv() and units_csv() write from the
/// same rows.
///
///     auto stream = CsvRowStream::open(dir, scenario, true);
///     stream->begin_policy("red");
///     collector.set_sink(stream->get());   // MetricsCollector hands over every row
///     ... run ...
///     stream->flush();                     // after each policy, and before reading back
///     stream->finish();                    // at the end: renamed into place
///
/// A write that fails (a full disk) stops that file only: its later rows are dropped, the
/// run goes on, and flush() and finish() return the error.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "red/core/clock.hpp"
#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// A policy's rows of a streamed run, for the report.
struct StreamedRows {
  std::string policy;
  std::vector<JobRow> jobs;
  std::vector<UnitRow> units;
};

/// Writes jobs.csv (and units.csv) rows as they come. Not thread-safe: one thread reports
/// the rows (the runtime's observer thread).
class CsvRowStream final : public RowSink {
 public:
  /// Bytes buffered before a write (whole rows): 64 KiB.
  static constexpr std::size_t kBufferBytes = std::size_t{1} << 16;
  /// Rows kept in memory for the report by default (jobs and units together, every
  /// policy): past it the report reads the rows back from the files.
  static constexpr std::size_t kDefaultWindow = std::size_t{1} << 13;
  /// The longest a row waits in the buffer once a row or a poll() comes after it: a kill
  /// loses at most the rows of the last second.
  static constexpr Duration kFlushInterval = std::chrono::seconds(1);

  /// Creates `dir` and its jobs.csv.partial (and units.csv.partial when `units`) with their
  /// headers, replacing any there. `clock` (null: the steady clock) times kFlushInterval and
  /// must outlive the stream. Error names the path that cannot be created or opened and the
  /// reason; a header that cannot be written is flush()'s error, as a row's would be.
  static Expected<std::unique_ptr<CsvRowStream>> open(const std::string& dir, const Scenario& s,
                                                      bool units,
                                                      std::size_t window = kDefaultWindow,
                                                      const Clock* clock = nullptr);
  ~CsvRowStream() override;
  CsvRowStream(const CsvRowStream&) = delete;
  CsvRowStream& operator=(const CsvRowStream&) = delete;

  /// The rows that follow belong to `policy` (its runs come one after another).
  void begin_policy(std::string policy);

  void on_job_row(const JobRow& row) override;
  void on_unit_row(const UnitRow& row) override;
  /// Writes what is buffered when the last write is kFlushInterval old or more.
  void poll() override;

  /// Writes what is buffered. The first write error (also one met while buffering), if any.
  [[nodiscard]] std::optional<Error> flush();
  /// Flushes, closes the files and renames each one that was written whole into place
  /// (jobs.csv.partial to jobs.csv). The first error (a write or a rename), if any; a file
  /// that failed keeps its .partial name. Call once, after the last flush() and rows().
  [[nodiscard]] std::optional<Error> finish();
  /// The files renamed into place by finish() ("jobs.csv", "units.csv").
  [[nodiscard]] const std::vector<std::string>& finished() const noexcept { return finished_; }

  /// True while every row so far is also held in memory (rows()).
  [[nodiscard]] bool windowed() const noexcept { return !overflowed_; }
  /// The rows of every policy so far, from memory while windowed(), else read back from
  /// the files (after a flush). Error: a file that cannot be read back.
  [[nodiscard]] Expected<std::vector<StreamedRows>> rows() const;

  [[nodiscard]] std::int64_t job_rows() const noexcept { return job_rows_; }
  [[nodiscard]] std::int64_t unit_rows() const noexcept { return unit_rows_; }
  /// Rows held in memory now (at most the window).
  [[nodiscard]] std::size_t kept() const noexcept;

 private:
  struct File {
    std::string name;     // "jobs.csv"
    std::string path;     // dir/jobs.csv
    std::string partial;  // dir/jobs.csv.partial, where the rows go until finish()
    int fd = -1;
    bool failed = false;  // a write failed: later rows are dropped
    bool renamed = false;
    std::string buffer;
  };
  CsvRowStream(const Scenario& s, std::size_t window, const Clock* clock);
  void write_out(File& f);
  void flush_if_due();
  void keep(bool job, const JobRow* j, const UnitRow* u);

  const Scenario& scenario_;
  SteadyClock own_clock_;
  const Clock* clock_;
  TimePoint last_write_{};
  std::vector<std::string> finished_;
  std::size_t window_;
  File jobs_, units_;
  bool with_units_ = false;
  std::string policy_;
  std::vector<std::string> policies_;
  std::vector<StreamedRows> kept_;
  std::size_t kept_rows_ = 0;
  bool overflowed_ = false;
  std::int64_t job_rows_ = 0, unit_rows_ = 0;
  std::optional<Error> error_;
};

/// Rows of a jobs.csv (as jobs_csv() writes it) per policy, in file order. `s` gives the
/// operation names. Error: `file:line: what is wrong`.
Expected<std::vector<std::pair<std::string, std::vector<JobRow>>>> read_job_rows(
    const std::string& path, const Scenario& s);

/// Rows of a units.csv (as units_csv() writes it) per policy, in file order. Error as
/// read_job_rows().
Expected<std::vector<std::pair<std::string, std::vector<UnitRow>>>> read_unit_rows(
    const std::string& path, const Scenario& s);

}  // namespace red
