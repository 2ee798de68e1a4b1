#pragma once
/// \file
/// Holding the CPU wake-up latency at 0 through the kernel's PM QoS while a real run or a
/// profile is measured (docs/FIDELITY.md, "Idle cores").

#include <string>

namespace red {

/// While it lives, asks the kernel (PM QoS, /dev/cpu_dma_latency) for a CPU wake-up latency of
/// 0: idle cores poll instead of entering an idle state they take tens of microseconds to
/// leave (a halt, on a virtual machine): a frame, a deadline or a completion is acted on
/// without that wake-up, and LibTorch's intra-op workers, woken at each parallel region of a
/// unit, start at once. The request lives as long as the file is open; it needs the right
/// to open it (root, as a rule) and is reported either way, never required. rt-tests'
/// cyclictest holds it for the same reason. The price: idle cores spin while it is held.
class WakeupLatencyHold {
 public:
  /// Holds nothing.
  WakeupLatencyHold() = default;
  /// Asks for a wake-up latency of 0 now.
  static WakeupLatencyHold zero();
  WakeupLatencyHold(WakeupLatencyHold&& other) noexcept;
  WakeupLatencyHold& operator=(WakeupLatencyHold&& other) noexcept;
  WakeupLatencyHold(const WakeupLatencyHold&) = delete;
  WakeupLatencyHold& operator=(const WakeupLatencyHold&) = delete;
  ~WakeupLatencyHold();

  [[nodiscard]] bool held() const noexcept { return fd_ >= 0; }
  /// "CPU wake-up latency: held at 0 us (/dev/cpu_dma_latency)", or "…: not held (why)";
  /// empty when it was not asked for.
  [[nodiscard]] const std::string& report() const noexcept { return report_; }
  /// Ends the request (the kernel drops it with the file).
  void release() noexcept;

 private:
  int fd_ = -1;
  std::string report_;
};

}  // namespace red
