#pragma once
/// \file
/// Internal to src/sched: how red-robust sheds a job (docs/DESIGN.md, "Overload" "shed early,
/// shed little", and "Drops" hopeless), one mechanism in one place: its state, its constants and
/// its rules. The scheduler calls it at named points:
///
/// * at a release: `rejects_at_release` (shedding by rate, before the job is made), then
///   `released` (the offered load; the job rejected by rate ends there);
/// * before a decision: `admit_released` (admission: `shed_lone`, then Moore and Hodgson, over
///   the jobs released since the last decision);
/// * at a pick: `abort_hopeless` (a member job of the task chosen that cannot make it);
/// * at a job's end: `on_end`; when the workload changes: `on_workload`; when its costs are
///   planned again: `on_costs`.
///
/// The demand test it asks (Overload::first_overrun, overload.hpp, and the work figures) is
/// the scheduler's, shared with the per-round overload test; the offered load and
/// the jobs periodic operations will release (`expected_due`) are this type's, and the demand
/// test reads them while admission looks ahead.

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "overload.hpp"
#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

// Shedding by rate (PolicyOptions::shed_by_rate, part of red-robust): periodic operations
// without sensors are ordered by the lane time one job needs; one whose cheaper ones alone
// ask for every lane at their rates is outranked, and while the lanes are past capacity (with
// equal criticalities, on evidence of overload) and one of those cheaper operations sheds jobs
// itself, its jobs are rejected at release, before they cost anything.
class ShedByRate {
 public:
  /// How long an operation counts as shedding after it shed a job: the offered load's window
  /// (Shedding::kOfferedWindow), in seconds.
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

class Shedding {
 public:
  /// The offered load: work released (drop estimate, seconds), decayed over kOfferedWindow.
  static constexpr double kOfferedWindow = 0.25;  // seconds
  static_assert(ShedByRate::kWindow == kOfferedWindow);
  /// Offered load (× the lanes) past which admission looks ahead (PolicyOptions::lookahead):
  /// with less, a momentary burst would reject jobs the idle time absorbs.
  static constexpr double kLookaheadAt = 1.1;

  // ---- the named points -------------------------------------------------------------------

  /// At a release of operation `op`, before its job is made: whether shedding by rate rejects
  /// it (admission=shed, shed_by_rate, equal criticalities).
  bool rejects_at_release(Scheduler::Impl& m, int op, TimePoint now);
  /// The job in `slot` was released at `now` (its ready units made ready): its work joins the
  /// offered load (admission=shed), and admission will look at it before the next decision.
  /// `rejected`: what rejects_at_release said; the job then ends, rejected.
  void released(Scheduler::Impl& m, int slot, bool rejected, TimePoint now);
  /// Before a decision: admission of the jobs released since the last one (a policy that sheds).
  void admit_released(Scheduler::Impl& m, TimePoint now);
  /// docs/DESIGN.md, "Drops" hopeless, at a pick: aborts the first member job of task `t` (the
  /// task chosen, on a dispatch that pays round trip `rt`) that cannot make its deadline; true
  /// when one was aborted (the ready set then changed).
  bool abort_hopeless(Scheduler::Impl& m, int t, Duration rt, TimePoint now);
  /// A job of operation `op` ended.
  void on_end(int op, JobOutcome outcome, DropReason reason, TimePoint now) {
    by_rate_.on_end(op, outcome, reason, now);
  }
  /// Rates or graphs changed (an event, an operation's last release).
  void on_workload() noexcept { by_rate_.on_workload(); }
  /// The work figures were planned again (Scheduler::Impl::plan_work, Overload::plan): the jobs to
  /// come are counted again when next asked.
  void on_costs() noexcept { expected_stale_ = true; }

  // ---- what the demand test reads while admission looks ahead ------------------------------

  /// Lookahead (PolicyOptions::lookahead): true while admission also counts the jobs periodic
  /// operations will release, i.e. once the offered load passes kLookaheadAt × the lanes.
  bool looking_ahead(const Scheduler::Impl& m, TimePoint now) const;
  /// The work of the jobs periodic operations (own rate or triggered by a sensor) will release
  /// after `now` with deadlines by `t`, at their current rates, on estimate kind k: a job its
  /// units' cost, a frame's encoder run divided among the operations it triggers. `largest`,
  /// when given, is raised to the largest one such job of criticality at most `criticality`
  /// needs. Operations less critical than `min_crit` are left out.
  Duration expected_due(Scheduler::Impl& m, TimePoint now, TimePoint t, std::size_t k,
                        Duration* largest = nullptr, int criticality = 0,
                        int min_crit = kAnyCriticality);

 private:
  // True when the offered load exceeds what the lanes can do (docs/DESIGN.md, "Overload" detect
  // from demand).
  bool past_capacity(const Scheduler::Impl& m) const;
  // Admission (docs/DESIGN.md, "Overload" "shed early, shed little"): while the work due by some
  // deadline exceeds what the lanes can do by then (on the optimistic drop estimate), reject one
  // unstarted job due by then: the least critical, then the one whose removal saves the most
  // work, then the latest. On one lane this is Moore and Hodgson's rule (1968: drop the longest
  // job when a deadline is overrun), which minimizes the number of late jobs.
  void admit(Scheduler::Impl& m, TimePoint now);
  // docs/DESIGN.md, "Overload" "shed early", by frame (PolicyOptions::shed_lone, past capacity):
  // rejects the jobs released now that no other job in flight shares a frame with (other
  // operations read the sensor, but skipped or rejected this frame) and that leave their
  // operation fewer than half its max_inflight slots free, while those slots limit it (a release
  // of it skipped at max_inflight lately, or the demand test overrun). Called by admit() before
  // Moore and Hodgson. Lone jobs more critical than some job in flight go only when the jobs
  // of their criticality or more overrun by themselves (first_overrun's min_crit; k and
  // margin its).
  void shed_lone_jobs(Scheduler::Impl& m, TimePoint now, std::size_t k, int margin);
  // The job's remaining critical path under the drop estimate (docs/DESIGN.md, "Overload":
  // optimistic, so that a job that can still make it is kept): the longest path through its
  // unfinished units, a running unit counting its remainder. A lower bound on its response from
  // now on any number of lanes, unlike the docs/DESIGN.md, "Intermediate deadlines" sum of level
  // costs.
  static Duration remaining_for_drop(Scheduler::Impl& m, Job& j, TimePoint now);
  // The least criticality of the jobs in flight (INT_MAX with none).
  static int least_criticality(Scheduler::Impl& m);
  // The least criticality of the workload's live operations: admission and shed_lone reject
  // only jobs of it (docs/DESIGN.md, "Criticality").
  static int least_op_criticality(const Scheduler::Impl& m);
  // Ends the job in `slot`, rejected at release for `why`.
  static void reject(Scheduler::Impl& m, int slot, DropReason why, TimePoint now);

  bool released_ = false;  // a release came since the last admission test
  double offered_ = 0.0;   // the offered load, seconds of work
  TimePoint offered_at_{0};
  std::vector<int> lone_;  // shed_lone_jobs' victims, reused
  ShedByRate by_rate_;
  // Per operation: a job to come's work by estimate kind; stale when graphs or rates changed
  // since it was computed.
  std::vector<std::array<Duration, kEstimates>> expected_work_;
  bool expected_stale_ = true;
};

}  // namespace sched_detail
}  // namespace red
