#pragma once
/// \file
/// Deterministic discrete-event simulator (docs/DESIGN.md, "Metrics", as SimGrid/ns-3): events
/// ordered by (time, sequence number), so equal times always come out in the same order. It drives
/// the same Scheduler and Policy the real runtime drives; only the clock (virtual) and the
/// executor (sampled execution times) differ.

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/scheduler.hpp"
#include "red/sim/cost_sampler.hpp"

namespace red {

/// Options of one simulation run.
struct SimOptions {
  std::uint64_t seed = 1;
  /// After duration, releases stop and in-flight jobs may finish for at most this long.
  Duration drain_limit = std::chrono::seconds{60};
  /// The unit costs the simulator draws, when they are not the scheduler's profile: e.g.
  /// a calibration of the machine (docs/FIDELITY.md) under a run planned with another
  /// profile. Not owned; must outlive the simulator.
  const Profile* costs = nullptr;
  /// SchedulerConfig::group_from, when set (the tests compare decisions with and without groups).
  std::optional<int> group_from;
};

/// What a run did, besides what observers saw.
struct SimResult {
  TimePoint end{0};               ///< simulated time when the run stopped
  std::uint64_t unit_events = 0;  ///< unit starts + unit completions
  std::uint64_t events = 0;       ///< every event handled (frames, completions, wake-ups)
  bool stopped = false;           ///< ended early by a stop request (core/stop.hpp)
  SchedulerStats stats;
};

class Simulator {
 public:
  /// `scenario` and `profile` must outlive the simulator.
  Simulator(const Scenario& scenario, const Profile& profile, std::unique_ptr<Policy> policy,
            SimOptions options);

  /// Observers of the scheduler; not owned.
  void add_observer(Observer* o) { scheduler_.add_observer(o); }
  /// Runs to the end of the scenario (plus draining) and reports.
  SimResult run();

  [[nodiscard]] Scheduler& scheduler() noexcept { return scheduler_; }
  /// The round-trip cost charged before a dispatch that needs the global synchronizer.
  [[nodiscard]] Duration sync_cost() const noexcept { return sync_cost_; }

 private:
  struct Run;  // one run's state (simulator.cpp)

  const Scenario& scenario_;
  SimOptions options_;
  Scheduler scheduler_;
  CostSampler sampler_;
  Duration sync_cost_;
  Duration handoff_;  ///< hand-off without a round trip (a calibrated profile's; else 0)
  /// End of a unit -> start of the unit queued behind it on its lane (a calibrated
  /// profile's; else 0)
  Duration queued_gap_;
  // The planning profile's encoder and heads (by head index): when a handler queues ahead.
  const UnitProfile* encoder_ = nullptr;
  std::vector<const UnitProfile*> heads_;
};

}  // namespace red
