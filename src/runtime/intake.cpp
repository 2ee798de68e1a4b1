// Frames into the runtime: the camera thread that releases each sensor's frames at their
// nominal capture times, frames pushed by the application (Runtime::push_frame), a frame's
// release by the thread that brought it (arrive), and the count of frames offered.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "red/runtime/runtime.hpp"
#include "runtime_impl.hpp"

namespace red {

using runtime_detail::realtime_thread;

// A frame arrived (the camera thread, or push_frame on the caller's thread): its release.
// When the scheduler's lock is free, the arriving thread runs the round itself (what waits
// in the inbox, then this frame) instead of waking the global synchronizer and waiting
// for the kernel to run it, and wakes it only when its next timer moved earlier. A thread
// that ordinary threads could preempt while it holds the lock (not real-time while the
// runtime's threads are) posts the frame to the global synchronizer instead.
void Runtime::Impl::arrive(int sensor, std::uint64_t frame, TimePoint captured) {
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

// Releases each sensor's frames at their nominal capture times. Releasing costs no model
// work here (Backend::on_frame only names the frame; its tensor is made off this thread),
// so the camera keeps the sensors' rates whatever the lanes are doing; a frame released
// late is still counted against its nominal time (RuntimeReport::release_late_us).
void Runtime::Impl::camera_main() {
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
        std::chrono::duration_cast<std::chrono::steady_clock::duration>(clock.origin() + next[s])));
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
void Runtime::Impl::count_offered() {
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

}  // namespace red
