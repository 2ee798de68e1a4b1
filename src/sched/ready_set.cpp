// The ready set's groups. pick() ranks every ready task at every decision: under
// re-assignment a task's deadline moves with `now`, so no order holds between decisions.
// But tasks whose policy view (TaskView) is the same at every `now` rank alike under any
// policy (rank() reads only the view and `now`) and keep their order among themselves
// (their tie-break keys), so of each such group a scan needs only the least. With N jobs released
// together that turns N scans of N tasks into N scans of a few groups. What a group is:
// GroupKey (scheduler_impl.hpp). Part of the scheduler: pick() forms the groups as it ranks,
// and every change to a job's caches (touch) or to what ranking reads (an event) breaks
// them up again, so a grouped task always ranks as its group's least would.

#include <algorithm>

#include "scheduler_impl.hpp"

namespace red {

bool Scheduler::Impl::group_key(int t, TimePoint now, GroupKey& gk) {
  // Not the units that merge (encoders) or batch (heads, encoders): pick() reads every one
  // of those, not only the first of a group.
  const Task& k = task(t);
  if (k.kind == UnitKind::Encoder || k.kind == UnitKind::Head || k.members.size() != 1 ||
      k.lane_only >= 0)
    return false;
  const auto [slot, unit] = k.members.front();
  Job& j = job(slot);
  // Nothing is computed here that ranking did not: a job whose caches are stale (ranking by
  // job deadline reads none) or depend on `now` (a unit running) stays out.
  if (j.dirty || !j.running_units.empty()) return false;
  const int height = k.member_at.front().first;
  if (reassign.shares_deadline()) {
    gk.deadline = j.plan;  // what Reassignment::deadline reads
    gk.share = j.frac[static_cast<std::size_t>(height)];
  } else {
    gk.deadline = unit_deadline(j, height, now);  // fixed in these modes
    gk.share = 0.0;
  }
  gk.release = j.release;
  gk.cost = k.cost;
  gk.remaining = j.remaining_base;
  gk.job_deadline = j.plan;
  gk.by_job = ranking.rank_deadline(j, unit);
  gk.criticality = ops[static_cast<std::size_t>(j.op)].criticality;
  return true;
}

void Scheduler::Impl::join_group(int t, const GroupKey& gk) {
  int g;
  if (const auto it = group_of.find(gk); it != group_of.end()) {
    g = it->second;
  } else {
    if (!free_groups.empty()) {
      g = free_groups.back();
      free_groups.pop_back();
    } else {
      groups.emplace_back();
      g = static_cast<int>(groups.size() - 1);
    }
    ReadyGroup& ng = groups[static_cast<std::size_t>(g)];
    ng.key = gk;
    ng.live_pos = static_cast<int>(live_groups.size());
    live_groups.push_back(g);
    group_of.emplace(gk, g);
  }
  Task& k = task(t);
  unlist_ready(k);  // no encoder count to keep: a group holds none
  k.group = g;
  groups[static_cast<std::size_t>(g)].tasks.emplace(task_rank(t).tie, t);
  ++job(k.members.front().first).grouped;
  ++grouped_tasks;
}

void Scheduler::Impl::leave_group(int t, bool keep_ready) {
  Task& k = task(t);
  ReadyGroup& g = groups[static_cast<std::size_t>(k.group)];
  g.tasks.erase({task_rank(t).tie, t});
  if (g.tasks.empty()) {
    group_of.erase(g.key);
    const int moved = live_groups.back();
    live_groups[static_cast<std::size_t>(g.live_pos)] = moved;
    groups[static_cast<std::size_t>(moved)].live_pos = g.live_pos;
    live_groups.pop_back();
    g.live_pos = -1;
    free_groups.push_back(k.group);
  }
  k.group = -1;
  --job(k.members.front().first).grouped;
  --grouped_tasks;
  if (keep_ready) {
    k.ready_pos = static_cast<int>(ready.size());
    ready.push_back(t);
  }
}

void Scheduler::Impl::ungroup_job(Job& j) {
  for (const UnitRt& u : j.u) {
    if (u.state != UState::Queued || u.task < 0 || task(u.task).group < 0) continue;
    leave_group(u.task, true);
    if (j.grouped == 0) return;
  }
}

void Scheduler::Impl::ungroup_all() {
  while (!live_groups.empty()) {
    const ReadyGroup& g = groups[static_cast<std::size_t>(live_groups.back())];
    leave_group(g.tasks.begin()->second, true);
  }
}

}  // namespace red
