#pragma once
/// \file
/// A RowSink that hands its rows to another sink on a thread of its own, so that formatting
/// and writing rows (CsvRowStream) stays off the thread that reports them: in a real run
/// that is a lane's handler, between one unit's completion and the next unit's start, under
/// the scheduler's lock (docs/REPORTS.md, "Streamed rows").
///
///     auto stream = CsvRowStream::open(dir, scenario, true);
///     RowQueue queue(**stream);           // its writer thread starts here
///     collector.set_sink(&queue);         // rows go into the queue as they are made
///     ... run ...
///     queue.drain();                      // every row so far has reached the stream
///     (*stream)->flush();
///
/// The reporting side only moves the row into a vector under a mutex that the writer holds
/// just long enough to swap vectors; it never waits for a write and makes no system call
/// (the writer is not woken: it looks every `period`). At each look the writer also calls
/// `inner.poll()`, so a buffering sink writes out rows in time when no new row comes.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <thread>
#include <variant>
#include <vector>

#include "red/metrics/metrics.hpp"

namespace red {

/// Queues rows and forwards them, in the order they came, to `inner` on its own thread.
/// on_job_row() and on_unit_row() may be called from any thread (one at a time or not);
/// `inner` is called from one thread at a time: the writer's, or drain()'s caller.
class RowQueue final : public RowSink {
 public:
  /// How often the writer thread looks for rows by default.
  static constexpr std::chrono::milliseconds kDefaultPeriod{20};

  /// Starts the writer thread. `inner` must outlive the queue.
  explicit RowQueue(RowSink& inner, std::chrono::milliseconds period = kDefaultPeriod);
  /// Forwards what is left (drain()) and stops the writer thread.
  ~RowQueue() override;
  RowQueue(const RowQueue&) = delete;
  RowQueue& operator=(const RowQueue&) = delete;

  void on_job_row(const JobRow& row) override;
  void on_unit_row(const UnitRow& row) override;

  /// Forwards every row queued so far to `inner` before it returns (on the caller's thread,
  /// or by waiting for the writer's batch in progress). Call before reading what `inner`
  /// made (CsvRowStream::flush(), rows(), begin_policy()).
  void drain();

  /// Rows forwarded to `inner` so far.
  [[nodiscard]] std::int64_t forwarded() const;
  /// Rows waiting in the queue now (forwarded at the writer's next look).
  [[nodiscard]] std::size_t pending() const;
  /// The most rows that waited at once: what the queue's memory grows with.
  [[nodiscard]] std::size_t peak_pending() const;

 private:
  using Row = std::variant<JobRow, UnitRow>;
  void push(Row&& row);
  void forward_pending();  // swaps the queue out and hands it to inner_; holds write_mutex_
  void writer();

  RowSink& inner_;
  std::chrono::milliseconds period_;
  mutable std::mutex queue_mutex_;  // guards queue_, peak_ and stop_
  std::vector<Row> queue_;
  std::size_t peak_ = 0;
  bool stop_ = false;
  std::condition_variable stop_cv_;  // wakes the writer only to stop
  // Held while rows go to inner_, so that batches reach it whole and in order.
  mutable std::mutex write_mutex_;
  std::vector<Row> batch_;  // the batch being forwarded (kept for its capacity)
  std::int64_t forwarded_ = 0;
  std::thread thread_;
};

}  // namespace red
