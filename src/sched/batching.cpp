// Batching (batching.hpp; docs/DESIGN.md, "Refinement" inter-DAG batching, and "Overload"
// batch_by_job): what a batch of b costs by the profile, how many may join, by when a head batch
// must end for its members' jobs, and the batch a pick forms. Part of the scheduler
// (scheduler_impl.hpp), which calls it at the points batching.hpp names.

#include "batching.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {
namespace sched_detail {

void Batching::price(const Profile& p, const CostModel& costs, const ModelSpec& model) {
  enc_prof_ = p.find("encoder");
  enc_single_ = costs.encoder();
  enc_max_batch_ = enc_prof_ != nullptr ? enc_prof_->max_batch() : 1;
  head_single_.clear();
  head_prof_.clear();
  for (std::size_t h = 0; h < model.heads.size(); ++h) {
    head_single_.push_back(costs.head(static_cast<int>(h)));
    head_prof_.push_back(p.find("head/" + model.heads[h]));
  }
}

Duration Batching::estimate(const Scheduler::Impl& m, const Task& k, int b) const {
  const UnitProfile* p = unit_profile(k);
  return p != nullptr ? p->at(b).estimate(m.s.config().estimate) : k.cost * b;
}

int Batching::limit(const Scheduler::Impl& m, const Task& k) const {
  const UnitProfile* p = unit_profile(k);
  return std::min(m.s.config().max_batch, p != nullptr ? p->max_batch() : 1);
}

TimePoint Batching::latest_end(const Scheduler::Impl& m, const Task& k) {
  // The scheduler's estimate (p99, by default) of the path after the unit: on the mean,
  // batches formed that their members' later units then missed (docs/journal/overload-grid.md,
  // round 7).
  TimePoint d = kNever;
  for (const auto& [slot, unit] : k.members) {
    const Job& j = m.jobs[static_cast<std::size_t>(slot)];
    d = std::min(d, j.deadline - m.ranking.path_after(j, unit));
  }
  return d;
}

TimePoint Batching::form(Scheduler::Impl& m, TimePoint now, int best, TimePoint deadline,
                         const Placement& at) {
  const Duration rt = at.rt;
  const PolicyOptions& opt = m.opt;
  Task& k = m.task(best);
  batch_.clear();
  batch_.push_back(best);
  if (!opt.batching || (k.kind != UnitKind::Encoder && k.kind != UnitKind::Head)) return deadline;
  // docs/DESIGN.md, "Overload" batch_by_job: while ranked by job deadline, a head batch is
  // checked against what each member's job still needs after the head, not the task's
  // intermediate deadline (past due under overload, it let no batch form).
  const bool by_job = opt.batch_by_job && k.kind == UnitKind::Head && m.ranking.by_job_deadline(k);
  if (by_job) deadline = std::max(deadline, latest_end(m, k));
  const int lim = limit(m, k);
  const Duration single =
      k.kind == UnitKind::Encoder ? enc_single_ : head_single_[static_cast<std::size_t>(k.head)];
  // The first to join makes a batch of two, checked below against the best's deadline or
  // an earlier one: where two are dearer than two runs or miss that deadline, none joins,
  // and the candidates are not ranked.
  const bool joinable = lim >= 2 && [&] {
    const Duration cb = estimate(m, k, 2);
    return cb < single * 2 && now + rt + cb <= deadline;
  }();
  if (!joinable) return deadline;
  candidates(m, now, best, by_job, lim);
  const bool guarding = opt.guard && m.ranking.mixed_criticality();
  for (const auto& [kk, t] : cand_) {
    const int b = static_cast<int>(batch_.size()) + 1;
    if (b > lim) break;
    // Batch only when it is cheaper than running one by one and, by estimate, still
    // meets the earliest member deadline once the round trip it pays is over (docs/DESIGN.md,
    // "Refinement" inter-DAG batching).
    const Duration cb = estimate(m, k, b);
    const TimePoint dl = std::min(deadline, TimePoint{kk.rank});
    if (cb >= single * b || now + rt + cb > dl) break;
    // Nor may the larger run make more critical work miss (the criticality guard): work
    // outside the batch, or a more critical member of it.
    if (guarding) {
      const TimePoint begin = m.dispatch_begin(at, now) + rt;
      if (!CriticalityGuard::join(m, batch_, t, begin, cb, estimate(m, k, b - 1))) break;
      batch_.push_back(t);
      const bool blocks = m.crit_guard.check(m, batch_, at.lane, now, begin).blocks;
      batch_.pop_back();
      if (blocks) break;
    }
    batch_.push_back(t);
    deadline = dl;
  }
  return deadline;
}

void Batching::candidates(Scheduler::Impl& m, TimePoint now, int best, bool by_job, int limit) {
  using Scan = Scheduler::Impl::Scan;
  const Task& k = m.task(best);
  cand_.clear();
  for (const Scan& e : m.scanned) {
    if (e.task == best || e.kind != k.kind || e.head != k.head || e.out == Scan::Out::Waits)
      continue;
    Key byd = e.key;
    // A batch takes its members by deadline.
    byd.rank =
        (e.deadline_known ? e.deadline : Ranking::task_deadline(m, m.task(e.task), now)).count();
    if (by_job) byd.rank = std::max(byd.rank, latest_end(m, m.task(e.task)).count());
    cand_.emplace_back(byd, e.task);
  }
  // Only the max_batch − 1 earliest can join: order just those.
  const auto take = std::min(cand_.size(), static_cast<std::size_t>(std::max(0, limit - 1)));
  std::partial_sort(cand_.begin(), cand_.begin() + static_cast<std::ptrdiff_t>(take), cand_.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  cand_.resize(take);
}

}  // namespace sched_detail
}  // namespace red
