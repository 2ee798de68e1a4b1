// Ranking and the pick of one decision (docs/DESIGN.md, "Dispatch"): a ready task's rank and
// tie-break key, and pick(): the scan of the ready set, the lane, hopeless aborts, merge
// waits and batching, in that order. Part of the scheduler (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

Key Scheduler::Impl::key(int t, TimePoint now, TaskView& v) {
  Task& k = task(t);
  v = TaskView{};
  v.deadline = kNever;
  v.release = kNever;
  v.job_deadline = kNever;
  // What ranking by job deadline reads (rank_deadline), when this round ranks k so.
  const bool rank_by_job = by_job_deadline(k);
  TimePoint by_job = kNever;
  v.cost = k.cost;
  Key best{0, kNever, std::numeric_limits<int>::max(), 0, 0, 0};
  for (std::size_t i = 0; i < k.members.size(); ++i) {
    const auto [slot, unit] = k.members[i];
    const auto [height, node] = k.member_at[i];
    Job& j = job(slot);
    v.deadline = std::min(v.deadline, unit_deadline(j, height, now));
    v.remaining = std::max(v.remaining, remaining_work(j, now));
    v.release = std::min(v.release, j.release);
    v.job_deadline = std::min(v.job_deadline, j.plan);
    if (rank_by_job) by_job = std::min(by_job, rank_deadline(j, unit));
    if (mixed_criticality)
      v.criticality = std::max(v.criticality, ops[static_cast<std::size_t>(j.op)].criticality);
    const Key mk{0, j.release, j.op, j.seq, node, unit};
    if (mk < best) best = mk;
  }
  // Equal criticalities everywhere (every version of every operation): no look at them.
  if (!mixed_criticality && !k.members.empty())
    v.criticality = std::max(v.criticality, uniform_criticality);
  v.overloaded = overloaded;
  // docs/DESIGN.md, "Overload" "finish what was started": while overloaded (or always,
  // rank=job-deadline) the policy ranks by the job's end-to-end deadline; the task's own deadline
  // stays what batching is checked against.
  if (rank_by_job) {
    TaskView view = v;
    view.deadline = by_job;
    best.rank = s.policy_->rank(view, now);
  } else {
    best.rank = s.policy_->rank(v, now);
  }
  return best;
}

TimePoint Scheduler::Impl::task_deadline(const Task& k, TimePoint now) {
  // key()'s deadline, with no other look: the members' caches are as key() left them.
  TimePoint d = kNever;
  for (std::size_t i = 0; i < k.members.size(); ++i)
    d = std::min(d, unit_deadline(job(k.members[i].first), k.member_at[i].first, now));
  return d;
}

bool Scheduler::Impl::pick(TimePoint now) {
  for (;;) {
    // One scan ranks every ready task (the policy's key, and the deadline batching
    // orders by); a merge wait then only moves to the next best entry of the scan.
    scanned.clear();
    // Criticality (docs/DESIGN.md, "Criticality"): under overload — the demand test finds more work
    // due than the lanes can do, or some ready job cannot, by estimate, finish alone by its
    // deadline — ready work of the most critical operations goes first and lower-criticality work
    // waits, so it is shed first. With equal criticalities (the default) nothing changes.
    // The demand test's verdict alone: not red-robust's wider `overloaded` (an operation at
    // its max_inflight, the hold after an overload), which put every critical unit first
    // while the lanes could carry everything (issue 37: red-robust missed 2-3x red's jobs).
    bool overload = demand_overrun;
    int top = std::numeric_limits<int>::min();
    // With equal criticalities the order is the keys' alone: the least is kept as they come.
    std::size_t least = 0;
    auto rank_task = [&](int t) __attribute__((always_inline)) {
      Task& tk = task(t);
      if (tk.wait_until > now) return;
      if (tk.lane_only >= 0 && tk.lane_only != ahead_lane) return;  // behind a busy lane
      if (ranks_from_tasks() && by_job_deadline(tk)) {
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
        const TaskRank& r = task_rank(t);
        Key k = r.tie;
        k.rank = r.job_deadline.count();  // rank() of the view by job deadline (the trait)
        // key()'s criticality with equal ones: the view's 0 or more.
        const int crit = std::max(0, uniform_criticality);
        scanned.push_back({k, TimePoint{0}, t, crit, tk.kind, false, tk.head});
        top = std::max(top, crit);
      } else {
        TaskView v;
        const Key k = key(t, now, v);
        scanned.push_back({k, v.deadline, t, v.criticality, tk.kind, true, tk.head});
        overload = overload || now + v.remaining > v.job_deadline;
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
    const bool grouping = ready_count() >= s.config_.group_from;
    to_group.clear();
    for (int t : ready) {
      rank_task(t);
      if (grouping) to_group.push_back(t);
    }
    for (int g : live_groups) rank_task(groups[static_cast<std::size_t>(g)].tasks.begin()->second);
    // Those that rank alike from now on join their group, with nothing changed since the scan.
    for (int t : to_group) {
      GroupKey gk;
      if (group_key(t, now, gk)) join_group(t, gk);
    }
    const int shed_below = overload ? top : std::numeric_limits<int>::min();
    auto before = [shed_below](const Scan& a, const Scan& b) {
      const bool shed_a = a.criticality < shed_below, shed_b = b.criticality < shed_below;
      return shed_a != shed_b ? shed_b : a.key < b.key;
    };
    int best = -1;
    int lane_index = -1;
    Duration rt{0};  // the round trip the dispatch to lane_index pays
    const Scan* best_scan = nullptr;
    TimePoint best_deadline{};
    bool rescan = false;
    // Every scanned task was past its merge wait; only a wait begun below changes that.
    bool began_wait = false;
    // The criticality guard (guard.cpp) acts only between different criticalities.
    const bool guarding = opt.guard && mixed_criticality;
    guard_held.clear();
    for (;;) {
      best = -1;
      best_scan = nullptr;
      if (!began_wait && !mixed_criticality) {
        if (!scanned.empty()) {
          best_scan = &scanned[least];
          best = best_scan->task;
        }
      } else {
        for (const Scan& e : scanned) {
          if (began_wait && task(e.task).wait_until > now) continue;  // began a wait this round
          if (!guard_held.empty() &&
              std::find(guard_held.begin(), guard_held.end(), e.task) != guard_held.end())
            continue;  // yielded to more critical work this pick
          if (best_scan == nullptr || before(e, *best_scan)) {
            best_scan = &e;
            best = e.task;
          }
        }
      }
      if (best < 0) return false;
      Task& k = task(best);
      lane_index = choose_lane(k, now);
      if (lane_index < 0) return false;
      rt = round_trip_cost(
          ahead_lane < 0 &&
          !on_demand_continuation(lanes[static_cast<std::size_t>(lane_index)], k, now));
      if (guarding && best_scan->criticality < top_criticality) {
        const GuardVerdict g = guard(std::span<const int>(&best, 1), lane_index, now,
                                     dispatch_begin(lane_index, now) + rt);
        if (g.blocks) {
          if (g.until != kNever && g.until > now) {
            // Held until the more critical release it would block (a wake-up, as a merge wait).
            k.wait_until = g.until;
            began_wait = true;
            if (!k.in_waits) {
              k.in_waits = true;
              waits.push_back(best);
            }
            min_wait = std::min(min_wait, g.until);
            ++s.stats_.guard_holds;
          } else {
            guard_held.push_back(best);
          }
          continue;
        }
      }
      // docs/DESIGN.md, "Drops" hopeless, on the drop estimate and with the round trip this
      // dispatch pays. An overload-aware policy (rank=overload) aborts only while overloaded: with
      // the lanes to spare, a job that may still make it costs no other job anything; nor does a
      // job alone in flight (the estimate may be pessimistic, and its deadline still ends it).
      if (opt.drop == DropMode::Hopeless &&
          (opt.rank != RankMode::Overload || (overloaded && by_deadline.size() > 1))) {
        for (const auto& [slot, unit] : k.members) {
          Job& j = job(slot);
          // Below capacity a job is kept while its best case (0.9 × the drop estimate, the
          // default profile's min) still makes it: aborting it frees lanes no one lacks.
          // So is a job of the most critical operations at any load: it runs first under
          // overload (docs/DESIGN.md, "Criticality"), so keeping it costs only less critical work.
          const Duration cp = remaining_for_drop(j, now);
          const bool most_critical =
              mixed_criticality &&
              ops[static_cast<std::size_t>(j.op)].criticality >= top_criticality;
          if (now + rt + (past_capacity() && !most_critical ? cp : cp * 9 / 10) > j.deadline) {
            j.reason = "hopeless";
            ++s.stats_.hopeless;
            end_job(slot, JobOutcome::Dropped, now);  // may free this task: rank again
            rescan = true;
            break;
          }
        }
        if (rescan) break;
      }
      if (opt.merge && k.kind == UnitKind::Encoder && k.gamma) {
        const TimePoint until = predicted_member(k, now);
        if (until != kNever && slack_covers(k, now, until)) {
          k.wait_until = until;
          began_wait = true;
          if (!k.in_waits) {
            k.in_waits = true;
            waits.push_back(best);
          }
          min_wait = std::min(min_wait, until);
          ++s.stats_.merge_waits;
          for (Observer* ob : observers) ob->on_merge_wait(k.sensor, now, until);
          continue;
        }
      }
      break;
    }
    if (rescan) continue;
    Task& k = task(best);
    best_deadline = best_scan->deadline_known ? best_scan->deadline : task_deadline(k, now);
    batch.clear();
    batch.push_back(best);
    TimePoint deadline = best_deadline;
    if (opt.batching && (k.kind == UnitKind::Encoder || k.kind == UnitKind::Head)) {
      // docs/DESIGN.md, "Overload" batch_by_job: while ranked by job deadline, a head batch is
      // checked against what each member's job still needs after the head, not the task's
      // intermediate deadline (past due under overload, it let no batch form).
      const bool by_job = opt.batch_by_job && k.kind == UnitKind::Head && by_job_deadline(k);
      if (by_job) deadline = std::max(deadline, latest_batch_end(k));
      const int limit = batch_limit(k);
      const Duration single =
          k.kind == UnitKind::Encoder ? enc_single : head_single[static_cast<std::size_t>(k.head)];
      // The first to join makes a batch of two, checked below against the best's deadline or
      // an earlier one: where two are dearer than two runs or miss that deadline, none joins,
      // and the candidates are not ranked.
      const bool joinable = limit >= 2 && [&] {
        const Duration cb = batch_estimate(k, 2);
        return cb < single * 2 && now + rt + cb <= deadline;
      }();
      cand.clear();
      for (const Scan& e : scanned) {
        if (!joinable) break;
        if (e.task == best || e.kind != k.kind || e.head != k.head ||
            (began_wait && task(e.task).wait_until > now))
          continue;
        Key byd = e.key;
        // A batch takes its members by deadline.
        byd.rank = (e.deadline_known ? e.deadline : task_deadline(task(e.task), now)).count();
        if (by_job) byd.rank = std::max(byd.rank, latest_batch_end(task(e.task)).count());
        cand.emplace_back(byd, e.task);
      }
      // Only the max_batch − 1 earliest can join: order just those.
      const auto take = std::min(cand.size(), static_cast<std::size_t>(std::max(0, limit - 1)));
      std::partial_sort(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(take), cand.end(),
                        [](const auto& a, const auto& b) { return a.first < b.first; });
      cand.resize(take);
      for (const auto& [kk, t] : cand) {
        const int b = static_cast<int>(batch.size()) + 1;
        if (b > limit) break;
        // Batch only when it is cheaper than running one by one and, by estimate, still
        // meets the earliest member deadline once the round trip it pays is over (docs/DESIGN.md,
        // "Refinement" inter-DAG batching).
        const Duration cb = batch_estimate(k, b);
        const TimePoint dl = std::min(deadline, TimePoint{kk.rank});
        if (cb >= single * b || now + rt + cb > dl) break;
        // Nor may the larger run make more critical work miss (the criticality guard): work
        // outside the batch, or a more critical member of it.
        if (guarding) {
          const TimePoint begin = dispatch_begin(lane_index, now) + rt;
          if (!guard_join(batch, t, begin, cb, batch_estimate(k, b - 1))) break;
          batch.push_back(t);
          const bool blocks = guard(batch, lane_index, now, begin).blocks;
          batch.pop_back();
          if (blocks) break;
        }
        batch.push_back(t);
        deadline = dl;
      }
    }
    start_dispatch(lane_index, now, deadline);
    return true;
  }
}

}  // namespace red
