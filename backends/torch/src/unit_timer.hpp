#pragma once
/// \file
/// Times one call of a unit on its device (docs/DESIGN.md, "Profiles", `red profile`): host wall
/// time on the CPU; on a GPU, the time between two device events recorded on the current stream
/// around the call, which is what the device spent, without the host's launch gaps. LibTorch's
/// device-generic event (c10::Event) times events in LibTorch 2.6 (checked against its
/// headers; it came in 2.4 or 2.5); with an older LibTorch a GPU unit is timed by the host
/// clock after a device sync.

#include <c10/core/Device.h>
#include <c10/core/Event.h>
#include <c10/core/Stream.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>
#include <torch/version.h>

#include <chrono>
#include <functional>

#include "red/core/time.hpp"

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
  explicit UnitTimer(const c10::Device& device) : device_(device) {}

  /// Whether units run on an accelerator (asynchronously) rather than the CPU.
  [[nodiscard]] bool on_device() const noexcept { return !device_.is_cpu(); }

  /// How time() measures, for the profile.
  [[nodiscard]] const char* method() const noexcept {
    if (!on_device()) return "host wall clock";
    return RED_TORCH_EVENT_TIMING ? "device events" : "host wall clock after a device sync";
  }

  /// Runs fn once and returns how long the unit took.
  [[nodiscard]] Duration time(const std::function<void()>& fn) const {
#if RED_TORCH_EVENT_TIMING
    if (on_device()) {
      const auto* impl = c10::impl::getDeviceGuardImpl(device_.type());
      const c10::Stream stream = impl->getStream(device_);
      // BACKEND_DEFAULT: events that keep timing (LibTorch's own default disables it).
      c10::Event start(device_.type(), c10::EventFlag::BACKEND_DEFAULT);
      c10::Event end(device_.type(), c10::EventFlag::BACKEND_DEFAULT);
      start.record(stream);
      fn();
      end.record(stream);
      end.synchronize();
      const double ms = start.elapsedTime(end);
      return Duration{static_cast<std::int64_t>(ms * 1e6)};
    }
#endif
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    sync();  // kernels run asynchronously on a GPU: the unit ends when its work has finished
    return std::chrono::duration_cast<Duration>(std::chrono::steady_clock::now() - t0);
  }

  /// Waits for everything queued on the device (nothing on the CPU).
  void sync() const {
    if (!on_device()) return;
    const auto* impl = c10::impl::getDeviceGuardImpl(device_.type());
    impl->synchronizeStream(impl->getStream(device_));
  }

 private:
  c10::Device device_;
};

}  // namespace red::torchb
