#pragma once
/// \file
/// The limits a scenario is checked against when it is read (docs/SCENARIOS.md, "Limits"):
/// beyond them a number overflows or vanishes on the nanosecond timeline, or a run would not
/// fit a machine. Internal to the loader.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/scenario/scenario.hpp"

namespace red::limits {

// Rates give a period that fits the nanosecond timeline with room to spare: between one
// frame a day and a million frames a second.
inline constexpr double kMinRateHz = 1.0 / 86400.0;
inline constexpr double kMaxRateHz = 1e6;
// A deadline is at least 1 us (less rounds towards nothing a clock can tell apart) and at
// most 1e12 ms; critical_path_x within [1e-3, 1e6] (beyond, its product with a critical path
// overflows or vanishes).
inline constexpr Duration kMinDeadline = std::chrono::microseconds{1};
inline constexpr double kMinCriticalPathX = 1e-3;
inline constexpr double kMaxCriticalPathX = 1e6;
// How large a workload may be: beyond, a run's memory (about 0.6 KB per job in the
// simulator) or its threads (one per lane) would exceed a machine's.
inline constexpr std::int64_t kMaxLanes = 256;
inline constexpr std::int64_t kMaxReleaseCount = 1'000'000;
inline constexpr double kMaxReleases = 1e7;  // jobs over the whole run, every operation
inline constexpr std::size_t kMaxOperations = 100'000;
inline constexpr std::size_t kMaxNodes = 1'000'000;  // over every operation's definitions
// Collections (mappings and lists) inside one another: a scenario needs about 8 levels; the
// same bound as a profile's JSON.
inline constexpr int kMaxNesting = 64;

/// nullopt when the workload is within the size limits (operations, nodes, jobs per run);
/// else an Error naming the scenario's file. The jobs a run releases are bounded by each
/// operation's highest rate (its own, or its trigger sensor's over every rate change) times
/// the duration, or its release count. Linear in the scenario's size.
std::optional<Error> check_size(const Scenario& s);

}  // namespace red::limits
