#pragma once
/// \file
/// Internal to src/runtime: Runtime::Impl, the runtime's one state, shared by the files of its
/// parts (listed at the top of runtime.cpp, which keeps the order of a run), and the waits
/// they all use.

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <latch>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "red/core/clock.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/wakeup_latency.hpp"

namespace red {
namespace runtime_detail {

// Spin for `spin`, then park on the condition variable until `pred` or `until`.
template <typename Pred>
void spin_then_park(std::mutex& m, std::condition_variable& cv, const Clock& clock, Duration spin,
                    TimePoint until, Pred pred) {
  const TimePoint spin_end = clock.now() + spin;
  while (clock.now() < spin_end) {
    if (pred()) return;
    std::this_thread::yield();
  }
  std::unique_lock lock(m);
  if (until == kNever) {
    cv.wait(lock, pred);
  } else {
    const auto wall = std::chrono::steady_clock::now() + (until - clock.now());
    cv.wait_until(lock, wall, pred);
  }
}

// Takes `m`. The scheduler's critical sections are short, and a thread that blocks on a held
// std::mutex sleeps in the kernel and pays a wake-up when it is freed (tens of microseconds
// on a loaded machine, longer than the section itself): so it spins for up to `spin` first,
// yielding, so that a holder on the same core at the same SCHED_FIFO priority runs. Returns
// whether another thread held `m` when it was asked for.
inline bool lock_spinning(std::mutex& m, const Clock& clock, Duration spin) {
  if (m.try_lock()) return false;
  const TimePoint spin_end = clock.now() + spin;
  while (clock.now() < spin_end) {
    std::this_thread::yield();
    if (m.try_lock()) return true;
  }
  m.lock();
  return true;
}

// Whether the calling thread runs under a real-time policy: ordinary threads cannot
// preempt it while it holds the scheduler's lock.
inline bool realtime_thread() noexcept {
  const int policy = sched_getscheduler(0);
  return policy == SCHED_FIFO || policy == SCHED_RR;
}

}  // namespace runtime_detail

// The fields keep one order (construction and destruction follow it); the comments above each
// group name the file of the part that uses it most.
struct Runtime::Impl {
  // Watchdog states of a handler's current unit (Handler::watch).
  static constexpr std::uint8_t kWatchIdle = 0;     // no unit running
  static constexpr std::uint8_t kWatchRunning = 1;  // running, limit in Handler::limit_ns
  static constexpr std::uint8_t kWatchTimedOut =
      2;  // failed by the watchdog; the call is still out

  // A frame or a completion on its way to the scheduler (the inbox, one round's events).

  struct InEvent {
    enum Kind : std::uint8_t { Frame, Complete } kind;
    int index;  // sensor or lane
    std::uint64_t frame;
    TimePoint t;  // a completion's end; a frame's nominal capture time (pushed: its arrival)
    UnitStatus status;
    std::string reason;
    TimePoint started = kNever;  // a completion: its start as the device read it, if known
  };

  // ---- What the run is given, the clock and the scheduler (runtime.cpp).
  const Scenario& scenario;
  Backend& backend;
  RuntimeOptions options;
  SteadyClock clock;
  Scheduler sched;
  SyncMode sync;
  // docs/DESIGN.md, "Queued lanes": units are enqueued on the backend's lanes and waited for
  // (Backend::enqueue, Backend::wait); with on-demand synchronization a handler queues up
  // to the scheduler's queue_depth units, so the device does not wait for the host.
  bool async;

  // ---- The scheduler's lock and the global synchronizer's round (runtime.cpp).
  // The scheduler is driven by one thread at a time: the global synchronizer, a handler
  // taking a local decision (on-demand), or a thread releasing the frame it brought.
  std::mutex sched_mu;
  TimePoint last_now{0};            // under sched_mu
  bool releasing = true;            // under sched_mu: releases have not ended
  TimePoint releases_end = kNever;  // under sched_mu: when they ended
  // One round's events, taken from the inbox, and the lanes whose units completed in them
  // (under sched_mu; their capacity is reused).
  std::vector<InEvent> round_events;
  std::vector<int> round_completed;
  std::atomic<bool> realtime_on{false};  // SCHED_FIFO applied to the synchronizer and handlers

  // Global synchronizer's inbox (frames, completions), spin-then-park.
  std::mutex inbox_mu;
  std::condition_variable inbox_cv;
  std::vector<InEvent> inbox;
  std::atomic<std::uint64_t> inbox_seq{0};
  std::atomic<bool> poke{false};

  // ---- The lanes' handlers, their state machines and the watchdog (handlers.cpp,
  // async_lanes.cpp).
  struct Handler {
    std::thread thread;
    std::mutex mu;
    std::condition_variable cv;
    std::atomic<std::uint64_t> assigned{0};  // bumped on every assignment
    const Dispatch* work = nullptr;
    std::deque<const Dispatch*> queue;  // asynchronous lanes: assignments not yet taken
    TimePoint prev_end = kNever;        // end of the unit this assignment follows, if immediate
    std::atomic<HandlerState> state{HandlerState::Idle};
    // Watchdog. The handler runs a copy of its dispatch: once the watchdog has failed a
    // unit, the scheduler may hand the lane its next dispatch while the call is still out.
    Dispatch copy;
    std::atomic<std::uint8_t> watch{kWatchIdle};
    std::atomic<std::int64_t> limit_ns{0};      // when the running unit times out
    std::atomic<std::int64_t> timed_out_ns{0};  // when the watchdog failed it
  };
  std::vector<std::unique_ptr<Handler>> handlers;
  std::optional<std::latch> warmed;  // counts down as each lane finishes Backend::warm_up
  std::atomic<bool> stopping{false};
  // ---- Frames in: the camera and pushed frames (intake.cpp); stopping (runtime.cpp).
  std::atomic<bool> cameras_on{true};
  // The camera's next nominal capture time per sensor and the frames it reached in the
  // measured window (its thread's, read after it is joined).
  std::vector<TimePoint> camera_next;
  std::uint64_t camera_offered = 0;
  std::atomic<std::uint64_t> pushed_offered{0};  // external frames accepted after the warm-up
  std::atomic<bool> accepting{false};  // external frames: between run() start and release end
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> stop_now_requested{false};  // stop_now(): no draining
  // ---- Waking the global synchronizer (runtime.cpp); the watchdog's limits (handlers.cpp).
  // When the global synchronizer will wake next (kNever while it recomputes): a handler
  // starting a unit whose watchdog limit comes earlier pokes it, and so does a thread whose
  // round (a local decision, a direct release) moved the scheduler's next timer earlier.
  std::atomic<std::int64_t> global_wake_at{kNever.count()};
  // Profiled p99 of the encoder and of each head (for watchdog limits).
  const UnitProfile* encoder_profile = nullptr;
  std::vector<const UnitProfile*> head_profiles;

  // ---- What the run reports, timing samples (samples.cpp).
  RuntimeReport report;
  mutable std::mutex report_mu;
  std::uint64_t reservoir_rng = 0x9E3779B97F4A7C15ULL;  // under report_mu
  // The newest decision times in order, for decision_us_since() (live reports): a ring of
  // kRecentDecisions, `recent_total` ever recorded. Under report_mu.
  static constexpr std::size_t kRecentDecisions = 4096;
  std::vector<double> recent_decision_us;
  std::uint64_t recent_total = 0;

  std::mutex sample_mu;
  std::condition_variable sample_cv;
  bool sampling = true;  // under sample_mu

  Impl(const Scenario& s, const Profile& p, std::unique_ptr<Policy> policy, Backend& b,
       RuntimeOptions o);

  // ---- Small helpers.
  bool watchdog_on() const noexcept { return options.watchdog_x > 0; }

  // The scheduler's settings for this backend: a synchronous backend runs one unit per lane
  // at a time; an asynchronous one queues the scenario's device.queue_depth (default 2).
  static SchedulerConfig config_of(const Scenario& s, const Profile& p, const Backend& b) {
    SchedulerConfig c = SchedulerConfig::from(s, p);
    c.queue_depth = b.asynchronous() ? s.device.queue_depth.value_or(2) : 1;
    return c;
  }

  // A steady_clock time a backend reported, on this run's clock (kNever when not given).
  TimePoint on_clock(std::chrono::steady_clock::time_point t) const noexcept {
    if (t == std::chrono::steady_clock::time_point{}) return kNever;
    return TimePoint{std::chrono::duration_cast<Duration>(t.time_since_epoch()) - clock.origin()};
  }

  TimePoint advance_now(TimePoint t) {
    last_now = std::max(last_now, t);
    return last_now;
  }

  // ---- runtime.cpp: the run, the global synchronizer's round, its inbox.
  RuntimeReport run();
  std::thread start_camera();
  void finish_run();
  void post(InEvent e);
  std::uint64_t take_inbox(bool global);
  std::uint64_t round(TimePoint now);
  bool must_wake_global();
  void wake_global();
  void assign(const Dispatch* d, TimePoint now, TimePoint prev_end);
  const Dispatch* decide(TimePoint now, int own_lane, std::span<const int> completed_lanes,
                         TimePoint completed_at);

  // ---- handlers.cpp: a lane's handler thread and the watchdog.
  void start_lane(int lane);
  // An idle lane's wait for its next assignment (spinning longer right after it reported a
  // completion, `answer_due`, which it clears). False when the run is stopping.
  bool await_assignment(Handler& h, std::uint64_t seen, bool& answer_due);
  void handler_main(int lane);
  Duration p99_of(const Dispatch& d) const;
  // A lost device: the first report is kept, and the run stops now. Returns the unit's
  // failure reason ("device lost: ...").
  std::string device_lost(int lane, std::string reason);
  Duration watchdog_limit(const Dispatch& d) const;
  void check_watchdog(TimePoint now);
  TimePoint next_watchdog() const;

  // ---- async_lanes.cpp: the handler of an asynchronous lane.
  // A unit an asynchronous lane holds: the handler's copy of its dispatch (the scheduler
  // may reuse its slot once the watchdog has failed it), when it was enqueued, and a failure
  // to enqueue it (then it is not waited for).
  struct Held {
    Dispatch d;
    TimePoint enqueued{0};
    TimePoint began = kNever;  // when it became the oldest (the one before it ended)
    bool queued = false;       // enqueued while the unit before it was still held
    bool enqueue_failed = false;
    bool device_lost = false;  // enqueue_failed with DeviceLostError
    UnitStatus status = UnitStatus::Completed;
    std::string reason;
  };
  void async_handler_main(int lane);
  void enqueue_unit(int lane, std::deque<Held>& held, const Dispatch& d, TimePoint prev_end,
                    Duration& enqueue_cost);
  TimePoint queue_ahead_at(const std::deque<Held>& held, Duration enqueue_cost) const;
  bool await_unit(Handler& h, int lane, TimePoint expected, TimePoint limit);
  void decide_ahead(int lane, TimePoint now, std::vector<const Dispatch*>& out);
  void fill_ahead(int lane, Handler& h, std::deque<Held>& held, std::vector<const Dispatch*>& taken,
                  TimePoint prev_end, Duration& enqueue_cost);
  UnitDone await_oldest(int lane, Handler& h, Held& u, TimePoint watched, TimePoint limit,
                        bool& abandoned);

  // ---- intake.cpp: frames in.
  void arrive(int sensor, std::uint64_t frame, TimePoint captured);
  void camera_main();
  void count_offered();

  // ---- realtime.cpp: the real-time knobs and background load.
  void apply_realtime();
  // Ends what apply_realtime() holds for the run (memory locks, the wake-up latency).
  void release_realtime();
  // The CPU wake-up latency held at 0 while the run lasts (RuntimeOptions::hold_wakeup_latency).
  WakeupLatencyHold wakeup_latency;
  // The machine's online cores and each lane's share of them: cores / lanes, at least one.
  struct CoreShare {
    long cores;
    long share;
  };
  CoreShare core_share() const;
  cpu_set_t lane_cores(std::size_t i) const;
  int control_priority() const;
  void at_handler_priority(std::thread& t) const;
  static std::string scheduling_of(std::vector<std::thread>& threads);
  void interference_main(double intensity, std::atomic<bool>& on);

  // ---- samples.cpp: timing samples.
  void record(std::vector<double>& v, std::uint64_t& seen, double x) noexcept;
  void take_sample();
  void sampler_main();
};

}  // namespace red
