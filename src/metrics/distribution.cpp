#include "red/metrics/distribution.hpp"

#include <algorithm>
#include <cmath>

#include "red/metrics/metrics.hpp"

namespace red {

namespace {

// Values at or below this (ms) are counted as zero by the histogram (log buckets cannot
// hold them): a femtosecond, far below any clock's resolution.
constexpr double kTiny = 1e-12;

}  // namespace

BoundedDistribution::BoundedDistribution(std::size_t cap, double relative_error)
    : cap_(cap),
      alpha_(std::clamp(relative_error, 1e-6, 0.499)),
      log_gamma_(std::log((1 + alpha_) / (1 - alpha_))) {}

void BoundedDistribution::add(double v) {
  v = std::max(0.0, v);
  ++count_;
  sum_ += v;
  max_ = count_ == 1 ? v : std::max(max_, v);
  if (exact() && samples_.size() < cap_) {
    // A bounded one reserves its cap once (no copy as it fills); an unbounded one grows.
    if (samples_.capacity() == 0 && cap_ <= kDefaultCap) samples_.reserve(cap_);
    samples_.push_back(v);
    return;
  }
  to_histogram(v);
}

void BoundedDistribution::to_histogram(double v) {
  if (!samples_.empty()) {
    // The cap is reached: the exact samples move into the histogram and their memory goes.
    std::vector<double> kept;
    kept.swap(samples_);
    for (double x : kept) to_histogram(x);
  }
  if (v <= kTiny)
    ++zeros_;
  else
    ++histogram_[bucket(v)];
}

int BoundedDistribution::bucket(double v) const {
  // Bucket i holds (gamma^(i-1), gamma^i]; its value 2 gamma^i / (gamma + 1) is within
  // alpha of every value in it (relative).
  return static_cast<int>(std::ceil(std::log(v) / log_gamma_));
}

double BoundedDistribution::bucket_value(int b) const {
  const double gamma = std::exp(log_gamma_);
  return 2 * std::exp(log_gamma_ * b) / (gamma + 1);
}

double BoundedDistribution::percentile(double p) const {
  return percentiles({p}).front();
}

std::vector<double> BoundedDistribution::percentiles(const std::vector<double>& ps) const {
  std::vector<double> out;
  out.reserve(ps.size());
  if (exact()) {
    std::vector<double> sorted = samples_;
    std::sort(sorted.begin(), sorted.end());
    for (double p : ps) out.push_back(percentile_sorted(sorted, p));
    return out;
  }
  for (double p : ps) {
    // Nearest rank, as percentile_sorted: the value at 1-based rank ceil(p n), at least 1.
    const auto rank = std::max<std::int64_t>(
        1, static_cast<std::int64_t>(std::ceil(p * static_cast<double>(count_))));
    std::int64_t seen = zeros_;
    double v = 0;
    if (rank >= count_) {
      v = max_;  // the last rank is the maximum, kept exactly
    } else if (seen < rank) {
      v = max_;
      for (const auto& [b, n] : histogram_) {
        seen += n;
        if (seen >= rank) {
          v = std::min(bucket_value(b), max_);
          break;
        }
      }
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace red
