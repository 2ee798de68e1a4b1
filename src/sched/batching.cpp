// Batching (docs/DESIGN.md, "Refinement" inter-DAG batching, and "Overload" batch_by_job):
// what a batch of b costs by the profile, how many may join, and by when a head batch must
// end for its members' jobs. Part of the scheduler (scheduler_impl.hpp); pick() forms batches.

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

Duration Scheduler::Impl::batch_estimate(const Task& k, int b) const {
  const UnitProfile* p =
      k.kind == UnitKind::Encoder ? enc_prof : head_prof[static_cast<std::size_t>(k.head)];
  return p != nullptr ? p->at(b).estimate(s.config_.estimate) : k.cost * b;
}

int Scheduler::Impl::batch_limit(const Task& k) const {
  const UnitProfile* p =
      k.kind == UnitKind::Encoder ? enc_prof : head_prof[static_cast<std::size_t>(k.head)];
  return std::min(s.config_.max_batch, p != nullptr ? p->max_batch() : 1);
}

TimePoint Scheduler::Impl::latest_batch_end(const Task& k) const {
  // The scheduler's estimate (p99, by default) of the path after the unit: on the mean,
  // batches formed that their members' later units then missed (docs/journal/overload-grid.md,
  // round 7).
  TimePoint d = kNever;
  for (const auto& [slot, unit] : k.members) {
    const Job& j = jobs[static_cast<std::size_t>(slot)];
    d = std::min(d, j.deadline - path_after(j, unit));
  }
  return d;
}

}  // namespace red
