#pragma once
/// \file
/// Internal to src/sched: deadline inheritance (docs/DESIGN.md, "Overload"; PolicyOptions::
/// inherit, part of red-robust), one mechanism in one place: with `depends_on`, the job a new
/// job waits for is planned to end in time for the units that wait (its `plan`, which its unit
/// deadlines and its rank read, beside the `deadline` its outcome reads). The scheduler calls it
/// at one named point: `released`, when a job that depends on another is released.

#include <cstddef>

#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class Inheritance {
 public:
  /// At the start: whether plans are inherited (PolicyOptions::inherit), and the scheduler's
  /// estimate, on which the path from the waiting units is counted.
  void set_up(bool on, EstimateKind estimate) noexcept {
    on_ = on;
    estimate_ = idx(estimate);
  }

  /// Job `j` was released depending on `d`, its operation's newest job still in flight: under
  /// inherit, `d` is planned to end by j's deadline less the longest path from j's units that
  /// wait for it (its head sources), when that is earlier than its plan.
  void released(Scheduler::Impl& m, const Job& j, Job& d) const;

 private:
  // Plans `d` to end by `due` when that is earlier than its plan: its ready tasks leave their
  // groups and their cached rank (TaskRank) follows.
  static void plan(Scheduler::Impl& m, Job& d, TimePoint due);

  bool on_ = false;
  std::size_t estimate_ = 0;
};

}  // namespace sched_detail
}  // namespace red
