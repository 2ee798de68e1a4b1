// Starting a dispatch on its lane (docs/DESIGN.md, "Dispatch"): the dispatch's record, its
// members' units running, the run it joins (OnDemandSync, sync.hpp), when it starts. Part of the
// scheduler (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::set_start(Dispatch& d, TimePoint start) {
  d.start = start;
  for (const Member& mb : d.members) {
    Job& j = job(mb.slot);
    if (j.live && j.id == mb.job) j.u[static_cast<std::size_t>(mb.unit)].start = start;
  }
}

void Scheduler::Impl::start_dispatch(const Placement& at, TimePoint now, TimePoint deadline) {
  const int lane_index = at.lane;
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
  // As the pick placed it: a continuation of the lane's run, or a task queued behind the
  // lane's running unit by its own handler, pays no round trip; a round trip starts a new run
  // (sync.hpp).
  d.round_trip = at.round_trip;
  sync.started(lane_index, d.round_trip);
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
      sync.joins(lane_index, slot, j.id);
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
