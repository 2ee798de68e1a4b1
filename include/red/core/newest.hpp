#pragma once
/// \file
/// The newest values of a stream in bounded memory: a vector that fills up to `capacity`
/// and then wraps, value number n (0-based, counted by the caller) at index n % capacity.
/// Used for the runtime's recent decision times and the ROS 2 node's timing windows and
/// latencies, which report "the newest N" rather than a uniform sample.
///
///     std::vector<double> ring;
///     std::uint64_t seen = 0;
///     keep_newest(ring, seen++, 1024, x);              // the newest 1024, unordered
///     for (double v : newest_since(ring, seen, from))  // those after `from`, oldest first

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace red {

/// Stores value number `n` (0-based) of a stream, keeping the newest `capacity`: appended
/// while the ring is short, else over value n − capacity. Allocates only while filling
/// (not at all where the caller reserved `capacity`).
template <typename T>
void keep_newest(std::vector<T>& ring, std::uint64_t n, std::size_t capacity, T value) {
  if (ring.size() < capacity)
    ring.push_back(value);
  else if (capacity > 0)
    ring[static_cast<std::size_t>(n % capacity)] = value;
}

/// The values numbered `from` to `total` − 1 that the ring (filled by keep_newest() with
/// `total` values so far) still holds, oldest first; those older than the ring are gone.
template <typename T>
std::vector<T> newest_since(const std::vector<T>& ring, std::uint64_t total, std::uint64_t from) {
  std::vector<T> out;
  if (ring.empty()) return out;
  const std::uint64_t kept = ring.size();
  for (std::uint64_t i = std::max(from, total - std::min(total, kept)); i < total; ++i)
    out.push_back(ring[static_cast<std::size_t>(i % kept)]);
  return out;
}

}  // namespace red
