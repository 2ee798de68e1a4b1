#pragma once
/// \file
/// Times one call of a unit on its device (docs/DESIGN.md, "Profiles", `red profile`): host wall
/// time on the CPU; on a GPU, the time between two device events recorded on the current stream
/// around the call, which is what the device spent. LibTorch's device-generic event (c10::Event)
/// times events in LibTorch 2.6 (checked against its headers; it came in 2.4 or 2.5); with an
/// older LibTorch a GPU unit is timed by the host clock after the device has run it.
///
/// On a GPU the timed call follows an untimed one: on an idle stream the start event fires at
/// once and the device then waits for each kernel's launch, so the events would time the
/// host's launch gaps too; behind the untimed call's kernels, the timed call's are queued
/// before the device reaches them, as in a run whose lane holds a unit ahead.

#include <torch/version.h>

#include <chrono>
#include <functional>
#include <memory>
#include <utility>

#include "red/core/time.hpp"
#include "red/torch/lane_device.hpp"

// c10::Event::elapsedTime (milliseconds between two recorded events) and
// c10::Event::synchronize: in LibTorch 2.6 and later (not in 1.13).
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 6)
#define RED_TORCH_EVENT_TIMING 1
#else
#define RED_TORCH_EVENT_TIMING 0
#endif

namespace red::torchb {

class UnitTimer {
 public:
  /// Times on `device`: the CPU (null) or a LaneDevice (a GPU, or a stand-in in tests).
  explicit UnitTimer(std::shared_ptr<LaneDevice> device = nullptr) : device_(std::move(device)) {}

  /// Whether units run on an accelerator (asynchronously) rather than the CPU.
  [[nodiscard]] bool on_device() const noexcept { return device_ != nullptr; }

  /// How time() measures, for the profile.
  [[nodiscard]] const char* method() const noexcept {
    if (!on_device()) return "host wall clock";
    return device_->times() ? "device events, each timed call after an untimed one"
                            : "host wall clock after a device sync";
  }

  /// Runs fn (twice on a device that times events: untimed, then timed) and returns how
  /// long the timed call took.
  [[nodiscard]] Duration time(const std::function<void()>& fn) const {
    if (on_device() && device_->times()) {
      const LaneDevice::StreamId stream = device_->current_stream();
      fn();  // untimed: the timed call's kernels queue behind it
      const auto start = device_->record(stream);
      fn();
      const auto end = device_->record(stream);
      finish(*end);
      const double ms = device_->elapsed_ms(*start, *end);
      return Duration{static_cast<std::int64_t>(ms * 1e6)};
    }
    const auto t0 = now();
    fn();
    sync();  // kernels run asynchronously on a GPU: the unit ends when its work has finished
    return std::chrono::duration_cast<Duration>(now() - t0);
  }

  /// Waits for everything queued on the current stream (nothing on the CPU).
  void sync() const {
    if (!on_device()) return;
    finish(*device_->record(device_->current_stream()));
  }

 private:
  [[nodiscard]] LaneDevice::HostTime now() const {
    return on_device() ? device_->now() : std::chrono::steady_clock::now();
  }
  // Polls until `e` completes. The profiling thread is not a lane (not SCHED_FIFO, not
  // pinned): it polls back to back, as a timed synchronization must.
  void finish(const LaneDevice::Event& e) const {
    while (!device_->query(e)) {
    }
  }

  std::shared_ptr<LaneDevice> device_;
};

}  // namespace red::torchb
