#pragma once
/// \file
/// Time in RED: integer nanoseconds inside, milliseconds or seconds only at the edges
/// (docs/DESIGN.md, "Task model").

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

namespace red {

/// A span of time. All scheduling arithmetic uses this type.
using Duration = std::chrono::nanoseconds;

/// A point on the scheduler's timeline, measured from the start of a run.
/// Simulated and real runs share this representation; only the Clock differs.
using TimePoint = std::chrono::nanoseconds;

/// The largest representable time, used for "never".
inline constexpr TimePoint kNever = TimePoint{std::numeric_limits<std::int64_t>::max()};

/// Converts milliseconds given as a floating-point number (files, CLI) to a Duration.
inline Duration from_ms(double ms) noexcept {
  return Duration{static_cast<std::int64_t>(std::llround(ms * 1e6))};
}

/// Converts microseconds given as a floating-point number to a Duration.
inline Duration from_us(double us) noexcept {
  return Duration{static_cast<std::int64_t>(std::llround(us * 1e3))};
}

/// Converts seconds given as a floating-point number to a Duration.
inline Duration from_s(double s) noexcept {
  return Duration{static_cast<std::int64_t>(std::llround(s * 1e9))};
}

/// a * b / c without intermediate overflow (128-bit product), truncating toward zero.
inline std::int64_t mul_div(std::int64_t a, std::int64_t b, std::int64_t c) noexcept {
  __extension__ using i128 = __int128;
  return static_cast<std::int64_t>(static_cast<i128>(a) * b / c);
}

/// The period of a rate in hertz, clamped to a day (the loader rejects slower rates).
inline Duration period_of(double hz) noexcept {
  const double ns = std::min(1e9 / hz, 86400e9);
  return Duration{static_cast<std::int64_t>(std::llround(ns))};
}

/// d × f, rounded to the nanosecond: a cost slowed (interference, calibration factors) as the
/// simulator charges it.
inline Duration scaled_by(Duration d, double f) noexcept {
  return Duration{static_cast<std::int64_t>(std::llround(static_cast<double>(d.count()) * f))};
}

/// A Duration as floating-point milliseconds, for reports.
inline double to_ms(Duration d) noexcept {
  return static_cast<double>(d.count()) / 1e6;
}

/// A Duration as floating-point microseconds, for reports.
inline double to_us(Duration d) noexcept {
  return static_cast<double>(d.count()) / 1e3;
}

/// A Duration as floating-point seconds, for reports.
inline double to_s(Duration d) noexcept {
  return static_cast<double>(d.count()) / 1e9;
}

}  // namespace red
