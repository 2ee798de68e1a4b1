#pragma once
/// \file
/// Internal to src/sched: the scheduler's state behind Scheduler::Impl (the records of
/// state.hpp; the parts that are types, each owning its state: the slots of jobs and tasks,
/// pools.hpp; what releases jobs, releases.hpp; the ready set, ready_set.hpp; overload,
/// overload.hpp; and the mechanisms' types), shared by the files of its mechanisms (listed at
/// the top of scheduler.cpp, which keeps the order of a decision).

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
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
#include "overload.hpp"
#include "pools.hpp"
#include "ranking.hpp"
#include "ready_set.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sched/scheduler.hpp"
#include "releases.hpp"
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
  // What releases jobs besides the operations (releases.hpp): the sensors' newest frames, the
  // own-clock ticks, the workload events still to come.
  Releases releases;
  // The slots of jobs and tasks (pools.hpp).
  JobPool jobs;
  TaskPool tasks;
  // The ready set (ready_set.hpp): tasks scanned one by one, and those kept in groups that
  // rank alike, scanned by their least only; its state.
  ReadySet ready;
  std::vector<Lane> lanes;
  std::vector<Dispatch*> out;
  std::vector<std::pair<TimePoint, std::pair<int, JobId>>> deadlines;  // min-heap
  std::vector<Observer*> observers;
  std::uint64_t stamp = 1;
  std::uint64_t dispatch_seq = 0;
  // Overload (docs/DESIGN.md, "Overload"; overload.hpp): the live jobs by deadline, the demand
  // test and the necessary work it counts, the evidence of overload and the round's verdict;
  // its state.
  Overload overload;
  // Ranking (docs/DESIGN.md, "Dispatch"; ranking.hpp): the rank mode, the policy's rank, the
  // scenario's criticalities, who ranks by job deadline this round.
  Ranking ranking;
  struct Scan {  // one cache line
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

  Job& job(int slot) { return jobs[slot]; }
  Task& task(int t) { return tasks[t]; }
  TaskRank& task_rank(int t) { return tasks.rank(t); }

  // ---- jobs ---------------------------------------------------------------------------

  void release(int op_index, TimePoint now, int trigger_sensor, std::uint64_t trigger_frame);

  void end_job(int slot, JobOutcome outcome, TimePoint now);

  // The job in `slot` is over and nothing refers to it any more.
  void free_job(int slot) { jobs.free(slot); }

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

  // docs/DESIGN.md, "Overload" demand: the lane time a job still needs under estimate kind k, units
  // counted at the necessary work (Overload::unit_cost). A queued encoder run is shared by the
  // members of its task and a running unit by the members of its dispatch, so shared encoder runs
  // are counted once.
  Duration work_left(Job& j, TimePoint now, std::size_t k);

  // The necessary work of the workload in effect (Overload::plan), computed again when the
  // workload changes (an event, an operation's last release) or the plan's costs do; the jobs'
  // work figures then go stale.
  void plan_work();
  // Plans with `p` from now on (scheduler.cpp): unit costs, batch costs, every active
  // operation's graph priced again (its deadline kept), the demand model. Jobs in flight
  // keep the graph they were released with.
  void use_costs(const Profile& p);
  // Unit and batch costs from `p` (the constructor, use_costs()).
  void price(const Profile& p);
  // What unit `ru` counts for in the work figures under estimate kind k (Overload::unit_cost).
  [[nodiscard]] Duration unit_cost(const RefinedUnit& ru, std::size_t k) const {
    return overload.unit_cost(ru, k);
  }

  // A job that cannot finish by its deadline even alone: its critical path under estimate
  // kind k ends after it.
  bool doomed(Job& j, TimePoint now, std::size_t k);

  // True when an operation that still releases jobs is at its max_inflight (docs/DESIGN.md,
  // "max_inflight").
  bool saturated() const;

  // ---- tasks --------------------------------------------------------------------------

  void free_task(int t);

  void remove_member(int t, int slot, int unit);

  // ---- the ready set's groups (ready_set.cpp) -------------------------------------------

  // The key task t ranks by at every `now`, when it can be kept in a group (pick() has just
  // ranked it); false when it cannot.
  bool group_key(int t, TimePoint now, GroupKey& gk);
  // A job whose caches are about to change (dirty): its grouped tasks are listed again.
  void touch(Job& j) {
    j.dirty = true;
    if (j.grouped > 0) ungroup_job(j);
  }
  void ungroup_job(Job& j) { ready.ungroup_job(*this, j); }

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
