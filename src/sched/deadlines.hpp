#pragma once
/// \file
/// Internal to src/sched: re-assignment (docs/DESIGN.md, "Re-assignment"; PolicyOptions::
/// reassign, on the deadline split of PolicyOptions::deadlines), one mechanism in one place:
/// the budget left, B = deadline − now, is spread over the heights that still have work in
/// proportion to their remaining level costs (or per-node overrides); height h ends at
/// now + B · frac[h], frac[h] the cumulative share up to h (exactly 1 for the last height: its
/// deadline is the job's). The scheduler calls it at named points:
///
/// * a job's cache is rebuilt (one of its units started or ended): `rebuilt`, the shares when
///   none of its units runs, the same at every decision then;
/// * a job with running units is evaluated at a decision: `evaluated`, the shares at `now`;
/// * a unit's deadline (Scheduler::Impl::unit_deadline, inline: ranking calls it for every
///   member of every ready task): `deadline`, from the shares of the job's cache;
/// * the ready set's groups (ready_set.cpp): `shares_deadline`, whether a deadline follows from
///   the job's plan and a share.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class Reassignment {
 public:
  /// At the start: whether deadlines are re-assigned at each decision, and the deadline split
  /// (PolicyOptions::reassign, deadlines).
  void set_up(bool reassign, DeadlineMode mode) noexcept {
    on_ = reassign;
    split_ = mode;
  }
  /// Whether deadlines are re-assigned at each decision (else static: refinement's offsets).
  [[nodiscard]] bool on() const noexcept { return on_; }
  /// The deadline split (none, e2e, proportional, equal).
  [[nodiscard]] DeadlineMode split() const noexcept { return split_; }
  /// Whether a unit's deadline is the job's plan less a share of the budget left: re-assigned,
  /// on a split that spreads the budget.
  [[nodiscard]] bool shares_deadline() const noexcept { return on_ && splits_budget(split_); }

  /// Job `j`'s cache was rebuilt: with none of its units running, the shares of its level
  /// costs then (Job::frac), the same at every decision until a unit starts.
  void rebuilt(Job& j) const {
    if (on_ && j.running_units.empty()) shares(j, j.lvl_base, j.has_base, j.frac);
  }
  /// Job `j`, with units running, was evaluated at a decision: the shares of its level costs
  /// at that instant (Job::frac_now).
  void evaluated(Job& j) const {
    if (on_) shares(j, j.lvl, j.has_base, j.frac_now);
  }

  /// The re-assigned deadline of height `h` of job `j` at `now` (on()), from the shares of the
  /// job's cache as they are at `now`: `caches` (Scheduler::Impl) refreshes and evaluates it.
  /// Inline: the hottest path of a decision.
  template <class Caches>
  static TimePoint deadline(Caches& caches, Job& j, std::size_t h, TimePoint now) {
    caches.refresh(j);
    if (j.running_units.empty()) return from_share(j, j.frac[h], now);
    caches.eval(j, now);
    return from_share(j, j.frac_now[h], now);
  }

 private:
  // The end of a cumulative share `frac` of the budget left at `now`.
  static TimePoint from_share(const Job& j, double frac, TimePoint now) {
    const Duration budget = j.plan - now;
    if (budget <= Duration{0} || frac == 1.0) return j.plan;
    return now + Duration{static_cast<std::int64_t>(static_cast<double>(budget.count()) * frac)};
  }
  // The cumulative shares of the budget per height (frac) from level costs `lvl` of the
  // heights that still have work (`has`).
  void shares(const Job& j, const std::vector<Duration>& lvl, const std::vector<std::uint8_t>& has,
              std::vector<double>& frac) const;

  bool on_ = false;
  DeadlineMode split_ = DeadlineMode::Proportional;
};

}  // namespace sched_detail
}  // namespace red
