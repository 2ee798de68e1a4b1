// The real-time knobs of a run: SCHED_FIFO priorities, each lane's share of the cores,
// mlockall (apply_realtime, reported either way), and the background CPU load of a
// scenario's `interference`.

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "red/runtime/runtime.hpp"
#include "runtime_impl.hpp"

namespace red {

Runtime::Impl::CoreShare Runtime::Impl::core_share() const {
  const long cores = std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
  const long lanes = std::max(1L, static_cast<long>(scenario.device.lanes));
  return {cores, std::max(1L, cores / lanes)};
}

// Lane i's share of the cores: [i*k, (i+1)*k), k = core_share().share.
cpu_set_t Runtime::Impl::lane_cores(std::size_t i) const {
  const auto [cores, share] = core_share();
  cpu_set_t set;
  CPU_ZERO(&set);
  const long first = (static_cast<long>(i) * share) % cores;
  for (long c = first; c < std::min(cores, first + share); ++c) CPU_SET(static_cast<int>(c), &set);
  return set;
}

// The SCHED_FIFO priority of the threads that decide and release (synchronizer, camera):
// one above the handlers', within what the kernel allows.
int Runtime::Impl::control_priority() const {
  return std::min(options.rt_priority + 1, sched_get_priority_max(SCHED_FIFO));
}

// A thread started from this one after apply_realtime() inherits the synchronizer's
// priority, above the handlers and their LibTorch workers: the background load of a
// scenario's `interference` then preempted the units for its whole busy share (in-run
// encoder 3.2 x its time without load at intensity 0.75, against 1.1 x when it ran at the
// handlers' priority, as before the synchronizer went one above). The load and the RSS
// sampler run at the handlers' priority, competing with the units as before.
void Runtime::Impl::at_handler_priority(std::thread& t) const {
  if (!realtime_on.load(std::memory_order_acquire)) return;
  sched_param sp{};
  sp.sched_priority = options.rt_priority;
  (void)pthread_setschedparam(t.native_handle(), SCHED_FIFO, &sp);
}

// What the threads run at, as the kernel has it: "SCHED_FIFO priority P" when every one
// has the same, "ordinary priority" when none is real-time, else "mixed".
std::string Runtime::Impl::scheduling_of(std::vector<std::thread>& threads) {
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

void Runtime::Impl::interference_main(double intensity, std::atomic<bool>& on) {
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

void Runtime::Impl::release_realtime() {
  if (!options.realtime) return;
  munlockall();
  wakeup_latency.release();
}

void Runtime::Impl::apply_realtime() {
  if (!options.realtime) {
    report.realtime.push_back("real-time knobs: off (--no-realtime)");
    return;
  }
  // Idle cores poll for the run (red/runtime/wakeup_latency.hpp): on this project's quiet 2-vCPU
  // virtual machine a completion's next unit then started after 8.5-10 us (p50; p99 28 us)
  // instead of 15-20 us (p99 48-57 us), and decisions took 4.2-4.7 us instead of 6.2-6.7 us
  // (docs/FIDELITY.md, "Idle cores").
  if (options.hold_wakeup_latency) {
    wakeup_latency = WakeupLatencyHold::zero();
    report.realtime.push_back(wakeup_latency.report());
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
    report.realtime.push_back(std::string("mlockall: not applied (") + std::strerror(errno) + ")");
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
  report.realtime.push_back(
      applied == static_cast<int>(handlers.size()) + 1
          ? "SCHED_FIFO priority " + std::to_string(options.rt_priority) + " (synchronizer " +
                std::to_string(control_priority()) + "): applied"
          : "SCHED_FIFO: not applied (" + std::string(std::strerror(err == 0 ? EPERM : err)) + ")");
  // Each lane gets its own share of the cores (lane i: cores [i*k, (i+1)*k), k = cores /
  // lanes, at least one), so a backend's worker threads, which inherit the handler's
  // mask, stay on that lane's cores instead of piling onto one.
  const auto [cores, share] = core_share();
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

}  // namespace red
