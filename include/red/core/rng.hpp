#pragma once
/// \file
/// Counter-based random numbers for common random numbers (docs/DESIGN.md, "Metrics" paired
/// comparison): a sample is a pure function of (seed, what, which instance), so every policy sees
/// the same execution time for the same unit instance, whatever order it runs things in.

#include <cstdint>
#include <string_view>

namespace red {

/// SplitMix64 finalizer: a bijective 64-bit mix with good avalanche.
constexpr std::uint64_t mix64(std::uint64_t x) noexcept {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30U)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27U)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31U);
}

/// Combines a running hash with one more value.
constexpr std::uint64_t hash_combine(std::uint64_t h, std::uint64_t v) noexcept {
  return mix64(h ^ (v + 0x9e3779b97f4a7c15ULL + (h << 6U) + (h >> 2U)));
}

/// FNV-1a of a string, for stable keys derived from names.
constexpr std::uint64_t hash_name(std::string_view s) noexcept {
  std::uint64_t h = 1469598103934665603ULL;
  for (char c : s) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ULL;
  }
  return h;
}

/// A uniform number in [0, 1) from a 64-bit key.
constexpr double unit_uniform(std::uint64_t key) noexcept {
  return static_cast<double>(mix64(key) >> 11U) * 0x1.0p-53;
}

}  // namespace red
