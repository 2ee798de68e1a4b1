#include "red/report/row_queue.hpp"

#include <utility>

namespace red {

RowQueue::RowQueue(RowSink& inner, std::chrono::milliseconds period)
    : inner_(inner), period_(period) {
  // Both vectors keep their capacity across swaps, so a steady run stops allocating for
  // the queue after its first batches.
  queue_.reserve(256);
  batch_.reserve(256);
  thread_ = std::thread([this] { writer(); });
}

RowQueue::~RowQueue() {
  {
    const std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  stop_cv_.notify_one();
  thread_.join();
  forward_pending();
}

void RowQueue::push(Row&& row) {
  const std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.push_back(std::move(row));
  if (queue_.size() > peak_) peak_ = queue_.size();
}

void RowQueue::on_job_row(const JobRow& row) {
  push(Row(std::in_place_type<JobRow>, row));
}

void RowQueue::on_unit_row(const UnitRow& row) {
  push(Row(std::in_place_type<UnitRow>, row));
}

void RowQueue::forward_pending() {
  const std::lock_guard<std::mutex> write(write_mutex_);
  {
    const std::lock_guard<std::mutex> lock(queue_mutex_);
    if (queue_.empty()) return;
    batch_.swap(queue_);
  }
  for (const Row& r : batch_) {
    if (const auto* j = std::get_if<JobRow>(&r))
      inner_.on_job_row(*j);
    else
      inner_.on_unit_row(std::get<UnitRow>(r));
  }
  forwarded_ += static_cast<std::int64_t>(batch_.size());
  batch_.clear();
}

void RowQueue::drain() {
  forward_pending();
}

void RowQueue::writer() {
  std::unique_lock<std::mutex> lock(queue_mutex_);
  while (!stop_) {
    stop_cv_.wait_for(lock, period_, [this] { return stop_; });
    if (stop_) break;
    lock.unlock();
    forward_pending();
    {
      // Even with no new rows: what the sink buffers is written out in time (stream.hpp).
      const std::lock_guard<std::mutex> write(write_mutex_);
      inner_.poll();
    }
    lock.lock();
  }
}

std::int64_t RowQueue::forwarded() const {
  const std::lock_guard<std::mutex> lock(write_mutex_);
  return forwarded_;
}

std::size_t RowQueue::pending() const {
  const std::lock_guard<std::mutex> lock(queue_mutex_);
  return queue_.size();
}

std::size_t RowQueue::peak_pending() const {
  const std::lock_guard<std::mutex> lock(queue_mutex_);
  return peak_;
}

}  // namespace red
