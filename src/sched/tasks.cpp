// Tasks: a ready unit becomes a task (or joins a queued encoder run: DynamicMerge, merge.hpp),
// enters the ready set and leaves it. Part of the scheduler
// (scheduler_impl.hpp); the ready set's groups are in ready_set.cpp.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

int Scheduler::Impl::alloc_task() {
  int t;
  if (!free_tasks.empty()) {
    t = free_tasks.back();
    free_tasks.pop_back();
  } else {
    tasks.emplace_back();
    task_ranks.emplace_back();
    t = static_cast<int>(tasks.size() - 1);
  }
  Task& k = task(t);
  k.live = true;
  k.members.clear();
  k.member_at.clear();
  k.wait_until = TimePoint{0};
  k.ready_pos = -1;
  k.group = -1;
  k.lane_only = -1;
  return t;
}

void Scheduler::Impl::push_ready(int t) {
  task(t).ready_pos = static_cast<int>(ready.size());
  ready_encoders += task(t).kind == UnitKind::Encoder ? 1 : 0;
  ready.push_back(t);
}

void Scheduler::Impl::pop_ready(int t) {
  Task& k = task(t);
  if (k.group >= 0) {
    leave_group(t, false);
    return;
  }
  if (k.ready_pos < 0) return;
  ready_encoders -= k.kind == UnitKind::Encoder ? 1 : 0;
  unlist_ready(k);
}

void Scheduler::Impl::free_task(int t) {
  pop_ready(t);
  merge.closed(task(t), t);
  task(t).live = false;
  free_tasks.push_back(t);
}

void Scheduler::Impl::remove_member(int t, int slot, int unit) {
  Task& k = task(t);
  if (k.group >= 0) leave_group(t, true);  // its members change
  auto& m = k.members;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (m[i] == std::pair<int, int>{slot, unit}) continue;
    m[kept] = m[i];
    k.member_at[kept] = k.member_at[i];
    ++kept;
  }
  m.resize(kept);
  k.member_at.resize(kept);
  // The others' share of a queued encoder run grew: their bounds on the work left go stale.
  if (k.kind == UnitKind::Encoder)
    for (auto [js, ju] : m) touch(job(js));
  if (m.empty()) {
    free_task(t);
    return;
  }
  k.min_release = kNever;
  TaskRank& r = task_rank(t);
  r.job_deadline = kNever;
  r.tie = Ranking::tie_key(job(m.front().first), m.front().second, k.member_at.front().second);
  for (std::size_t i = 0; i < m.size(); ++i) {
    const Job& j = job(m[i].first);
    k.min_release = std::min(k.min_release, j.release);
    r.job_deadline = std::min(r.job_deadline, ranking.rank_deadline(j, m[i].second));
    const Key mk = Ranking::tie_key(j, m[i].second, k.member_at[i].second);
    if (mk < r.tie) r.tie = mk;
  }
}

void Scheduler::Impl::make_ready(int slot, int unit) {
  Job& j = job(slot);
  const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
  UnitRt& u = j.u[static_cast<std::size_t>(unit)];
  u.state = UState::Queued;
  if (merge.join(*this, slot, unit)) return;  // DynamicMerge (merge.hpp)
  const int t = alloc_task();
  Task& k = task(t);
  k.kind = ru.kind;
  k.head = ru.head;
  k.sensor = ru.sensor;
  k.gamma = ru.kind == UnitKind::Encoder && j.samples_newest;
  k.frame = ru.sensor >= 0 ? j.frame[static_cast<std::size_t>(ru.sensor)] : 0;
  k.frame_time = ru.sensor >= 0 ? j.frame_time[static_cast<std::size_t>(ru.sensor)] : j.release;
  k.members.emplace_back(slot, unit);
  k.member_at.emplace_back(ru.height, ru.node);
  k.min_release = j.release;
  task_rank(t) = TaskRank{Ranking::tie_key(j, unit, ru.node), ranking.rank_deadline(j, unit)};
  k.cost = ru.estimate;
  u.task = t;
  push_ready(t);
  merge.opened(*this, t);
}

}  // namespace red
