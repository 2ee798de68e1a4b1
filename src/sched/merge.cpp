// DynamicMerge (merge.hpp, docs/DESIGN.md, "DynamicMerge"): an encoder unit's join into a queued
// encoder task, the predicted member a run may wait for and whether every member's slack
// covers the wait, the list of waits, and the newest frame a γ-merged run reads. Part of the
// scheduler (scheduler_impl.hpp), which calls it at the points merge.hpp names.

#include "merge.hpp"

#include <algorithm>
#include <cstdint>

#include "scheduler_impl.hpp"

namespace red {
namespace sched_detail {

bool DynamicMerge::join(Scheduler::Impl& m, int slot, int unit) {
  Job& j = m.job(slot);
  const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
  if (ru.kind != UnitKind::Encoder || !m.opt.merge) return false;
  UnitRt& u = j.u[static_cast<std::size_t>(unit)];
  const auto si = static_cast<std::size_t>(ru.sensor);
  const std::uint64_t frame = j.frame[si];
  // DynamicMerge (docs/DESIGN.md, "DynamicMerge"): 1. same frame, unconditionally; 2. a γ-cluster
  // of releases that sample the newest frame, while max(release) − min(release) ≤ γ.
  for (int t : open_[si]) {
    Task& k = m.task(t);
    const bool same = k.frame == frame && (!k.gamma || j.samples_newest);
    const bool gamma =
        k.gamma && j.samples_newest && j.release - k.min_release <= m.s.config().gamma;
    if (!same && !gamma) continue;
    k.members.emplace_back(slot, unit);
    k.member_at.emplace_back(ru.height, ru.node);
    TaskRank& r = m.task_rank(t);
    r.job_deadline = std::min(r.job_deadline, m.ranking.rank_deadline(j, unit));
    if (const Key mk = Ranking::tie_key(j, unit, ru.node); mk < r.tie) r.tie = mk;
    if (gamma && frame > k.frame) {
      k.frame = frame;
      k.frame_time = j.frame_time[si];
    }
    k.wait_until = TimePoint{0};  // the member it may have waited for has come
    u.task = t;
    return true;
  }
  return false;
}

void DynamicMerge::opened(const Scheduler::Impl& m, int t) {
  const Task& k = m.tasks[static_cast<std::size_t>(t)];
  if (k.kind == UnitKind::Encoder && m.opt.merge)
    open_[static_cast<std::size_t>(k.sensor)].push_back(t);
}

void DynamicMerge::closed(const Task& k, int t) {
  if (k.kind != UnitKind::Encoder) return;
  auto& v = open_[static_cast<std::size_t>(k.sensor)];
  v.erase(std::remove(v.begin(), v.end(), t), v.end());
}

TimePoint DynamicMerge::wait_until(Scheduler::Impl& m, Task& k, TimePoint now) const {
  if (!m.opt.merge || k.kind != UnitKind::Encoder || !k.gamma) return kNever;
  const TimePoint until = predicted_member(m, k, now);
  if (until == kNever || !slack_covers(m, k, now, until)) return kNever;
  return until;
}

TimePoint DynamicMerge::predicted_member(const Scheduler::Impl& m, const Task& k, TimePoint now) {
  TimePoint best = kNever;
  for (std::size_t i = 0; i < m.ops.size(); ++i) {
    const OpState& o = m.ops[i];
    // An operation at max_inflight will skip its next release: nothing to wait for.
    if (o.g == nullptr || !o.own_rate || o.remaining == 0 || o.inflight >= o.max_inflight) continue;
    if (o.next_tick <= now || o.next_tick - k.min_release > m.s.config().gamma) continue;
    if (std::find(o.sensors_read.begin(), o.sensors_read.end(), k.sensor) == o.sensors_read.end())
      continue;
    bool member = false;
    for (auto [slot, unit] : k.members)
      member = member || m.jobs[static_cast<std::size_t>(slot)].op == static_cast<int>(i);
    if (!member) best = std::min(best, o.next_tick);
  }
  return best;
}

bool DynamicMerge::slack_covers(Scheduler::Impl& m, Task& k, TimePoint now, TimePoint until) {
  for (auto [slot, unit] : k.members) {
    Job& j = m.job(slot);
    if (j.deadline - now - m.remaining_work(j, now) - m.sync.round_trip() < until - now)
      return false;
  }
  return true;
}

void DynamicMerge::begin_wait(Task& k, int t, TimePoint until) {
  k.wait_until = until;
  if (!k.in_waits) {
    k.in_waits = true;
    waits_.push_back(t);
  }
  min_wait_ = std::min(min_wait_, until);
}

int DynamicMerge::sweep(Scheduler::Impl& m, TimePoint now) {
  // The earliest end of a merge wait still running is a wake-up (next_wakeup). Recomputed
  // after every round from the waits that end after now, so a wait that is over (its member
  // came, or every lane is busy) never becomes a wake-up in the past.
  // Only tasks that began a wait can be waiting: waits_ lists them (a wait ends for good
  // once it is over or the task left the ready set).
  int waiting = 0;
  min_wait_ = kNever;
  for (std::size_t i = 0; i < waits_.size();) {
    Task& k = m.task(waits_[i]);
    if (!k.live || k.ready_pos < 0 || k.wait_until <= now) {
      k.in_waits = false;
      waits_[i] = waits_.back();
      waits_.pop_back();
      continue;
    }
    ++waiting;
    min_wait_ = std::min(min_wait_, k.wait_until);
    ++i;
  }
  return waiting;
}

void DynamicMerge::at_start(const Scheduler::Impl& m, Task& k) const {
  if (!m.opt.merge || k.kind != UnitKind::Encoder || !k.gamma) return;
  // A γ-merged run uses the newest frame available when it starts (docs/DESIGN.md,
  // "Refinement"). Without DynamicMerge a job keeps the frame it sampled at release: its
  // encoders on one sensor run as separate tasks, and their heads must all read that one frame.
  const SensorState& sn = m.releases.sensor(k.sensor);
  if (sn.has_frame && sn.frame > k.frame) {
    k.frame = sn.frame;
    k.frame_time = sn.time;
  }
}

}  // namespace sched_detail
}  // namespace red
