// The handler of an asynchronous lane (Backend::asynchronous(), docs/DESIGN.md, "Queued
// lanes"): units enqueued on the backend's lane and waited for, the lane's queue filled
// ahead under on-demand synchronization.

#include <algorithm>
#include <atomic>
#include <deque>
#include <exception>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "red/runtime/runtime.hpp"
#include "red/sched/round.hpp"
#include "red/sim/cost_sampler.hpp"
#include "runtime_impl.hpp"

namespace red {

using runtime_detail::lock_spinning;
using runtime_detail::spin_then_park;

// Enqueues one dispatch on an asynchronous lane (docs/DESIGN.md, "Queued lanes"): the backend
// returns without waiting for the device.
void Runtime::Impl::enqueue_unit(int lane, std::deque<Held>& held, const Dispatch& d,
                                 TimePoint prev_end, Duration& enqueue_cost) {
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
  } catch (const DeviceLostError& e) {
    u.enqueue_failed = true;
    u.device_lost = true;
    u.status = UnitStatus::Failed;
    u.reason = e.what();
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

// When the lane's handler decides the units its queue has room for (the scheduler's
// queue-ahead rule): a lead before the units `held` are expected to end, the oldest's start plus
// their profiled p50, the lead at least twice what an enqueue costs the host.
TimePoint Runtime::Impl::queue_ahead_at(const std::deque<Held>& held, Duration enqueue_cost) const {
  Duration p50{0};
  for (const Held& u : held)
    p50 += profiled_cost(u.d, encoder_profile, head_profiles, &LatencyStats::p50);
  return sched.queue_ahead_at(held.front().began, p50, enqueue_cost);
}

// Polls the backend until the lane's oldest unit has ended (Backend::ready()), spin-then-park
// as every wait of the runtime: parked between polls every kPollEarly until a spin before the
// unit's expected end (it may end early), polling back to back for options.spin, then parked
// between polls for kPollRest, doubled each time up to kPollRestMax. A waiting lane thread
// (SCHED_FIFO, pinned) thus leaves its cores to others, and a unit's times come from the
// backend, not from when this saw it end. False when the run is stopping and the unit is still
// not done at `limit` (its watchdog limit): the device hangs, and the unit is abandoned so that
// the run can end.
bool Runtime::Impl::await_unit(Handler& h, int lane, TimePoint expected, TimePoint limit) {
  constexpr Duration kPollEarly = std::chrono::microseconds{200};
  constexpr Duration kPollRest = std::chrono::microseconds{20};
  constexpr Duration kPollRestMax = std::chrono::milliseconds{1};
  const auto stop = [&] { return stopping.load(std::memory_order_acquire); };
  for (;;) {
    if (backend.ready(lane)) return true;
    const TimePoint now = clock.now();
    if (stop() || now >= expected - options.spin) break;
    spin_then_park(h.mu, h.cv, clock, Duration{0},
                   std::min(now + kPollEarly, expected - options.spin), stop);
  }
  const TimePoint spin_end = clock.now() + options.spin;
  while (clock.now() < spin_end) {
    if (backend.ready(lane)) return true;
    std::this_thread::yield();
  }
  Duration rest = kPollRest;
  for (;;) {
    if (backend.ready(lane)) return true;
    const bool stopping_now = stop();
    const TimePoint now = clock.now();
    if (stopping_now && now >= limit) return false;
    TimePoint until = now + rest;
    if (stopping_now) until = std::min(until, limit);
    // Woken early only by the run starting to stop (then `limit` counts).
    spin_then_park(h.mu, h.cv, clock, Duration{0}, until, [&] { return stop() != stopping_now; });
    rest = std::min(rest * 2, kPollRestMax);
  }
}

// On-demand, at a unit boundary of `lane` (caller holds sched_mu): the units the lane's
// queue has room for, decided now and handed to the caller to enqueue after it lets go
// of the lock (what is decided counts as dispatched).
void Runtime::Impl::decide_ahead(int lane, TimePoint now, std::vector<const Dispatch*>& out) {
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

// On-demand, with room in the lane's queue: waits until the lead before what the lane holds
// is expected to end, then decides the units its queue has room for and enqueues them.
void Runtime::Impl::fill_ahead(int lane, Handler& h, std::deque<Held>& held,
                               std::vector<const Dispatch*>& taken, TimePoint prev_end,
                               Duration& enqueue_cost) {
  // The lane's queue is filled when what it holds is about to end (the lead), not at
  // once: a release meanwhile is seen before the next unit is chosen.
  const TimePoint at = queue_ahead_at(held, enqueue_cost);
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

// The oldest unit the lane holds, `u`, watched from `watched` until `limit`: its result, or a
// failure (`abandoned` when the run stopped with the device still on it).
UnitDone Runtime::Impl::await_oldest(int lane, Handler& h, Held& u, TimePoint watched,
                                     TimePoint limit, bool& abandoned) {
  UnitDone done;
  if (u.enqueue_failed) {
    done.status = u.status;
    done.reason = std::move(u.reason);
    done.device_lost = u.device_lost;
  } else {
    const TimePoint began = u.began == kNever ? watched : u.began;
    const TimePoint expected =
        began + profiled_cost(u.d, encoder_profile, head_profiles, &LatencyStats::p50);
    try {
      if (await_unit(h, lane, expected, limit)) {
        done = backend.wait(lane);
      } else {
        backend.abandon(lane);
        abandoned = true;
        done.status = UnitStatus::Failed;
        done.reason = "abandoned: the device had not finished it when the run ended";
      }
    } catch (const std::exception& e) {  // the contract says report, not throw: still
      done.status = UnitStatus::Failed;
      done.reason = e.what();
    }
  }
  return done;
}

// The handler of an asynchronous lane (Backend::asynchronous()): the same state machine
// as handler_main, over the units the lane holds. It enqueues what it is given and, under
// on-demand synchronization, decides at each unit boundary (an enqueue, a completion) the
// units its queue has room for, so the next unit is on the device before the one before
// it ends; then it waits for the oldest. Every completion reaches the scheduler in the
// lane's order: under on-demand the handler reports each itself (a failure too, then
// wakes the global synchronizer, which decides the lane's next run); under per-edge it
// posts each to the global synchronizer and holds one unit at a time.
void Runtime::Impl::async_handler_main(int lane) {
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
    if (held.empty() && !await_assignment(h, seen, answer_due)) return;
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
    if (sync == SyncMode::OnDemand && !stopping.load() && held.size() < depth)
      fill_ahead(lane, h, held, taken, prev_end, enqueue_cost);
    // Wait for the oldest, watched from now (the units before it have ended).
    Held& u = held.front();
    h.state.store(HandlerState::Running, std::memory_order_release);
    const TimePoint watched = clock.now();
    const TimePoint limit = watched + (watchdog_on() ? watchdog_limit(u.d) : options.watchdog_min);
    if (watchdog_on()) {
      h.limit_ns.store(limit.count(), std::memory_order_release);
      h.watch.store(kWatchRunning);
      if (limit.count() < global_wake_at.load()) wake_global();
    }
    bool abandoned = false;
    UnitDone done = await_oldest(lane, h, u, watched, limit, abandoned);
    if (done.device_lost) done.reason = device_lost(lane, std::move(done.reason));
    if (abandoned) {
      std::lock_guard rl(report_mu);
      ++report.abandoned;
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
      // scheduler; its late result (or its abandonment) is ignored.
      std::lock_guard rl(report_mu);
      if (!abandoned) ++report.late_returns;
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

}  // namespace red
