#include "red/runtime/runtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <fstream>
#include <latch>
#include <mutex>
#include <optional>
#include <span>
#include <thread>

#include "red/core/assert.hpp"
#include "red/core/clock.hpp"
#include "red/sched/round.hpp"
#include "red/sim/cost_sampler.hpp"

namespace red {

const char* to_string(HandlerState s) noexcept {
  switch (s) {
    case HandlerState::Idle:
      return "idle";
    case HandlerState::Assigned:
      return "assigned";
    case HandlerState::Running:
      return "running";
    case HandlerState::Completed:
      return "completed";
    case HandlerState::Failed:
      return "failed";
    case HandlerState::OutOfMemory:
      return "out-of-memory";
    case HandlerState::Cancelled:
      return "cancelled";
  }
  return "?";
}

std::int64_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::int64_t size = 0, resident = 0;
  if (!(f >> size >> resident)) return 0;
  return resident * static_cast<std::int64_t>(sysconf(_SC_PAGESIZE));
}

namespace {

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
bool lock_spinning(std::mutex& m, const Clock& clock, Duration spin) {
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
bool realtime_thread() noexcept {
  const int policy = sched_getscheduler(0);
  return policy == SCHED_FIFO || policy == SCHED_RR;
}

// Watchdog states of a handler's current unit (Handler::watch).
constexpr std::uint8_t kWatchIdle = 0;      // no unit running
constexpr std::uint8_t kWatchRunning = 1;   // running, limit in Handler::limit_ns
constexpr std::uint8_t kWatchTimedOut = 2;  // failed by the watchdog; the call is still out

struct InEvent {
  enum Kind : std::uint8_t { Frame, Complete } kind;
  int index;  // sensor or lane
  std::uint64_t frame;
  TimePoint t;  // a completion's end; a frame's nominal capture time (pushed: its arrival)
  UnitStatus status;
  std::string reason;
  TimePoint started = kNever;  // a completion: its start as the device read it, if known
};

}  // namespace

struct Runtime::Impl {
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
  std::atomic<bool> cameras_on{true};
  // The camera's next nominal capture time per sensor and the frames it reached in the
  // measured window (its thread's, read after it is joined).
  std::vector<TimePoint> camera_next;
  std::uint64_t camera_offered = 0;
  std::atomic<std::uint64_t> pushed_offered{0};  // external frames accepted after the warm-up
  std::atomic<bool> accepting{false};  // external frames: between run() start and release end
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> stop_now_requested{false};  // stop_now(): no draining
  // When the global synchronizer will wake next (kNever while it recomputes): a handler
  // starting a unit whose watchdog limit comes earlier pokes it, and so does a thread whose
  // round (a local decision, a direct release) moved the scheduler's next timer earlier.
  std::atomic<std::int64_t> global_wake_at{kNever.count()};
  // Profiled p99 of the encoder and of each head (for watchdog limits).
  const UnitProfile* encoder_profile = nullptr;
  std::vector<const UnitProfile*> head_profiles;

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
       RuntimeOptions o)
      : scenario(s),
        backend(b),
        options(o),
        sched(s, p, std::move(policy), config_of(s, p, b)),
        sync(sched.policy().options().sync),
        async(b.asynchronous()) {
    report.decision_us.reserve(options.max_timing_samples);
    recent_decision_us.reserve(kRecentDecisions);
    report.handoff_us.reserve(options.max_timing_samples);
    if (async) report.queued_gap_us.reserve(options.max_timing_samples);
    report.lock_wait_us.reserve(options.max_timing_samples);
    round_events.reserve(64);
    round_completed.reserve(static_cast<std::size_t>(s.device.lanes));
    encoder_profile = p.find("encoder");
    for (const std::string& h : s.model.heads) head_profiles.push_back(p.find("head/" + h));
  }

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

  // Keeps a uniform sample of at most max_timing_samples values (reservoir sampling,
  // Algorithm R); `seen` counts every value offered. Caller holds report_mu.
  void record(std::vector<double>& v, std::uint64_t& seen, double x) noexcept {
    ++seen;
    if (v.size() < options.max_timing_samples) {
      v.push_back(x);  // within the reserved capacity
      return;
    }
    reservoir_rng ^= reservoir_rng << 13;
    reservoir_rng ^= reservoir_rng >> 7;
    reservoir_rng ^= reservoir_rng << 17;
    const std::uint64_t j = reservoir_rng % seen;
    if (j < v.size()) v[static_cast<std::size_t>(j)] = x;
  }

  // One RuntimeSample (the sampler thread).
  void take_sample() {
    RuntimeSample s;
    s.t = clock.now();
    s.rss_bytes = resident_bytes();
    {
      std::lock_guard lock(sched_mu);
      s.ready = sched.ready_tasks();
      s.in_flight = sched.jobs_in_flight();
    }
    std::lock_guard rl(report_mu);
    report.samples.push_back(s);
  }

  // Samples every sample_period until `sampling` is cleared.
  void sampler_main() {
    std::unique_lock lock(sample_mu);
    TimePoint next = options.sample_period;
    for (;;) {
      const auto wall = std::chrono::steady_clock::time_point(
          std::chrono::duration_cast<std::chrono::steady_clock::duration>(clock.origin() + next));
      if (sample_cv.wait_until(lock, wall, [this] { return !sampling; })) return;
      lock.unlock();
      take_sample();
      lock.lock();
      next += options.sample_period;
    }
  }

  // Profiled p99 of what `d` runs (the watchdog's base), allocation-free.
  Duration p99_of(const Dispatch& d) const {
    return profiled_cost(d, encoder_profile, head_profiles, &LatencyStats::p99);
  }

  Duration watchdog_limit(const Dispatch& d) const {
    const double base = static_cast<double>(p99_of(d).count()) * options.watchdog_x;
    return std::max(options.watchdog_min, Duration{static_cast<std::int64_t>(base)});
  }

  // Fails every unit that ran past its watchdog limit (global synchronizer, sched_mu held).
  // The handler's own exchange on `watch` decides who reports a unit: exactly one of the
  // watchdog (here) and the handler (when the call returns) does.
  void check_watchdog(TimePoint now) {
    for (std::size_t l = 0; l < handlers.size(); ++l) {
      Handler& h = *handlers[l];
      if (h.watch.load(std::memory_order_acquire) != kWatchRunning) continue;
      if (now < TimePoint{h.limit_ns.load(std::memory_order_acquire)}) continue;
      // Stored before the exchange that publishes it (read only after a timeout).
      h.timed_out_ns.store(now.count(), std::memory_order_release);
      std::uint8_t expected = kWatchRunning;
      if (!h.watch.compare_exchange_strong(expected, kWatchTimedOut)) continue;
      // Towards the scheduler the unit ends here; its jobs fail with the reason
      // "timeout". The lane's next dispatch waits for the call to return.
      sched.on_complete(static_cast<int>(l), now, UnitStatus::Failed, "timeout");
      std::lock_guard rl(report_mu);
      ++report.timeouts;
      ++report.failures;
      ++report.failure_reasons["timeout"];
    }
  }

  // The earliest watchdog limit of a running unit, or kNever.
  TimePoint next_watchdog() const {
    TimePoint t = kNever;
    for (const auto& h : handlers)
      if (h->watch.load() == kWatchRunning) t = std::min(t, TimePoint{h->limit_ns.load()});
    return t;
  }

  TimePoint advance_now(TimePoint t) {
    last_now = std::max(last_now, t);
    return last_now;
  }

  void post(InEvent e) {
    {
      std::lock_guard lock(inbox_mu);
      inbox.push_back(std::move(e));
      inbox_seq.fetch_add(1, std::memory_order_release);
    }
    inbox_cv.notify_one();
  }

  // Moves the inbox into `round_events` (caller holds sched_mu); returns inbox_seq at the move.
  // Only the global synchronizer clears `poke`: it is its own wake-up.
  std::uint64_t take_inbox(bool global) {
    std::lock_guard il(inbox_mu);
    round_events.swap(inbox);
    if (global) poke.store(false, std::memory_order_relaxed);
    return inbox_seq.load(std::memory_order_acquire);
  }

  // One round of the global synchronizer's logic on `round_events` (caller holds sched_mu):
  // workload events, then completions and frames in arrival order, timers, and a decision
  // for every idle lane. Returns the number of frames released.
  std::uint64_t round(TimePoint now) {
    round_completed.clear();
    TimePoint completed_at = kNever;
    std::uint64_t frames = 0;
    open_round(sched, now, [&] {  // red/sched/round.hpp: events, these inputs, releases
      for (InEvent& e : round_events) {
        if (e.kind == InEvent::Complete) {
          sched.on_complete(e.index, now, e.status, e.reason, e.started);
          round_completed.push_back(e.index);  // within the reserved capacity (one per lane)
          completed_at = std::min(completed_at, e.t);
        } else if (releasing) {
          sched.on_frame(e.index, e.frame, now);
          ++frames;
          std::lock_guard rl(report_mu);
          if (options.external_frames) report.frame_release_us.push_back(to_us(clock.now() - e.t));
          if (e.t >= scenario.warmup) {
            ++report.frames_released;
            report.release_late_us.push_back(to_us(now - e.t));
            if (now - e.t > period_of(sched.sensor_rate(e.index))) ++report.frames_behind;
          }
        }
      }
      round_events.clear();
      if (watchdog_on()) check_watchdog(now);
    });
    // Per-edge: a handler that completed waits here for its next unit (a round trip).
    const Dispatch* none = decide(now, -1, round_completed, completed_at);
    RED_ASSERT(none == nullptr);
    return frames;
  }

  // Whether the global synchronizer, parked until global_wake_at, must wake after a round
  // taken by another thread: the scheduler's next timer moved earlier, or releases are over
  // (it ends the run when the last job ends). Caller holds sched_mu.
  bool must_wake_global() {
    if (!releasing) return true;
    const TimePoint t = sched.next_wakeup();
    if (t >= TimePoint{global_wake_at.load()}) return false;
    global_wake_at.store(t.count());  // one poke is enough until it recomputes
    return true;
  }

  // A frame arrived (the camera thread, or push_frame on the caller's thread): its release.
  // When the scheduler's lock is free, the arriving thread runs the round itself (what waits
  // in the inbox, then this frame) instead of waking the global synchronizer and waiting
  // for the kernel to run it, and wakes it only when its next timer moved earlier. A thread
  // that ordinary threads could preempt while it holds the lock (not real-time while the
  // runtime's threads are) posts the frame to the global synchronizer instead.
  void arrive(int sensor, std::uint64_t frame, TimePoint captured) {
    InEvent e{InEvent::Frame, sensor, frame, captured, UnitStatus::Completed, {}};
    const bool may_run = !realtime_on.load(std::memory_order_acquire) || realtime_thread();
    if (may_run && sched_mu.try_lock()) {
      std::unique_lock lock(sched_mu, std::adopt_lock);
      const TimePoint now = advance_now(clock.now());
      // The end of releases is the global synchronizer's: past it, post as before.
      if (releasing && now < scenario.duration && !stop_requested.load() &&
          !stop_now_requested.load()) {
        {
          // After what waits in the inbox (frames of a sensor are released in order). Not
          // counted in inbox_seq: this round takes it, the global synchronizer need not wake.
          std::lock_guard il(inbox_mu);
          inbox.push_back(std::move(e));
        }
        take_inbox(false);
        const std::uint64_t frames = round(now);
        const bool wake = must_wake_global();
        lock.unlock();
        {
          std::lock_guard rl(report_mu);
          report.direct_releases += frames;
        }
        if (wake) wake_global();
        return;
      }
    }
    post(std::move(e));
  }

  void wake_global() {
    {
      std::lock_guard lock(inbox_mu);
      poke.store(true, std::memory_order_release);
    }
    inbox_cv.notify_one();
  }

  // Hands a dispatch to its lane's handler (Idle -> Assigned). Caller holds sched_mu.
  void assign(const Dispatch* d, TimePoint now, TimePoint prev_end) {
    sched.on_start(d->lane, now);
    Handler& h = *handlers[static_cast<std::size_t>(d->lane)];
    {
      std::lock_guard lock(h.mu);
      h.work = d;
      if (async) h.queue.push_back(d);
      h.prev_end = prev_end;
      h.state.store(HandlerState::Assigned, std::memory_order_release);
      h.assigned.fetch_add(1, std::memory_order_release);
    }
    h.cv.notify_one();
  }

  // One scheduling decision round. Caller holds sched_mu. Returns the dispatch for
  // `own_lane` (taken by the calling handler itself) if any.
  const Dispatch* decide(TimePoint now, int own_lane, std::span<const int> completed_lanes,
                         TimePoint completed_at) {
    const TimePoint t0 = clock.now();
    const auto ds = sched.dispatch(now);
    const TimePoint t1 = clock.now();
    const Dispatch* own = nullptr;
    if (!ds.empty()) {
      std::lock_guard lock(report_mu);
      record(report.decision_us, report.decisions, to_us(t1 - t0));
      const double us = to_us(t1 - t0);
      if (recent_decision_us.size() < kRecentDecisions)
        recent_decision_us.push_back(us);  // within the reserved capacity
      else
        recent_decision_us[recent_total % kRecentDecisions] = us;
      ++recent_total;
    }
    for (const Dispatch* d : ds) {
      const bool follows = std::find(completed_lanes.begin(), completed_lanes.end(), d->lane) !=
                           completed_lanes.end();
      if (d->lane == own_lane) {
        sched.on_start(d->lane, now);
        own = d;
        continue;
      }
      assign(d, now, follows ? completed_at : kNever);
    }
    return own;
  }

  // Lane i's share of the cores: [i*k, (i+1)*k), k = cores / lanes, at least one.
  cpu_set_t lane_cores(std::size_t i) const {
    const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
    const long lanes = std::max(1L, static_cast<long>(scenario.device.lanes));
    const long share = std::max(1L, cores / lanes);
    cpu_set_t set;
    CPU_ZERO(&set);
    const long first = (static_cast<long>(i) * share) % cores;
    for (long c = first; c < std::min(cores, first + share); ++c)
      CPU_SET(static_cast<int>(c), &set);
    return set;
  }

  // The SCHED_FIFO priority of the threads that decide and release (synchronizer, camera):
  // one above the handlers', within what the kernel allows.
  int control_priority() const {
    return std::min(options.rt_priority + 1, sched_get_priority_max(SCHED_FIFO));
  }

  // A thread started from this one after apply_realtime() inherits the synchronizer's
  // priority, above the handlers and their LibTorch workers: the background load of a
  // scenario's `interference` then preempted the units for its whole busy share (in-run
  // encoder 3.2 x its time without load at intensity 0.75, against 1.1 x when it ran at the
  // handlers' priority, as before the synchronizer went one above). The load and the RSS
  // sampler run at the handlers' priority, competing with the units as before.
  void at_handler_priority(std::thread& t) const {
    if (!realtime_on.load(std::memory_order_acquire)) return;
    sched_param sp{};
    sp.sched_priority = options.rt_priority;
    (void)pthread_setschedparam(t.native_handle(), SCHED_FIFO, &sp);
  }

  // What the threads run at, as the kernel has it: "SCHED_FIFO priority P" when every one
  // has the same, "ordinary priority" when none is real-time, else "mixed".
  static std::string scheduling_of(std::vector<std::thread>& threads) {
    int fifo = 0, other = 0, priority = -1;
    bool same = true;
    for (std::thread& t : threads) {
      int policy = 0;
      sched_param sp{};
      if (pthread_getschedparam(t.native_handle(), &policy, &sp) != 0) return "mixed";
      if (policy == SCHED_FIFO) {
        same = same && (priority < 0 || priority == sp.sched_priority);
        priority = sp.sched_priority;
        ++fifo;
      } else {
        ++other;
      }
    }
    if (other == static_cast<int>(threads.size())) return "ordinary priority";
    if (fifo == static_cast<int>(threads.size()) && same)
      return "SCHED_FIFO priority " + std::to_string(priority);
    return "mixed";
  }

  // A lane's thread before its first unit. The real-time class and the lane's cores go on
  // before the backend's first call: worker threads a backend starts then (LibTorch's
  // intra-op team, created by the warm-up) inherit them from this thread. Set after the
  // warm-up instead, only the handler had them and its workers ran as ordinary threads
  // behind every SCHED_FIFO spinner: the first policy of a process ran its units ~25 %
  // slower than the next. apply_realtime() sets them again and reports (memory is locked
  // only after the warm-up).
  void start_lane(int lane) {
    if (options.realtime) {
      sched_param sp{};
      sp.sched_priority = options.rt_priority;
      (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
      const cpu_set_t set = lane_cores(static_cast<std::size_t>(lane));
      (void)pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    }
    backend.init_lane(lane);
    backend.warm_up(lane);
    warmed->count_down();
  }

  void handler_main(int lane) {
    Handler& h = *handlers[static_cast<std::size_t>(lane)];
    start_lane(lane);
    std::uint64_t seen = 0;
    const Dispatch* next = nullptr;
    TimePoint prev_end = kNever;
    bool answer_due = false;  // a completion was reported to the global synchronizer
    for (;;) {
      if (next == nullptr) {
        h.state.store(HandlerState::Idle, std::memory_order_release);
        const Duration spin =
            answer_due ? std::max(options.spin, options.answer_spin) : options.spin;
        answer_due = false;
        spin_then_park(h.mu, h.cv, clock, spin, kNever, [&] {
          return h.assigned.load(std::memory_order_acquire) != seen ||
                 stopping.load(std::memory_order_acquire);
        });
        if (h.assigned.load(std::memory_order_acquire) == seen) return;  // stopping
        // A dispatch that waited behind a timed-out call when the run ended: its jobs are
        // reported unfinished.
        if (stopping.load(std::memory_order_acquire)) return;
        seen = h.assigned.load(std::memory_order_acquire);
        std::lock_guard lock(h.mu);
        next = h.work;
        prev_end = h.prev_end;
      }
      if (watchdog_on()) h.copy = *next;  // reuses its capacity: no allocation in steady state
      const Dispatch& d = watchdog_on() ? h.copy : *next;
      next = nullptr;
      h.state.store(HandlerState::Running, std::memory_order_release);
      const TimePoint start = clock.now();
      if (prev_end != kNever) {
        std::lock_guard lock(report_mu);
        record(report.handoff_us, report.handoffs, to_us(start - prev_end));
      }
      if (watchdog_on()) {
        const TimePoint limit = start + watchdog_limit(d);
        h.limit_ns.store(limit.count(), std::memory_order_release);
        h.watch.store(kWatchRunning);
        // The global synchronizer may be parked past this limit: poke it (see
        // global_wake_at; both sides are sequentially consistent).
        if (limit.count() < global_wake_at.load()) wake_global();
      }
      UnitStatus status = UnitStatus::Completed;
      std::string reason;
      try {
        backend.run(lane, d);
      } catch (const OutOfMemoryError& e) {
        status = UnitStatus::OutOfMemory;
        reason = std::string("out of memory: ") + e.what();
      } catch (const std::exception& e) {
        status = UnitStatus::Failed;
        reason = e.what();
      } catch (...) {
        status = UnitStatus::Failed;
        reason = "unknown exception";
      }
      const TimePoint end = clock.now();
      if (watchdog_on() && h.watch.exchange(kWatchIdle) == kWatchTimedOut) {
        // The watchdog already failed this unit's jobs and freed the lane towards the
        // scheduler: the late result is ignored. The lane is back in service; a dispatch
        // assigned meanwhile is picked up below.
        std::lock_guard rl(report_mu);
        ++report.late_returns;
        report.out_of_service += end - TimePoint{h.timed_out_ns.load(std::memory_order_acquire)};
        prev_end = kNever;
        continue;
      }
      h.state.store(status == UnitStatus::Completed   ? HandlerState::Completed
                    : status == UnitStatus::Failed    ? HandlerState::Failed
                    : status == UnitStatus::Cancelled ? HandlerState::Cancelled
                                                      : HandlerState::OutOfMemory,
                    std::memory_order_release);
      if (sync == SyncMode::OnDemand && status == UnitStatus::Completed && !stopping.load()) {
        // On-demand: the local synchronizer takes the decision at this unit boundary
        // and goes on without a round trip to the global synchronizer.
        const bool waited = lock_spinning(sched_mu, clock, options.spin);
        std::unique_lock lock(sched_mu, std::adopt_lock);
        const TimePoint locked = waited ? clock.now() : end;
        const TimePoint now = advance_now(end);
        // A round like the global synchronizer's (red/sched/round.hpp): workload events due
        // by now first, so that this decision never runs on a replaced version.
        open_round(sched, now, [&] { sched.on_complete(lane, now, status); });
        next = decide(now, lane, std::span<const int>(&lane, 1), end);
        prev_end = next != nullptr ? end : kNever;
        // It does not need to answer: wake it only when its timers moved earlier.
        const bool wake = must_wake_global();
        lock.unlock();
        {
          std::lock_guard rl(report_mu);
          ++report.local_decisions;
          if (waited) record(report.lock_wait_us, report.lock_waits, to_us(locked - end));
        }
        if (wake) wake_global();
        continue;
      }
      if (status != UnitStatus::Completed) {
        std::lock_guard rl(report_mu);
        ++report.failures;
        ++report.failure_reasons[reason];  // also when the unit's jobs had ended already
      }
      // Per-edge (and every non-Completed transition): report to the global synchronizer
      // and wait for it.
      post({InEvent::Complete, lane, 0, end, status, std::move(reason)});
      prev_end = kNever;
      answer_due = true;
    }
  }

  // A unit an asynchronous lane holds: the handler's copy of its dispatch (the scheduler
  // may reuse its slot once the watchdog has failed it), when it was enqueued, and a failure
  // to enqueue it (then it is not waited for).
  struct Held {
    Dispatch d;
    TimePoint enqueued{0};
    TimePoint began = kNever;  // when it became the oldest (the one before it ended)
    bool queued = false;       // enqueued while the unit before it was still held
    bool enqueue_failed = false;
    UnitStatus status = UnitStatus::Completed;
    std::string reason;
  };

  // Enqueues one dispatch on an asynchronous lane (docs/DESIGN.md, "Queued lanes"): the backend
  // returns without waiting for the device.
  void enqueue_unit(int lane, std::deque<Held>& held, const Dispatch& d, TimePoint prev_end,
                    Duration& enqueue_cost) {
    Held& u = held.emplace_back();
    u.d = d;
    u.queued = held.size() > 1;
    u.enqueued = clock.now();
    if (!u.queued) u.began = u.enqueued;
    if (!u.queued && prev_end != kNever) {
      std::lock_guard lock(report_mu);
      record(report.handoff_us, report.handoffs, to_us(u.enqueued - prev_end));
    }
    try {
      backend.enqueue(lane, u.d);
    } catch (const OutOfMemoryError& e) {
      u.enqueue_failed = true;
      u.status = UnitStatus::OutOfMemory;
      u.reason = e.what();
    } catch (const std::exception& e) {
      u.enqueue_failed = true;
      u.status = UnitStatus::Failed;
      u.reason = e.what();
    } catch (...) {
      u.enqueue_failed = true;
      u.status = UnitStatus::Failed;
      u.reason = "unknown exception";
    }
    // What an enqueue costs the host (launching a unit's kernels), smoothed: the next
    // unit is decided at least twice that before the lane runs dry.
    enqueue_cost = (enqueue_cost * 7 + (clock.now() - u.enqueued)) / 8;
  }

  // When the units `held` are expected to end: the oldest's start plus their profiled p50.
  TimePoint expected_end(const std::deque<Held>& held) const {
    TimePoint t = held.front().began;
    for (const Held& u : held)
      t += profiled_cost(u.d, encoder_profile, head_profiles, &LatencyStats::p50);
    return t;
  }

  // On-demand, at a unit boundary of `lane` (caller holds sched_mu): the units the lane's
  // queue has room for, decided now and handed to the caller to enqueue after it lets go
  // of the lock (what is decided counts as dispatched).
  void decide_ahead(int lane, TimePoint now, std::vector<const Dispatch*>& out) {
    while (sched.has_room_ahead(lane)) {
      const TimePoint t0 = clock.now();
      const auto ds = sched.dispatch_ahead(now, lane);
      if (ds.empty()) return;
      const TimePoint t1 = clock.now();
      sched.on_start(lane, now);  // moved to the device's start when it runs
      out.push_back(ds.front());
      std::lock_guard lock(report_mu);
      record(report.decision_us, report.decisions, to_us(t1 - t0));
      ++report.enqueued_ahead;
    }
  }

  // The handler of an asynchronous lane (Backend::asynchronous()): the same state machine
  // as handler_main, over the units the lane holds. It enqueues what it is given and, under
  // on-demand synchronization, decides at each unit boundary (an enqueue, a completion) the
  // units its queue has room for, so the next unit is on the device before the one before
  // it ends; then it waits for the oldest. Every completion reaches the scheduler in the
  // lane's order: under on-demand the handler reports each itself (a failure too, then
  // wakes the global synchronizer, which decides the lane's next run); under per-edge it
  // posts each to the global synchronizer and holds one unit at a time.
  void async_handler_main(int lane) {
    Handler& h = *handlers[static_cast<std::size_t>(lane)];
    start_lane(lane);
    std::uint64_t seen = 0;
    const auto depth = static_cast<std::size_t>(sched.config().queue_depth);  // constant
    std::deque<Held> held;                                                    // oldest first
    std::vector<const Dispatch*> taken;  // assignments and own decisions to enqueue
    TimePoint prev_end = kNever;         // end of the unit before, while the lane is busy
    Duration enqueue_cost{0};            // what an enqueue costs the host, smoothed
    bool answer_due = false;
    for (;;) {
      if (held.empty()) {
        h.state.store(HandlerState::Idle, std::memory_order_release);
        const Duration spin =
            answer_due ? std::max(options.spin, options.answer_spin) : options.spin;
        answer_due = false;
        spin_then_park(h.mu, h.cv, clock, spin, kNever, [&] {
          return h.assigned.load(std::memory_order_acquire) != seen ||
                 stopping.load(std::memory_order_acquire);
        });
        if (h.assigned.load(std::memory_order_acquire) == seen) return;  // stopping
        if (stopping.load(std::memory_order_acquire)) return;
      }
      if (!stopping.load(std::memory_order_acquire)) {
        // What the global synchronizer assigned (it assigns only to an idle lane; once the
        // run stops, what it assigned is reported unfinished, as on a synchronous lane).
        std::lock_guard lock(h.mu);
        seen = h.assigned.load(std::memory_order_acquire);
        taken.insert(taken.end(), h.queue.begin(), h.queue.end());
        h.queue.clear();
        if (held.empty() && prev_end == kNever) prev_end = h.prev_end;
      }
      if (!taken.empty()) h.state.store(HandlerState::Assigned, std::memory_order_release);
      for (const Dispatch* d : taken) enqueue_unit(lane, held, *d, prev_end, enqueue_cost);
      taken.clear();
      if (held.empty()) continue;
      if (sync == SyncMode::OnDemand && !stopping.load() && held.size() < depth) {
        // The lane's queue is filled when what it holds is about to end (the lead), not at
        // once: a release meanwhile is seen before the next unit is chosen.
        const Duration lead = std::max(sched.config().ahead_lead, enqueue_cost * 2);
        const TimePoint at = expected_end(held) - lead;
        // Parked until a spin before it, then spinning (a wake-up can take longer).
        auto stop = [&] { return stopping.load(std::memory_order_acquire); };
        if (at - options.spin > clock.now())
          spin_then_park(h.mu, h.cv, clock, Duration{0}, at - options.spin, stop);
        while (clock.now() < at && !stop()) std::this_thread::yield();
        lock_spinning(sched_mu, clock, options.spin);
        std::unique_lock lock(sched_mu, std::adopt_lock);
        decide_ahead(lane, advance_now(clock.now()), taken);
        const bool wake = must_wake_global();
        lock.unlock();
        if (wake) wake_global();
        for (const Dispatch* d : taken) enqueue_unit(lane, held, *d, prev_end, enqueue_cost);
        taken.clear();
      }
      // Wait for the oldest, watched from now (the units before it have ended).
      Held& u = held.front();
      h.state.store(HandlerState::Running, std::memory_order_release);
      if (watchdog_on()) {
        const TimePoint limit = clock.now() + watchdog_limit(u.d);
        h.limit_ns.store(limit.count(), std::memory_order_release);
        h.watch.store(kWatchRunning);
        if (limit.count() < global_wake_at.load()) wake_global();
      }
      UnitDone done;
      if (u.enqueue_failed) {
        done.status = u.status;
        done.reason = std::move(u.reason);
      } else {
        try {
          done = backend.wait(lane);
        } catch (const std::exception& e) {  // the contract says report, not throw: still
          done.status = UnitStatus::Failed;
          done.reason = e.what();
        }
      }
      const TimePoint end = std::min(clock.now(), on_clock(done.ended));
      const TimePoint started = on_clock(done.started);
      if (u.queued && started != kNever && prev_end != kNever) {
        std::lock_guard rl(report_mu);
        record(report.queued_gap_us, report.queued_gaps,
               to_us(std::max(Duration{0}, started - prev_end)));
      }
      const bool timed_out = watchdog_on() && h.watch.exchange(kWatchIdle) == kWatchTimedOut;
      held.pop_front();
      if (!held.empty()) held.front().began = end;  // in the lane's order, it starts now
      if (timed_out) {
        // The watchdog failed this unit's jobs and took it off the lane towards the
        // scheduler; its late result is ignored.
        std::lock_guard rl(report_mu);
        ++report.late_returns;
        report.out_of_service += end - TimePoint{h.timed_out_ns.load(std::memory_order_acquire)};
        prev_end = kNever;
        continue;
      }
      const UnitStatus status = done.status;
      std::string reason = status == UnitStatus::OutOfMemory ? "out of memory: " + done.reason
                                                             : std::move(done.reason);
      h.state.store(status == UnitStatus::Completed ? HandlerState::Completed
                    : status == UnitStatus::Failed  ? HandlerState::Failed
                                                    : HandlerState::OutOfMemory,
                    std::memory_order_release);
      if (status != UnitStatus::Completed) {
        std::lock_guard rl(report_mu);
        ++report.failures;
        ++report.failure_reasons[reason];
      }
      prev_end = end;
      if (sync == SyncMode::OnDemand && !stopping.load()) {
        // The local synchronizer reports the completion and takes the decision at this
        // unit boundary; a failure ends the run, and the global synchronizer is woken to
        // decide what the lane runs next.
        const bool waited = lock_spinning(sched_mu, clock, options.spin);
        std::unique_lock lock(sched_mu, std::adopt_lock);
        const TimePoint locked = waited ? clock.now() : end;
        const TimePoint now = advance_now(end);
        // A round like the global synchronizer's (red/sched/round.hpp): workload events due
        // by now first, so that this decision never runs on a replaced version.
        open_round(sched, now, [&] { sched.on_complete(lane, now, status, reason, started); });
        if (status == UnitStatus::Completed) {
          // Every idle lane gets work (this one too, when it holds nothing more).
          // (The unit behind it, if any, is decided later, by the lead.)
          if (const Dispatch* own = decide(now, lane, std::span<const int>(&lane, 1), end))
            taken.push_back(own);
        }
        const bool wake = status != UnitStatus::Completed || must_wake_global();
        lock.unlock();
        {
          std::lock_guard rl(report_mu);
          ++report.local_decisions;
          if (waited) record(report.lock_wait_us, report.lock_waits, to_us(locked - end));
        }
        if (wake) wake_global();
        for (const Dispatch* d : taken) enqueue_unit(lane, held, *d, prev_end, enqueue_cost);
        taken.clear();
        if (held.empty()) prev_end = kNever;
        continue;
      }
      // Per-edge (and every completion once the run is stopping): to the global
      // synchronizer, in the lane's order.
      post({InEvent::Complete, lane, 0, end, status, std::move(reason), started});
      prev_end = kNever;
      answer_due = held.empty();
    }
  }

  // Releases each sensor's frames at their nominal capture times. Releasing costs no model
  // work here (Backend::on_frame only names the frame; its tensor is made off this thread),
  // so the camera keeps the sensors' rates whatever the lanes are doing; a frame released
  // late is still counted against its nominal time (RuntimeReport::release_late_us).
  void camera_main() {
    const std::size_t n = scenario.sensors.size();
    std::vector<TimePoint>& next = camera_next;
    std::vector<std::uint64_t> frame(n, 0);
    for (std::size_t s = 0; s < n; ++s) next[s] = scenario.sensors[s].phase;
    while (cameras_on.load(std::memory_order_acquire)) {
      std::size_t s = 0;
      for (std::size_t i = 1; i < n; ++i)
        if (next[i] < next[s]) s = i;
      if (n == 0) return;
      std::this_thread::sleep_until(std::chrono::steady_clock::time_point(
          std::chrono::duration_cast<std::chrono::steady_clock::duration>(clock.origin() +
                                                                          next[s])));
      if (!cameras_on.load(std::memory_order_acquire)) return;
      if (next[s] >= scenario.warmup && next[s] < scenario.duration) ++camera_offered;
      backend.on_frame(static_cast<int>(s), frame[s]);
      arrive(static_cast<int>(s), frame[s], next[s]);
      ++frame[s];
      double rate = 0;
      {
        std::lock_guard lock(sched_mu);
        rate = sched.sensor_rate(static_cast<int>(s));
      }
      next[s] += period_of(rate);
    }
  }

  // Frames offered in the measured window: those the camera reached, and the nominal
  // capture times it had not reached when releases ended (it fell behind, or slept through
  // the end); pushed frames: those accepted. Caller holds sched_mu, the camera is joined.
  void count_offered() {
    std::lock_guard rl(report_mu);
    if (options.external_frames) {
      report.frames_offered = pushed_offered.load();
      return;
    }
    std::uint64_t offered = camera_offered;
    const TimePoint until = std::min(releases_end, scenario.duration);
    for (std::size_t s = 0; s < camera_next.size(); ++s) {
      const Duration period = period_of(sched.sensor_rate(static_cast<int>(s)));
      for (TimePoint t = camera_next[s]; t < until && period > Duration{0}; t += period)
        if (t >= scenario.warmup) ++offered;
    }
    report.frames_offered = offered;
  }

  void interference_main(double intensity, std::atomic<bool>& on) {
    // Background CPU load: busy for `intensity` of every 10 ms, asleep for the rest.
    const Duration slice = std::chrono::milliseconds{10};
    volatile double sink = 0;
    while (on.load(std::memory_order_acquire)) {
      const TimePoint busy_until =
          clock.now() +
          Duration{static_cast<std::int64_t>(intensity * static_cast<double>(slice.count()))};
      while (clock.now() < busy_until) sink = sink + std::sqrt(sink + 1.0);
      std::this_thread::sleep_for(slice - Duration{static_cast<std::int64_t>(
                                              intensity * static_cast<double>(slice.count()))});
    }
  }

  void apply_realtime() {
    if (!options.realtime) {
      report.realtime.push_back("real-time knobs: off (--no-realtime)");
      return;
    }
    // Lock only the pages the process touches (MCL_ONFAULT): the ones resident after the
    // warm-up now, others as they are first touched. Locking every mapped page instead
    // (MCL_CURRENT | MCL_FUTURE alone) would make every page of every mapped library
    // resident, hundreds of MB with LibTorch. A kernel without MCL_ONFAULT (before 4.4)
    // answers EINVAL: then every page is locked, as the report says.
    if (mlockall(MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT) == 0) {
      report.realtime.push_back("mlockall: applied (pages as they are touched, MCL_ONFAULT)");
    } else if (errno == EINVAL && mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      report.realtime.push_back(
          "mlockall: applied to every mapped page (this kernel has no MCL_ONFAULT)");
    } else {
      report.realtime.push_back(std::string("mlockall: not applied (") + std::strerror(errno) +
                                ")");
    }
    // The synchronizer one above the handlers: at the same priority it could not preempt a
    // unit's compute threads (SCHED_FIFO runs equal priorities to completion), so a deadline
    // that fell while both cores computed was acted on only when a worker yielded, up to
    // milliseconds late, and the next frame found the job still in flight.
    sched_param top{};
    top.sched_priority = control_priority();
    int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &top);
    int applied = err == 0 ? 1 : 0;
    sched_param sp{};
    sp.sched_priority = options.rt_priority;
    for (auto& h : handlers) {
      if (pthread_setschedparam(h->thread.native_handle(), SCHED_FIFO, &sp) == 0)
        ++applied;
      else
        err = errno;
    }
    realtime_on.store(applied == static_cast<int>(handlers.size()) + 1, std::memory_order_release);
    report.realtime.push_back(applied == static_cast<int>(handlers.size()) + 1
                                  ? "SCHED_FIFO priority " + std::to_string(options.rt_priority) +
                                        " (synchronizer " + std::to_string(control_priority()) +
                                        "): applied"
                                  : "SCHED_FIFO: not applied (" +
                                        std::string(std::strerror(err == 0 ? EPERM : err)) + ")");
    // Each lane gets its own share of the cores (lane i: cores [i*k, (i+1)*k), k = cores /
    // lanes, at least one), so a backend's worker threads, which inherit the handler's
    // mask, stay on that lane's cores instead of piling onto one.
    const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
    const long lanes = static_cast<long>(handlers.size());
    const long share = std::max(1L, cores / std::max(1L, lanes));
    int pinned = 0;
    for (std::size_t i = 0; i < handlers.size(); ++i) {
      const cpu_set_t set = lane_cores(i);
      if (pthread_setaffinity_np(handlers[i]->thread.native_handle(), sizeof(set), &set) == 0)
        ++pinned;
    }
    report.realtime.push_back("CPU affinity: " + std::to_string(pinned) + " of " +
                              std::to_string(handlers.size()) + " handler(s) pinned, " +
                              std::to_string(share) + " core(s) each of " + std::to_string(cores));
  }

  RuntimeReport run() {
    report.resident_bytes_before = resident_bytes();
    for (int l = 0; l < scenario.device.lanes; ++l) handlers.push_back(std::make_unique<Handler>());
    warmed.emplace(scenario.device.lanes);
    for (int l = 0; l < scenario.device.lanes; ++l)
      handlers[static_cast<std::size_t>(l)]->thread =
          std::thread([this, l] { async ? async_handler_main(l) : handler_main(l); });
    // Memory is locked after the warm-up pass, when the pages the run uses are resident.
    warmed->wait();
    report.resident_bytes_warm = resident_bytes();
    apply_realtime();
    std::atomic<bool> load_on{true};
    std::vector<std::thread> load;
    if (options.interference && scenario.interference && scenario.interference->intensity > 0) {
      const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
      for (long i = 0; i < cores; ++i) {
        load.emplace_back(
            [this, &load_on] { interference_main(scenario.interference->intensity, load_on); });
        at_handler_priority(load.back());
      }
      report.realtime.push_back("background load: " + std::to_string(load.size()) + " thread(s), " +
                                scheduling_of(load));
    }
    clock.reset();
    std::thread camera;
    camera_next.assign(scenario.sensors.size(), kNever);
    if (options.external_frames) {
      accepting.store(true, std::memory_order_release);
    } else {
      camera = std::thread([this] { camera_main(); });
      if (realtime_on.load(std::memory_order_acquire)) {
        // The camera releases frames itself when the scheduler's lock is free (arrive()):
        // at the synchronizer's priority, so neither ordinary threads nor a unit's compute
        // threads hold a frame back or preempt it holding the lock.
        sched_param sp{};
        sp.sched_priority = control_priority();
        const int err = pthread_setschedparam(camera.native_handle(), SCHED_FIFO, &sp);
        report.realtime.push_back(err == 0 ? "camera thread: SCHED_FIFO"
                                           : "camera thread: SCHED_FIFO not applied (" +
                                                 std::string(std::strerror(err)) + ")");
      }
    }
    std::thread sampler;
    if (options.sample_period > Duration{0}) {
      sampler = std::thread([this] { sampler_main(); });
      at_handler_priority(sampler);
    }

    std::uint64_t seen = 0;
    TimePoint hard_stop = scenario.duration + options.drain_limit;
    for (;;) {
      TimePoint wake;
      {
        lock_spinning(sched_mu, clock, options.spin);  // a per-edge answer may wait on it
        std::lock_guard lock(sched_mu, std::adopt_lock);
        TimePoint now = advance_now(clock.now());
        const bool stop_now = stop_now_requested.load();
        if (releasing && (now >= scenario.duration || stop_requested.load() || stop_now)) {
          releasing = false;
          releases_end = std::min(now, scenario.duration);
          cameras_on.store(false, std::memory_order_release);
          accepting.store(false, std::memory_order_release);
          sched.apply_events(std::min(now, scenario.duration - Duration{1}));
          sched.stop_releases();
          hard_stop = std::min(hard_stop, now + options.drain_limit);
        }
        if (stop_now) hard_stop = std::min(hard_stop, now);
        // What is in the inbox now is handled in this round; anything posted after it bumps
        // inbox_seq past `seen` and ends the wait below.
        seen = take_inbox(true);
        if (!releasing && sched.jobs_in_flight() == 0 && round_events.empty()) break;
        if (now >= hard_stop) break;
        round(now);
        // Releases are over and nothing is in flight: done. (Checked again here, after the
        // round: frames that arrived with the end of the scenario release nothing, and no
        // one would wake the loop before the drain limit.)
        if (!releasing && sched.jobs_in_flight() == 0) break;
        wake = sched.next_wakeup();
        if (releasing) wake = std::min(wake, scenario.duration);
        wake = std::min(wake, hard_stop);
        global_wake_at.store(kNever.count());  // handlers starting a unit now poke
        if (watchdog_on()) wake = std::min(wake, next_watchdog());
        global_wake_at.store(wake.count());
        ++report.wakeups;
      }
      spin_then_park(inbox_mu, inbox_cv, clock, options.spin, wake, [&] {
        return inbox_seq.load(std::memory_order_acquire) != seen ||
               poke.load(std::memory_order_acquire);
      });
    }
    cameras_on.store(false, std::memory_order_release);
    accepting.store(false, std::memory_order_release);
    // Before waiting for the camera (asleep until its next frame): from here a handler
    // whose unit completes reports it instead of deciding its next unit itself.
    stopping.store(true, std::memory_order_release);
    if (camera.joinable()) camera.join();
    for (auto& h : handlers) {
      { std::lock_guard lock(h->mu); }
      h->cv.notify_all();
    }
    for (auto& h : handlers) h->thread.join();
    load_on.store(false, std::memory_order_release);
    for (std::thread& t : load) t.join();
    if (sampler.joinable()) {
      {
        std::lock_guard lock(sample_mu);
        sampling = false;
      }
      sample_cv.notify_all();
      sampler.join();
      take_sample();  // the end of the run
    }
    {
      std::lock_guard lock(sched_mu);
      // Units that returned after the loop ended (or while the loop broke off at the hard
      // stop, still in `round_events`) still completed: report them, so that only a unit cut by
      // the end of the run is reported unfinished.
      {
        std::lock_guard il(inbox_mu);
        for (std::vector<InEvent>* events : {&round_events, &inbox})
          for (InEvent& e : *events)
            if (e.kind == InEvent::Complete && sched.running(e.index) != nullptr)
              sched.on_complete(e.index, advance_now(e.t), e.status, e.reason, e.started);
        round_events.clear();
        inbox.clear();
      }
      const TimePoint end = advance_now(clock.now());
      sched.finish(end);
      report.end = end;
      report.stats = sched.stats();
      count_offered();
    }
    if (options.realtime) munlockall();
    // decision_us_since() may read the report from another thread until now.
    std::lock_guard lock(report_mu);
    report.resident_bytes_after = resident_bytes();
    return std::move(report);
  }
};

Runtime::Runtime(const Scenario& scenario, const Profile& profile, std::unique_ptr<Policy> policy,
                 Backend& backend, RuntimeOptions options)
    : impl_(std::make_unique<Impl>(scenario, profile, std::move(policy), backend, options)) {}

Runtime::~Runtime() = default;

void Runtime::add_observer(Observer* o) {
  impl_->sched.add_observer(o);
}

RuntimeReport Runtime::run() {
  return impl_->run();
}

bool Runtime::push_frame(int sensor, std::uint64_t frame, const FrameView* pixels) {
  Impl& m = *impl_;
  if (!m.accepting.load(std::memory_order_acquire)) return false;
  if (sensor < 0 || static_cast<std::size_t>(sensor) >= m.scenario.sensors.size()) return false;
  if (pixels != nullptr)
    m.backend.on_external_frame(sensor, frame, *pixels);
  else
    m.backend.on_frame(sensor, frame);
  const TimePoint now = m.clock.now();
  if (now >= m.scenario.warmup) m.pushed_offered.fetch_add(1, std::memory_order_relaxed);
  m.arrive(sensor, frame, now);
  return true;
}

bool Runtime::accepting_frames() const noexcept {
  return impl_->accepting.load(std::memory_order_acquire);
}

void Runtime::stop() {
  impl_->stop_requested.store(true, std::memory_order_release);
  impl_->wake_global();
}

void Runtime::stop_now() {
  impl_->stop_now_requested.store(true, std::memory_order_release);
  impl_->wake_global();
}

std::vector<double> Runtime::decision_us_since(std::uint64_t& cursor) const {
  // From the ring of the newest decisions: report.decision_us is a uniform sample once it
  // is full, so it has no "since". Decisions older than the ring are gone.
  std::lock_guard lock(impl_->report_mu);
  const Impl& m = *impl_;
  const std::uint64_t total = m.recent_total;
  const std::uint64_t kept = m.recent_decision_us.size();
  std::uint64_t first = std::max<std::uint64_t>(cursor, total - kept);
  cursor = total;
  std::vector<double> out;
  for (; first < total; ++first)
    out.push_back(m.recent_decision_us[static_cast<std::size_t>(first % Impl::kRecentDecisions)]);
  return out;
}

}  // namespace red
