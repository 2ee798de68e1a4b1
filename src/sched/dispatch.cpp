// The pick of one decision (docs/DESIGN.md, "Dispatch"): the scan of the ready set (each
// task ranked by Ranking, ranking.hpp), the lane, hopeless aborts, merge waits and batching,
// in that order. Part of the scheduler (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

// pick(): the stages of one pick, in order. A hopeless abort may free the task chosen (or
// change what others rank by): the ready set is then scanned again.
bool Scheduler::Impl::pick(TimePoint now, int ahead) {
  Pick p;
  p.ahead = ahead;
  // The round's overload state (overload.hpp), as ranking reads it (ranking.hpp).
  ranking.at_pick(overload.overloaded(), overload.demand_overrun());
  for (;;) {
    scan(now, p);
    switch (choose(now, p)) {
      case Chosen::Nothing:
        return false;
      case Chosen::Rescan:
        continue;
      case Chosen::Task:
        break;
    }
    start_dispatch(p.at, now, form_batch(now, p));
    return true;
  }
}

// Stage 1, the scan: one ranks every ready task (the policy's key, and the deadline batching
// orders by); a merge wait or a guard's hold then only moves to the next best entry of it.
void Scheduler::Impl::scan(TimePoint now, Pick& p) {
  scanned.clear();
  const int ahead = p.ahead;  // the lane it fills stays
  p = Pick{};
  p.ahead = ahead;
  // Criticality (docs/DESIGN.md, "Criticality"): under overload — the demand test finds more work
  // due than the lanes can do, or some ready job cannot, by estimate, finish alone by its
  // deadline — ready work of the most critical operations goes first and lower-criticality work
  // waits, so it is shed first. With equal criticalities (the default) nothing changes.
  // The demand test's verdict alone: not red-robust's wider `overloaded` (an operation at
  // its max_inflight, the hold after an overload), which put every critical unit first
  // while the lanes could carry everything (issue 37: red-robust missed 2-3x red's jobs).
  bool overrun = overload.demand_overrun();
  int top = std::numeric_limits<int>::min();
  // With equal criticalities the order is the keys' alone: the least is kept as they come.
  std::size_t least = 0;
  auto rank_task = [&](int t) __attribute__((always_inline)) {
    Task& tk = task(t);
    if (tk.wait_until > now) return;
    if (tk.lane_only >= 0 && tk.lane_only != ahead) return;  // behind a busy lane
    if (ranking.ranks_from_tasks() && ranking.by_job_deadline(tk)) {
      // EDF by job deadline reads only the earliest job deadline and the least member
      // key, both kept beside the task (TaskRank): no look into the jobs. The task's own
      // deadline is computed where it is read (task_deadline). With equal criticalities
      // neither the remaining work nor the criticality orders anything. The jobs' caches
      // read later give what this scan would have left, or values that decide the same:
      // refresh() rebuilds from the job's state (of the changes made without `dirty`, a
      // dependent's head source becoming ready changes nothing rebuild() computes, and
      // another member joining a queued encoder run only loosens work_most, a bound the
      // demand test backs with its exact walk), and start_dispatch takes a job's
      // evaluation at `now` before it changes the job.
      const int crit = ranking.kept_criticality();
      scanned.push_back({Ranking::kept_key(task_rank(t)), TimePoint{0}, t, crit, tk.kind, false,
                         Scan::Out::No, tk.head});
      top = std::max(top, crit);
    } else {
      TaskView v;
      const Key k = ranking.key(*this, t, now, v);
      scanned.push_back({k, v.deadline, t, v.criticality, tk.kind, true, Scan::Out::No, tk.head});
      overrun = overrun || now + v.remaining > v.job_deadline;
      top = std::max(top, v.criticality);
    }
    if (scanned.back().key < scanned[least].key) least = scanned.size() - 1;
  };
  // Every task scanned one by one, and the least of each group of tasks that rank alike
  // (ready_set.cpp): the others of a group rank as it does and come after it in the
  // tie-break, so neither the best, nor under criticality the order, nor batching
  // (groups hold plain units only) reads them.
  // Groups form only in a ready set this large (SchedulerConfig::group_from): below it a
  // scan of every task is as cheap.
  const bool grouping = ready.count() >= s.config_.group_from;
  for (int t : ready.listed()) rank_task(t);
  ready.for_each_group_least(rank_task);
  // Those that rank alike from now on join their group, with nothing changed since the scan.
  if (grouping) ready.regroup(*this, now);
  p.least = least;
  p.shed_below = overrun ? top : std::numeric_limits<int>::min();
}

// The best entry of the scan still a candidate: with equal criticalities and none out, the
// least key kept by the scan; else, under overload, the most critical first (the others are
// shed first), then by key.
const Scheduler::Impl::Scan* Scheduler::Impl::best_candidate(const Pick& p) const {
  if (p.out == 0 && !ranking.mixed_criticality())
    return scanned.empty() ? nullptr : &scanned[p.least];
  const Scan* best = nullptr;
  for (const Scan& e : scanned) {
    if (e.out != Scan::Out::No) continue;  // waits, or yielded to more critical work
    if (best == nullptr) {
      best = &e;
      continue;
    }
    const bool shed_e = e.criticality < p.shed_below, shed_b = best->criticality < p.shed_below;
    if (shed_e != shed_b ? shed_b : e.key < best->key) best = &e;
  }
  return best;
}

// Takes scan entry e out of this pick: its task waits until `until` (a wake-up, as every merge
// wait), or, with `until` kNever, only yields this pick.
void Scheduler::Impl::set_out(Pick& p, Scan& e, TimePoint until) {
  ++p.out;
  if (until == kNever) {
    e.out = Scan::Out::Yields;
    return;
  }
  e.out = Scan::Out::Waits;
  merge.begin_wait(task(e.task), e.task, until);
}

// Stage 2, the choice: the best candidate, its lane and round trip, then what may keep it
// from starting now: the criticality guard, a hopeless member job, a merge wait.
Scheduler::Impl::Chosen Scheduler::Impl::choose(TimePoint now, Pick& p) {
  for (;;) {
    p.best = best_candidate(p);
    if (p.best == nullptr) return Chosen::Nothing;
    Task& k = task(p.best->task);
    p.at = sync.place(lanes, jobs, k, now, p.ahead);
    if (p.at.lane < 0) return Chosen::Nothing;
    if (guard_holds(now, p)) continue;
    if (shedding.abort_hopeless(*this, p.best->task, p.at.rt, now)) return Chosen::Rescan;
    if (merge_waits(now, p)) continue;
    return Chosen::Task;
  }
}

// The criticality guard (guard.cpp), acting only between different criticalities: whether the
// best may not run now, for the more critical work it would make miss.
bool Scheduler::Impl::guard_holds(TimePoint now, Pick& p) {
  if (!opt.guard || !ranking.mixed_criticality() ||
      p.best->criticality >= ranking.top_criticality())
    return false;
  const int t = p.best->task;
  const CriticalityGuard::Verdict g = crit_guard.check(
      *this, std::span<const int>(&t, 1), p.at.lane, now, dispatch_begin(p.at, now) + p.at.rt);
  if (!g.blocks) return false;
  // Held until the more critical release it would block; a job in flight: yields this pick.
  const bool wakes = g.until != kNever && g.until > now;
  set_out(p, scanned[static_cast<std::size_t>(p.best - scanned.data())], wakes ? g.until : kNever);
  if (wakes) ++s.stats_.guard_holds;
  return true;
}

// docs/DESIGN.md, "DynamicMerge" rule 2: a γ-mergeable encoder task waits for the predicted
// release of another operation on its sensor, when every member's slack covers the wait.
bool Scheduler::Impl::merge_waits(TimePoint now, Pick& p) {
  Task& k = task(p.best->task);
  const TimePoint until = merge.wait_until(*this, k, now);
  if (until == kNever) return false;
  set_out(p, scanned[static_cast<std::size_t>(p.best - scanned.data())], until);
  ++s.stats_.merge_waits;
  for (Observer* ob : observers) ob->on_merge_wait(k.sensor, now, until);
  return true;
}

// Stage 3, batching (batching.hpp): the best's batch (Batching::batch, the best first) and the
// deadline the dispatch is checked against.
TimePoint Scheduler::Impl::form_batch(TimePoint now, const Pick& p) {
  const int best = p.best->task;
  const TimePoint deadline =
      p.best->deadline_known ? p.best->deadline : Ranking::task_deadline(*this, task(best), now);
  return batching.form(*this, now, best, deadline, p.at);
}

}  // namespace red
