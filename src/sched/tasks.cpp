// Tasks: a ready unit becomes a task (or joins a queued encoder run: DynamicMerge, merge.hpp),
// enters the ready set and leaves it. Part of the scheduler
// (scheduler_impl.hpp); the ready set is ReadySet (ready_set.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::free_task(int t) {
  ready.pop(*this, t);
  merge.closed(task(t), t);
  tasks.free(t);
}

void Scheduler::Impl::remove_member(int t, int slot, int unit) {
  Task& k = task(t);
  if (k.group >= 0) ready.leave(*this, t, true);  // its members change
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
  const int t = tasks.alloc();
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
  ready.push(*this, t);
  merge.opened(*this, t);
}

}  // namespace red
