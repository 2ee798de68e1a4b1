#pragma once
/// \file
/// Internal to src/sched: ranking (docs/DESIGN.md, "Dispatch", "Overload" and "Criticality";
/// PolicyOptions::rank and path_rank), one mechanism in one place: the rank mode, the policy's
/// rank, the criticalities of the scenario, and who ranks by job deadline this round. The
/// scheduler calls it at named points:
///
/// * at the start: `set_up` (the policy, the scenario's criticalities, the estimate);
/// * a task is made or its members change: `tie_key` and `rank_deadline`, what TaskRank keeps
///   (tasks.cpp, DynamicMerge::join, deadline inheritance);
/// * at a pick, before its scan: `at_pick` (the round's overload state), then for each ready
///   task `key`, or `kept_key` where `ranks_from_tasks` and `by_job_deadline` say the task
///   ranks from what it keeps;
/// * at a pick's last stage: `task_deadline` (the deadline a batch is checked against) and
///   `by_job_deadline` (batch_by_job).
///
/// The criticality guard, shedding, batching and the overload test read the criticalities
/// (`mixed_criticality`, `top_criticality`), the overload test and hopeless aborts the rank
/// mode (`overload_aware`), and the guard and batching `path_after`.

#include <algorithm>
#include <cstddef>

#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class Ranking {
 public:
  /// At the start: the policy (its options and rank), the scheduler's estimate and lanes, and
  /// the criticalities of every operation the scenario runs (its initial ones and its events').
  void set_up(const Policy& policy, const Scenario& sc, const SchedulerConfig& config);

  // ---- the scenario's criticalities ---------------------------------------------------------

  /// Whether criticalities differ somewhere in the scenario (docs/DESIGN.md, "Criticality").
  [[nodiscard]] bool mixed_criticality() const noexcept { return mixed_; }
  /// The highest criticality of any operation.
  [[nodiscard]] int top_criticality() const noexcept { return top_; }

  /// rank=overload (red-robust): tasks rank by job deadline while the lanes are judged
  /// overloaded, and until the jobs in flight then are due (docs/DESIGN.md, "Overload"); the
  /// round's overload state and hopeless aborts follow that judgement.
  [[nodiscard]] bool overload_aware() const noexcept { return mode_ == RankMode::Overload; }

  // ---- what a task keeps (TaskRank) ---------------------------------------------------------

  /// The member's tie-break key (rank 0): release, operation, job, node, unit.
  static Key tie_key(const Job& j, int unit, int node) noexcept {
    return Key{0, j.release, j.op, j.seq, node, unit};
  }
  /// The longest path after a unit of j (the unit itself not counted) on the scheduler's
  /// estimate (p99 by default): what j still needs once the unit has ended.
  [[nodiscard]] Duration path_after(const Job& j, int unit) const {
    const RefinedUnit& u = j.g->units[static_cast<std::size_t>(unit)];
    return u.tail[estimate_] - u.costs[estimate_];
  }
  /// What ranking by job deadline reads for one member: the job's deadline, less the path
  /// after the unit with path_rank (docs/DESIGN.md, "Overload"; docs/journal/overload-grid.md,
  /// round 9: on mean costs instead, one of the tests' 216 sets lost a job to edf at capacity).
  [[nodiscard]] TimePoint rank_deadline(const Job& j, int unit) const {
    return path_rank_ ? j.plan - path_after(j, unit) : j.plan;
  }

  // ---- at a pick ----------------------------------------------------------------------------

  /// Before a pick's scan: the round's overload state (Overload::assess, overload.hpp),
  /// `overloaded` and whether the demand test overran, which say who ranks by job deadline.
  void at_pick(bool overloaded, bool demand_overrun) noexcept {
    const bool robust = mode_ == RankMode::Overload && overloaded;
    overloaded_ = overloaded;
    by_job_ = mode_ == RankMode::JobDeadline || robust;
    by_job_encoders_ = mode_ == RankMode::JobDeadline || (robust && (one_lane_ || demand_overrun));
  }
  /// True when the policy ranks task `k` by its jobs' end-to-end deadline this round
  /// (docs/DESIGN.md, "Overload": rank=job-deadline, or rank=overload while overloaded; a ready
  /// encoder on several lanes only when the demand test overran).
  [[nodiscard]] bool by_job_deadline(const Task& k) const noexcept {
    return k.kind == UnitKind::Encoder ? by_job_encoders_ : by_job_;
  }
  /// True when this round ranks tasks by job deadline with the EDF rank and equal
  /// criticalities (those by_job_deadline picks): a pick reads what each task keeps then,
  /// with no look into its jobs.
  [[nodiscard]] bool ranks_from_tasks() const noexcept { return edf_rank_ && !mixed_ && by_job_; }
  /// The key of a task ranked from what it keeps (ranks_from_tasks): the rank() of its view by
  /// job deadline (the EDF trait) on its least member's tie-break key.
  static Key kept_key(const TaskRank& r) noexcept {
    Key k = r.tie;
    k.rank = r.job_deadline.count();
    return k;
  }
  /// key()'s criticality with equal ones (ranks_from_tasks): the view's 0 or more.
  [[nodiscard]] int kept_criticality() const noexcept { return std::max(0, uniform_); }

  /// Rank and tie-break key of ready task `t` at `now` (computes its member jobs' deadlines);
  /// `v` the policy's view of it.
  Key key(Scheduler::Impl& m, int t, TimePoint now, TaskView& v) const;
  /// The task's deadline as key() computes it (the earliest of its members' deadlines).
  static TimePoint task_deadline(Scheduler::Impl& m, const Task& k, TimePoint now);

 private:
  const Policy* policy_ = nullptr;
  RankMode mode_ = RankMode::Policy;
  bool path_rank_ = false;
  // The policy's rank is the deadline it is shown, and it reads no other field of the
  // task's view (Policy::ranks_by_deadline_only).
  bool edf_rank_ = false;
  bool one_lane_ = true;
  std::size_t estimate_ = 0;  // the scheduler's estimate kind (path_after)
  bool mixed_ = false;
  int uniform_ = 0;  // every operation's criticality, when not mixed
  int top_ = 0;      // the highest of any operation's
  // This round's (at_pick): the lanes judged overloaded; tasks other than encoders, and
  // encoders, rank by job deadline.
  bool overloaded_ = false;
  bool by_job_ = false;
  bool by_job_encoders_ = false;
};

}  // namespace sched_detail
}  // namespace red
