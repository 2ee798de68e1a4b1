#pragma once
/// \file
/// The real-time runtime (docs/DESIGN.md, "Synchronization"): one global synchronizer (the
/// scheduler loop, on the thread that calls run()) and one handler thread per lane, each with a
/// local synchronizer that owns the handler's state machine
///
///     Idle -> Assigned -> Running -> {Completed | Failed | OutOfMemory | Cancelled} -> Idle
///
/// Per-edge synchronization: every completed unit makes one round trip to the global
/// synchronizer before its handler gets more work. On-demand: a handler whose unit
/// completed normally takes the scheduler's decision itself at the unit boundary (the only
/// preemption point) and goes on without waking the global synchronizer; failures and
/// timers still go through it, and it is woken only when a local decision moved its next
/// timer earlier. A frame is released by the thread that brought it (the camera thread,
/// push_frame's caller) when the scheduler's lock is free and that thread cannot be
/// preempted by ordinary threads while holding it; otherwise the global synchronizer
/// releases it. Waiting is spin-then-park; taking the scheduler's lock spins before it
/// blocks. It drives the same Scheduler and Policy as the simulator; only the clock and the
/// executor differ.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/online_costs.hpp"
#include "red/sched/scheduler.hpp"

namespace red {

/// States of a handler's state machine (docs/DESIGN.md, "Synchronization").
enum class HandlerState : std::uint8_t {
  Idle,
  Assigned,
  Running,
  Completed,
  Failed,
  OutOfMemory,
  Cancelled
};

const char* to_string(HandlerState s) noexcept;

/// Options of a real run.
struct RuntimeOptions {
  bool realtime = true;  ///< try SCHED_FIFO, CPU affinity and mlockall (reported either way)
  /// With `realtime`: hold the CPU wake-up latency at 0 while the run lasts, so that idle
  /// cores poll (red/runtime/wakeup_latency.hpp; reported either way, never required).
  bool hold_wakeup_latency = true;
  /// SCHED_FIFO priority of the lane handlers (and the backend's workers, which inherit it).
  /// The global synchronizer and the threads that release frames run one above, so that a
  /// deadline, a frame or a decision is not held up by a unit's compute threads.
  int rt_priority = 10;
  /// Spin before parking, and before blocking on the scheduler's lock.
  Duration spin = std::chrono::microseconds{50};
  /// A handler that reported a completion to the global synchronizer (per-edge) spins this
  /// long for the answer before parking: the answer is due within a round trip, and a
  /// parked handler pays a second wake-up.
  Duration answer_spin = std::chrono::microseconds{200};
  Duration drain_limit = std::chrono::seconds{5};  ///< after the scenario ends
  bool interference = true;                        ///< run the scenario's background load
  /// Frames come from push_frame() (e.g. a DDS node) instead of the synthetic cameras;
  /// releases end at stop() or at the scenario's duration, whichever comes first.
  bool external_frames = false;
  /// Watchdog: a unit still running after watchdog_x × its profiled p99 (at its batch
  /// size; a Mono or Coarse unit sums its parts) fails its jobs with the reason "timeout",
  /// and its lane is out of service until the backend call returns (it cannot be
  /// interrupted; its late result is ignored). 0 turns the watchdog off.
  double watchdog_x = 10.0;
  Duration watchdog_min = std::chrono::milliseconds{50};  ///< no unit's limit is shorter
  Duration sample_period = std::chrono::seconds{1};       ///< RuntimeReport::samples (0: none)
  /// Most entries kept in decision_us and handoff_us (a uniform sample beyond), so a long
  /// run's memory stays flat; reserved up front, so recording never allocates.
  std::size_t max_timing_samples = 16384;
};

/// One sample of the process and the scheduler, taken every sample_period of a run.
struct RuntimeSample {
  Duration t{0};               ///< since the start of the run
  std::int64_t rss_bytes = 0;  ///< resident set size
  int ready = 0;               ///< ready units waiting for a lane
  int in_flight = 0;           ///< jobs released and not ended
};

/// What a real run measured, besides what observers saw.
struct RuntimeReport {
  TimePoint end{0};
  SchedulerStats stats;
  std::vector<std::string> realtime;  ///< one line per knob: applied or why not
  std::vector<double> decision_us;    ///< time of scheduling decisions (dispatch()), sampled
  std::vector<double> handoff_us;  ///< unit completion -> next unit started on that lane, sampled
  /// Asynchronous lanes: the end of a unit -> the start of the unit already queued behind it
  /// (the device's gap, from the backend's times), sampled; `queued_gaps` counts them all.
  std::vector<double> queued_gap_us;
  std::uint64_t queued_gaps = 0;
  std::uint64_t enqueued_ahead = 0;      ///< units a handler queued behind a running one
  std::vector<double> frame_release_us;  ///< external frame pushed -> handed to the scheduler
  /// Frames in the measured window (capture time after the warm-up, before releases ended):
  /// offered by the sensors (the camera's nominal capture times, or the frames pushed), and
  /// released to the scheduler. Fewer released than offered: the run fell behind its sensors
  /// and the rest were never released (docs/REPORTS.md, "Frames offered and released").
  std::uint64_t frames_offered = 0;
  std::uint64_t frames_released = 0;
  /// Of the released frames: release - nominal capture time (pushed frames: - arrival), one
  /// per frame, in μs; and how many came later than one period of their sensor.
  std::vector<double> release_late_us;
  std::uint64_t frames_behind = 0;
  /// Frames released by the thread that brought them (camera, push_frame) because the
  /// scheduler's lock was free, without waking the global synchronizer.
  std::uint64_t direct_releases = 0;
  /// Local decisions (on-demand) whose handler found the scheduler's lock held by another
  /// thread; lock_wait_us holds a uniform sample of how long each waited for it.
  std::uint64_t lock_waits = 0;
  std::vector<double> lock_wait_us;   ///< see lock_waits
  std::uint64_t decisions = 0;        ///< decisions timed (decision_us holds a uniform sample)
  std::uint64_t handoffs = 0;         ///< hand-offs timed (handoff_us holds a uniform sample)
  std::uint64_t wakeups = 0;          ///< times the global synchronizer woke
  std::uint64_t local_decisions = 0;  ///< decisions taken by handlers (on-demand)
  std::uint64_t failures = 0;         ///< units that ended Failed, OutOfMemory or timed out
  std::map<std::string, std::uint64_t> failure_reasons;  ///< failed units by reason
  std::uint64_t timeouts = 0;                            ///< units failed by the watchdog
  std::uint64_t late_returns = 0;  ///< timed-out backend calls that returned later
  /// Units an asynchronous lane gave up on at the end of the run because the device had not
  /// finished them past their watchdog limit (a hung device; Backend::abandon).
  std::uint64_t abandoned = 0;
  /// The device was lost (Backend's DeviceLostError, UnitDone::device_lost): what the first
  /// unit to see it said, and its lane (-1: none). The run stopped there, as stop_now().
  std::string device_lost;
  int device_lost_lane = -1;
  Duration out_of_service{0};              ///< lane time spent waiting for timed-out calls
  std::vector<RuntimeSample> samples;      ///< one per sample_period, and one at the end
  std::int64_t resident_bytes_before = 0;  ///< process RSS before the runtime's threads start
  /// after the backend's warm-up pass, before memory is locked and the run starts
  std::int64_t resident_bytes_warm = 0;
  std::int64_t resident_bytes_after = 0;  ///< and after the run
  /// After the caller released what the run kept (Backend::end_run, malloc_trim); set by
  /// the caller, 0 when it did not
  std::int64_t resident_bytes_released = 0;
  /// Online cost estimates (docs/DESIGN.md, "Online costs"): the profile's costs against the
  /// run's, per unit and batch size, and how often the plan changed; empty when disabled.
  std::vector<UnitCostFigures> costs;
  int plan_changes = 0;
  bool online_costs = false;
};

class Runtime {
 public:
  /// `scenario`, `profile` and `backend` must outlive the runtime.
  Runtime(const Scenario& scenario, const Profile& profile, std::unique_ptr<Policy> policy,
          Backend& backend, RuntimeOptions options);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  /// Observers are called with the scheduler's lock held, from the synchronizer, a handler
  /// thread or the thread that brought a frame (push_frame's caller, the camera thread),
  /// never two at once; not owned.
  void add_observer(Observer* o);
  /// Runs the scenario in real time (duration, then draining); blocks until done.
  RuntimeReport run();

  /// External-frame mode: frame `frame` of `sensor` arrived now, a release (docs/ROS2.md); its
  /// pixels, when given, go to the backend (Backend::on_external_frame). Frame ids of one
  /// sensor must increase. Thread-safe; ignored before run() starts and after releases
  /// ended. Returns false when ignored. When the scheduler's lock is free the release (and
  /// the decision it triggers, observers included) runs on the calling thread, unless the
  /// runtime's threads are real-time and the caller is not (see the file comment).
  bool push_frame(int sensor, std::uint64_t frame, const FrameView* pixels = nullptr);
  /// Whether push_frame() would be accepted now (run() started, releases not ended).
  [[nodiscard]] bool accepting_frames() const noexcept;
  /// Ends releases now (then in-flight jobs drain, as at the scenario's end). Thread-safe,
  /// async-signal-unsafe; may be called before run().
  void stop();
  /// Ends the run now, without draining (e.g. on SIGINT): releases end and the jobs in
  /// flight are reported unfinished once the units running return (a backend call cannot
  /// be interrupted). Thread-safe, async-signal-unsafe; may be called before run().
  void stop_now();
  /// Decision times (μs) recorded since `cursor` (a count of decisions), newest 4096 at
  /// most, and moves `cursor` past them; thread-safe (for live reports).
  [[nodiscard]] std::vector<double> decision_us_since(std::uint64_t& cursor) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Resident set size of this process in bytes (/proc/self/statm), or 0.
std::int64_t resident_bytes();

}  // namespace red
