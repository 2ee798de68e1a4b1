// Deadline inheritance (inherit.hpp): a job that others wait for is planned to end in time for
// them. Part of the scheduler (scheduler_impl.hpp).

#include "inherit.hpp"

#include <algorithm>

#include "scheduler_impl.hpp"

namespace red::sched_detail {

void Inheritance::released(Scheduler::Impl& m, const Job& j, Job& d) const {
  if (!on_) return;
  // j's units that wait for `d` (the head sources) must start by j's deadline less the longest
  // path from them.
  const RefinedGraph& g = *j.g;
  Duration path{0};
  for (int u : g.head_sources)
    path = std::max(path, g.units[static_cast<std::size_t>(u)].tail[estimate_]);
  plan(m, d, j.deadline - path);
}

void Inheritance::plan(Scheduler::Impl& m, Job& d, TimePoint due) {
  if (due >= d.plan) return;
  d.plan = due;
  if (d.grouped > 0) m.ungroup_job(d);
  for (std::size_t u = 0; u < d.u.size(); ++u) {
    const UnitRt& ur = d.u[u];
    if (ur.state != UState::Queued || ur.task < 0) continue;
    TaskRank& r = m.task_rank(ur.task);
    r.job_deadline = std::min(r.job_deadline, m.ranking.rank_deadline(d, static_cast<int>(u)));
  }
}

}  // namespace red::sched_detail
