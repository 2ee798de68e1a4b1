#pragma once
/// \file
/// Internal to src/sched: DynamicMerge (docs/DESIGN.md, "DynamicMerge"; PolicyOptions::merge),
/// one mechanism in one place: its state and its rules. The scheduler calls it at named points:
///
/// * a unit becomes ready: `join` (an encoder unit joins a queued encoder task of its sensor),
///   else, once its own task is made, `opened`; a task leaves: `closed`;
/// * at a pick: `wait_until` (rule 2, a merge wait for a predicted member), and `begin_wait`
///   for every wait a pick takes (a merge wait, or the criticality guard's hold);
/// * after a decision: `sweep` (the waits still running, the earliest end a wake-up,
///   `earliest_wait`);
/// * a dispatch starts: `at_start` (a γ-merged run reads the newest frame).

#include <cstddef>
#include <vector>

#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class DynamicMerge {
 public:
  /// The scenario's sensors (the constructor).
  void set_sensors(std::size_t sensors) { open_.resize(sensors); }

  // ---- joins (rule 1: the same frame; rule 2: a γ-cluster of releases) ---------------------

  /// Unit `unit` of the job in `slot` became ready: true when it joined a queued encoder task
  /// of its sensor (rule 1: the same frame, unconditionally; rule 2: releases that sample the
  /// newest frame within γ), its UnitRt::task then set.
  bool join(Scheduler::Impl& m, int slot, int unit);
  /// Task `t` was made for a ready unit: an encoder task is open to joins (under merge).
  void opened(const Scheduler::Impl& m, int t);
  /// Task `t` left: no more joins.
  void closed(const Task& k, int t);

  // ---- merge waits (rule 2) -----------------------------------------------------------------

  /// When ready task `k`, chosen at a pick, waits for the predicted release, within γ of its
  /// first member, of another operation that samples its sensor, every member's slack
  /// covering the wait; kNever when it does not wait.
  TimePoint wait_until(Scheduler::Impl& m, Task& k, TimePoint now) const;
  /// Task `t` waits until `until` (a merge wait or the guard's hold): listed until it is over.
  void begin_wait(Task& k, int t, TimePoint until);
  /// After a decision: the waits still running (returned), their earliest end kept for
  /// earliest_wait; waits that are over (their member came, the task left) are forgotten.
  int sweep(Scheduler::Impl& m, TimePoint now);
  /// The earliest end of a wait still running (a wake-up), kNever when none.
  [[nodiscard]] TimePoint earliest_wait() const noexcept { return min_wait_; }

  /// A dispatch starts task `k`: a γ-merged run uses the newest frame available when it starts
  /// (docs/DESIGN.md, "Refinement").
  void at_start(const Scheduler::Impl& m, Task& k) const;

 private:
  // The predicted release, within γ of the task's first member, of another operation that
  // samples the same sensor; kNever if none.
  static TimePoint predicted_member(const Scheduler::Impl& m, const Task& k, TimePoint now);
  // A merge wait until `until` is taken only if every member's slack still covers it; the
  // run after the wait pays a round trip (the handler parked meanwhile).
  static bool slack_covers(Scheduler::Impl& m, Task& k, TimePoint now, TimePoint until);

  std::vector<std::vector<int>> open_;  // per sensor: queued encoder tasks
  std::vector<int> waits_;  // tasks that began a wait (a superset of those still waiting)
  TimePoint min_wait_ = kNever;
};

}  // namespace sched_detail
}  // namespace red
