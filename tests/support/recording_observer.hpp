#pragma once
/// \file
/// Test support: an Observer that records everything the scheduler reports, in order, so
/// tests can check invariants after a run (precedence, accounting, lane use, frames).

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/sched/observer.hpp"

namespace red::test {

/// One job as the observer saw it.
struct SeenJob {
  JobId id = 0;
  int operation = -1;
  std::uint64_t seq = 0;
  TimePoint release{0};
  TimePoint deadline{0};
  TimePoint finish{0};
  bool counted = true;
  const RefinedGraph* graph = nullptr;
  JobOutcome outcome = JobOutcome::Unfinished;
  std::string reason;
  std::uint64_t release_event = 0;  ///< order of its on_job_release among all callbacks
  std::uint64_t end_event = 0;      ///< order of its (first) on_job_end, 0 if none
  int releases = 0;                 ///< on_job_release calls for this id
  int ends = 0;                     ///< on_job_end calls for this id
  bool skipped_at_release = false;  ///< the release record already said Skipped
};

/// One unit execution (a dispatch) as the observer saw it.
struct SeenUnit {
  Dispatch d;  ///< copy taken at on_unit_start (members, lane, ...); start as at its end
  std::uint64_t start_event = 0;
  std::uint64_t end_event = 0;  ///< 0 while running
  TimePoint end = kNever;
  UnitStatus status = UnitStatus::Completed;
  bool ended = false;
};

/// A decision round after which a lane stayed idle although a task was ready.
struct IdleViolation {
  TimePoint now{0};
  int ready = 0, idle_lanes = 0, waiting = 0;
};

/// Records every callback. Memory grows with the run: use it on short runs. Graph pointers
/// in the records point to the observer's own copies, valid as long as it lives.
class RecordingObserver final : public Observer {
 public:
  void on_job_release(const JobRecord& j) override {
    ++event_;
    ++release_events_;
    SeenJob& s = job_slot(j.id);
    ++s.releases;
    s.id = j.id;
    s.operation = j.operation;
    s.seq = j.seq;
    s.release = j.release;
    s.deadline = j.deadline;
    s.counted = j.counted;
    s.graph = intern(j.graph);
    s.release_event = event_;
    s.skipped_at_release = j.outcome == JobOutcome::Skipped;
  }

  void on_job_end(const JobRecord& j) override {
    ++event_;
    ++end_events_;
    SeenJob& s = job_slot(j.id);
    ++s.ends;
    if (s.ends == 1) {
      s.end_event = event_;
      s.outcome = j.outcome;
      s.finish = j.finish;
      s.reason = std::string(j.reason);
    }
  }

  void on_unit_start(const Dispatch& d) override {
    ++event_;
    SeenUnit u;
    u.d = d;
    for (Member& m : u.d.members) m.graph = intern(m.graph);
    u.start_event = event_;
    unit_by_dispatch_[d.id] = units_.size();
    units_.push_back(std::move(u));
  }

  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) override {
    ++event_;
    const auto it = unit_by_dispatch_.find(d.id);
    if (it == unit_by_dispatch_.end()) {
      ++unknown_unit_ends_;
      return;
    }
    SeenUnit& u = units_[it->second];
    if (u.ended) ++double_unit_ends_;
    // The start it ended with: a unit queued behind another on an asynchronous lane is
    // given its start when it was queued, corrected once that one ended (Scheduler::on_complete).
    u.d.start = d.start;
    u.ended = true;
    u.end = end;
    u.end_event = event_;
    u.status = s;
  }

  void on_merge_wait(int /*sensor*/, TimePoint /*now*/, TimePoint /*until*/) override {
    ++merge_waits_;
  }

  void on_decision(TimePoint now, int ready, int idle_lanes, int waiting) override {
    ++decisions_;
    // docs/DESIGN.md, "Dispatch": a free lane with a ready task must take it, unless the task waits
    // for a predicted merge member (DynamicMerge rule 2).
    if (idle_lanes > 0 && ready != waiting && idle_violations_.size() < 20)
      idle_violations_.push_back({now, ready, idle_lanes, waiting});
    if (idle_lanes > 0 && ready != waiting) ++idle_violation_count_;
  }

  [[nodiscard]] const std::vector<SeenJob>& jobs() const noexcept { return jobs_; }
  [[nodiscard]] const std::vector<SeenUnit>& units() const noexcept { return units_; }
  [[nodiscard]] const SeenJob* find_job(JobId id) const {
    const auto it = job_index_.find(id);
    return it == job_index_.end() ? nullptr : &jobs_[it->second];
  }
  [[nodiscard]] std::uint64_t release_events() const noexcept { return release_events_; }
  [[nodiscard]] std::uint64_t end_events() const noexcept { return end_events_; }
  [[nodiscard]] std::uint64_t decisions() const noexcept { return decisions_; }
  [[nodiscard]] std::uint64_t merge_waits() const noexcept { return merge_waits_; }
  [[nodiscard]] std::uint64_t unknown_unit_ends() const noexcept { return unknown_unit_ends_; }
  [[nodiscard]] std::uint64_t double_unit_ends() const noexcept { return double_unit_ends_; }
  [[nodiscard]] const std::vector<IdleViolation>& idle_violations() const noexcept {
    return idle_violations_;
  }
  [[nodiscard]] std::uint64_t idle_violation_count() const noexcept {
    return idle_violation_count_;
  }

 private:
  // The scheduler's graphs die with it (simulate_policy returns after the simulator is
  // gone): keep a copy of every graph version seen, so records can be checked afterwards.
  const RefinedGraph* intern(const RefinedGraph* g) {
    if (g == nullptr) return nullptr;
    auto [it, fresh] = graphs_.try_emplace(g);
    if (fresh) it->second = std::make_unique<RefinedGraph>(*g);
    return it->second.get();
  }

  SeenJob& job_slot(JobId id) {
    const auto [it, fresh] = job_index_.try_emplace(id, jobs_.size());
    if (fresh) jobs_.emplace_back();
    return jobs_[it->second];
  }

  std::uint64_t event_ = 0;
  std::vector<SeenJob> jobs_;
  std::map<JobId, std::size_t> job_index_;
  std::map<const RefinedGraph*, std::unique_ptr<const RefinedGraph>> graphs_;
  std::vector<SeenUnit> units_;
  std::map<std::uint64_t, std::size_t> unit_by_dispatch_;
  std::uint64_t release_events_ = 0, end_events_ = 0, decisions_ = 0, merge_waits_ = 0;
  std::uint64_t unknown_unit_ends_ = 0, double_unit_ends_ = 0;
  std::vector<IdleViolation> idle_violations_;
  std::uint64_t idle_violation_count_ = 0;
};

}  // namespace red::test
