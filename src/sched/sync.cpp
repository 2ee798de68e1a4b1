// On-demand synchronization and placement (sync.hpp; docs/DESIGN.md, "Synchronization"): the
// runs the lanes' handlers hold, whether a dispatch continues one, the lane it goes to. Part of
// the scheduler (scheduler_impl.hpp).

#include "sync.hpp"

#include <algorithm>

namespace red::sched_detail {

void OnDemandSync::set_up(SyncMode mode, Duration cost, int lanes) {
  on_demand_ = mode == SyncMode::OnDemand;
  cost_ = cost;
  runs_.assign(static_cast<std::size_t>(lanes), Run{});
}

bool OnDemandSync::continues(std::size_t lane, const JobPool& jobs, const Task& k,
                             TimePoint now) const {
  const Run& r = runs_[lane];
  if (!on_demand_ || r.completed_at != now || !r.open) return false;
  for (auto [slot, unit] : k.members) {
    const JobId id = jobs[slot].id;
    for (const auto& [rs, rid] : r.jobs)
      if (rs == slot && rid == id) return true;
  }
  return false;
}

Placement OnDemandSync::place(const std::vector<Lane>& lanes, const JobPool& jobs, const Task& k,
                              TimePoint now, int ahead) const {
  Placement at;
  if (ahead >= 0) {
    // dispatch_ahead: the lane is given, and its own handler queues the task: no round trip.
    at.lane = ahead;
    at.ahead = true;
    return at;
  }
  bool fallback_open = true;
  for (std::size_t i = 0; i < lanes.size(); ++i) {
    if (lanes[i].busy()) continue;
    if (continues(i, jobs, k, now)) {
      at.lane = static_cast<int>(i);
      return at;
    }
    const bool open = runs_[i].open && runs_[i].completed_at == now;
    if (at.lane < 0 || (fallback_open && !open)) {
      at.lane = static_cast<int>(i);
      fallback_open = open;
    }
  }
  // No idle lane whose run it continues: a round trip.
  at.round_trip = at.lane >= 0;
  at.rt = at.round_trip ? cost_ : Duration{0};
  return at;
}

void OnDemandSync::started(int lane, bool pays_round_trip) {
  Run& r = runs_[static_cast<std::size_t>(lane)];
  if (pays_round_trip) r.jobs.clear();
  r.open = false;
}

void OnDemandSync::joins(int lane, int slot, JobId id) {
  auto& v = runs_[static_cast<std::size_t>(lane)].jobs;
  if (std::find(v.begin(), v.end(), std::pair<int, JobId>{slot, id}) == v.end())
    v.emplace_back(slot, id);
}

void OnDemandSync::completed(int lane, TimePoint now, UnitStatus status) {
  Run& r = runs_[static_cast<std::size_t>(lane)];
  r.completed_at = now;
  r.open = status == UnitStatus::Completed;
}

}  // namespace red::sched_detail
