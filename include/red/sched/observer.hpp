#pragma once
/// \file
/// Observers of the scheduler (as taskflow's ObserverInterface): metrics, traces and tests
/// watch what happens without living inside the scheduler. Callbacks run on the scheduler's
/// thread, synchronously; they must not call back into the scheduler.

#include "red/core/time.hpp"
#include "red/sched/records.hpp"

namespace red {

/// Observer interface. Every callback has an empty default.
class Observer {
 public:
  Observer() = default;
  Observer(const Observer&) = default;
  Observer& operator=(const Observer&) = default;
  virtual ~Observer() = default;

  virtual void on_job_release(const JobRecord& /*job*/) {}
  virtual void on_job_end(const JobRecord& /*job*/) {}
  /// A dispatch was decided; `d.start` is when its unit begins.
  virtual void on_unit_start(const Dispatch& /*d*/) {}
  virtual void on_unit_end(const Dispatch& /*d*/, TimePoint /*end*/, UnitStatus /*s*/) {}
  /// An encoder run waits for a predicted member until `until` (docs/DESIGN.md, "DynamicMerge").
  virtual void on_merge_wait(int /*sensor*/, TimePoint /*now*/, TimePoint /*until*/) {}
  virtual void on_workload_event(int /*index*/, TimePoint /*at*/) {}
  /// After each dispatch round: ready tasks left, idle lanes left, tasks in a merge wait.
  virtual void on_decision(TimePoint /*now*/, int /*ready*/, int /*idle_lanes*/, int /*waiting*/) {}
};

}  // namespace red
