// Tasks: a ready unit becomes a task (or joins a queued encoder run, docs/DESIGN.md,
// "DynamicMerge"), enters the ready set and leaves it. Part of the scheduler
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

void Scheduler::Impl::drop_open(int t) {
  Task& k = task(t);
  if (k.kind != UnitKind::Encoder) return;
  auto& v = open_enc[static_cast<std::size_t>(k.sensor)];
  v.erase(std::remove(v.begin(), v.end(), t), v.end());
}

void Scheduler::Impl::free_task(int t) {
  pop_ready(t);
  drop_open(t);
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
  r.tie = tie_key(m.front().first, m.front().second, k.member_at.front().second);
  for (std::size_t i = 0; i < m.size(); ++i) {
    const Job& j = job(m[i].first);
    k.min_release = std::min(k.min_release, j.release);
    r.job_deadline = std::min(r.job_deadline, rank_deadline(j, m[i].second));
    const Key mk = tie_key(m[i].first, m[i].second, k.member_at[i].second);
    if (mk < r.tie) r.tie = mk;
  }
}

void Scheduler::Impl::make_ready(int slot, int unit) {
  Job& j = job(slot);
  const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
  UnitRt& u = j.u[static_cast<std::size_t>(unit)];
  u.state = UState::Queued;
  if (ru.kind == UnitKind::Encoder && opt.merge) {
    const auto si = static_cast<std::size_t>(ru.sensor);
    const std::uint64_t frame = j.frame[si];
    // DynamicMerge (docs/DESIGN.md, "DynamicMerge"): 1. same frame, unconditionally; 2. a γ-cluster
    // of releases that sample the newest frame, while max(release) − min(release) ≤ γ.
    for (int t : open_enc[si]) {
      Task& k = task(t);
      const bool same = k.frame == frame && (!k.gamma || j.samples_newest);
      const bool gamma =
          k.gamma && j.samples_newest && j.release - k.min_release <= s.config_.gamma;
      if (!same && !gamma) continue;
      k.members.emplace_back(slot, unit);
      k.member_at.emplace_back(ru.height, ru.node);
      TaskRank& r = task_rank(t);
      r.job_deadline = std::min(r.job_deadline, rank_deadline(j, unit));
      if (const Key mk = tie_key(slot, unit, ru.node); mk < r.tie) r.tie = mk;
      if (gamma && frame > k.frame) {
        k.frame = frame;
        k.frame_time = j.frame_time[si];
      }
      k.wait_until = TimePoint{0};  // the member it may have waited for has come
      u.task = t;
      return;
    }
  }
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
  task_rank(t) = TaskRank{tie_key(slot, unit, ru.node), rank_deadline(j, unit)};
  k.cost = ru.estimate;
  u.task = t;
  push_ready(t);
  if (ru.kind == UnitKind::Encoder && opt.merge)
    open_enc[static_cast<std::size_t>(ru.sensor)].push_back(t);
}

}  // namespace red
