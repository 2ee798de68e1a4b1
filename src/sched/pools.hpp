#pragma once
/// \file
/// Internal to src/sched: the slots jobs and tasks live in. A slot is reused once freed, so that
/// the scheduler allocates nothing in steady state; a slot's number stays its job's or task's
/// name while it lives (Member::slot, UnitRt::task). The scheduler calls them where a job is
/// released (`alloc`, `next_id`) and freed (`free`), and where a task is made and freed.

#include <cstddef>
#include <vector>

#include "state.hpp"

namespace red {
namespace sched_detail {

/// Numbered slots of T with a free list: what JobPool and TaskPool share.
template <class T>
class Slots {
 public:
  [[nodiscard]] T& operator[](int slot) noexcept { return items_[static_cast<std::size_t>(slot)]; }
  [[nodiscard]] const T& operator[](int slot) const noexcept {
    return items_[static_cast<std::size_t>(slot)];
  }
  [[nodiscard]] T& operator[](std::size_t slot) noexcept { return items_[slot]; }
  [[nodiscard]] const T& operator[](std::size_t slot) const noexcept { return items_[slot]; }
  /// Every slot, live or not.
  [[nodiscard]] std::vector<T>& all() noexcept { return items_; }

 protected:
  /// A free slot, reused as it was left, or a new one (`fresh`).
  int take(bool& fresh) {
    fresh = free_.empty();
    if (fresh) {
      items_.emplace_back();
      return static_cast<int>(items_.size() - 1);
    }
    const int slot = free_.back();
    free_.pop_back();
    return slot;
  }
  void give_back(int slot) { free_.push_back(slot); }

 private:
  std::vector<T> items_;
  std::vector<int> free_;
};

class JobPool : public Slots<Job> {
 public:
  /// A free slot (its job as it was left: release() sets every field).
  int alloc() {
    bool fresh = false;
    return take(fresh);
  }
  /// The job in `slot` is over and nothing refers to it any more: its slot is free.
  void free(int slot) {
    (*this)[slot].live = false;
    give_back(slot);
  }
  /// The id of the next release (a job, or a release skipped at max_inflight).
  JobId next_id() noexcept { return next_id_++; }

 private:
  JobId next_id_ = 1;
};

class TaskPool : public Slots<Task> {
 public:
  /// Task t's ranking by job deadline, kept beside the tasks (TaskRank).
  [[nodiscard]] TaskRank& rank(int t) noexcept { return ranks_[static_cast<std::size_t>(t)]; }

  /// A free slot, its task live with no members, not ready, not waiting.
  int alloc() {
    bool fresh = false;
    const int t = take(fresh);
    if (fresh) ranks_.emplace_back();
    Task& k = (*this)[t];
    k.live = true;
    k.members.clear();
    k.member_at.clear();
    k.wait_until = TimePoint{0};
    k.ready_pos = -1;
    k.group = -1;
    k.lane_only = -1;
    return t;
  }
  /// Task t left the ready set and every list: its slot is free.
  void free(int t) {
    (*this)[t].live = false;
    give_back(t);
  }

 private:
  std::vector<TaskRank> ranks_;  // beside the tasks, slot for slot
};

}  // namespace sched_detail
}  // namespace red
