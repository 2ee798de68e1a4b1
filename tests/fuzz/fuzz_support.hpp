#pragma once
/// \file
/// Shared by the libFuzzer targets: a bounded simulation of a scenario that loaded, so a
/// scenario that validation accepts is also shown not to crash the scheduler.

#include <cstdio>
#include <cstdlib>

#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red::fuzz {

/// Aborts (a finding for libFuzzer) with a message.
[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what);
  std::abort();
}

/// True when a simulation of `s` stays small enough for a fuzzing iteration: few lanes,
/// few releases (sensor and own rates, including every set_rate event, over the duration).
inline bool small_enough(const Scenario& s) {
  constexpr double kMaxReleases = 400;
  constexpr int kMaxLanes = 8;
  if (s.device.lanes > kMaxLanes || !s.model.manifest.empty() || !s.profile.empty()) return false;
  const double seconds = std::chrono::duration<double>(s.duration).count();
  if (!(seconds > 0) || seconds > 60) return false;
  double rate = 0;
  for (const SensorSpec& x : s.sensors) rate += x.rate_hz;
  for (const auto& op : s.initial)
    if (op) rate += op->rate_hz + op->release_count.value_or(0) / seconds;
  for (const EventSpec& e : s.events) {
    for (const auto& [sensor, r] : e.sensor_rates) rate += r;
    for (const auto& [op, spec] : e.changes)
      if (spec) rate += spec->rate_hz;
  }
  return rate * seconds <= kMaxReleases;
}

/// Simulates `s` under two presets (fine and coarse graphs) on the built-in profile when
/// small enough; any crash or sanitizer report is a finding.
inline void simulate_if_small(const Scenario& s) {
  // A scenario whose scheduler options do not check is refused where it is loaded (the CLI)
  // and by simulate_policy alike, with the file and line: not a run.
  if (const auto e = check_policy_options(s)) {
    if (e->file != s.file || e->message.empty())
      fail("policy option error without file or message");
    if (simulate_policy(s, default_profile(), "red", s.seed, {}, false))
      fail("simulate_policy ran a scenario whose policy options do not check");
    return;
  }
  if (!small_enough(s)) return;
  const Profile p = default_profile();
  if (check_profile_covers(p, s)) return;
  for (const char* policy : {"red", "edf"}) {
    auto run = simulate_policy(s, p, policy, s.seed, {}, false);
    if (!run) fail("simulate_policy refused a preset");
    const PolicyMetrics& m = run->metrics;
    if (m.completed < 0 || m.dropped < 0) fail("negative job counts");
  }
}

}  // namespace red::fuzz
