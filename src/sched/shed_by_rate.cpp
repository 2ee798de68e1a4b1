// Shedding by rate (shed_by_rate.hpp): the order of the operations and whether one ahead of
// another sheds. Part of the scheduler.

#include "shed_by_rate.hpp"

#include <algorithm>
#include <chrono>

namespace red {
namespace sched_detail {

void ShedByRate::on_end(int op, JobOutcome outcome, DropReason reason, TimePoint now) {
  if (outcome != JobOutcome::Dropped || reason == DropReason::RejectedByRate) return;
  const auto i = static_cast<std::size_t>(op);
  if (i >= last_shed_.size()) last_shed_.resize(i + 1, kNever);
  last_shed_[i] = now;
}

void ShedByRate::plan(const std::vector<OpState>& ops, int lanes, std::size_t k) {
  stale_ = false;
  outranked_.assign(ops.size(), 0);
  order_.clear();
  // Operations that read sensors are left out (neither outranked nor counted): a job's own
  // cost says little where encoder runs are shared and heads batched across jobs; with
  // them in, 17 more grid points fell below 0.9 x the bound, every one a MIMONet set.
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const OpState& o = ops[i];
    if (o.g == nullptr || o.remaining == 0 || !o.own_rate || !o.g->sensors.empty()) continue;
    Duration w{0};
    for (const RefinedUnit& ru : o.g->units) w += ru.costs[k];
    order_.push_back({w, static_cast<int>(i)});
  }
  std::sort(order_.begin(), order_.end());
  double used = 0.0;  // lanes asked for by the operations with cheaper jobs
  for (const auto& [w, i] : order_) {
    const auto ii = static_cast<std::size_t>(i);
    if (used >= static_cast<double>(lanes)) outranked_[ii] = 1;
    used += ops[ii].rate_hz * std::chrono::duration<double>(w).count();
  }
}

bool ShedByRate::ahead_shed(int op, TimePoint now) const {
  const Duration window = from_s(kWindow);
  for (const auto& [w, i] : order_) {
    if (i == op) return false;
    const auto ii = static_cast<std::size_t>(i);
    const TimePoint t = ii < last_shed_.size() ? last_shed_[ii] : kNever;
    if (t != kNever && now - t < window) return true;
  }
  return false;
}

}  // namespace sched_detail
}  // namespace red
