#pragma once
/// \file
/// The device under the LibTorch backend's asynchronous lanes (docs/GPU.md, "Asynchronous
/// lanes"): its streams and events, the copy of a frame's pixels to it, and the host's clock
/// and pause between polls. Everything the backend's lane logic asks of a GPU goes through
/// this interface, so that the logic (unit times from events, polling instead of blocking,
/// abandoning a hung unit, recognising a lost device) is tested on the CPU with a stand-in
/// whose events complete late, hang or fail (tests/torch/lane_device_test.cpp).
///
/// The real one, make_lane_device(), uses LibTorch's device-generic c10 interface
/// (c10::Event, c10::Stream, the device's guard implementation): on a CUDA LibTorch that
/// is c10::cuda's streams and events; it builds against a CPU-only LibTorch too.
///
///     auto dev = red::torchb::make_lane_device(c10::Device("cuda:0"));
///     const auto s = dev->new_stream();
///     auto before = dev->record(s);
///     // ... launch kernels on s ...
///     auto after = dev->record(s);
///     while (!dev->query(*after)) dev->pause(std::chrono::microseconds{50});
///     const double ms = dev->times() ? dev->elapsed_ms(*before, *after) : 0.0;
///
/// Thread safety: every call may come from any lane's thread at once; an Event is used by
/// one thread at a time. Calls that reach the device throw what LibTorch throws (c10::Error).

#include <ATen/Tensor.h>
#include <c10/core/Device.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace red::torchb {

class LaneDevice {
 public:
  /// A stream of the device, by the device's own number for it.
  using StreamId = std::int64_t;
  /// The host clock the backend stamps units with (UnitDone's times are on it).
  using HostTime = std::chrono::steady_clock::time_point;

  /// An event recorded on a stream: it completes when the device has run everything queued
  /// on that stream before it. Opaque; made by record().
  class Event {
   public:
    Event() = default;
    virtual ~Event() = default;
    Event(const Event&) = delete;
    Event& operator=(const Event&) = delete;
  };

  LaneDevice() = default;
  virtual ~LaneDevice() = default;
  LaneDevice(const LaneDevice&) = delete;
  LaneDevice& operator=(const LaneDevice&) = delete;

  /// Where tensors of this device live (what the model runs on).
  [[nodiscard]] virtual c10::Device device() const = 0;
  /// A stream for one lane, from the device's pool.
  virtual StreamId new_stream() = 0;
  /// The calling thread's current stream (where LibTorch queues its kernels).
  virtual StreamId current_stream() = 0;
  /// Makes `s` the calling thread's current stream (LibTorch queues its kernels there);
  /// returns the stream that was current.
  virtual StreamId exchange_stream(StreamId s) = 0;
  /// Records an event on `s`, with timing when times().
  virtual std::unique_ptr<Event> record(StreamId s) = 0;
  /// Whether `e` has completed. Never blocks; throws on a device error.
  virtual bool query(const Event& e) = 0;
  /// Whether elapsed_ms() can time events (LibTorch 2.6 and later).
  [[nodiscard]] virtual bool times() const noexcept = 0;
  /// Milliseconds from `from` to `to` on the device's clock; both completed. Only when
  /// times().
  virtual double elapsed_ms(const Event& from, const Event& to) = 0;
  /// Makes `s` wait on the device for `e` (another stream's work) before what is queued on
  /// it next; the host does not wait.
  virtual void block(StreamId s, const Event& e) = 0;
  /// Host memory of `shape` bytes that the device can copy from asynchronously (pinned).
  virtual at::Tensor host_buffer(const std::vector<std::int64_t>& shape) = 0;
  /// Queues a copy of `host` (from host_buffer()) to the device on the current stream; the
  /// host does not wait, so `host` must live until the stream has run the copy.
  virtual at::Tensor to_device(const at::Tensor& host) = 0;
  /// The host's clock.
  [[nodiscard]] virtual HostTime now() const = 0;
  /// Lets the host thread rest for `d` between two polls (a sleep).
  virtual void pause(std::chrono::nanoseconds d) = 0;
};

/// The device `d` through LibTorch's device-generic interface (a CUDA device on a CUDA
/// LibTorch). `d` must not be the CPU.
std::shared_ptr<LaneDevice> make_lane_device(const c10::Device& d);

/// Sets LibTorch's CUDA synchronization debug mode to warn (`--debug-sync`): every operation
/// that makes the host wait for the GPU says so on stderr (torch.cuda.set_sync_debug_mode).
/// Returns what it did, or why it could not (a LibTorch without CUDA).
std::string warn_on_device_sync();

}  // namespace red::torchb
