// Ranking (ranking.hpp): the scenario's criticalities, and a ready task's rank and tie-break
// key at a pick. Part of the scheduler (scheduler_impl.hpp).

#include "ranking.hpp"

#include <algorithm>
#include <limits>
#include <memory>

#include "scheduler_impl.hpp"

namespace red::sched_detail {

void Ranking::set_up(const Policy& policy, const Scenario& sc, const SchedulerConfig& config) {
  policy_ = &policy;
  const PolicyOptions& opt = policy.options();
  mode_ = opt.rank;
  path_rank_ = opt.path_rank;
  edf_rank_ = policy.ranks_by_deadline_only();
  one_lane_ = config.lanes == 1;
  estimate_ = idx(config.estimate);
  // Criticality orders work only under overload (docs/DESIGN.md, "Criticality"); the demand test
  // that detects it runs only when criticalities differ somewhere in the scenario, or the policy
  // ranks by it.
  int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
  auto see = [&](const std::shared_ptr<const OperationSpec>& op) {
    if (!op) return;
    lo = std::min(lo, op->criticality);
    hi = std::max(hi, op->criticality);
  };
  for (const auto& op : sc.initial) see(op);
  for (const EventSpec& e : sc.events)
    for (const auto& [i, op] : e.changes) see(op);
  mixed_ = lo < hi;
  top_ = hi;
  uniform_ = lo <= hi ? lo : 0;
  at_pick(false, false);
}

Key Ranking::key(Scheduler::Impl& m, int t, TimePoint now, TaskView& v) const {
  Task& k = m.task(t);
  v = TaskView{};
  v.deadline = kNever;
  v.release = kNever;
  v.job_deadline = kNever;
  // What ranking by job deadline reads (rank_deadline), when this round ranks k so.
  const bool rank_by_job = by_job_deadline(k);
  TimePoint by_job = kNever;
  v.cost = k.cost;
  Key best{0, kNever, std::numeric_limits<int>::max(), 0, 0, 0};
  for (std::size_t i = 0; i < k.members.size(); ++i) {
    const auto [slot, unit] = k.members[i];
    const auto [height, node] = k.member_at[i];
    Job& j = m.job(slot);
    v.deadline = std::min(v.deadline, m.unit_deadline(j, height, now));
    v.remaining = std::max(v.remaining, m.remaining_work(j, now));
    v.release = std::min(v.release, j.release);
    v.job_deadline = std::min(v.job_deadline, j.plan);
    if (rank_by_job) by_job = std::min(by_job, rank_deadline(j, unit));
    if (mixed_)
      v.criticality = std::max(v.criticality, m.ops[static_cast<std::size_t>(j.op)].criticality);
    const Key mk = tie_key(j, unit, node);
    if (mk < best) best = mk;
  }
  // Equal criticalities everywhere (every version of every operation): no look at them.
  if (!mixed_ && !k.members.empty()) v.criticality = std::max(v.criticality, uniform_);
  v.overloaded = overloaded_;
  // docs/DESIGN.md, "Overload" "finish what was started": while overloaded (or always,
  // rank=job-deadline) the policy ranks by the job's end-to-end deadline; the task's own deadline
  // stays what batching is checked against.
  if (rank_by_job) {
    TaskView view = v;
    view.deadline = by_job;
    best.rank = policy_->rank(view, now);
  } else {
    best.rank = policy_->rank(v, now);
  }
  return best;
}

TimePoint Ranking::task_deadline(Scheduler::Impl& m, const Task& k, TimePoint now) {
  // key()'s deadline, with no other look: the members' caches are as key() left them.
  TimePoint d = kNever;
  for (std::size_t i = 0; i < k.members.size(); ++i)
    d = std::min(d, m.unit_deadline(m.job(k.members[i].first), k.member_at[i].first, now));
  return d;
}

}  // namespace red::sched_detail
