// Deadline assignment (docs/DESIGN.md, "Intermediate deadlines" and "Re-assignment"): a
// job's cached level costs, rebuilt when one of its units starts or ends and evaluated at a
// decision while one runs, and re-assignment's budget shares over them (Reassignment,
// deadlines.hpp). The deadline of each height at a decision is Scheduler::Impl::unit_deadline
// (inline). Part of the scheduler (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::rebuild(Job& j) {
  j.dirty = false;
  const RefinedGraph& g = *j.g;
  const auto levels = static_cast<std::size_t>(g.levels);
  const bool sum = s.config_.level_cost == LevelCost::Sum;
  j.lvl_base.assign(levels, Duration{0});
  j.has_base.assign(levels, 0);
  j.running_units.clear();
  j.enc_queued.clear();
  j.work_base.fill(Duration{0});
  j.work_most.fill(Duration{0});
  j.cp_base.fill(Duration{0});
  j.cp_least = Duration{0};
  j.started = false;
  for (std::size_t i = 0; i < g.units.size(); ++i) {
    const UnitRt& u = j.u[i];
    const RefinedUnit& ru = g.units[i];
    if (u.state == UState::Done || u.state == UState::Running) j.started = true;
    if (u.state == UState::Done || u.state == UState::Cancelled) continue;
    const auto h = static_cast<std::size_t>(ru.height);
    j.has_base[h] = 1;
    if (u.state == UState::Running) {
      j.running_units.push_back(static_cast<int>(i));
      for (std::size_t k = 0; k < kEstimates; ++k)
        j.work_most[k] += ru.costs[k] / std::max(1, u.share);
      continue;
    }
    const Duration c = ru.estimate;
    j.lvl_base[h] = sum ? j.lvl_base[h] + c : std::max(j.lvl_base[h], c);
    for (std::size_t k = 0; k < kEstimates; ++k) j.cp_base[k] = std::max(j.cp_base[k], ru.tail[k]);
    j.cp_least = std::max(j.cp_least, ru.least_tail);
    if (ru.kind == UnitKind::Encoder && u.state == UState::Queued) {
      j.enc_queued.push_back(static_cast<int>(i));
      // Shared by the task's members now; more may join (less each), and a member that
      // leaves marks the others dirty (remove_member).
      const auto members =
          static_cast<std::int64_t>(std::max<std::size_t>(1, task(u.task).members.size()));
      for (std::size_t k = 0; k < kEstimates; ++k) j.work_most[k] += unit_cost(ru, k) / members;
    } else {
      for (std::size_t k = 0; k < kEstimates; ++k) {
        j.work_base[k] += unit_cost(ru, k);
        j.work_most[k] += unit_cost(ru, k);
      }
    }
  }
  j.remaining_base = Duration{0};
  for (Duration l : j.lvl_base) j.remaining_base += l;

  reassign.rebuilt(j);
}

void Scheduler::Impl::eval_now(Job& j, TimePoint now) {
  j.stamp = stamp;
  const RefinedGraph& g = *j.g;
  const bool sum = s.config_.level_cost == LevelCost::Sum;
  j.lvl = j.lvl_base;
  for (int i : j.running_units) {
    const UnitRt& u = j.u[static_cast<std::size_t>(i)];
    Duration c = g.units[static_cast<std::size_t>(i)].estimate;
    if (now > u.start) c = std::max(Duration{0}, c - (now - u.start));
    const auto h = static_cast<std::size_t>(g.units[static_cast<std::size_t>(i)].height);
    j.lvl[h] = sum ? j.lvl[h] + c : std::max(j.lvl[h], c);
  }
  j.remaining = Duration{0};
  for (Duration l : j.lvl) j.remaining += l;
  reassign.evaluated(j);
}

}  // namespace red

namespace red::sched_detail {

void Reassignment::shares(const Job& j, const std::vector<Duration>& lvl,
                          const std::vector<std::uint8_t>& has, std::vector<double>& frac) const {
  const RefinedGraph& g = *j.g;
  const std::size_t levels = lvl.size();
  frac.resize(levels);
  double last = 0.0;  // before the first height with work: now
  for_each_share(
      split_, levels, [&](std::size_t h) { return split_weight(g, h, lvl[h]); },
      [&](std::size_t h) { return has[h] != 0; },
      [&](std::size_t h, bool counts, std::int64_t cum, std::int64_t denom) {
        if (counts)
          last = cum == denom ? 1.0 : static_cast<double>(cum) / static_cast<double>(denom);
        frac[h] = last;
      });
}

}  // namespace red::sched_detail
