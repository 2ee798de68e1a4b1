#include "device_lanes.hpp"

#include <algorithm>
#include <exception>
#include <stdexcept>
#include <utility>

#include "internal.hpp"

namespace red::torchb {

namespace {

// Polling: back to back for the runtime's default spin, then resting between polls from
// kRestMin, doubled each time up to kRestMax (a lane thread is SCHED_FIFO and pinned: a
// busy wait would starve its cores).
constexpr std::chrono::microseconds kSpin{50};
constexpr std::chrono::microseconds kRestMin{20};
constexpr std::chrono::microseconds kRestMax{1000};
// A renewed reference event on an idle stream completes at once; if it is not seen within
// kRenewSpan of its record (work still runs there: an abandoned unit, a failed unit's
// kernels), its place on the host's clock is unknown, and the old one stays.
constexpr std::chrono::microseconds kRenewSpan{200};

std::string failure_of(const std::exception& e) {
  return "LibTorch: " + detail::describe(e);
}

}  // namespace

DeviceLanes::DeviceLanes(std::shared_ptr<LaneDevice> device) : device_(std::move(device)) {}

DeviceLanes::~DeviceLanes() {
  drain();
  std::lock_guard lock(grave_mu_);
  if (!graveyard_.empty()) {
    // The device never finished these (it hangs): freeing their memory under kernels that
    // may still run would let the allocator hand it out again. Left to the process's end.
    new std::vector<Unit>(std::move(graveyard_));  // NOLINT(cppcoreguidelines-owning-memory)
  }
}

DeviceLanes::Lane& DeviceLanes::lane(int l) {
  std::lock_guard lock(mu_);
  auto& p = lanes_[l];
  if (!p) p = std::make_unique<Lane>();
  return *p;
}

template <typename Done>
bool DeviceLanes::poll(Done done, HostTime deadline) const {
  const HostTime spin_end = device_->now() + kSpin;
  for (;;) {
    if (done()) return true;
    const HostTime now = device_->now();
    if (now >= deadline) return false;
    if (now >= spin_end) break;
  }
  Duration rest = kRestMin;
  for (;;) {
    device_->pause(rest);
    if (done()) return true;
    if (device_->now() >= deadline) return false;
    rest = std::min<Duration>(rest * 2, kRestMax);
  }
}

// The lane's reference event: recorded on its idle stream and polled until it completes,
// it is placed on the host's clock halfway between the record and the poll that saw it.
void DeviceLanes::anchor(Lane& l, Duration limit) {
  if (!device_->times()) return;
  const HostTime before = device_->now();
  std::shared_ptr<Event> e = device_->record(*l.stream);
  if (!poll([&] { return device_->query(*e); }, before + limit)) {
    if (l.anchor) return;  // keep the old one
    throw std::runtime_error("the device did not run an event on an idle stream within " +
                             std::to_string(std::chrono::duration<double>(limit).count()) + " s");
  }
  const HostTime after = device_->now();
  if (l.anchor && after - before > kRenewSpan) return;
  l.anchor = std::move(e);
  l.anchor_host = before + (after - before) / 2;
}

void DeviceLanes::init(int l) {
  Lane& ln = lane(l);
  ln.stream = device_->new_stream();
  ln.anchor.reset();
  anchor(ln, kDrainLimit);
}

DeviceLanes::StreamId DeviceLanes::stream(int l) {
  Lane& ln = lane(l);
  if (!ln.stream) init(l);
  return *ln.stream;
}

DeviceLanes::Current::Current(DeviceLanes& lanes, int lane)
    : device_(lanes.device()), previous_(device_.exchange_stream(lanes.stream(lane))) {}

DeviceLanes::Current::~Current() {
  try {
    device_.exchange_stream(previous_);
  } catch (...) {  // NOLINT(bugprone-empty-catch): a lost device; the unit reports it
  }
}

void DeviceLanes::renew(int l) {
  Lane& ln = lane(l);
  if (ln.stream && ln.units.empty() && ln.anchor && device_->now() - ln.anchor_host > kAnchorAge)
    anchor(ln, kRenewSpan);
}

std::shared_ptr<DeviceLanes::Event> DeviceLanes::record(int l) {
  return device_->record(stream(l));
}

void DeviceLanes::block(int l, const std::shared_ptr<Event>& e, StreamId recorded_on) {
  const StreamId s = stream(l);
  if (e && recorded_on != s) device_->block(s, *e);
}

void DeviceLanes::push(int l, Unit u) {
  lane(l).units.push_back(std::move(u));
}

bool DeviceLanes::ready(int l) noexcept {
  Lane& ln = lane(l);
  if (ln.units.empty()) return true;
  Unit& u = ln.units.front();
  if (u.host_work || u.observed != HostTime{} || !u.failure.empty()) return true;
  try {
    if (!device_->query(*u.end)) return false;
    u.observed = device_->now();
  } catch (const std::exception& e) {
    u.failure = failure_of(e);
  } catch (...) {
    u.failure = "LibTorch: unknown exception";
  }
  return true;
}

void DeviceLanes::set_times(const Lane& l, const Unit& u, UnitDone& done) const {
  if (device_->times() && l.anchor && u.start) {
    try {
      const auto at = [&](const Event& e) {
        const std::chrono::duration<double, std::milli> ms(device_->elapsed_ms(*l.anchor, e));
        return l.anchor_host + std::chrono::duration_cast<HostTime::duration>(ms);
      };
      done.started = at(*u.start);
      done.ended = at(*u.end);
      return;
    } catch (...) {  // NOLINT(bugprone-empty-catch): untimed; the host's observation below
    }
  }
  // Without event times: the end as the host saw it; the runtime places the start.
  done.ended = u.observed;
}

UnitDone DeviceLanes::wait(int l) {
  Lane& ln = lane(l);
  UnitDone done;
  if (ln.units.empty()) {  // a caller's mistake; reported as the unit's failure
    done.status = UnitStatus::Failed;
    done.reason = "no unit enqueued on lane " + std::to_string(l);
    return done;
  }
  if (ln.units.front().host_work) {
    // Every unit before it on the lane has been reported: it starts now, on the host.
    const Duration work = *ln.units.front().host_work;
    ln.units.pop_front();
    done.started = device_->now();
    spin(work);
    done.ended = device_->now();
    return done;
  }
  (void)poll([&] { return ready(l); }, HostTime::max());
  Unit u = std::move(ln.units.front());
  ln.units.pop_front();
  if (!u.failure.empty()) {
    done.status = UnitStatus::Failed;
    done.reason = u.failure;
    if (check_lost(l, u.what, u.failure)) {
      done.device_lost = true;
      done.reason = lost();
    }
    return done;  // its tensors go: the device will not run its kernels
  }
  set_times(ln, u, done);
  return done;
}

void DeviceLanes::abandon(int l) {
  Lane& ln = lane(l);
  if (ln.units.empty()) return;
  Unit u = std::move(ln.units.front());
  ln.units.pop_front();
  if (!u.end) return;  // host work holds nothing of the device's
  std::lock_guard lock(grave_mu_);
  graveyard_.push_back(std::move(u));
}

void DeviceLanes::retire(int l, std::vector<at::Tensor> keep) noexcept {
  try {
    Unit u;
    u.keep = std::move(keep);
    u.end = device_->record(stream(l));
    std::lock_guard lock(grave_mu_);
    graveyard_.push_back(std::move(u));
  } catch (...) {  // NOLINT(bugprone-empty-catch): the device is gone; nothing runs there
  }
}

void DeviceLanes::sweep() noexcept {
  std::lock_guard lock(grave_mu_);
  std::erase_if(graveyard_, [&](const Unit& u) {
    try {
      return device_->query(*u.end);
    } catch (...) {
      return true;  // a device error: its kernels will not run
    }
  });
}

void DeviceLanes::drain() noexcept {
  {
    std::lock_guard lock(mu_);
    for (auto& [l, p] : lanes_) {
      auto& units = p->units;
      std::lock_guard gl(grave_mu_);
      for (Unit& u : units)
        if (u.end) graveyard_.push_back(std::move(u));
      units.clear();
    }
  }
  try {
    const HostTime deadline = device_->now() + kDrainLimit;
    (void)poll(
        [&] {
          sweep();
          return abandoned() == 0;
        },
        deadline);
  } catch (...) {  // NOLINT(bugprone-empty-catch): the clock cannot throw; nothing to do
  }
}

std::size_t DeviceLanes::abandoned() const {
  std::lock_guard lock(grave_mu_);
  return graveyard_.size();
}

bool DeviceLanes::check_lost(int l, const std::string& what, const std::string& reason) noexcept {
  if (!lost().empty()) return true;
  bool lost_now = false;
  try {
    // A fault that sticks: every later call on the device fails too (a CUDA kernel's
    // illegal address, a device-side assert). A unit's own error (a shape, an
    // allocation) leaves the device working, and this probe passes.
    const std::shared_ptr<Event> probe = device_->record(stream(l));
    (void)device_->query(*probe);
  } catch (...) {
    lost_now = true;
  }
  if (!lost_now) return false;
  std::lock_guard lock(lost_mu_);
  if (lost_.empty())
    lost_ = "device lost: " + reason + " (first seen on lane " + std::to_string(l) +
            (what.empty() ? std::string() : ", " + what) + ")";
  return true;
}

std::string DeviceLanes::lost() const {
  std::lock_guard lock(lost_mu_);
  return lost_;
}

void DeviceLanes::finish(int l) {
  const std::shared_ptr<Event> e = device_->record(stream(l));
  if (!poll([&] { return device_->query(*e); }, device_->now() + kDrainLimit))
    throw std::runtime_error("the device did not finish lane " + std::to_string(l) +
                             "'s work within " + std::to_string(kDrainLimit.count()) + " s");
}

void DeviceLanes::spin(Duration d) const {
  const HostTime until = device_->now() + std::chrono::duration_cast<HostTime::duration>(d);
  while (device_->now() < until) {
  }
}

}  // namespace red::torchb
