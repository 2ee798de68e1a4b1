#include "red/runtime/synthetic_backend.hpp"

#include <chrono>
#include <stdexcept>
#include <thread>

namespace red {

SyntheticBackend::SyntheticBackend(const Scenario& s, const Profile& p, std::uint64_t seed,
                                   Options o)
    : sampler_(s, p, seed), options_(std::move(o)) {}

SyntheticBackend::~SyntheticBackend() {
  {
    std::lock_guard lock(hang_mu_);
    ending_ = true;
  }
  hang_cv_.notify_all();
  for (auto& w : workers_) {
    {
      std::lock_guard lock(w->mu);
      w->stop = true;
    }
    w->cv.notify_all();
    w->thread.join();
  }
}

void SyntheticBackend::run(int /*lane*/, const Dispatch& d) {
  spend(d);
}

void SyntheticBackend::spend(const Dispatch& d) {
  runs_.fetch_add(1, std::memory_order_relaxed);
  if (lost_.load(std::memory_order_acquire))
    throw DeviceLostError("injected device fault (seen earlier)");
  if (options_.inject) {
    const int what = options_.inject(d);
    if (what == 4) {
      std::unique_lock lock(hang_mu_);
      hang_cv_.wait(lock, [this] { return ending_; });
      return;
    }
    if (what == 5) {
      lost_.store(true, std::memory_order_release);
      throw DeviceLostError("injected device fault");
    }
    if (what == 1) throw std::runtime_error("injected failure");
    if (what == 2) throw OutOfMemoryError("injected out-of-memory");
    if (what == 3) {
      // A hang: the call does not return for `hang`, then returns as if it had worked.
      std::this_thread::sleep_for(options_.hang);
      return;
    }
  }
  const auto t = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      Duration{static_cast<std::int64_t>(static_cast<double>(sampler_.sample(d).count()) *
                                         options_.time_scale)});
  if (t <= std::chrono::steady_clock::duration::zero()) return;
  const auto until = std::chrono::steady_clock::now() + t;
  if (options_.spin) {
    while (std::chrono::steady_clock::now() < until) {
    }
  } else {
    std::this_thread::sleep_until(until);
  }
}

SyntheticBackend::Worker& SyntheticBackend::worker(int lane) {
  std::lock_guard lock(workers_mu_);
  const auto l = static_cast<std::size_t>(lane);
  if (workers_.size() <= l) workers_.resize(l + 1);
  if (!workers_[l]) {
    workers_[l] = std::make_unique<Worker>();
    Worker& w = *workers_[l];
    // Started from the lane's handler: it inherits the handler's scheduling class and cores,
    // as a backend's compute threads do.
    w.thread = std::thread([this, &w] { worker_main(w); });
  }
  return *workers_[l];
}

void SyntheticBackend::enqueue(int lane, const Dispatch& d) {
  if (!options_.asynchronous) {
    run(lane, d);
    return;
  }
  Worker& w = worker(lane);
  {
    std::lock_guard lock(w.mu);
    w.queued.push_back(d);  // the unit keeps its own copy: `d` is only borrowed
  }
  w.cv.notify_all();
}

UnitDone SyntheticBackend::wait(int lane) {
  if (!options_.asynchronous) return {};
  Worker& w = worker(lane);
  std::unique_lock lock(w.mu);
  w.cv.wait(lock, [&] { return !w.done.empty(); });
  UnitDone u = std::move(w.done.front());
  w.done.pop_front();
  return u;
}

bool SyntheticBackend::ready(int lane) {
  if (!options_.asynchronous) return true;
  Worker& w = worker(lane);
  std::lock_guard lock(w.mu);
  return !w.done.empty();
}

void SyntheticBackend::abandon(int lane) {
  if (!options_.asynchronous) return;
  Worker& w = worker(lane);
  std::lock_guard lock(w.mu);
  // The oldest unit: ended, running (its result is dropped when it returns), or not started
  // (it never runs: its dispatch refers to the scheduler's graphs, which may be gone then).
  if (!w.done.empty()) {
    w.done.pop_front();
  } else if (w.busy && w.skip == 0) {
    w.skip = 1;
  } else if (!w.queued.empty()) {
    w.queued.pop_front();
  }
}

void SyntheticBackend::worker_main(Worker& w) {
  std::unique_lock lock(w.mu);
  for (;;) {
    w.cv.wait(lock, [&] { return w.stop || !w.queued.empty(); });
    if (w.queued.empty()) return;  // stopping, nothing left
    const Dispatch d = std::move(w.queued.front());
    w.queued.pop_front();
    w.busy = true;
    lock.unlock();
    UnitDone u;
    u.started = std::chrono::steady_clock::now();
    try {
      spend(d);
    } catch (const DeviceLostError& e) {
      u.status = UnitStatus::Failed;
      u.reason = e.what();
      u.device_lost = true;
    } catch (const OutOfMemoryError& e) {
      u.status = UnitStatus::OutOfMemory;
      u.reason = e.what();  // the runtime says "out of memory: "
    } catch (const std::exception& e) {
      u.status = UnitStatus::Failed;
      u.reason = e.what();
    }
    u.ended = std::chrono::steady_clock::now();
    lock.lock();
    w.busy = false;
    if (w.skip > 0) {
      --w.skip;
      continue;
    }
    w.done.push_back(std::move(u));
    w.cv.notify_all();
  }
}

}  // namespace red
