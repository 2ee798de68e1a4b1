#pragma once
/// \file
/// Internal to src/sched: on-demand synchronization and placement (docs/DESIGN.md,
/// "Synchronization"; PolicyOptions::sync), one mechanism in one place: the runs the lanes'
/// handlers hold, the round trip's cost and the rule of when a dispatch pays one. The scheduler
/// calls it at named points:
///
/// * at a pick: `place` (the lane for the task chosen, and whether it pays a round trip);
/// * a dispatch starts: `started` (a round trip starts a new run), `joins` for each member job;
/// * a unit ends: `completed` (a transition other than Completed ends the run).
///
/// Admission, merge waits and the criticality guard read the price of a round trip,
/// `round_trip`.

#include <cstddef>
#include <utility>
#include <vector>

#include "pools.hpp"
#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

/// Where a pick places its dispatch (OnDemandSync::place).
struct Placement {
  int lane = -1;  ///< the lane; -1: none idle
  /// Queued behind what the lane holds (Scheduler::dispatch_ahead fills it), not on an idle lane.
  bool ahead = false;
  bool round_trip = false;  ///< the dispatch pays a round trip (it continues no run)
  Duration rt{0};           ///< what that round trip costs: 0 when it pays none
};

class OnDemandSync {
 public:
  /// At the start: the mode (PolicyOptions::sync), what a round trip costs, the lanes.
  void set_up(SyncMode mode, Duration cost, int lanes);

  /// Whether a dispatch may continue the run a lane's handler holds (SyncMode::OnDemand).
  [[nodiscard]] bool on_demand() const noexcept { return on_demand_; }
  /// What one round trip costs.
  [[nodiscard]] Duration round_trip() const noexcept { return cost_; }

  /// At a pick: where task `k` goes at `now`. `ahead`: the lane dispatch_ahead fills (its
  /// handler queues the task behind what it holds: no round trip), -1 for an idle lane: one
  /// whose run the task continues, else one without an open run (keeping open runs for their
  /// own work), else the first idle one (docs/DESIGN.md, "Synchronization" placement).
  [[nodiscard]] Placement place(const std::vector<Lane>& lanes, const JobPool& jobs, const Task& k,
                                TimePoint now, int ahead) const;

  /// A dispatch starts on lane `lane`: a round trip starts a new run (the handler is handed
  /// its jobs' work); either way the run is not open to a continuation until a unit completes.
  void started(int lane, bool pays_round_trip);
  /// The job in `slot` (id `id`), a member of the dispatch started on lane `lane`, joins its run.
  void joins(int lane, int slot, JobId id);
  /// A unit on lane `lane` ended at `now` with `status`: Completed keeps the run open for a
  /// continuation at `now`; any other transition ends it.
  void completed(int lane, TimePoint now, UnitStatus status);

 private:
  // The task continues the run lane `lane`'s handler holds: its last unit completed just now
  // and the task is ready work of a job of the run (a merged encoder's member heads, a job's
  // ready units of a height, their successors), so the handler goes on without a round trip.
  // Anything else, or per-edge synchronization, pays one.
  bool continues(std::size_t lane, const JobPool& jobs, const Task& k, TimePoint now) const;

  // The run a lane's handler holds: the jobs it was handed; open to a continuation at
  // `completed_at` after a Completed unit. It ends on a round trip or another transition.
  struct Run {
    TimePoint completed_at = kNever;
    bool open = false;
    std::vector<std::pair<int, JobId>> jobs;  // (slot, id)
  };
  std::vector<Run> runs_;  // per lane
  bool on_demand_ = false;
  Duration cost_{0};
};

}  // namespace sched_detail
}  // namespace red
