// Lanes that hold more than one unit (SchedulerConfig::queue_depth, docs/DESIGN.md, "Queued
// lanes"): a lane's handler queues its next unit behind the one running (dispatch_ahead), and a
// successor of a unit the lane holds is ready for that lane alone, in the lane's order.
// The lane's slots themselves are sched_detail::Lane (scheduler_impl.hpp).

#include <algorithm>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::ready_in_lane_order(int lane_index) {
  const Lane& lane = lanes[static_cast<std::size_t>(lane_index)];
  for (int q = 0; q < lane.count; ++q)
    for (const Member& mb : lane.at(q).members) {
      Job& j = job(mb.slot);
      if (!j.live || j.ended || j.id != mb.job) continue;
      if (j.u[static_cast<std::size_t>(mb.unit)].state != UState::Running) continue;
      for (int sx : j.g->units[static_cast<std::size_t>(mb.unit)].succs) {
        UnitRt& su = j.u[static_cast<std::size_t>(sx)];
        if (su.state != UState::Blocked || su.pending != 1 ||
            j.g->units[static_cast<std::size_t>(sx)].kind == UnitKind::Encoder)
          continue;
        su.pending = 0;
        su.early = true;
        make_ready(mb.slot, sx);
        task(su.task).lane_only = lane_index;
        touch(j);
      }
    }
}

bool Scheduler::has_room_ahead(int lane) const {
  const auto& l = impl_->lanes[static_cast<std::size_t>(lane)];
  return l.busy() && l.count < config_.queue_depth;
}

bool Scheduler::queues_ahead() const {
  return config_.queue_depth > 1 && impl_->sync.on_demand();
}

TimePoint Scheduler::queue_ahead_at(TimePoint held_start, Duration held_p50,
                                    Duration enqueue_cost) const {
  return held_start + held_p50 - std::max(config_.ahead_lead, enqueue_cost * 2);
}

std::span<Dispatch* const> Scheduler::dispatch_ahead(TimePoint now, int lane) {
  Impl& m = *impl_;
  m.out.clear();
  if (!has_room_ahead(lane)) return m.out;
  ++m.stamp;  // a scheduling point: deadlines are re-assigned from now
  // A decision like dispatch()'s: admission of what was released since, then the overload
  // state (the demand test) at this instant. With queued lanes most decisions are these:
  // a lane that always holds a unit is never idle at dispatch().
  m.shedding.admit_released(m, now);
  m.ready_in_lane_order(lane);
  if (m.ready.count() == 0) return m.out;
  ++stats_.decisions;
  m.overload.assess(m, now);
  (void)m.pick(now, lane);  // for this lane's queue
  return m.out;
}

}  // namespace red
