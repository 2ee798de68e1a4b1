#pragma once
/// \file
/// The host side of the LibTorch backend's asynchronous lanes on a device (docs/GPU.md,
/// "Asynchronous lanes"), over a LaneDevice: each lane's own stream, the units it has
/// enqueued and not yet reported, their times from device events placed on the host's clock,
/// polling instead of blocking, abandoned units kept until the device is done with them, and
/// a lost device recognised once. Not installed; tested with a stand-in device
/// (tests/torch/lane_device_test.cpp).
///
/// Thread safety: each lane is used by one thread at a time (its handler); drain() and the
/// destructor only when no lane is in use. lost() and check_lost() from any thread.

#include <ATen/Tensor.h>

#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/runtime/backend.hpp"
#include "red/torch/lane_device.hpp"

namespace red::torchb {

class DeviceLanes {
 public:
  using Event = LaneDevice::Event;
  using StreamId = LaneDevice::StreamId;
  using HostTime = LaneDevice::HostTime;

  /// A unit enqueued on a lane and not yet reported by wait().
  struct Unit {
    /// Device events around the unit's kernels (none for host work).
    std::shared_ptr<Event> start;
    std::shared_ptr<Event> end;
    /// Every tensor the unit reads or writes, held until the device has run it: the host
    /// may drop a frame or an encoder output (made on another lane's stream) while the unit
    /// still reads it, and the caching allocator would hand its block out again.
    std::vector<at::Tensor> keep;
    /// Host work (a plain unit's cost), run by wait() when every unit before it on the lane
    /// has ended, and timed on the host: it has no device time.
    std::optional<Duration> host_work;
    /// What the unit is, for a lost device's message ("encoder unit").
    std::string what;
    // When the host first saw it end, or how it failed (ready()).
    HostTime observed{};
    std::string failure;
  };

  /// How long a lost anchor or a drain waits for the device before giving up on it.
  static constexpr std::chrono::seconds kDrainLimit{10};
  /// A lane's reference event is recorded again, when the lane is idle, after this long:
  /// event times are single precision in milliseconds, and the device's clock drifts.
  static constexpr std::chrono::seconds kAnchorAge{1};

  explicit DeviceLanes(std::shared_ptr<LaneDevice> device);
  /// Waits for what the lanes still hold, up to kDrainLimit; a unit the device never
  /// finishes (a hung device) is left allocated rather than freed under its kernels.
  ~DeviceLanes();
  DeviceLanes(const DeviceLanes&) = delete;
  DeviceLanes& operator=(const DeviceLanes&) = delete;

  [[nodiscard]] LaneDevice& device() const noexcept { return *device_; }

  /// Gives `lane` a new stream of its own (each backend instance its own streams, whatever
  /// thread calls) and its reference event. Throws what the device throws.
  void init(int lane);
  /// The lane's stream; init()s the lane first when it was not.
  StreamId stream(int lane);

  /// Makes the lane's stream the calling thread's current stream while it lives.
  class Current {
   public:
    Current(DeviceLanes& lanes, int lane);
    ~Current();
    Current(const Current&) = delete;
    Current& operator=(const Current&) = delete;

   private:
    LaneDevice& device_;
    StreamId previous_;
  };

  /// Renews the lane's reference event when the lane holds no unit and it is older than
  /// kAnchorAge (before anything of the next unit is queued: the stream must be idle).
  void renew(int lane);
  /// Records an event on the lane's stream.
  std::shared_ptr<Event> record(int lane);
  /// Makes the lane's stream wait for `e` when `e` was recorded on another stream.
  void block(int lane, const std::shared_ptr<Event>& e, StreamId recorded_on);

  /// Appends a unit to the lane's queue.
  void push(int lane, Unit u);
  /// Whether the lane's oldest unit has ended (or failed, or there is none). Never blocks.
  bool ready(int lane) noexcept;
  /// Waits for the lane's oldest unit (polling, resting between polls) and says how it
  /// ended: times from its events on the host's clock, a failure, a lost device.
  UnitDone wait(int lane);
  /// Gives up on the lane's oldest unit: its tensors are let go when its end event
  /// completes (sweep()).
  void abandon(int lane);
  /// Lets go of abandoned units the device has finished.
  void sweep() noexcept;
  /// Waits up to kDrainLimit for every lane's units, lets go of them; what is left is
  /// abandoned (end of a run; no lane in use).
  void drain() noexcept;
  /// Abandoned units not yet let go (for reports and tests).
  [[nodiscard]] std::size_t abandoned() const;
  /// Keeps `keep` until everything queued on the lane's stream now has run (a unit that
  /// failed while its first kernels were queued).
  void retire(int lane, std::vector<at::Tensor> keep) noexcept;

  /// After a failure on `lane`: whether the device is lost (a probe on the lane's stream
  /// fails too). The first one seen is kept with the lane and unit that saw it.
  bool check_lost(int lane, const std::string& what, const std::string& reason) noexcept;
  /// "device lost: <reason> (first seen on lane L, encoder unit)", or empty.
  [[nodiscard]] std::string lost() const;

  /// Waits (polling) until everything queued on the lane's stream so far has run. Throws
  /// a device error, or when the device has not done so within kDrainLimit.
  void finish(int lane);
  /// Spins the calling thread for `d` on the device's host clock (a plain unit's work).
  void spin(Duration d) const;

 private:
  struct Lane {
    std::optional<StreamId> stream;
    std::shared_ptr<Event> anchor;  // the reference event
    HostTime anchor_host{};         // when it completed, on the host's clock
    std::deque<Unit> units;
  };
  Lane& lane(int lane);
  void anchor(Lane& l, Duration limit);
  // Polls `done` until it is true or `deadline` passes: back to back for a spin, then
  // resting between polls, longer each time up to a limit. Whether it became true.
  template <typename Done>
  bool poll(Done done, HostTime deadline) const;
  void set_times(const Lane& l, const Unit& u, UnitDone& done) const;

  std::shared_ptr<LaneDevice> device_;
  mutable std::mutex mu_;  // guards the map (each lane's contents are its thread's)
  std::map<int, std::unique_ptr<Lane>> lanes_;
  mutable std::mutex grave_mu_;
  std::vector<Unit> graveyard_;  // abandoned, kept until their end event completes
  mutable std::mutex lost_mu_;
  std::string lost_;
};

}  // namespace red::torchb
