#pragma once
/// \file
/// A backend that spends each unit's profiled time instead of running a network: the
/// sampled execution time of the simulator (common random numbers), spent sleeping or
/// spinning on the lane's thread. It lets the real-time runtime run and be tested without
/// LibTorch, and injects failures and out-of-memory errors on request.
///
/// Asynchronous (Options::asynchronous), it is the CPU stand-in of a GPU lane: each lane is
/// a worker thread that takes enqueued units from a queue in order and spends their time
/// there, so the lane's handler enqueues the next unit while one runs and waits for the
/// oldest, as with a CUDA stream and its events (Backend::enqueue, Backend::wait).

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "red/runtime/backend.hpp"
#include "red/sim/cost_sampler.hpp"

namespace red {

class SyntheticBackend final : public Backend {
 public:
  struct Options {
    double time_scale = 1.0;  ///< multiplies every sampled time (0: return at once)
    bool spin = false;        ///< spin instead of sleeping (keeps a core busy like compute)
    /// Decides whether a dispatch fails: 0 ok, 1 throws std::runtime_error, 2 throws
    /// OutOfMemoryError, 3 hangs for `hang` before returning normally, 4 hangs until the
    /// backend is destroyed (a hung device: on an asynchronous lane the units behind it
    /// wait too), 5 loses the device (DeviceLostError; every later unit fails so too).
    /// Called on the lane's thread (an asynchronous lane's worker).
    std::function<int(const Dispatch&)> inject;
    Duration hang = std::chrono::seconds{1};  ///< how long an injected hang lasts
    /// Lanes are worker threads fed through enqueue() and wait() (a GPU lane's stand-in).
    bool asynchronous = false;
  };

  SyntheticBackend(const Scenario& s, const Profile& p, std::uint64_t seed, Options o);
  ~SyntheticBackend() override;
  SyntheticBackend(const SyntheticBackend&) = delete;
  SyntheticBackend& operator=(const SyntheticBackend&) = delete;

  [[nodiscard]] std::string_view name() const noexcept override {
    return options_.asynchronous ? "synthetic asynchronous" : "synthetic";
  }
  void run(int lane, const Dispatch& d) override;
  [[nodiscard]] bool asynchronous() const noexcept override { return options_.asynchronous; }
  void enqueue(int lane, const Dispatch& d) override;
  UnitDone wait(int lane) override;
  [[nodiscard]] bool ready(int lane) override;
  void abandon(int lane) override;

  /// Units run so far (all lanes).
  [[nodiscard]] std::uint64_t runs() const noexcept { return runs_.load(); }

 private:
  // One asynchronous lane: its worker thread, the units queued for it, and those ended and
  // not yet waited for (both in order).
  struct Worker {
    std::thread thread;
    std::mutex mu;
    std::condition_variable cv;
    std::deque<Dispatch> queued;
    std::deque<UnitDone> done;
    bool busy = false;     // the worker is running a unit (taken from `queued`)
    std::size_t skip = 0;  // 1: the running unit was abandoned, its result is dropped
    bool stop = false;
  };
  Worker& worker(int lane);
  void worker_main(Worker& w);
  // Spends one unit's time (or injects its failure) on the calling thread.
  void spend(const Dispatch& d);

  CostSampler sampler_;
  Options options_;
  std::atomic<std::uint64_t> runs_{0};
  std::atomic<bool> lost_{false};  // an injected device fault happened (5)
  std::mutex hang_mu_;             // injected endless hangs (4) wait on hang_cv_
  std::condition_variable hang_cv_;
  bool ending_ = false;  // under hang_mu_: the destructor releases the hangs
  std::mutex workers_mu_;
  std::vector<std::unique_ptr<Worker>> workers_;  // by lane, made on a lane's first enqueue
};

}  // namespace red
