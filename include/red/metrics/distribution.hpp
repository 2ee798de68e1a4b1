#pragma once
/// \file
/// A distribution of non-negative values (latencies, frame ages in ms) in bounded memory:
/// every value is kept exactly up to a cap, so percentiles are exact (nearest rank, as
/// percentile()) for runs of up to `cap` values; past the cap the values go into a
/// log-bucketed histogram whose percentiles have a stated relative error (docs/REPORTS.md,
/// "Exact and estimated percentiles"). The count, the sum (in the order the values came,
/// so a mean is the same as summing a vector) and the maximum stay exact.
///
///     BoundedDistribution d;            // exact up to kDefaultCap values
///     for (double ms : latencies) d.add(ms);
///     double p99 = d.percentile(0.99);  // exact while d.exact()

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

namespace red {

/// Values kept exactly, then a log-bucketed histogram. Not thread-safe.
class BoundedDistribution {
 public:
  /// Values kept exactly by default: 65,536 (512 KB, reserved on the first value when the
  /// cap is at most this).
  static constexpr std::size_t kDefaultCap = std::size_t{1} << 16;
  /// A cap that is never reached: every value kept, as a plain vector would.
  static constexpr std::size_t kUnbounded = static_cast<std::size_t>(-1);
  /// Relative error of a percentile once the histogram is used: 0.5 %.
  static constexpr double kDefaultRelativeError = 0.005;

  /// `cap` values kept exactly (0: histogram from the first value); `relative_error` in
  /// (0, 0.5): the most a histogram percentile differs from the exact one, relative to it.
  explicit BoundedDistribution(std::size_t cap = kDefaultCap,
                               double relative_error = kDefaultRelativeError);

  /// Adds one value (negative values count as 0). Allocates only while filling the exact
  /// samples (once, reserved) or when a new histogram bucket is first used.
  void add(double v);

  /// Nearest-rank percentile, p in [0, 1]; 0 when empty. Exact while exact(); else within
  /// relative_error() of the exact value, and never above max(). Sorts a copy of the exact
  /// samples: ask percentiles() for several at once.
  [[nodiscard]] double percentile(double p) const;

  /// percentile() of each of `ps`, sorting the exact samples once.
  [[nodiscard]] std::vector<double> percentiles(const std::vector<double>& ps) const;

  [[nodiscard]] std::int64_t count() const noexcept { return count_; }
  /// Sum of the values in the order added.
  [[nodiscard]] double sum() const noexcept { return sum_; }
  [[nodiscard]] double max() const noexcept { return max_; }
  /// True while every value is kept (percentiles exact).
  [[nodiscard]] bool exact() const noexcept { return histogram_.empty() && zeros_ == 0; }
  [[nodiscard]] std::size_t cap() const noexcept { return cap_; }
  [[nodiscard]] double relative_error() const noexcept { return alpha_; }
  /// Values and buckets held: exact samples plus histogram buckets (what its memory grows
  /// with; at most cap() + the buckets of the values' range).
  [[nodiscard]] std::size_t kept() const noexcept {
    return samples_.size() + histogram_.size() + (zeros_ > 0 ? 1 : 0);
  }

 private:
  void to_histogram(double v);
  [[nodiscard]] int bucket(double v) const;
  [[nodiscard]] double bucket_value(int b) const;

  std::size_t cap_;
  double alpha_;
  double log_gamma_;  // log((1 + alpha) / (1 - alpha))
  std::vector<double> samples_;
  std::map<int, std::int64_t> histogram_;  // bucket -> values
  std::int64_t zeros_ = 0;                 // values <= kTiny, in the histogram's mode
  std::int64_t count_ = 0;
  double sum_ = 0;
  double max_ = 0;
};

}  // namespace red
