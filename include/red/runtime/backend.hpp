#pragma once
/// \file
/// What a runtime lane executes units on (§6). The LibTorch backend lives in its own
/// target (backends/torch); the core knows only this interface.
///
///     class MyBackend : public red::Backend {
///       std::string_view name() const noexcept override { return "mine"; }
///       void run(int lane, const red::Dispatch& d) override { /* run d.kind on d.members */ }
///     };

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "red/sched/observer.hpp"

namespace red {

/// Thrown by a backend when a unit runs out of memory: the unit ends OutOfMemory.
class OutOfMemoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Pixels of an external frame (e.g. received over DDS), already at the model's input height
/// and width: 8-bit, row-major, `channels` interleaved (RGB order, or gray). Borrowed for the
/// duration of the call only.
struct FrameView {
  int width = 0;
  int height = 0;
  int channels = 0;
  const std::uint8_t* data = nullptr;
};

/// Executes units. run() is called from the lane's own thread; different lanes call it
/// concurrently, one lane never twice at once. on_frame() is called from the camera
/// thread. A failing unit throws; the runtime turns that into a failed job (§6).
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
  /// A synthetic camera captured frame `frame` of `sensor`: produce its pixels in memory.
  virtual void on_frame(int /*sensor*/, std::uint64_t /*frame*/) {}
  /// An external frame arrived with its pixels: keep them as frame `frame` of `sensor`
  /// (called from the thread that received it). The default ignores the pixels and
  /// synthesizes the frame as on_frame() does.
  virtual void on_external_frame(int sensor, std::uint64_t frame, const FrameView& /*pixels*/) {
    on_frame(sensor, frame);
  }
  /// Runs one dispatched unit (merged members share one encoder output; a batch runs as
  /// one tensor batch). Throws on failure, OutOfMemoryError when out of memory.
  virtual void run(int lane, const Dispatch& d) = 0;
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
