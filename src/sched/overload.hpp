#pragma once
/// \file
/// Internal to src/sched: overload (docs/DESIGN.md, "Overload"), the state and the rules that
/// tell it: the live jobs by deadline, the demand test over them (and its scratch), the
/// necessary work it counts units at, the evidence of overload (the last miss) and the round's
/// verdict. The scheduler calls it at named points:
///
/// * a job is released: `on_release`; a release is skipped: `on_skip`; a job ends: `on_end`;
/// * the workload or the plan's costs change: `plan` (the necessary work);
/// * before a pick: `assess` (the round's verdict: `overloaded`, `demand_overrun`, which the
///   pick hands to Ranking::at_pick);
/// * shedding and the criticality guard ask `first_overrun`, `evidenced`, `by_deadline`.

#include <array>
#include <cstddef>
#include <limits>
#include <vector>

#include "pools.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

// Criticalities counted by the demand test and the jobs to come when none is given: all.
inline constexpr int kAnyCriticality = std::numeric_limits<int>::min();

class Overload {
 public:
  // ---- the round's verdict ----------------------------------------------------------------

  /// The round's overload state before a pick (dispatch() and dispatch_ahead()): saturation,
  /// the demand test, the hold of "finish what was started".
  void assess(Scheduler::Impl& m, TimePoint now);
  /// Whether the lanes are judged overloaded this round.
  [[nodiscard]] bool overloaded() const noexcept { return overloaded_; }
  /// Whether this round's demand test found more work than the lanes do.
  [[nodiscard]] bool demand_overrun() const noexcept { return demand_overrun_; }

  // ---- evidence of overload (opt.miss_gate) -------------------------------------------------

  /// The mechanisms that act on signs of overload other than the demand test (lookahead,
  /// shed_lone, shedding by rate, ranking by job deadline at max_inflight) act only within
  /// kMissWindow of the last job that ended without meeting its deadline (missed, dropped,
  /// skipped at max_inflight).
  static constexpr double kMissWindow = 1.0;  // seconds
  [[nodiscard]] bool evidenced(const Scheduler::Impl& m, TimePoint now) const;

  // ---- the live jobs by (deadline, id) ------------------------------------------------------

  [[nodiscard]] const std::vector<int>& by_deadline() const noexcept { return by_deadline_; }
  /// The job in `slot` was released (live, its deadline set).
  void on_release(const JobPool& jobs, int slot);
  /// A release was skipped at max_inflight at `now`.
  void on_skip(TimePoint now) noexcept { last_miss_ = now; }
  /// The job in `slot` ended at `now` with `outcome`.
  void on_end(const JobPool& jobs, int slot, JobOutcome outcome, TimePoint now);

  // ---- the necessary work ---------------------------------------------------------------------

  /// The necessary work of the workload in effect (red/graph/necessary_work.hpp): the lane time
  /// one run of each unit takes as RED runs it (encoder runs shared, runs batched as the
  /// deadlines allow), by WorkModel slot and estimate kind. Every work figure of the overload
  /// mechanisms (work_left, the demand test, admission, the jobs to come) counts a unit at it,
  /// so that they agree with `red analyze` and the sweep's limit. Computed again when the
  /// workload changes (an event, an operation's last release) or the plan's costs do.
  void plan(const Scheduler::Impl& m);
  /// What unit `ru` counts for in the work figures under estimate kind k.
  [[nodiscard]] Duration unit_cost(const RefinedUnit& ru, std::size_t k) const {
    switch (ru.kind) {
      case UnitKind::Encoder:
        return run_cost_[WorkModel::kEncoder][k];
      case UnitKind::Head:
        return run_cost_[WorkModel::head_slot(ru.head)][k];
      case UnitKind::Coarse:
        return run_cost_[WorkModel::kEncoder][k] + run_cost_[WorkModel::head_slot(ru.head)][k];
      default:
        return ru.costs[k];
    }
  }
  /// One encoder run under estimate kind k.
  [[nodiscard]] Duration encoder_run(std::size_t k) const {
    return run_cost_[WorkModel::kEncoder][k];
  }
  /// The encoder runs one job of operation `op` needs (WorkEstimate); empty before plan().
  [[nodiscard]] const std::vector<double>& encoder_runs_per_job() const noexcept {
    return encoder_runs_per_job_;
  }

  // ---- the demand test --------------------------------------------------------------------

  /// Taking live jobs by deadline, the first that the lanes cannot finish by its deadline under
  /// estimate kind k; -1 when all of it fits. A position in by_deadline(). On one lane that is
  /// the first whose deadline comes before the work due by it (its own and every earlier
  /// job's): exact for non-preemptive EDF up to blocking. On several lanes the work due does
  /// not say enough: a DAG's critical path cannot use the lanes' parallelism. `schedule` then
  /// list-schedules the remaining units (admission, at releases); without it (the per-round
  /// overload check) the bound is the larger of the job's own critical path and the work due
  /// spread over every lane, a lower bound. `margin` (percent) pads every estimate (admission's
  /// margin, docs/DESIGN.md, "Overload"); 0 in the per-round overload test. Admission passes
  /// `from` (the first position that may be returned; earlier jobs still count) and
  /// `skip_doomed` (jobs that cannot make it alone count for nothing). `min_crit`: only the
  /// jobs (and jobs to come) of that criticality or more count, besides the units the lanes
  /// hold: the test for what pick() runs first under overload (docs/DESIGN.md, "Criticality").
  int first_overrun(Scheduler::Impl& m, TimePoint now, std::size_t k, bool schedule, int margin,
                    std::size_t from, bool skip_doomed, int min_crit = kAnyCriticality);

  /// d padded by `margin` percent (d itself for 0).
  static Duration padded(Duration d, int margin) {
    return margin == 0 ? d : d * (100 + margin) / 100;
  }

 private:
  // first_overrun(m, now, k, false, 0, 0, false) >= 0, the per-round overload test, decided
  // where it can be from bounds kept per job (work_base and work_most bracket work_left),
  // walking the jobs' units only where the bounds do not tell.
  bool demand_overruns(Scheduler::Impl& m, TimePoint now, std::size_t k);
  // The demand test on several lanes: jobs by deadline, each remaining unit at its earliest
  // start (its predecessors' end, a lane's end) on the lane that leaves the smallest gap (or in
  // an idle gap it fits).
  int first_overrun_lanes(Scheduler::Impl& m, TimePoint now, std::size_t k, int margin,
                          std::size_t from, bool skip_doomed, int min_crit);
  // The order of by_deadline_: end-to-end deadline, then job id.
  static bool earlier(const JobPool& jobs, int a, int b);

  std::vector<int> by_deadline_;  // live jobs by (deadline, id)
  bool overloaded_ = false;
  bool demand_overrun_ = false;
  TimePoint last_miss_ = kNever;
  // red-robust ranks by job deadline until then (docs/DESIGN.md, "Overload").
  TimePoint hold_{0};
  std::vector<std::array<Duration, kEstimates>> run_cost_;  // by WorkModel slot
  std::vector<double> encoder_runs_per_job_;                // by operation
  // Scratch of the demand test on several lanes: per lane when it is free and its largest
  // idle gap so far; per unit of the job at hand when it ends.
  std::vector<TimePoint> lane_free_;
  std::vector<TimePoint> gap_begin_, gap_end_;
  std::vector<TimePoint> unit_end_;
};

}  // namespace sched_detail
}  // namespace red
