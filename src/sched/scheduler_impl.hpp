#pragma once
/// \file
/// Internal to src/sched: the scheduler's state (the records of state.hpp, the ready set, lanes)
/// behind Scheduler::Impl, shared by the files of its mechanisms (listed at the top of
/// scheduler.cpp, which keeps the order of a decision).

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "batching.hpp"
#include "deadlines.hpp"
#include "guard.hpp"
#include "inherit.hpp"
#include "merge.hpp"
#include "ranking.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sched/scheduler.hpp"
#include "shedding.hpp"
#include "state.hpp"
#include "sync.hpp"

namespace red {

// Internal header, included only by the scheduler's own files.
using namespace sched_detail;  // NOLINT(google-build-using-namespace)

struct Scheduler::Impl {
  Scheduler& s;
  // The profile the scheduler plans with: the given one, or the online estimates' scaling
  // of it (docs/DESIGN.md, "Online costs"; use_costs()).
  const Profile* profile;
  std::optional<OnlineCosts> online;
  PolicyOptions opt;
  CostModel costs;
  CostModel given;  // on the profile given: deadlines resolve on it, whatever the plan's costs
  RefineOptions ropt;
  std::vector<std::shared_ptr<const RefinedGraph>> graphs;  // every version ever used
  std::vector<OpState> ops;
  // Own-clock releases (own rate, release: {count}) as a min-heap of (tick, operation): the
  // earliest comes first, ties in operation order, without a pass over every operation at
  // each event. An entry is current while its operation still releases (g set, remaining
  // not 0) at that tick; others are stale and dropped when they reach the top. Every change
  // of a next_tick pushes an entry (note_tick).
  mutable std::vector<std::pair<TimePoint, int>> ticks;
  void note_tick(int i) {
    const TimePoint t = ops[static_cast<std::size_t>(i)].next_tick;
    if (t == kNever) return;
    ticks.emplace_back(t, i);
    std::push_heap(ticks.begin(), ticks.end(), std::greater<>{});
  }
  // The earliest current entry (kNever, -1 when none), stale ones above it dropped.
  std::pair<TimePoint, int> next_tick() const {
    while (!ticks.empty()) {
      const auto [t, i] = ticks.front();
      const OpState& o = ops[static_cast<std::size_t>(i)];
      if (o.g != nullptr && o.remaining != 0 && o.next_tick == t) return {t, i};
      std::pop_heap(ticks.begin(), ticks.end(), std::greater<>{});
      ticks.pop_back();
    }
    return {kNever, -1};
  }
  std::vector<SensorState> sensors;
  std::size_t next_event = 0;
  std::vector<Job> jobs;
  std::vector<int> free_jobs;
  JobId next_job_id = 1;
  std::vector<Task> tasks;
  std::vector<TaskRank> task_ranks;  // beside `tasks`
  std::vector<int> free_tasks;
  // The ready set: tasks scanned one by one (`ready`), and those kept in groups that rank
  // alike (ready_set.cpp), scanned by their least only.
  std::vector<int> ready;
  std::vector<ReadyGroup> groups;
  std::vector<int> free_groups;
  std::vector<int> live_groups;
  std::map<GroupKey, int> group_of;
  int grouped_tasks = 0;
  std::vector<int> to_group;  // scratch of pick(): tasks that can join a group after the scan
  int ready_encoders = 0;     // encoder tasks in `ready`
  std::vector<Lane> lanes;
  std::vector<Dispatch*> out;
  std::vector<std::pair<TimePoint, std::pair<int, JobId>>> deadlines;  // min-heap
  std::vector<Observer*> observers;
  std::uint64_t stamp = 1;
  std::uint64_t dispatch_seq = 0;
  // Overload (docs/DESIGN.md, "Overload"): live jobs by (deadline, id), for the demand test;
  // whether the lanes are judged overloaded this round.
  std::vector<int> by_deadline;
  bool overloaded = false;
  // Evidence of overload (opt.miss_gate): when a job last ended without meeting its deadline
  // (missed, dropped, skipped at max_inflight). The mechanisms that act on signs of overload
  // other than the demand test (lookahead, shed_lone, shedding by rate, ranking by job deadline
  // at max_inflight) act only within kMissWindow of it.
  static constexpr double kMissWindow = 1.0;  // seconds
  TimePoint last_miss = kNever;
  bool evidenced(TimePoint now) const {
    return !opt.miss_gate || (last_miss != kNever && now - last_miss <= from_s(kMissWindow));
  }
  bool demand_overrun = false;  // this round's demand test found more work than the lanes do
  // red-robust ranks by job deadline until then (docs/DESIGN.md, "Overload").
  TimePoint overload_hold{0};
  // Ranking (docs/DESIGN.md, "Dispatch"; ranking.hpp): the rank mode, the policy's rank, the
  // scenario's criticalities, who ranks by job deadline this round.
  Ranking ranking;
  std::vector<TimePoint> lane_free;  // scratch of the demand test on several lanes
  std::vector<TimePoint> unit_end;
  std::vector<TimePoint> gap_begin, gap_end;  // per lane: its largest idle gap so far
  struct Scan {                               // one cache line
    Key key;
    TimePoint deadline;  // valid where deadline_known; else task_deadline() gives it
    int task;
    int criticality;
    UnitKind kind;  // the task's, for batching without another look at it
    bool deadline_known;
    // Taken out of this pick: its task began a wait (merge wait, the guard's hold until a
    // release), or yielded to more critical work (the guard; it may still join a batch).
    enum class Out : std::uint8_t { No, Waits, Yields } out;
    int head;
  };
  static_assert(sizeof(Scan) <= 64);
  std::vector<Scan> scanned;
  // Inter-DAG batching (docs/DESIGN.md, "Refinement"; batching.hpp): batch costs and the batch
  // a pick forms; its state.
  Batching batching;

  Impl(Scheduler& owner, const Profile& p);

  void notify_job(const Job& j, JobOutcome o, TimePoint finish, bool release_event);

  // Makes snapshot `spec` the current definition of operation `i` (docs/DESIGN.md, "Intermediate
  // deadlines": one refinement per graph version, shared by every job released with it).
  void install(int i, const std::shared_ptr<const OperationSpec>& spec, TimePoint at, bool initial);

  Job& job(int slot) { return jobs[static_cast<std::size_t>(slot)]; }
  Task& task(int t) { return tasks[static_cast<std::size_t>(t)]; }
  TaskRank& task_rank(int t) { return task_ranks[static_cast<std::size_t>(t)]; }

  // ---- jobs ---------------------------------------------------------------------------

  int alloc_job();

  // True when every sensor the graph reads has produced a frame (the trigger frame counts).
  bool inputs_ready(const RefinedGraph& g, int trigger_sensor) const;

  void release(int op_index, TimePoint now, int trigger_sensor, std::uint64_t trigger_frame);

  void end_job(int slot, JobOutcome outcome, TimePoint now);

  // Order of live jobs in by_deadline: end-to-end deadline, then job id.
  bool earlier(int a, int b) const;

  void free_job(int slot);

  // Rebuilds what changes only when one of the job's units starts or ends: the costs of
  // its units not yet started, per height, and — when none is running — the shares of the
  // re-assigned budget (docs/DESIGN.md, "Intermediate deadlines"), which are then the same at every
  // decision.
  void refresh(Job& j) {
    if (j.dirty) rebuild(j);
  }
  void rebuild(Job& j);

  // Re-assignment (docs/DESIGN.md, "Re-assignment"; deadlines.hpp): the budget left spread over
  // the heights that still have work, at each decision; the deadline split.
  Reassignment reassign;

  // A job with running units: their remaining cost is c(x) − elapsed, at least 0 (docs/DESIGN.md,
  // "Intermediate deadlines"), so level costs, the remaining work and the shares depend on now.
  // Cached per decision.
  void eval(Job& j, TimePoint now) {
    refresh(j);
    if (j.stamp != stamp) eval_now(j, now);
  }
  void eval_now(Job& j, TimePoint now);

  // The one place a unit's deadline is assigned: the absolute intermediate deadline of height
  // h of a job at `now` (docs/DESIGN.md, "Intermediate deadlines" and "Policies"). Ranking,
  // batching, the ready set's groups and Scheduler::unit_deadline all read it. Inline: ranking
  // calls it for every member of every ready task.
  TimePoint unit_deadline(Job& j, int h, TimePoint now) {
    return height_deadline(reassign.split(), j.release, j.plan, [&] {
      const auto hi = static_cast<std::size_t>(h);
      // Re-assignment: the shares of the job's cache, as they are at `now`; else refinement's.
      return reassign.on() ? Reassignment::deadline(*this, j, hi, now)
                           : j.release + j.g->static_offset[hi];
    });
  }

  // Estimated work left in a job (Σ remaining level costs: its critical-path estimate).
  Duration remaining_work(Job& j, TimePoint now) {
    refresh(j);
    if (j.running_units.empty()) return j.remaining_base;
    eval(j, now);
    return j.remaining;
  }

  // The longest path through a job's unfinished units under estimate kind k, a running unit
  // counting its remainder.
  Duration critical_path(Job& j, TimePoint now, std::size_t k);

  // Remaining cost of a running unit under estimate kind k (docs/DESIGN.md, "Intermediate
  // deadlines": c(x) − elapsed, at least 0).
  static Duration residual(const Job& j, std::size_t unit, TimePoint now, std::size_t k) {
    const Duration c = j.g->units[unit].costs[k];
    const TimePoint start = j.u[unit].start;
    return now > start ? std::max(Duration{0}, c - (now - start)) : c;
  }

  // docs/DESIGN.md, "Overload" demand: the lane time a job still needs under estimate kind k. A
  // queued encoder run is shared by the members of its task and a running unit by the members of
  // its dispatch, so shared encoder runs are counted once.
  Duration work_left(Job& j, TimePoint now, std::size_t k);

  // The necessary work of the workload in effect (red/graph/necessary_work.hpp): the lane time one
  // run of each unit takes as RED runs it (encoder runs shared, runs batched as the deadlines
  // allow), by WorkModel slot and estimate kind. Every work figure of the overload mechanisms
  // (work_left, the demand test, admission, the jobs to come) counts a unit at it, so that they
  // agree with `red analyze` and the sweep's limit. Recomputed by plan_work() when the workload
  // changes (an event, an operation's last release).
  std::vector<std::array<Duration, kEstimates>> run_cost;
  std::vector<double> encoder_runs_per_job;  // by operation (WorkEstimate)
  void plan_work();
  // Plans with `p` from now on (scheduler.cpp): unit costs, batch costs, every active
  // operation's graph priced again (its deadline kept), the demand model. Jobs in flight
  // keep the graph they were released with.
  void use_costs(const Profile& p);
  // Unit and batch costs from `p` (the constructor, use_costs()).
  void price(const Profile& p);
  // What unit `ru` counts for in the work figures under estimate kind k.
  [[nodiscard]] Duration unit_cost(const RefinedUnit& ru, std::size_t k) const {
    switch (ru.kind) {
      case UnitKind::Encoder:
        return run_cost[WorkModel::kEncoder][k];
      case UnitKind::Head:
        return run_cost[WorkModel::head_slot(ru.head)][k];
      case UnitKind::Coarse:
        return run_cost[WorkModel::kEncoder][k] + run_cost[WorkModel::head_slot(ru.head)][k];
      default:
        return ru.costs[k];
    }
  }

  // The demand test (docs/DESIGN.md, "Overload"): taking live jobs by deadline, the first that the
  // lanes cannot finish by its deadline under estimate kind k; -1 when all of it fits. A position
  // in by_deadline. On one lane that is the first whose deadline comes before the work due by it
  // (its own and every earlier job's): exact for non-preemptive EDF up to blocking. On several
  // lanes the work due does not say enough: a DAG's critical path cannot use the lanes'
  // parallelism. `schedule` then list-schedules the remaining units (admission, at releases);
  // without it (the per-round overload check) the bound is the larger of the job's own critical
  // path and the work due spread over every lane, a lower bound. `margin` (percent) pads every
  // estimate (admission's margin, docs/DESIGN.md, "Overload"); 0 in the per-round overload test.
  // Admission passes `from` (the first position that may be returned; earlier jobs still
  // count) and `skip_doomed` (jobs that cannot make it alone count for nothing).
  // `min_crit`: only the jobs (and jobs to come) of that criticality or more count, besides
  // the units the lanes hold: the test for what pick() runs first under overload (docs/DESIGN.md,
  // "Criticality").
  int first_overrun(TimePoint now, std::size_t k, bool schedule, int margin, std::size_t from,
                    bool skip_doomed, int min_crit = kAnyCriticality);

  // first_overrun(now, k, false, 0, 0, false) >= 0, the per-round overload test (docs/DESIGN.md,
  // "Overload"), decided where it can be from bounds kept per job (work_base and work_most bracket
  // work_left), walking the jobs' units only where the bounds do not tell.
  bool demand_overruns(TimePoint now, std::size_t k);

  // A job that cannot finish by its deadline even alone: its critical path under estimate
  // kind k ends after it.
  bool doomed(Job& j, TimePoint now, std::size_t k);

  // d padded by `margin` percent (d itself for 0).
  static Duration padded(Duration d, int margin) {
    return margin == 0 ? d : d * (100 + margin) / 100;
  }

  // The demand test on several lanes: jobs by deadline, each remaining unit at its earliest
  // start (its predecessors' end, a lane's end) on the lane that leaves the smallest gap (or in an
  // idle gap it fits).
  int first_overrun_lanes(TimePoint now, std::size_t k, int margin, std::size_t from,
                          bool skip_doomed, int min_crit);

  // True when an operation that still releases jobs is at its max_inflight (docs/DESIGN.md,
  // "max_inflight").
  bool saturated() const;

  // ---- tasks --------------------------------------------------------------------------

  int alloc_task();

  void push_ready(int t);

  void pop_ready(int t);
  // Takes task t out of `ready` (where it is), keeping the others in place but the last.
  void unlist_ready(Task& k) {
    const int last = ready.back();
    ready[static_cast<std::size_t>(k.ready_pos)] = last;
    task(last).ready_pos = k.ready_pos;
    ready.pop_back();
    k.ready_pos = -1;
  }

  void free_task(int t);

  void remove_member(int t, int slot, int unit);

  // ---- the ready set's groups (ready_set.cpp) -------------------------------------------

  // Ready tasks in all (grouped or not).
  [[nodiscard]] int ready_count() const noexcept {
    return static_cast<int>(ready.size()) + grouped_tasks;
  }
  // The key task t ranks by at every `now`, when it can be kept in a group (pick() has just
  // ranked it); false when it cannot.
  bool group_key(int t, TimePoint now, GroupKey& gk);
  // Moves ready task t from `ready` into the group of key gk.
  void join_group(int t, const GroupKey& gk);
  // Takes task t out of its group (back into `ready` when `keep_ready`).
  void leave_group(int t, bool keep_ready);
  // A job whose caches are about to change (dirty): its grouped tasks go back to `ready`.
  void touch(Job& j) {
    j.dirty = true;
    if (j.grouped > 0) ungroup_job(j);
  }
  void ungroup_job(Job& j);
  // Every group back into `ready` (an event changed what ranking reads: criticalities).
  void ungroup_all();

  void make_ready(int slot, int unit);
  // Deadline inheritance (PolicyOptions::inherit; inherit.hpp): a job that a new one depends on
  // is planned to end in time for it.
  Inheritance inheritance;

  // DynamicMerge (docs/DESIGN.md, "DynamicMerge"; merge.hpp): joins of encoder units into
  // queued encoder tasks, merge waits and the list of every wait a pick takes, the newest frame
  // a γ-merged run reads; its state.
  DynamicMerge merge;

  // On-demand synchronization and placement (docs/DESIGN.md, "Synchronization"; sync.hpp): the
  // runs the lanes' handlers hold, the lane a pick places its task on and the round trip it pays.
  OnDemandSync sync;

  // Starts the batch formed (Batching::batch) where the pick placed it, checked against
  // `deadline`.
  void start_dispatch(const Placement& at, TimePoint now, TimePoint deadline);
  // Sets when a dispatched unit starts, on the dispatch and its members' units.
  void set_start(Dispatch& d, TimePoint start);
  // dispatch_ahead(): the successors that wait only on a unit `lane` holds become ready for
  // that lane alone (not encoders: they merge across lanes).
  void ready_in_lane_order(int lane);
  // The round's overload state before a pick (docs/DESIGN.md, "Overload"): saturation, the demand
  // test, the hold of "finish what was started" (dispatch() and dispatch_ahead()).
  void assess_overload(TimePoint now);
  // How red-robust sheds a job (docs/DESIGN.md, "Overload" and "Drops" hopeless; shedding.hpp):
  // shedding by rate and the offered load at a release, admission before a decision, hopeless
  // aborts at a pick; its state and constants.
  Shedding shedding;
  // The counters, for the mechanism types (which are not members of Scheduler).
  SchedulerStats& stats() noexcept { return s.stats_; }

  // Picks work for an idle lane (placed by OnDemandSync::place), or with `ahead` >= 0 for the
  // queue of that busy lane (dispatch_ahead()); false when nothing can start now. Its stages
  // (dispatch.cpp): scan, choose (best_candidate, the lane, guard_holds,
  // shedding.abort_hopeless, merge_waits), form_batch.
  bool pick(TimePoint now, int ahead);
  // One pick's state between its stages.
  struct Pick {
    int ahead = -1;         // the lane whose queue it fills (dispatch_ahead()), -1 for an idle lane
    std::size_t least = 0;  // the scan's least key
    int shed_below = std::numeric_limits<int>::min();  // criticalities shed first (overload)
    int out = 0;                                       // scan entries taken out (Scan::out)
    const Scan* best = nullptr;                        // the task chosen
    Placement at;  // its lane and the round trip it pays (OnDemandSync::place)
  };
  enum class Chosen : std::uint8_t { Task, Nothing, Rescan };
  void scan(TimePoint now, Pick& p);
  const Scan* best_candidate(const Pick& p) const;
  void set_out(Pick& p, Scan& e, TimePoint until);
  Chosen choose(TimePoint now, Pick& p);
  bool guard_holds(TimePoint now, Pick& p);
  bool merge_waits(TimePoint now, Pick& p);
  TimePoint form_batch(TimePoint now, const Pick& p);

  // The criticality guard (docs/DESIGN.md, "Criticality"; guard.hpp): whether a dispatch would
  // make a more critical job miss; its state.
  CriticalityGuard crit_guard;
  // When a lane is free to start more work, by the plan's estimates of what it holds.
  TimePoint lane_free_at(const Lane& l, TimePoint now) const;
  // When a dispatch picked now and placed `at` begins (before its round trip): now, or after
  // what the lane holds when the pick fills its queue (dispatch_ahead).
  TimePoint dispatch_begin(const Placement& at, TimePoint now) const {
    return at.ahead ? lane_free_at(lanes[static_cast<std::size_t>(at.lane)], now) : now;
  }
};

}  // namespace red
