// The real-time runtime's facade and its global synchronizer: the run's order (run(): the
// lanes' warm-up, the real-time knobs, the threads, the loop, the end of the run), one round
// of the scheduler (round(), decide(), assign()) and the inbox that brings it frames and
// completions. Its other parts are one file each behind the one state in runtime_impl.hpp:
// handlers.cpp (a lane's handler thread, its state machine, the watchdog), async_lanes.cpp
// (the handler of an asynchronous lane, Backend::enqueue and wait), intake.cpp (frames: the
// camera, push_frame, a frame's release by the thread that brought it), realtime.cpp
// (SCHED_FIFO, CPU affinity, mlockall, background load) and samples.cpp (timing samples,
// resident memory, decision_us_since).

#include "red/runtime/runtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "red/core/assert.hpp"
#include "red/core/newest.hpp"
#include "red/sched/round.hpp"
#include "runtime_impl.hpp"

namespace red {

using runtime_detail::lock_spinning;
using runtime_detail::spin_then_park;

Runtime::Impl::Impl(const Scenario& s, const Profile& p, std::unique_ptr<Policy> policy, Backend& b,
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

void Runtime::Impl::post(InEvent e) {
  {
    std::lock_guard lock(inbox_mu);
    inbox.push_back(std::move(e));
    inbox_seq.fetch_add(1, std::memory_order_release);
  }
  inbox_cv.notify_one();
}

// Moves the inbox into `round_events` (caller holds sched_mu); returns inbox_seq at the move.
// Only the global synchronizer clears `poke`: it is its own wake-up.
std::uint64_t Runtime::Impl::take_inbox(bool global) {
  std::lock_guard il(inbox_mu);
  round_events.swap(inbox);
  if (global) poke.store(false, std::memory_order_relaxed);
  return inbox_seq.load(std::memory_order_acquire);
}

// One round of the global synchronizer's logic on `round_events` (caller holds sched_mu):
// workload events, then completions and frames in arrival order, timers, and a decision
// for every idle lane. Returns the number of frames released.
std::uint64_t Runtime::Impl::round(TimePoint now) {
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
bool Runtime::Impl::must_wake_global() {
  if (!releasing) return true;
  const TimePoint t = sched.next_wakeup();
  if (t >= TimePoint{global_wake_at.load()}) return false;
  global_wake_at.store(t.count());  // one poke is enough until it recomputes
  return true;
}

void Runtime::Impl::wake_global() {
  {
    std::lock_guard lock(inbox_mu);
    poke.store(true, std::memory_order_release);
  }
  inbox_cv.notify_one();
}

// Hands a dispatch to its lane's handler (Idle -> Assigned). Caller holds sched_mu.
void Runtime::Impl::assign(const Dispatch* d, TimePoint now, TimePoint prev_end) {
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
const Dispatch* Runtime::Impl::decide(TimePoint now, int own_lane,
                                      std::span<const int> completed_lanes,
                                      TimePoint completed_at) {
  const TimePoint t0 = clock.now();
  const auto ds = sched.dispatch(now);
  const TimePoint t1 = clock.now();
  const Dispatch* own = nullptr;
  if (!ds.empty()) {
    std::lock_guard lock(report_mu);
    record(report.decision_us, report.decisions, to_us(t1 - t0));
    keep_newest(recent_decision_us, recent_total++, kRecentDecisions, to_us(t1 - t0));
  }
  for (const Dispatch* d : ds) {
    const bool follows =
        std::find(completed_lanes.begin(), completed_lanes.end(), d->lane) != completed_lanes.end();
    if (d->lane == own_lane) {
      sched.on_start(d->lane, now);
      own = d;
      continue;
    }
    assign(d, now, follows ? completed_at : kNever);
  }
  return own;
}

// Frames in: the synthetic cameras' thread (at the synchronizer's priority where real-time
// scheduling applies), or, with external frames, push_frame() accepting them.
std::thread Runtime::Impl::start_camera() {
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
  return camera;
}

// After the loop and every thread: what the scheduler still has to hear, its finish, and the
// report's figures from it.
void Runtime::Impl::finish_run() {
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
  if (const OnlineCosts* oc = sched.online_costs()) {
    report.online_costs = oc->options().follow;
    report.costs = oc->figures();
    report.plan_changes = oc->changes();
  }
  count_offered();
}

RuntimeReport Runtime::Impl::run() {
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
  std::thread camera = start_camera();
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
  finish_run();
  release_realtime();
  // decision_us_since() may read the report from another thread until now.
  std::lock_guard lock(report_mu);
  report.resident_bytes_after = resident_bytes();
  return std::move(report);
}

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

void Runtime::stop() {
  impl_->stop_requested.store(true, std::memory_order_release);
  impl_->wake_global();
}

void Runtime::stop_now() {
  impl_->stop_now_requested.store(true, std::memory_order_release);
  impl_->wake_global();
}

}  // namespace red
