#pragma once
/// \file
/// The scheduler core (the paper's global synchronizer logic, docs/DESIGN.md, "Refinement" to
/// "Dispatch"): jobs, refinement, deadline (re-)assignment, DynamicMerge, batching, drops and
/// dispatch. It reads no clock: the driver (simulator or real runtime) passes the time in. Same
/// code, both backends.
///
/// Driving it, at every scheduling point `now` (non-decreasing), in the order
/// red/sched/round.hpp keeps for every driver:
///
///     red::run_round(s, now, [&] {
///       s.on_complete(lane, now, status);  // units that finished by now
///       s.on_frame(sensor, frame_id, now); // frames that arrived by now
///     });  // = s.apply_events(now); the inputs; s.advance(now); s.dispatch(now)
///     then executor.start(*d) for every dispatch it returns, and wake up again at
///     s.next_wakeup() or at the next external input.
///
/// Not thread-safe: one thread (the global synchronizer) owns it.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sched/policy.hpp"

namespace red {

/// Scheduler settings that come from the scenario (and CLI overrides).
struct SchedulerConfig {
  int lanes = 1;
  Duration gamma = std::chrono::milliseconds{100};
  int max_batch = 4;
  EstimateKind estimate = EstimateKind::P99;
  LevelCost level_cost = LevelCost::Max;
  TimePoint warmup{0};
  /// What one synchronizer round trip costs (docs/DESIGN.md, "Synchronization"): every estimate
  /// that decides a dispatch (batching, merge waits, hopeless aborts) includes the round trip the
  /// dispatch pays.
  Duration sync_cost{0};
  /// Dispatches a lane holds at once (docs/DESIGN.md, "Queued lanes"): the running unit and those
  /// enqueued behind it. 1: a lane takes work only when idle. More: with on-demand
  /// synchronization the lane's handler queues its next unit(s) while one runs
  /// (dispatch_ahead()), so the device does not wait for the host between units.
  int queue_depth = 1;
  static constexpr int kMaxQueueDepth = red::kMaxQueueDepth;
  /// With queue_depth > 1: how long before the lane's units are expected to end (their
  /// profiled p50) its handler decides the unit queued behind them. Deciding then, not at
  /// once, keeps the unit boundary the preemption point: a release during the running unit
  /// is seen before the next unit is chosen. The runtime takes at least twice what its
  /// enqueue calls cost.
  Duration ahead_lead{std::chrono::microseconds{100}};
  /// Ready tasks from which the scheduler keeps those that rank alike at every instant (one
  /// plain unit each, of jobs in the same state) in groups, ranking only the first of each:
  /// N jobs released together then cost N decisions over a few groups, not over N tasks.
  /// Only the cost changes, never a decision (the tests run both ways and compare).
  int group_from = 256;
  /// Online cost estimates (docs/DESIGN.md, "Online costs"): plans follow what units cost in
  /// this run. Disabled: plans rest on the profile all run long.
  OnlineCostOptions online_costs;
  /// Measure what units cost in this run (Scheduler::online_costs()); false: neither measured
  /// nor followed (the simulator, drawing its costs from the profile it plans with).
  bool measure_costs = true;

  /// The settings a scenario gives.
  static SchedulerConfig from(const Scenario& s);
  /// The settings a scenario gives, with the profile's measured round trip unless the
  /// scenario sets `device.sync_cost_us`, and a queue depth of 2 on a profile measured on
  /// a GPU unless the scenario sets `device.queue_depth`.
  static SchedulerConfig from(const Scenario& s, const Profile& p);
};

/// Counters kept by the scheduler itself (everything else is an observer's business).
struct SchedulerStats {
  std::uint64_t decisions = 0;  ///< dispatch() calls that examined the ready set
  std::uint64_t dispatches = 0;
  std::uint64_t round_trips = 0;  ///< dispatches that needed a synchronizer round trip
  std::uint64_t merge_waits = 0;
  std::uint64_t releases = 0;
  std::uint64_t rejected = 0;  ///< jobs shed at release by admission (docs/DESIGN.md, "Overload")
  std::uint64_t hopeless = 0;  ///< jobs aborted at dispatch as hopeless
  /// Less critical units held back by the criticality guard (PolicyOptions::guard) until a more
  /// critical operation's predicted release.
  std::uint64_t guard_holds = 0;
};

class Scheduler {
 public:
  /// `profile` and `scenario` must outlive the scheduler.
  Scheduler(const Scenario& scenario, const Profile& profile, std::unique_ptr<Policy> policy,
            SchedulerConfig config);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  /// Observers are called synchronously, in the order added; not owned.
  void add_observer(Observer* o);

  // ---- inputs -----------------------------------------------------------------------
  /// Applies workload events with at ≤ now (docs/DESIGN.md, "Task model"): later releases use the
  /// new graphs.
  void apply_events(TimePoint now);
  /// A frame of `sensor` arrived (frame ids increase per sensor). Releases every operation
  /// triggered by this sensor.
  void on_frame(int sensor, std::uint64_t frame, TimePoint now);
  /// The oldest unit `lane` holds (the one running) ended at `now`. `reason` is kept for
  /// failed jobs. `started`, when known (an asynchronous lane reads it from the device),
  /// corrects the start the unit was given; a unit queued behind it starts at `now`.
  void on_complete(int lane, TimePoint now, UnitStatus status, std::string_view reason = {},
                   TimePoint started = kNever);
  /// The executor starts the unit last dispatched to `lane` at `start` (after any round
  /// trip; a unit queued behind another: when that one is expected to end). Must be called
  /// once for every dispatch, before the next; observers see the start here.
  void on_start(int lane, TimePoint start);
  /// No more releases or workload events (end of the scenario); in-flight jobs go on.
  void stop_releases();
  /// Own-rate and count releases due by now; strict drops of jobs whose deadline ≤ now.
  void advance(TimePoint now);

  // ---- decisions ----------------------------------------------------------------------
  /// Assigns work to idle lanes (docs/DESIGN.md, "Dispatch"). The returned dispatches stay valid
  /// until their lane completes them. Allocation-free in steady state.
  std::span<Dispatch* const> dispatch(TimePoint now);
  /// Assigns at most one more unit to `lane`, which holds a unit and has room in its queue
  /// (config().queue_depth): the lane's handler enqueues it behind what the lane holds, at
  /// a unit boundary (on-demand). Empty when the lane is idle, full, or nothing can start.
  std::span<Dispatch* const> dispatch_ahead(TimePoint now, int lane);
  /// Whether `lane` holds a unit and has room for one more (dispatch_ahead()).
  [[nodiscard]] bool has_room_ahead(int lane) const;
  /// Whether lanes' handlers queue units ahead (docs/DESIGN.md, "Queued lanes"): queue_depth > 1
  /// under on-demand synchronization.
  [[nodiscard]] bool queues_ahead() const;
  /// The queue-ahead rule (docs/DESIGN.md, "Queued lanes"), the one every driver follows: when a
  /// lane's handler decides the units its queue has room for (dispatch_ahead()). That is a lead
  /// before what the lane holds is expected to end: `held_start`, the oldest held unit's start,
  /// plus `held_p50`, the held units' profiled p50 summed. The lead is
  /// SchedulerConfig::ahead_lead, or twice `enqueue_cost` (what an enqueue costs the host: the
  /// runtime's, smoothed; nothing in the simulator) where that is more. Reads only the
  /// configuration: a lane's handler may ask without the scheduler's lock.
  [[nodiscard]] TimePoint queue_ahead_at(TimePoint held_start, Duration held_p50,
                                         Duration enqueue_cost = Duration{0}) const;
  /// The earliest time the scheduler needs to run again without external input (releases,
  /// events, deadlines, merge waits), or kNever.
  [[nodiscard]] TimePoint next_wakeup() const;
  /// Ends the run: reports jobs still in flight as Unfinished.
  void finish(TimePoint end);

  // ---- queries ------------------------------------------------------------------------
  [[nodiscard]] const Policy& policy() const noexcept { return *policy_; }
  [[nodiscard]] const SchedulerConfig& config() const noexcept { return config_; }
  [[nodiscard]] const SchedulerStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const Scenario& scenario() const noexcept { return scenario_; }
  [[nodiscard]] int jobs_in_flight() const noexcept { return in_flight_; }
  [[nodiscard]] int ready_tasks() const noexcept;
  /// True when no job is in flight and no release or event can happen any more.
  [[nodiscard]] bool drained() const;
  /// Current sensor rate (events may change it).
  [[nodiscard]] double sensor_rate(int sensor) const;
  /// The current refined graph of an operation (null when not active).
  [[nodiscard]] const RefinedGraph* graph(int operation) const;
  /// The dispatch running on a lane (the oldest it holds), or null.
  [[nodiscard]] const Dispatch* running(int lane) const;
  /// The online cost estimates, or null when not measured (SchedulerConfig::measure_costs).
  [[nodiscard]] const OnlineCosts* online_costs() const noexcept;
  /// The profile the scheduler plans with now: the given one, or the online estimates' one.
  [[nodiscard]] const Profile& plan_profile() const noexcept;
  /// Absolute intermediate deadline of (job slot, unit) at `now` under the policy (for
  /// reports and tests).
  [[nodiscard]] TimePoint unit_deadline(int slot, int unit, TimePoint now);

  struct Impl;

 private:
  const Scenario& scenario_;
  std::unique_ptr<Policy> policy_;
  SchedulerConfig config_;
  SchedulerStats stats_;
  int in_flight_ = 0;
  std::unique_ptr<Impl> impl_;
};

}  // namespace red
