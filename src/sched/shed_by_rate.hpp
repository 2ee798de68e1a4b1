#pragma once
/// \file
/// Internal to src/sched: shedding by rate (docs/DESIGN.md, "Overload" "shed early", by rate;
/// PolicyOptions::shed_by_rate, part of red-robust), one mechanism in one place: its state, its
/// constants and its rule. The scheduler calls it at named points: at a release (rejects), at a
/// job's end (on_end) and when the workload changes (on_workload).
///
/// The rule (the work bound's, cheapest jobs first): periodic operations without sensors are
/// ordered by the lane time one job needs; one whose cheaper ones alone ask for every lane at
/// their rates is outranked, and while the lanes are past capacity (with equal criticalities,
/// on evidence of overload) and one of those cheaper operations sheds jobs itself, its jobs are
/// rejected at release, before they cost anything.

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "state.hpp"

namespace red {
namespace sched_detail {

class ShedByRate {
 public:
  /// How long an operation counts as shedding after it shed a job: the offered load's window
  /// (Scheduler::Impl::kOfferedWindow), in seconds.
  static constexpr double kWindow = 0.25;

  /// Rates or graphs changed: the order is planned again at the next release that asks.
  void on_workload() noexcept { stale_ = true; }

  /// A job of operation `op` ended at `now`: a drop for want of lane time (rejected, hopeless,
  /// past its deadline; not this rule's rejection) marks the operation as shedding.
  void on_end(int op, JobOutcome outcome, DropReason reason, TimePoint now);

  /// Whether the job of operation `op` released at `now` is rejected: `op` is outranked (the
  /// order planned on `ops`, `lanes` lanes and estimate kind `k`), `gate()` holds (past
  /// capacity, on evidence of overload) and an operation ahead of it sheds.
  template <class Gate>
  bool rejects(int op, TimePoint now, const std::vector<OpState>& ops, int lanes, std::size_t k,
               Gate&& gate) {
    if (stale_) plan(ops, lanes, k);
    return outranked_[static_cast<std::size_t>(op)] != 0 && gate() && ahead_shed(op, now);
  }

 private:
  void plan(const std::vector<OpState>& ops, int lanes, std::size_t k);
  // True when an operation ahead of `op` in the order shed a job within the last kWindow.
  bool ahead_shed(int op, TimePoint now) const;

  bool stale_ = true;
  std::vector<std::uint8_t> outranked_;          // per operation
  std::vector<std::pair<Duration, int>> order_;  // (a job's cost, operation), cheapest first
  std::vector<TimePoint> last_shed_;             // per operation; kNever: none
};

}  // namespace sched_detail
}  // namespace red
