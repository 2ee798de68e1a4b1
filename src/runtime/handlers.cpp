// A lane's handler thread (Runtime::Impl::handler_main): its state machine, the local
// synchronizer's decision at a unit boundary (on-demand), and the watchdog that fails a unit
// that runs past its limit. The handler of an asynchronous lane is in async_lanes.cpp.

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <span>
#include <string>

#include "red/runtime/runtime.hpp"
#include "red/sched/round.hpp"
#include "red/sim/cost_sampler.hpp"
#include "runtime_impl.hpp"

namespace red {

using runtime_detail::lock_spinning;
using runtime_detail::spin_then_park;

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

// Profiled p99 of what `d` runs (the watchdog's base), allocation-free.
Duration Runtime::Impl::p99_of(const Dispatch& d) const {
  return profiled_cost(d, encoder_profile, head_profiles, &LatencyStats::p99);
}

Duration Runtime::Impl::watchdog_limit(const Dispatch& d) const {
  const double base = static_cast<double>(p99_of(d).count()) * options.watchdog_x;
  return std::max(options.watchdog_min, Duration{static_cast<std::int64_t>(base)});
}

// Fails every unit that ran past its watchdog limit (global synchronizer, sched_mu held).
// The handler's own exchange on `watch` decides who reports a unit: exactly one of the
// watchdog (here) and the handler (when the call returns) does.
void Runtime::Impl::check_watchdog(TimePoint now) {
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

std::string Runtime::Impl::device_lost(int lane, std::string reason) {
  if (reason.rfind("device lost", 0) != 0) reason = "device lost: " + reason;
  {
    std::lock_guard rl(report_mu);
    if (report.device_lost.empty()) {
      report.device_lost = reason;
      report.device_lost_lane = lane;
    }
  }
  // Every later unit would fail the same way (and blame its own lane): the run ends now,
  // its jobs in flight reported unfinished.
  stop_now_requested.store(true, std::memory_order_release);
  wake_global();
  return reason;
}

// The earliest watchdog limit of a running unit, or kNever.
TimePoint Runtime::Impl::next_watchdog() const {
  TimePoint t = kNever;
  for (const auto& h : handlers)
    if (h->watch.load() == kWatchRunning) t = std::min(t, TimePoint{h->limit_ns.load()});
  return t;
}

// A lane's thread before its first unit. The real-time class and the lane's cores go on
// before the backend's first call: worker threads a backend starts then (LibTorch's
// intra-op team, created by the warm-up) inherit them from this thread. Set after the
// warm-up instead, only the handler had them and its workers ran as ordinary threads
// behind every SCHED_FIFO spinner: the first policy of a process ran its units ~25 %
// slower than the next. apply_realtime() sets them again and reports (memory is locked
// only after the warm-up).
void Runtime::Impl::start_lane(int lane) {
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

bool Runtime::Impl::await_assignment(Handler& h, std::uint64_t seen, bool& answer_due) {
  h.state.store(HandlerState::Idle, std::memory_order_release);
  const Duration spin = answer_due ? std::max(options.spin, options.answer_spin) : options.spin;
  answer_due = false;
  spin_then_park(h.mu, h.cv, clock, spin, kNever, [&] {
    return h.assigned.load(std::memory_order_acquire) != seen ||
           stopping.load(std::memory_order_acquire);
  });
  return h.assigned.load(std::memory_order_acquire) != seen &&
         !stopping.load(std::memory_order_acquire);
}

void Runtime::Impl::handler_main(int lane) {
  Handler& h = *handlers[static_cast<std::size_t>(lane)];
  start_lane(lane);
  std::uint64_t seen = 0;
  const Dispatch* next = nullptr;
  TimePoint prev_end = kNever;
  bool answer_due = false;  // a completion was reported to the global synchronizer
  for (;;) {
    if (next == nullptr) {
      // A dispatch that waited behind a timed-out call when the run ended: its jobs are
      // reported unfinished.
      if (!await_assignment(h, seen, answer_due)) return;
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
    } catch (const DeviceLostError& e) {
      status = UnitStatus::Failed;
      reason = device_lost(lane, e.what());
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

}  // namespace red
