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

class JobPool {
 public:
  [[nodiscard]] Job& operator[](int slot) noexcept { return jobs_[static_cast<std::size_t>(slot)]; }
  [[nodiscard]] const Job& operator[](int slot) const noexcept {
    return jobs_[static_cast<std::size_t>(slot)];
  }
  [[nodiscard]] Job& operator[](std::size_t slot) noexcept { return jobs_[slot]; }
  [[nodiscard]] const Job& operator[](std::size_t slot) const noexcept { return jobs_[slot]; }
  /// Every slot, live (Job::live) or not.
  [[nodiscard]] std::vector<Job>& all() noexcept { return jobs_; }

  /// A free slot (its job as it was left: release() sets every field).
  int alloc() {
    if (!free_.empty()) {
      const int slot = free_.back();
      free_.pop_back();
      return slot;
    }
    jobs_.emplace_back();
    return static_cast<int>(jobs_.size() - 1);
  }
  /// The job in `slot` is over and nothing refers to it any more: its slot is free.
  void free(int slot) {
    (*this)[slot].live = false;
    free_.push_back(slot);
  }
  /// The id of the next release (a job, or a release skipped at max_inflight).
  JobId next_id() noexcept { return next_id_++; }

 private:
  std::vector<Job> jobs_;
  std::vector<int> free_;
  JobId next_id_ = 1;
};

class TaskPool {
 public:
  [[nodiscard]] Task& operator[](int t) noexcept { return tasks_[static_cast<std::size_t>(t)]; }
  [[nodiscard]] const Task& operator[](int t) const noexcept {
    return tasks_[static_cast<std::size_t>(t)];
  }
  [[nodiscard]] Task& operator[](std::size_t t) noexcept { return tasks_[t]; }
  [[nodiscard]] const Task& operator[](std::size_t t) const noexcept { return tasks_[t]; }
  /// Task t's ranking by job deadline, kept beside the tasks (TaskRank).
  [[nodiscard]] TaskRank& rank(int t) noexcept { return ranks_[static_cast<std::size_t>(t)]; }

  /// A free slot, its task live with no members, not ready, not waiting.
  int alloc() {
    int t;
    if (!free_.empty()) {
      t = free_.back();
      free_.pop_back();
    } else {
      tasks_.emplace_back();
      ranks_.emplace_back();
      t = static_cast<int>(tasks_.size() - 1);
    }
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
    free_.push_back(t);
  }

 private:
  std::vector<Task> tasks_;
  std::vector<TaskRank> ranks_;  // beside tasks_
  std::vector<int> free_;
};

}  // namespace sched_detail
}  // namespace red
