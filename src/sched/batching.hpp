#pragma once
/// \file
/// Internal to src/sched: inter-DAG batching (docs/DESIGN.md, "Refinement" inter-DAG batching,
/// and "Overload" batch_by_job; PolicyOptions::batching), one mechanism in one place: its state
/// (the profile's batch costs, the batch being formed) and its rules. The scheduler calls it at
/// named points: `price` when it plans on a profile, `form` at a pick's last stage (the task
/// chosen and the ready tasks that join it), `batch` when the dispatch starts, `estimate` for
/// what a batch costs.

#include <cstddef>
#include <span>
#include <utility>
#include <vector>

#include "red/sched/scheduler.hpp"
#include "state.hpp"
#include "sync.hpp"

namespace red {
namespace sched_detail {

class Batching {
 public:
  /// Batch costs from profile `p` (planned with `costs`) for the heads of `model`.
  void price(const Profile& p, const CostModel& costs, const ModelSpec& model);

  /// The profile of task `k`'s unit (the encoder, or its head); null when the profile has none.
  [[nodiscard]] const UnitProfile* unit_profile(const Task& k) const {
    return k.kind == UnitKind::Encoder ? enc_prof_ : head_prof_[static_cast<std::size_t>(k.head)];
  }
  /// What a batch of `b` tasks like `k` costs by the profile, on the scheduler's estimate.
  Duration estimate(const Scheduler::Impl& m, const Task& k, int b) const;

  /// A pick's last stage: the batch of `best` (the task chosen, checked against `deadline`,
  /// placed `at`: its lane, after the round trip it pays), the best first, in batch(); returns
  /// the deadline the dispatch is checked against.
  TimePoint form(Scheduler::Impl& m, TimePoint now, int best, TimePoint deadline,
                 const Placement& at);
  /// The batch formed last (the best first).
  [[nodiscard]] std::span<const int> batch() const noexcept { return batch_; }

 private:
  // How many tasks like k may run as one batch.
  int limit(const Scheduler::Impl& m, const Task& k) const;
  // The scanned tasks that may join the best's batch (cand_): of its kind and head, not
  // waiting, by deadline; only the limit − 1 earliest, ordered.
  void candidates(Scheduler::Impl& m, TimePoint now, int best, bool by_job, int limit);
  // The latest a batch may end for every member of task k to finish its job by the job's
  // deadline: the earliest over the members of the job deadline less the longest path
  // after the member's unit (scheduler estimate). docs/DESIGN.md, "Overload" batch_by_job.
  static TimePoint latest_end(const Scheduler::Impl& m, const Task& k);

  // The profile's costs: a run of one, and the batch rows (null: none in the profile).
  Duration enc_single_{0};
  int enc_max_batch_ = 1;
  std::vector<Duration> head_single_;
  std::vector<const UnitProfile*> head_prof_;
  const UnitProfile* enc_prof_ = nullptr;
  std::vector<std::pair<Key, int>> cand_;  // scratch of form(): the candidates, ordered
  std::vector<int> batch_;                 // the batch formed, the best first
};

}  // namespace sched_detail
}  // namespace red
