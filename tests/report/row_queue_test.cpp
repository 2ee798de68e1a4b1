// RowQueue (report/row_queue.hpp): rows reach the inner sink whole, once, in the order each
// thread reported them, one call at a time, off the reporting thread; drain() and the
// destructor leave nothing behind; streamed through it, jobs.csv and units.csv are the bytes
// a direct stream writes. Run under the thread sanitizer too (scripts/test.sh).

#include "red/report/row_queue.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../support/cli.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/report/stream.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;

// Records what it gets, and fails if two calls ever overlap.
class RecordingSink final : public RowSink {
 public:
  void on_job_row(const JobRow& row) override { record('j', row.operation, row.seq); }
  void on_unit_row(const UnitRow& row) override {
    record('u', row.lane, row.dispatch);
    EXPECT_EQ(row.jobs, "op#" + std::to_string(row.dispatch));
  }
  struct Seen {
    char kind;
    int source;
    std::uint64_t n;
    std::thread::id thread;
  };
  std::vector<Seen> seen() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return seen_;
  }
  bool overlapped() const { return overlapped_.load(); }

 private:
  void record(char kind, int source, std::uint64_t n) {
    if (busy_.exchange(true)) overlapped_ = true;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      seen_.push_back({kind, source, n, std::this_thread::get_id()});
    }
    busy_ = false;
  }
  std::mutex mutex_;
  std::vector<Seen> seen_;
  std::atomic<bool> busy_{false}, overlapped_{false};
};

JobRow job_row(int source, std::uint64_t n) {
  JobRow r;
  r.operation = source;
  r.seq = n;
  r.reason = n % 3 == 0 ? "a reason long enough to live outside the string's own buffer" : "";
  return r;
}

UnitRow unit_row(int source, std::uint64_t n) {
  UnitRow r;
  r.lane = source;
  r.dispatch = n;
  r.jobs = "op#" + std::to_string(n);
  return r;
}

TEST(RowQueue, EveryRowArrivesOnceInEachThreadsOrderOneCallAtATime) {
  RecordingSink sink;
  constexpr int kThreads = 4;
  constexpr std::uint64_t kRows = 3000;
  {
    RowQueue queue(sink, std::chrono::milliseconds(1));
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
      threads.emplace_back([&queue, t] {
        for (std::uint64_t i = 0; i < kRows; ++i) {
          if (i % 2 == 0)
            queue.on_job_row(job_row(t, i));
          else
            queue.on_unit_row(unit_row(t, i));
        }
      });
    // drain() beside the writer, while rows still come.
    for (int k = 0; k < 20; ++k) queue.drain();
    for (std::thread& th : threads) th.join();
    queue.drain();
    EXPECT_EQ(queue.pending(), 0u);
    EXPECT_EQ(queue.forwarded(), static_cast<std::int64_t>(kThreads * kRows));
    EXPECT_GE(queue.peak_pending(), 1u);
  }
  const auto seen = sink.seen();
  ASSERT_EQ(seen.size(), kThreads * kRows);
  EXPECT_FALSE(sink.overlapped());
  std::vector<std::uint64_t> next(kThreads, 0);
  for (const auto& s : seen) {
    ASSERT_GE(s.source, 0);
    ASSERT_LT(s.source, kThreads);
    EXPECT_EQ(s.n, next[static_cast<std::size_t>(s.source)]) << "thread " << s.source;
    EXPECT_EQ(s.kind, s.n % 2 == 0 ? 'j' : 'u');
    next[static_cast<std::size_t>(s.source)] = s.n + 1;
  }
  for (std::uint64_t n : next) EXPECT_EQ(n, kRows);
}

TEST(RowQueue, TheWriterThreadForwardsWithoutBeingAsked) {
  RecordingSink sink;
  RowQueue queue(sink, std::chrono::milliseconds(1));
  for (std::uint64_t i = 0; i < 10; ++i) queue.on_job_row(job_row(0, i));
  // Waits for the writer (no drain): up to a minute, so a loaded machine cannot fail it.
  const auto until = std::chrono::steady_clock::now() + std::chrono::minutes(1);
  while (queue.forwarded() < 10 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(queue.forwarded(), 10);
  for (const auto& s : sink.seen()) EXPECT_NE(s.thread, std::this_thread::get_id());
}

// Counts the polls it gets and says when the first came.
class PolledSink final : public RowSink {
 public:
  void on_job_row(const JobRow&) override {}
  void on_unit_row(const UnitRow&) override {}
  void poll() override {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++polls_;
    polled_.notify_all();
  }
  // Waits for a first poll; false if none came within `limit` (a hang, not a timing).
  bool wait_for_poll(std::chrono::seconds limit) {
    std::unique_lock<std::mutex> lock(mutex_);
    return polled_.wait_for(lock, limit, [this] { return polls_ > 0; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable polled_;
  int polls_ = 0;
};

// With no rows at all the writer still polls its sink, so that a stream writes out its
// buffered rows in time after the last row (stream.hpp, kFlushInterval).
TEST(RowQueue, TheWriterPollsItsSinkWithoutRows) {
  PolledSink sink;
  RowQueue queue(sink, std::chrono::milliseconds(1));
  EXPECT_TRUE(sink.wait_for_poll(std::chrono::seconds(60)));
  EXPECT_EQ(queue.forwarded(), 0);
}

TEST(RowQueue, TheDestructorForwardsWhatIsLeft) {
  RecordingSink sink;
  {
    // A writer that would not look for an hour: only the destructor can forward.
    RowQueue queue(sink, std::chrono::hours(1));
    for (std::uint64_t i = 0; i < 5; ++i) queue.on_unit_row(unit_row(1, i));
    EXPECT_EQ(queue.forwarded(), 0);
    EXPECT_EQ(queue.pending(), 5u);
  }
  EXPECT_EQ(sink.seen().size(), 5u);
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("red-row-queue-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

TEST(RowQueue, StreamedThroughItTheCsvFilesAreTheDirectStreamsBytes) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/case-dynamic.yaml");
  ASSERT_TRUE(s.has_value());
  std::vector<PolicyRun> runs;
  for (const char* p : {"edf", "red"}) {
    auto run = simulate_policy(*s, default_profile(), p, 1);
    ASSERT_TRUE(run.has_value());
    runs.push_back(std::move(run.value()));
  }
  const fs::path direct = fresh_dir("direct"), queued = fresh_dir("queued");
  {
    auto a = CsvRowStream::open(direct.string(), *s, true);
    auto b = CsvRowStream::open(queued.string(), *s, true);
    ASSERT_TRUE(a.has_value());
    ASSERT_TRUE(b.has_value());
    RowQueue queue(**b, std::chrono::milliseconds(1));
    for (const PolicyRun& run : runs) {
      (*a)->begin_policy(run.metrics.name);
      (*b)->begin_policy(run.metrics.name);
      // Jobs and units interleaved as a run reports them: the files are per kind.
      const std::size_t n = std::max(run.jobs.size(), run.units.size());
      for (std::size_t i = 0; i < n; ++i) {
        if (i < run.units.size()) {
          (*a)->on_unit_row(run.units[i]);
          queue.on_unit_row(run.units[i]);
        }
        if (i < run.jobs.size()) {
          (*a)->on_job_row(run.jobs[i]);
          queue.on_job_row(run.jobs[i]);
        }
      }
      queue.drain();
      EXPECT_FALSE((*a)->flush().has_value());
      EXPECT_FALSE((*b)->flush().has_value());
    }
    EXPECT_EQ((*b)->job_rows(), (*a)->job_rows());
    EXPECT_GT((*b)->job_rows(), 0);
    EXPECT_EQ((*b)->unit_rows(), (*a)->unit_rows());
    EXPECT_FALSE((*a)->finish().has_value());
    EXPECT_FALSE((*b)->finish().has_value());
  }
  for (const char* f : {"jobs.csv", "units.csv"})
    EXPECT_EQ(test::read_text(queued / f), test::read_text(direct / f)) << f;
  fs::remove_all(direct);
  fs::remove_all(queued);
}

}  // namespace
}  // namespace red
