// Streamed jobs.csv and units.csv (report/stream.hpp, issue 10 item 3): the same bytes as
// jobs_csv() and units_csv() write from the same rows; whole rows in the files at any
// moment; past the window the rows are read back from the files unchanged.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "../support/cli.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/report/report.hpp"
#include "red/report/stream.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::read_text;

Scenario load(const std::string& name) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
  EXPECT_TRUE(s.has_value()) << name;
  return std::move(s.value());
}

fs::path fresh_dir(const std::string& name) {
  // The process id: test processes running side by side (ctest -j) never share one.
  const fs::path d =
      fs::temp_directory_path() / ("red-stream-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

struct Runs {
  Scenario s;
  std::vector<PolicyRun> runs;
};

// Two simulated policies of a scenario whose workload changes (events, failures none).
Runs simulated() {
  Runs r{load("case-dynamic.yaml"), {}};
  for (const char* p : {"edf", "red"}) {
    auto run = simulate_policy(r.s, default_profile(), p, 1);
    EXPECT_TRUE(run.has_value());
    r.runs.push_back(std::move(run.value()));
  }
  return r;
}

std::unique_ptr<CsvRowStream> stream_all(const Runs& r, const fs::path& dir, std::size_t window) {
  auto st = CsvRowStream::open(dir.string(), r.s, true, window);
  EXPECT_TRUE(st.has_value());
  for (const PolicyRun& run : r.runs) {
    (*st)->begin_policy(run.metrics.name);
    // Interleaved as a run reports them: the files keep each kind's order.
    std::size_t u = 0;
    for (const JobRow& j : run.jobs) {
      (*st)->on_job_row(j);
      if (u < run.units.size()) (*st)->on_unit_row(run.units[u++]);
    }
    for (; u < run.units.size(); ++u) (*st)->on_unit_row(run.units[u]);
    EXPECT_FALSE((*st)->flush().has_value());
  }
  return std::move(st.value());
}

std::string jobs_text(const Scenario& s, const std::vector<StreamedRows>& rows) {
  std::vector<PolicyRows<JobRow>> pr;
  for (const StreamedRows& r : rows) pr.push_back({r.policy, &r.jobs});
  return jobs_csv(s, pr);
}

std::string units_text(const Scenario& s, const std::vector<StreamedRows>& rows) {
  std::vector<PolicyRows<UnitRow>> pr;
  for (const StreamedRows& r : rows) pr.push_back({r.policy, &r.units});
  return units_csv(s, pr);
}

TEST(CsvRowStream, WritesTheBytesTheInMemoryWritersWrite) {
  const Runs r = simulated();
  std::vector<PolicyRows<JobRow>> jobs;
  std::vector<PolicyRows<UnitRow>> units;
  for (const PolicyRun& run : r.runs) {
    ASSERT_FALSE(run.jobs.empty());
    ASSERT_FALSE(run.units.empty());
    jobs.push_back({run.metrics.name, &run.jobs});
    units.push_back({run.metrics.name, &run.units});
  }
  const fs::path dir = fresh_dir("same");
  auto st = stream_all(r, dir, CsvRowStream::kDefaultWindow);
  // Until finish() the rows are under the .partial names only.
  EXPECT_FALSE(fs::exists(dir / "jobs.csv"));
  EXPECT_EQ(read_text(dir / "jobs.csv.partial"), jobs_csv(r.s, jobs));
  EXPECT_EQ(read_text(dir / "units.csv.partial"), units_csv(r.s, units));
  ASSERT_FALSE(st->finish().has_value());
  EXPECT_EQ(st->finished(), (std::vector<std::string>{"jobs.csv", "units.csv"}));
  EXPECT_EQ(read_text(dir / "jobs.csv"), jobs_csv(r.s, jobs));
  EXPECT_EQ(read_text(dir / "units.csv"), units_csv(r.s, units));
  EXPECT_FALSE(fs::exists(dir / "jobs.csv.partial"));
  EXPECT_FALSE(fs::exists(dir / "units.csv.partial"));
  // Within the window the report's rows come from memory, the very rows given.
  ASSERT_TRUE(st->windowed());
  auto rows = st->rows();
  ASSERT_TRUE(rows.has_value());
  ASSERT_EQ(rows->size(), 2U);
  EXPECT_EQ(jobs_text(r.s, *rows), jobs_csv(r.s, jobs));
  EXPECT_EQ(units_text(r.s, *rows), units_csv(r.s, units));
  fs::remove_all(dir);
}

TEST(CsvRowStream, PastItsWindowReadsTheRowsBackUnchanged) {
  const Runs r = simulated();
  const fs::path dir = fresh_dir("back");
  auto st = stream_all(r, dir, 50);
  EXPECT_FALSE(st->windowed());
  EXPECT_EQ(st->kept(), 0U) << "past the window nothing is held";
  auto rows = st->rows();
  ASSERT_TRUE(rows.has_value()) << rows.error().to_string();
  ASSERT_EQ(rows->size(), 2U);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ((*rows)[i].policy, r.runs[i].metrics.name);
    ASSERT_EQ((*rows)[i].jobs.size(), r.runs[i].jobs.size());
    ASSERT_EQ((*rows)[i].units.size(), r.runs[i].units.size());
    for (std::size_t k = 0; k < r.runs[i].jobs.size(); ++k) {
      const JobRow& a = r.runs[i].jobs[k];
      const JobRow& b = (*rows)[i].jobs[k];
      EXPECT_EQ(a.operation, b.operation);
      EXPECT_EQ(a.seq, b.seq);
      EXPECT_EQ(a.release, b.release);
      EXPECT_EQ(a.deadline, b.deadline);
      EXPECT_EQ(a.outcome, b.outcome);
      if (a.outcome == JobOutcome::Met || a.outcome == JobOutcome::Missed) {
        EXPECT_EQ(a.finish, b.finish);
        EXPECT_EQ(a.frame_age, b.frame_age);
        EXPECT_NEAR(a.qoe, b.qoe, 5e-7);  // jobs.csv holds 6 decimals
      }
      EXPECT_EQ(a.reason, b.reason);
    }
  }
  // Written again, the rows read back give the same files.
  EXPECT_EQ(jobs_text(r.s, *rows), read_text(dir / "jobs.csv.partial"));
  EXPECT_EQ(units_text(r.s, *rows), read_text(dir / "units.csv.partial"));
  // Renamed into place, they are read back from there.
  ASSERT_FALSE(st->finish().has_value());
  auto again = st->rows();
  ASSERT_TRUE(again.has_value()) << again.error().to_string();
  EXPECT_EQ(jobs_text(r.s, *again), read_text(dir / "jobs.csv"));
  fs::remove_all(dir);
}

TEST(CsvRowStream, TheFilesHoldWholeRowsAtAnyMoment) {
  const Runs r = simulated();
  const fs::path dir = fresh_dir("whole");
  auto st = CsvRowStream::open(dir.string(), r.s, true);
  ASSERT_TRUE(st.has_value());
  (*st)->begin_policy("red");
  const std::vector<JobRow>& jobs = r.runs[1].jobs;
  std::size_t checked = 0;
  std::size_t n = 0;
  for (int round = 0; round < 40; ++round)
    for (const JobRow& j : jobs) {
      (*st)->on_job_row(j);
      if (++n % 97 != 0) continue;
      // Not flushed: what a reader (or a crash) finds now.
      const std::string text = read_text(dir / "jobs.csv.partial");
      if (text.size() <= jobs_csv_header().size()) continue;
      ++checked;
      ASSERT_EQ(text.back(), '\n');
      std::istringstream in(text);
      for (std::string line; std::getline(in, line);)
        ASSERT_EQ(std::count(line.begin(), line.end(), ','), 13) << line;
    }
  EXPECT_GT(checked, 0U) << "the buffer must have been written out at least once";
  EXPECT_FALSE((*st)->flush().has_value());
  EXPECT_EQ((*st)->job_rows(), static_cast<std::int64_t>(40 * jobs.size()));
  fs::remove_all(dir);
}

TEST(CsvRowStream, ABadFileReadBackNamesItsLine) {
  const Scenario s = load("case-dynamic.yaml");
  const fs::path dir = fresh_dir("bad");
  fs::create_directories(dir);
  {
    std::ofstream f(dir / "jobs.csv");
    f << jobs_csv_header() << "red,navigate,0,1.0,2.0,3.0,met,1.0,1.0,0.5,,2.0,,\n"
      << "red,nosuch,1,1.0,2.0,3.0,met,1.0,1.0,0.5,,2.0,,\n";
  }
  auto rows = read_job_rows((dir / "jobs.csv").string(), s);
  ASSERT_FALSE(rows.has_value());
  EXPECT_EQ(rows.error().line, 3);
  EXPECT_NE(rows.error().message.find("nosuch"), std::string::npos);
  auto missing = read_unit_rows((dir / "units.csv").string(), s);
  ASSERT_FALSE(missing.has_value());
  fs::remove_all(dir);
}

class FakeClock final : public Clock {
 public:
  [[nodiscard]] TimePoint now() const noexcept override { return now_; }
  void advance(Duration d) { now_ += d; }

 private:
  TimePoint now_{0};
};

// Issue 39 item 3: a row waits in the buffer at most kFlushInterval once another row or a
// poll() (RowQueue's writer, at each look) comes after it, so a kill loses at most the
// last second. Driven by a fake clock: no waiting, no timing.
TEST(CsvRowStream, ARowWaitsAtMostTheFlushInterval) {
  const Runs r = simulated();
  const fs::path dir = fresh_dir("interval");
  FakeClock clock;
  auto st = CsvRowStream::open(dir.string(), r.s, true, CsvRowStream::kDefaultWindow, &clock);
  ASSERT_TRUE(st.has_value());
  const fs::path jobs = dir / "jobs.csv.partial";
  const fs::path units = dir / "units.csv.partial";
  EXPECT_EQ(read_text(jobs), jobs_csv_header());  // the header at once
  (*st)->begin_policy("red");
  const JobRow& row = r.runs[1].jobs.front();
  (*st)->on_job_row(row);
  (*st)->on_unit_row(r.runs[1].units.front());
  // Far below the 64 KiB buffer and before the interval: still in memory.
  clock.advance(CsvRowStream::kFlushInterval - std::chrono::nanoseconds(1));
  (*st)->poll();
  EXPECT_EQ(read_text(jobs), jobs_csv_header());
  EXPECT_EQ(read_text(units), units_csv_header());
  // One interval after the last write: a poll writes both files out, whole rows.
  clock.advance(std::chrono::nanoseconds(1));
  (*st)->poll();
  std::string one;
  append_job_row(one, r.s, "red", row);
  EXPECT_EQ(read_text(jobs), jobs_csv_header() + one);
  EXPECT_GT(read_text(units).size(), units_csv_header().size());
  // A row that comes an interval later is written out with itself, no poll needed.
  (*st)->on_job_row(row);
  EXPECT_EQ(read_text(jobs), jobs_csv_header() + one);
  clock.advance(CsvRowStream::kFlushInterval);
  (*st)->on_job_row(row);
  EXPECT_EQ(read_text(jobs), jobs_csv_header() + one + one + one);
  fs::remove_all(dir);
}

// Issue 39 item 4: a file whose writes fail (jobs.csv.partial leads to /dev/full, as a full
// disk) stops alone: the other file is written whole and renamed into place, the rows are
// still counted and kept for the report, and flush() and finish() name the path and the
// system's reason.
TEST(CsvRowStream, AFileThatCannotBeWrittenStopsAloneAndTheRunGoesOn) {
  const Runs r = simulated();
  const fs::path dir = fresh_dir("full");
  fs::create_directories(dir);
  fs::create_symlink("/dev/full", dir / "jobs.csv.partial");
  auto st = CsvRowStream::open(dir.string(), r.s, true);
  ASSERT_TRUE(st.has_value()) << "a write that fails is no reason to stop before the run";
  for (const PolicyRun& run : r.runs) {
    (*st)->begin_policy(run.metrics.name);
    for (const JobRow& j : run.jobs) (*st)->on_job_row(j);
    for (const UnitRow& u : run.units) (*st)->on_unit_row(u);
  }
  const auto e = (*st)->flush();
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->file, (dir / "jobs.csv.partial").string());
  EXPECT_NE(e->message.find("No space left on device"), std::string::npos) << e->message;
  EXPECT_EQ((*st)->job_rows(),
            static_cast<std::int64_t>(r.runs[0].jobs.size() + r.runs[1].jobs.size()));
  auto rows = (*st)->rows();
  ASSERT_TRUE(rows.has_value());
  EXPECT_EQ((*rows)[1].jobs.size(), r.runs[1].jobs.size());
  ASSERT_TRUE((*st)->finish().has_value());
  EXPECT_EQ((*st)->finished(), std::vector<std::string>{"units.csv"});
  std::vector<PolicyRows<UnitRow>> units;
  for (const PolicyRun& run : r.runs) units.push_back({run.metrics.name, &run.units});
  EXPECT_EQ(read_text(dir / "units.csv"), units_csv(r.s, units));
  EXPECT_FALSE(fs::exists(dir / "jobs.csv"));
  fs::remove_all(dir);
}

// Without finish() (a kill, an error) the rows stay under the .partial names: a reader never
// takes them for a complete jobs.csv.
TEST(CsvRowStream, WithoutFinishOnlyPartialFilesRemain) {
  const Runs r = simulated();
  const fs::path dir = fresh_dir("unfinished");
  { auto st = stream_all(r, dir, CsvRowStream::kDefaultWindow); }
  EXPECT_FALSE(fs::exists(dir / "jobs.csv"));
  EXPECT_FALSE(fs::exists(dir / "units.csv"));
  EXPECT_GT(read_text(dir / "jobs.csv.partial").size(), jobs_csv_header().size());
  fs::remove_all(dir);
}

TEST(CsvRowStream, AnUnwritableDirectoryIsAnError) {
  const Scenario s = load("case-dynamic.yaml");
  auto st = CsvRowStream::open("/proc/red-no-such-dir", s, true);
  EXPECT_FALSE(st.has_value());
}

}  // namespace
}  // namespace red
