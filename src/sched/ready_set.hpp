#pragma once
/// \file
/// Internal to src/sched: the ready set, its state and the rules that keep it. Ready tasks are
/// listed one by one (`listed`), except those kept in groups that rank alike (ReadyGroup,
/// state.hpp; what a group is: GroupKey), of which a scan reads the least only. The scheduler
/// calls it at named points:
///
/// * a task becomes ready: `push`; it leaves: `pop`; its members change: `leave`;
/// * at a pick's scan: `listed`, `for_each_group_least`, then `regroup` (the tasks that rank
///   alike from now on join their group);
/// * what ranking reads changes: `ungroup_job` (a job's caches), `ungroup_all` (an event, new
///   costs).

#include <map>
#include <vector>

#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class ReadySet {
 public:
  /// Ready tasks in all (grouped or not).
  [[nodiscard]] int count() const noexcept { return static_cast<int>(listed_.size()) + grouped_; }
  /// The ready tasks not in a group, scanned one by one.
  [[nodiscard]] const std::vector<int>& listed() const noexcept { return listed_; }
  /// Encoder tasks among them (a group holds none).
  [[nodiscard]] int encoders() const noexcept { return encoders_; }
  /// Calls f(task) with the least task of each group.
  template <class F>
  void for_each_group_least(F&& f) const {
    for (int g : live_) f(groups_[static_cast<std::size_t>(g)].tasks.begin()->second);
  }

  /// Task `t` became ready: listed.
  void push(Scheduler::Impl& m, int t);
  /// Task `t` leaves the ready set (listed or grouped; nothing when it is in neither).
  void pop(Scheduler::Impl& m, int t);
  /// Takes grouped task `t` out of its group (listed again when `keep_listed`).
  void leave(Scheduler::Impl& m, int t, bool keep_listed);
  /// After a pick's scan at `now`, with nothing changed since: the listed tasks whose key is
  /// the same at every `now` (Impl::group_key) join their group.
  void regroup(Scheduler::Impl& m, TimePoint now);
  /// A job whose caches are about to change: its grouped tasks are listed again.
  void ungroup_job(Scheduler::Impl& m, Job& j);
  /// Every group listed again (an event changed what ranking reads: criticalities, costs).
  void ungroup_all(Scheduler::Impl& m);

 private:
  // Takes task k out of listed_, keeping the others in place but the last.
  void unlist(Scheduler::Impl& m, Task& k);
  // Moves listed task t into the group of key gk.
  void join(Scheduler::Impl& m, int t, const GroupKey& gk);

  std::vector<int> listed_;  // Task::ready_pos is a task's place here
  std::vector<ReadyGroup> groups_;
  std::vector<int> free_groups_;
  std::vector<int> live_;  // the groups holding tasks; ReadyGroup::live_pos is the place here
  std::map<GroupKey, int> group_of_;
  int grouped_ = 0;            // tasks in groups
  int encoders_ = 0;           // encoder tasks in listed_
  std::vector<int> to_group_;  // scratch of regroup(): the listed tasks after a scan
};

}  // namespace sched_detail
}  // namespace red
