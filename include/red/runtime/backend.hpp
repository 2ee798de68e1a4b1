#pragma once
/// \file
/// What a runtime lane executes units on (docs/DESIGN.md, "Synchronization"). The LibTorch backend
/// lives in its own target (backends/torch); the core knows only this interface.
///
///     class MyBackend : public red::Backend {
///       std::string_view name() const noexcept override { return "mine"; }
///       void run(int lane, const red::Dispatch& d) override { /* run d.kind on d.members */ }
///     };

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "red/sched/records.hpp"

namespace red {

/// Thrown by a backend when a unit runs out of memory: the unit ends OutOfMemory.
class OutOfMemoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Thrown by a backend when its device is lost (a fault that every later call on the device
/// reports again, such as a CUDA kernel's illegal memory access): the unit fails, and the
/// runtime stops the run rather than fail every later unit (RuntimeReport::device_lost).
class DeviceLostError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class LazyFrame;

/// How a unit enqueued on an asynchronous lane ended (Backend::wait()).
struct UnitDone {
  UnitStatus status = UnitStatus::Completed;  ///< Completed, Failed or OutOfMemory
  std::string reason;                         ///< a failure's message
  /// When the device started and ended the unit, on std::chrono::steady_clock (a GPU: its
  /// events' times on the device's clock, placed on the host's by a reference event of the
  /// lane). Left at the epoch, the runtime takes the unit's start as the later of its
  /// enqueue and the end of the unit before it, and its end as when wait() returned.
  std::chrono::steady_clock::time_point started{};
  std::chrono::steady_clock::time_point ended{};
  /// The unit failed because the device is lost (as DeviceLostError says): the runtime
  /// stops the run.
  bool device_lost = false;
};

/// Pixels of an external frame (e.g. received over DDS), already at the model's input height
/// and width: 8-bit, row-major, `channels` interleaved (RGB order, or gray). `data` is
/// borrowed for the duration of the call only. A frame released before its pixels are
/// converted (docs/ROS2.md: a DDS node) comes with `data` null and `lazy` set: a backend may keep
/// `lazy` and ask for the pixels when it needs them (LazyFrame::pixels()).
struct FrameView {
  int width = 0;
  int height = 0;
  int channels = 0;
  const std::uint8_t* data = nullptr;
  std::shared_ptr<const LazyFrame> lazy;  ///< the frame, converted on first use; may be null
};

/// An external frame whose pixels are converted when first asked for (docs/ROS2.md: a received
/// frame is released first and converted when the encoder starts). Thread-safe: the first caller of
/// pixels() runs convert(), concurrent callers wait for that one call, and every caller then reads
/// the whole converted frame (std::call_once orders the conversion's writes before every return); a
/// frame no one asks for is never converted.
///
///     struct Gray : red::LazyFrame {
///       Gray() : LazyFrame(384, 192, 1) {}
///       void convert(std::uint8_t* out) const override { /* 384 * 192 bytes */ }
///     };
///     red::FrameView px = frame->pixels();  // converts on the first call only
class LazyFrame {
 public:
  /// A frame of width × height pixels of `channels` bytes once converted.
  LazyFrame(int width, int height, int channels) noexcept
      : width_(width), height_(height), channels_(channels) {}
  virtual ~LazyFrame() = default;
  LazyFrame(const LazyFrame&) = delete;
  LazyFrame& operator=(const LazyFrame&) = delete;

  /// The converted pixels (valid while this frame lives); converts them on the first call.
  /// Throws what convert() throws (nothing is then converted, and a later call tries again).
  [[nodiscard]] FrameView pixels() const {
    std::call_once(once_, [this] {
      std::vector<std::uint8_t> out(static_cast<std::size_t>(width_) *
                                    static_cast<std::size_t>(height_) *
                                    static_cast<std::size_t>(channels_));
      convert(out.data());
      data_ = std::move(out);
      converted_.store(true, std::memory_order_release);
    });
    return {width_, height_, channels_, data_.data(), nullptr};
  }
  /// Whether pixels() has converted the frame (thread-safe; for reports and tests).
  [[nodiscard]] bool converted() const noexcept {
    return converted_.load(std::memory_order_acquire);
  }
  /// Width in pixels once converted.
  [[nodiscard]] int width() const noexcept { return width_; }
  /// Height in pixels once converted.
  [[nodiscard]] int height() const noexcept { return height_; }
  /// Bytes per pixel once converted (1 gray, 3 RGB).
  [[nodiscard]] int channels() const noexcept { return channels_; }

 protected:
  /// Writes the frame's width × height × channels bytes (row-major, interleaved) to `out`.
  /// Called at most once to the end, from the first thread that asks for the pixels.
  virtual void convert(std::uint8_t* out) const = 0;

 private:
  int width_;
  int height_;
  int channels_;
  mutable std::once_flag once_;
  mutable std::vector<std::uint8_t> data_;
  mutable std::atomic<bool> converted_{false};
};

/// Executes units. run() is called from the lane's own thread; different lanes call it
/// concurrently, one lane never twice at once. on_frame() is called from the camera
/// thread. A failing unit throws; the runtime turns that into a failed job (docs/DESIGN.md,
/// "Synchronization").
///
/// An asynchronous backend (a GPU: a lane is a stream) says so with asynchronous() and
/// implements enqueue() and wait() instead of run(): the lane's handler enqueues a unit
/// and, with an on-demand policy, the next one behind it (up to the scenario's
/// `device.queue_depth`) while the first runs, so the device does not wait for the host
/// between units; it then waits for the oldest. Units of one lane end in the order they
/// were enqueued; wait() reports each exactly once.
class Backend {
 public:
  Backend() = default;
  Backend(const Backend&) = delete;
  Backend& operator=(const Backend&) = delete;
  virtual ~Backend() = default;

  /// Short name for reports, e.g. "torch cpu".
  [[nodiscard]] virtual std::string_view name() const noexcept = 0;
  /// Called once on each lane's thread before it runs anything (e.g. to bind a stream).
  virtual void init_lane(int /*lane*/) {}
  /// A synthetic camera captured frame `frame` of `sensor`: have its pixels ready for the
  /// units that read it. Called on the camera thread right before the frame's release: keep
  /// it cheap (no model work, no copy to a device; make the tensor when a unit first reads
  /// it, or take it from a pool made before the run), or the camera falls behind.
  virtual void on_frame(int /*sensor*/, std::uint64_t /*frame*/) {}
  /// An external frame arrived with its pixels: keep them as frame `frame` of `sensor`
  /// (called from the thread that received it, before the frame's release: keep it cheap;
  /// with `pixels.lazy`, keep the frame and convert it when a unit needs it). The default
  /// ignores the pixels and synthesizes the frame as on_frame() does.
  virtual void on_external_frame(int sensor, std::uint64_t frame, const FrameView& /*pixels*/) {
    on_frame(sensor, frame);
  }
  /// Runs one dispatched unit (merged members share one encoder output; a batch runs as
  /// one tensor batch). Throws on failure, OutOfMemoryError when out of memory.
  virtual void run(int lane, const Dispatch& d) = 0;
  /// Whether this backend implements enqueue() and wait() (an asynchronous lane) rather
  /// than run(). Constant for the backend's life. Default: false.
  [[nodiscard]] virtual bool asynchronous() const noexcept { return false; }
  /// Asynchronous lanes: queues one unit on `lane` behind the units it holds and returns
  /// without waiting for the device (`d` is borrowed for the call only: keep what the unit
  /// needs). Called from the lane's thread. Throws when the unit cannot be queued (it then
  /// ends as if run() had thrown, and is not waited for). The default runs it (run()).
  virtual void enqueue(int lane, const Dispatch& d) { run(lane, d); }
  /// Asynchronous lanes: waits for the oldest unit enqueued on `lane` to end and says how
  /// (a unit's own failure is reported, not thrown). Called from the lane's thread, once
  /// per enqueued unit that was not abandoned. The default (for the default enqueue())
  /// reports Completed.
  virtual UnitDone wait(int /*lane*/) { return {}; }
  /// Asynchronous lanes: whether the oldest unit enqueued on `lane` has ended, so that
  /// wait() returns without waiting. Never blocks and never throws (a device error makes
  /// it true: wait() reports it). The runtime polls it, spinning then parking, so that a
  /// waiting lane does not hold its core, and so that it can give up on a hung unit.
  /// Called from the lane's thread. The default, true, leaves the waiting to wait().
  [[nodiscard]] virtual bool ready(int /*lane*/) { return true; }
  /// Asynchronous lanes: gives up on the oldest unit enqueued on `lane` without waiting
  /// for it (the device hangs at the end of a run): wait() will not report it, and what it
  /// holds is let go once the device has finished with it. Called from the lane's thread.
  /// The default waits for it.
  virtual void abandon(int lane) { (void)wait(lane); }
  /// Runs what a unit runs once, off the clock and outside any job, so that the memory a
  /// run touches is mapped and resident before the runtime locks its pages (mlockall with
  /// MCL_ONFAULT) and the first jobs do not pay for page faults. Called on each lane's
  /// thread after init_lane(), before the run starts. Must not throw.
  virtual void warm_up(int /*lane*/) noexcept {}
  /// The run ended (no lane is running): let go of what it kept (frames, intermediate
  /// outputs, allocator caches), so runs of several policies one after another on one
  /// backend do not add up in memory. The model stays loaded.
  virtual void end_run() {}
};

}  // namespace red
