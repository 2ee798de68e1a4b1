// Lanes and runs (docs/DESIGN.md, "Synchronization"): the round trip a dispatch pays, whether
// it continues the run a lane's handler holds (on demand), the lane it goes to, and starting
// the dispatch there. Part of the scheduler (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

Duration Scheduler::Impl::round_trip_cost(bool round_trip) const {
  return round_trip ? s.config_.sync_cost : Duration{0};
}

void Scheduler::Impl::set_start(Dispatch& d, TimePoint start) {
  d.start = start;
  for (const Member& mb : d.members) {
    Job& j = job(mb.slot);
    if (j.live && j.id == mb.job) j.u[static_cast<std::size_t>(mb.unit)].start = start;
  }
}

bool Scheduler::Impl::on_demand_continuation(const Lane& lane, const Task& k, TimePoint now) const {
  if (opt.sync != SyncMode::OnDemand || lane.completed_at != now || !lane.run_open) return false;
  for (auto [slot, unit] : k.members) {
    const JobId id = jobs[static_cast<std::size_t>(slot)].id;
    for (const auto& [rs, rid] : lane.run_jobs)
      if (rs == slot && rid == id) return true;
  }
  return false;
}

int Scheduler::Impl::choose_lane(const Task& k, TimePoint now) const {
  if (ahead_lane >= 0) return ahead_lane;  // dispatch_ahead: the lane is given
  int fallback = -1;
  bool fallback_open = true;
  for (std::size_t i = 0; i < lanes.size(); ++i) {
    const Lane& l = lanes[i];
    if (l.busy()) continue;
    if (on_demand_continuation(l, k, now)) return static_cast<int>(i);
    const bool open = l.run_open && l.completed_at == now;
    if (fallback < 0 || (fallback_open && !open)) {
      fallback = static_cast<int>(i);
      fallback_open = open;
    }
  }
  return fallback;
}

void Scheduler::Impl::start_dispatch(int lane_index, TimePoint now, TimePoint deadline) {
  Lane& lane = lanes[static_cast<std::size_t>(lane_index)];
  Dispatch& d = lane.next_slot();
  const std::span<const int> batch = batching.batch();
  const Task& first = task(batch.front());
  d.id = ++dispatch_seq;
  d.lane = lane_index;
  d.kind = first.kind;
  d.head = first.head;
  d.sensor = first.sensor;
  d.batch = static_cast<int>(batch.size());
  d.members.clear();
  d.task_begin.clear();
  d.deadline = deadline;
  d.decided_at = now;
  d.start = now;
  d.expected = first.kind == UnitKind::Encoder || first.kind == UnitKind::Head
                   ? batching.estimate(*this, first, d.batch)
                   : first.cost;
  // Queued behind the lane's running unit by its own handler: no round trip.
  d.round_trip = ahead_lane < 0 && !on_demand_continuation(lane, first, now);
  // A round trip starts a new run: the handler is handed these jobs' work (docs/DESIGN.md,
  // "Synchronization").
  if (d.round_trip) lane.run_jobs.clear();
  lane.run_open = false;
  for (int t : batch) {
    Task& k = task(t);
    d.task_begin.push_back(static_cast<int>(d.members.size()));
    merge.at_start(*this, k);  // a γ-merged run reads the newest frame (merge.hpp)
    for (auto [slot, unit] : k.members) {
      Job& j = job(slot);
      // Where ranking did not look into the jobs, the job's evaluation at `now` is taken
      // before its unit starts, as ranking would have taken it: a later look in this round
      // reads the values from before.
      if (ranking.ranks_from_tasks()) {
        refresh(j);
        if (!j.running_units.empty()) eval(j, now);
      }
      UnitRt& u = j.u[static_cast<std::size_t>(unit)];
      u.state = UState::Running;
      touch(j);
      u.task = -1;
      u.start = now;
      u.share = static_cast<int>(k.members.size());
      if (std::find(lane.run_jobs.begin(), lane.run_jobs.end(),
                    std::pair<int, JobId>{slot, j.id}) == lane.run_jobs.end())
        lane.run_jobs.emplace_back(slot, j.id);
      ++j.running;
      const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
      Member m;
      m.job = j.id;
      m.slot = slot;
      m.unit = unit;
      m.operation = j.op;
      m.node = ru.node;
      m.job_seq = j.seq;
      m.release = j.release;
      m.graph = j.g;
      if (ru.sensor >= 0) {
        const auto si = static_cast<std::size_t>(ru.sensor);
        if (ru.kind == UnitKind::Encoder) {
          j.frame[si] = k.frame;  // its head reads the features of this frame
          j.frame_time[si] = k.frame_time;
        }
        m.frame = j.frame[si];
        m.frame_time = j.frame_time[si];
        j.oldest_frame = std::min(j.oldest_frame, m.frame_time);
      } else if (ru.kind == UnitKind::Mono && !j.g->sensors.empty()) {
        const auto si = static_cast<std::size_t>(j.g->sensors.front());
        m.frame = j.frame[si];
        m.frame_time = j.frame_time[si];
        for (int sn : j.g->sensors)
          j.oldest_frame = std::min(j.oldest_frame, j.frame_time[static_cast<std::size_t>(sn)]);
      }
      d.members.push_back(m);
    }
    free_task(t);
  }
  d.task_begin.push_back(static_cast<int>(d.members.size()));
  ++lane.count;
  ++s.stats_.dispatches;
  if (d.round_trip) ++s.stats_.round_trips;
  out.push_back(&d);
}

}  // namespace red
