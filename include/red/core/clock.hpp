#pragma once
/// \file
/// Clocks. Only Clock implementations read a clock (STYLE.md): the scheduler and the
/// policies get the time passed in, so the simulator can drive them on virtual time.

#include <chrono>

#include "red/core/time.hpp"

namespace red {

/// A source of the current time on RED's timeline.
class Clock {
 public:
  Clock() = default;
  Clock(const Clock&) = default;
  Clock& operator=(const Clock&) = default;
  virtual ~Clock() = default;
  /// Time since this clock's origin.
  [[nodiscard]] virtual TimePoint now() const noexcept = 0;
};

/// The monotonic wall clock (std::chrono::steady_clock), measured from an origin.
class SteadyClock final : public Clock {
 public:
  SteadyClock() noexcept : origin_(std::chrono::steady_clock::now().time_since_epoch()) {}
  [[nodiscard]] TimePoint now() const noexcept override {
    return std::chrono::duration_cast<Duration>(
        std::chrono::steady_clock::now().time_since_epoch() - origin_);
  }
  /// Makes now the origin.
  void reset() noexcept { origin_ = std::chrono::steady_clock::now().time_since_epoch(); }
  /// The origin, as steady_clock's time since its epoch.
  [[nodiscard]] Duration origin() const noexcept {
    return std::chrono::duration_cast<Duration>(origin_);
  }

 private:
  std::chrono::steady_clock::duration origin_;
};

}  // namespace red
