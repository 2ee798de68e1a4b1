// DynamicMerge waits (docs/DESIGN.md, "DynamicMerge" rule 2): the predicted member an encoder
// run may wait for, and whether every member's slack covers the wait. Part of the scheduler
// (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

TimePoint Scheduler::Impl::predicted_member(const Task& k, TimePoint now) const {
  TimePoint best = kNever;
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const OpState& o = ops[i];
    // An operation at max_inflight will skip its next release: nothing to wait for.
    if (o.g == nullptr || !o.own_rate || o.remaining == 0 || o.inflight >= o.max_inflight) continue;
    if (o.next_tick <= now || o.next_tick - k.min_release > s.config_.gamma) continue;
    if (std::find(o.sensors_read.begin(), o.sensors_read.end(), k.sensor) == o.sensors_read.end())
      continue;
    bool member = false;
    for (auto [slot, unit] : k.members)
      member = member || jobs[static_cast<std::size_t>(slot)].op == static_cast<int>(i);
    if (!member) best = std::min(best, o.next_tick);
  }
  return best;
}

bool Scheduler::Impl::slack_covers(Task& k, TimePoint now, TimePoint until) {
  for (auto [slot, unit] : k.members) {
    Job& j = job(slot);
    if (j.deadline - now - remaining_work(j, now) - round_trip_cost(true) < until - now)
      return false;
  }
  return true;
}

}  // namespace red
