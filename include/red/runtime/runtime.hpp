#pragma once
/// \file
/// The real-time runtime (§6): one global synchronizer (the scheduler loop, on the thread
/// that calls run()) and one handler thread per lane, each with a local synchronizer that
/// owns the handler's state machine
///
///     Idle -> Assigned -> Running -> {Completed | Failed | OutOfMemory | Cancelled} -> Idle
///
/// Per-edge synchronization: every completed unit makes one round trip to the global
/// synchronizer before its handler gets more work. On-demand: a handler whose unit
/// completed normally takes the scheduler's decision itself at the unit boundary (the only
/// preemption point) and goes on without waking the global synchronizer; failures,
/// releases and timers still go through it. Waiting is spin-then-park. It drives the same
/// Scheduler and Policy as the simulator; only the clock and the executor differ.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/scheduler.hpp"

namespace red {

/// States of a handler's state machine (§6).
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
  int rt_priority = 10;  ///< SCHED_FIFO priority for the synchronizer and handlers
  Duration spin = std::chrono::microseconds{50};   ///< spin before parking
  Duration drain_limit = std::chrono::seconds{5};  ///< after the scenario ends
  bool interference = true;                        ///< run the scenario's background load
  /// Frames come from push_frame() (e.g. a DDS node) instead of the synthetic cameras;
  /// releases end at stop() or at the scenario's duration, whichever comes first.
  bool external_frames = false;
};

/// What a real run measured, besides what observers saw.
struct RuntimeReport {
  TimePoint end{0};
  SchedulerStats stats;
  std::vector<std::string> realtime;       ///< one line per knob: applied or why not
  std::vector<double> decision_us;         ///< time of each scheduling decision (dispatch())
  std::vector<double> handoff_us;          ///< unit completion -> next unit started on that lane
  std::vector<double> frame_release_us;    ///< external frame pushed -> handed to the scheduler
  std::uint64_t wakeups = 0;               ///< times the global synchronizer woke
  std::uint64_t local_decisions = 0;       ///< decisions taken by handlers (on-demand)
  std::uint64_t failures = 0;              ///< units that ended Failed or OutOfMemory
  std::int64_t resident_bytes_before = 0;  ///< process RSS before the runtime's threads start
  std::int64_t resident_bytes_after = 0;   ///< and after the run
};

class Runtime {
 public:
  /// `scenario`, `profile` and `backend` must outlive the runtime.
  Runtime(const Scenario& scenario, const Profile& profile, std::unique_ptr<Policy> policy,
          Backend& backend, RuntimeOptions options);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  /// Observers are called with the scheduler's lock held, from the synchronizer or a
  /// handler thread (never two at once); not owned.
  void add_observer(Observer* o);
  /// Runs the scenario in real time (duration, then draining); blocks until done.
  RuntimeReport run();

  /// External-frame mode: frame `frame` of `sensor` arrived now, a release (§14); its
  /// pixels, when given, go to the backend (Backend::on_external_frame). Frame ids of one
  /// sensor must increase. Thread-safe; ignored before run() starts and after releases
  /// ended. Returns false when ignored.
  bool push_frame(int sensor, std::uint64_t frame, const FrameView* pixels = nullptr);
  /// Whether push_frame() would be accepted now (run() started, releases not ended).
  [[nodiscard]] bool accepting_frames() const noexcept;
  /// Ends releases now (then in-flight jobs drain, as at the scenario's end). Thread-safe,
  /// async-signal-unsafe; may be called before run().
  void stop();
  /// Decision times (μs) recorded since the `from`-th one; thread-safe (for live reports).
  [[nodiscard]] std::vector<double> decision_us_since(std::size_t from) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Resident set size of this process in bytes (/proc/self/statm), or 0.
std::int64_t resident_bytes();

}  // namespace red
