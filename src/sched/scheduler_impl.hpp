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
#include "guard.hpp"
#include "merge.hpp"
#include "overload.hpp"
#include "pools.hpp"
#include "ready_set.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sched/scheduler.hpp"
#include "releases.hpp"
#include "shedding.hpp"
#include "state.hpp"

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
  // The policy's rank is the deadline it is shown, and it reads no other field of the
  // task's view (Policy::ranks_by_deadline_only).
  bool edf_rank = false;
  bool mixed_criticality = false;
  int uniform_criticality = 0;  // every operation's, when not mixed
  int top_criticality = 0;      // the highest of any operation's
  struct Scan {                 // one cache line
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

  // Re-assignment (docs/DESIGN.md, "Re-assignment"): the budget left, B = deadline − now, is spread
  // over the heights that still have work in proportion to their remaining level costs (or per-node
  // overrides); height h ends at now + B · frac[h], frac[h] the cumulative share up to h (exactly 1
  // for the last height: its deadline is the job's).
  void shares(const Job& j, const std::vector<Duration>& lvl, const std::vector<std::uint8_t>& has,
              std::vector<double>& frac) const;

  static TimePoint from_share(const Job& j, double frac, TimePoint now) {
    const Duration budget = j.plan - now;
    if (budget <= Duration{0} || frac == 1.0) return j.plan;
    return now + Duration{static_cast<std::int64_t>(static_cast<double>(budget.count()) * frac)};
  }

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
    return height_deadline(opt.deadlines, j.release, j.plan, [&] {
      const auto hi = static_cast<std::size_t>(h);
      if (!opt.reassign) return j.release + j.g->static_offset[hi];
      // Re-assignment: the shares of the job's cache, as they are at `now`.
      refresh(j);
      if (j.running_units.empty()) return from_share(j, j.frac[hi], now);
      eval(j, now);
      return from_share(j, j.frac_now[hi], now);
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

  // The longest path after a unit of j (the unit itself not counted) on the scheduler's
  // estimate (p99 by default): what j still needs once the unit has ended.
  Duration path_after(const Job& j, int unit) const {
    const RefinedUnit& u = j.g->units[static_cast<std::size_t>(unit)];
    const std::size_t e = idx(s.config_.estimate);
    return u.tail[e] - u.costs[e];
  }

  // What ranking by job deadline reads for one member: the job's deadline, less the path
  // after the unit with path_rank (docs/DESIGN.md, "Overload"; docs/journal/overload-grid.md,
  // round 9: on mean costs instead, one of the tests' 216 sets lost a job to edf at capacity).
  TimePoint rank_deadline(const Job& j, int unit) const {
    return opt.path_rank ? j.plan - path_after(j, unit) : j.plan;
  }

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
  // Deadline inheritance (PolicyOptions::inherit): plan `d` to end by `due` when that is
  // earlier than its plan; its ready tasks leave their groups and their cached rank follows.
  void inherit_plan(Job& d, TimePoint due);

  // Rank and tie-break key of a ready task at `now` (computes member jobs' deadlines).
  Key key(int t, TimePoint now, TaskView& v);

  // True when the policy ranks the task by its jobs' end-to-end deadline this round
  // (docs/DESIGN.md, "Overload": rank=job-deadline, or rank=overload while overloaded; a ready
  // encoder on several lanes only when the demand test overran).
  bool by_job_deadline(const Task& k) const {
    return opt.rank == RankMode::JobDeadline ||
           (opt.rank == RankMode::Overload && overload.overloaded() &&
            (k.kind != UnitKind::Encoder || s.config_.lanes == 1 || overload.demand_overrun()));
  }

  // True when this round ranks tasks by job deadline with the EDF rank and equal
  // criticalities (those by_job_deadline picks): pick() reads what each task keeps then,
  // with no look into its jobs.
  bool ranks_from_tasks() const {
    return edf_rank && !mixed_criticality &&
           (opt.rank == RankMode::JobDeadline ||
            (opt.rank == RankMode::Overload && overload.overloaded()));
  }

  // The task's deadline as key() computes it (the earliest of its members' deadlines).
  TimePoint task_deadline(const Task& k, TimePoint now);

  // The member's tie-break key (rank 0): release, operation, job, node, unit.
  Key tie_key(int slot, int unit, int node) {
    const Job& j = job(slot);
    return Key{0, j.release, j.op, j.seq, node, unit};
  }

  // DynamicMerge (docs/DESIGN.md, "DynamicMerge"; merge.hpp): joins of encoder units into
  // queued encoder tasks, merge waits and the list of every wait a pick takes, the newest frame
  // a γ-merged run reads; its state.
  DynamicMerge merge;

  Duration round_trip_cost(bool round_trip) const;

  // docs/DESIGN.md, "Synchronization" on-demand: the task continues the run the lane's handler
  // holds — its last unit completed just now and the task is ready work of a job of the run (a
  // merged encoder's member heads, a job's ready units of a height, their successors) — so the
  // handler goes on without a round trip. Anything else, or per-edge synchronization, pays one.
  bool on_demand_continuation(const Lane& lane, const Task& k, TimePoint now) const;

  // The idle lane for a task (docs/DESIGN.md, "Synchronization" placement): one whose run it
  // continues, else one without an open run (keeping open runs for their own work), else the first
  // idle lane; -1 if none.
  int choose_lane(const Task& k, TimePoint now) const;

  void start_dispatch(int lane_index, TimePoint now, TimePoint deadline);
  // Sets when a dispatched unit starts, on the dispatch and its members' units.
  void set_start(Dispatch& d, TimePoint start);
  // dispatch_ahead(): the lane that pick() fills (its queue), -1 for dispatch().
  int ahead_lane = -1;
  // dispatch_ahead(): the successors that wait only on a unit `lane` holds become ready for
  // that lane alone (not encoders: they merge across lanes).
  void ready_in_lane_order(int lane);
  // How red-robust sheds a job (docs/DESIGN.md, "Overload" and "Drops" hopeless; shedding.hpp):
  // shedding by rate and the offered load at a release, admission before a decision, hopeless
  // aborts at a pick; its state and constants.
  Shedding shedding;
  // The counters, for the mechanism types (which are not members of Scheduler).
  SchedulerStats& stats() noexcept { return s.stats_; }

  // Picks work for an idle lane (placed by choose_lane); false when nothing can start now.
  // Its stages (dispatch.cpp): scan, choose (best_candidate, the lane, guard_holds,
  // shedding.abort_hopeless, merge_waits), form_batch.
  bool pick(TimePoint now);
  // One pick's state between its stages.
  struct Pick {
    std::size_t least = 0;                             // the scan's least key
    int shed_below = std::numeric_limits<int>::min();  // criticalities shed first (overload)
    int out = 0;                                       // scan entries taken out (Scan::out)
    const Scan* best = nullptr;                        // the task chosen
    int lane = -1;                                     // its lane
    Duration rt{0};                                    // the round trip the dispatch pays
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
  // When a dispatch picked now for lane `lane` begins: now, or after what the lane holds when
  // pick() fills its queue (dispatch_ahead).
  TimePoint dispatch_begin(int lane, TimePoint now) const {
    return ahead_lane >= 0 ? lane_free_at(lanes[static_cast<std::size_t>(lane)], now) : now;
  }
};

}  // namespace red
