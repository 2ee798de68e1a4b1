// The ready set's groups. pick() ranks every ready task at every decision: under
// re-assignment a task's deadline moves with `now`, so no order holds between decisions.
// But tasks whose policy view (TaskView) is the same at every `now` rank alike under any
// policy (rank() reads only the view and `now`) and keep their order among themselves
// (their tie-break keys), so of each such group a scan needs only the least. With N jobs released
// together that turns N scans of N tasks into N scans of a few groups. What a group is:
// GroupKey (state.hpp). The type ReadySet (ready_set.hpp) keeps the set: pick() forms the groups
// as it ranks (regroup), and every change to a job's caches (touch) or to what ranking reads (an
// event) breaks them up again, so a grouped task always ranks as its group's least would.

#include "ready_set.hpp"

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

namespace sched_detail {

void ReadySet::push(Scheduler::Impl& m, int t) {
  Task& k = m.task(t);
  k.ready_pos = static_cast<int>(listed_.size());
  encoders_ += k.kind == UnitKind::Encoder ? 1 : 0;
  listed_.push_back(t);
}

void ReadySet::pop(Scheduler::Impl& m, int t) {
  Task& k = m.task(t);
  if (k.group >= 0) {
    leave(m, t, false);
    return;
  }
  if (k.ready_pos < 0) return;
  encoders_ -= k.kind == UnitKind::Encoder ? 1 : 0;
  unlist(m, k);
}

void ReadySet::unlist(Scheduler::Impl& m, Task& k) {
  const int last = listed_.back();
  listed_[static_cast<std::size_t>(k.ready_pos)] = last;
  m.task(last).ready_pos = k.ready_pos;
  listed_.pop_back();
  k.ready_pos = -1;
}

void ReadySet::regroup(Scheduler::Impl& m, TimePoint now) {
  // join() reorders listed_: the tasks as the scan saw them.
  to_group_.assign(listed_.begin(), listed_.end());
  for (int t : to_group_) {
    GroupKey gk;
    if (m.group_key(t, now, gk)) join(m, t, gk);
  }
}

void ReadySet::join(Scheduler::Impl& m, int t, const GroupKey& gk) {
  int g;
  if (const auto it = group_of_.find(gk); it != group_of_.end()) {
    g = it->second;
  } else {
    if (!free_groups_.empty()) {
      g = free_groups_.back();
      free_groups_.pop_back();
    } else {
      groups_.emplace_back();
      g = static_cast<int>(groups_.size() - 1);
    }
    ReadyGroup& ng = groups_[static_cast<std::size_t>(g)];
    ng.key = gk;
    ng.live_pos = static_cast<int>(live_.size());
    live_.push_back(g);
    group_of_.emplace(gk, g);
  }
  Task& k = m.task(t);
  unlist(m, k);  // no encoder count to keep: a group holds none
  k.group = g;
  groups_[static_cast<std::size_t>(g)].tasks.emplace(m.task_rank(t).tie, t);
  ++m.job(k.members.front().first).grouped;
  ++grouped_;
}

void ReadySet::leave(Scheduler::Impl& m, int t, bool keep_listed) {
  Task& k = m.task(t);
  ReadyGroup& g = groups_[static_cast<std::size_t>(k.group)];
  g.tasks.erase({m.task_rank(t).tie, t});
  if (g.tasks.empty()) {
    group_of_.erase(g.key);
    const int moved = live_.back();
    live_[static_cast<std::size_t>(g.live_pos)] = moved;
    groups_[static_cast<std::size_t>(moved)].live_pos = g.live_pos;
    live_.pop_back();
    g.live_pos = -1;
    free_groups_.push_back(k.group);
  }
  k.group = -1;
  --m.job(k.members.front().first).grouped;
  --grouped_;
  if (keep_listed) {
    k.ready_pos = static_cast<int>(listed_.size());
    listed_.push_back(t);
  }
}

void ReadySet::ungroup_job(Scheduler::Impl& m, Job& j) {
  for (const UnitRt& u : j.u) {
    if (u.state != UState::Queued || u.task < 0 || m.task(u.task).group < 0) continue;
    leave(m, u.task, true);
    if (j.grouped == 0) return;
  }
}

void ReadySet::ungroup_all(Scheduler::Impl& m) {
  while (!live_.empty()) {
    const ReadyGroup& g = groups_[static_cast<std::size_t>(live_.back())];
    leave(m, g.tasks.begin()->second, true);
  }
}

}  // namespace sched_detail
}  // namespace red
