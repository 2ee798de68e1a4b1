// The real LaneDevice: LibTorch's device-generic streams and events (c10::Stream, c10::Event
// and the device's DeviceGuardImplInterface), which are c10::cuda's on a CUDA device. Builds
// against a CPU-only LibTorch (it then has no device to run on); the CUDA-only
// synchronization debug mode is compiled where LibTorch has CUDA (RED_TORCH_CUDA).

#include "red/torch/lane_device.hpp"

#include <ATen/ATen.h>
#include <c10/core/Event.h>
#include <c10/core/Stream.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>

#include <stdexcept>
#include <thread>

#include "unit_timer.hpp"  // RED_TORCH_EVENT_TIMING

#if RED_TORCH_CUDA
#include <c10/cuda/CUDAFunctions.h>
#endif

namespace red::torchb {

namespace {

class C10Event final : public LaneDevice::Event {
 public:
  C10Event(c10::DeviceType type, const c10::Stream& s)
      // BACKEND_DEFAULT: an event that times (LibTorch's own default disables timing).
      : event(type, c10::EventFlag::BACKEND_DEFAULT) {
    event.record(s);
  }
  c10::Event event;
};

const c10::Event& of(const LaneDevice::Event& e) {
  return static_cast<const C10Event&>(e).event;
}

class C10LaneDevice final : public LaneDevice {
 public:
  explicit C10LaneDevice(const c10::Device& d)
      : device_(d), impl_(c10::impl::getDeviceGuardImpl(d.type())) {}

  [[nodiscard]] c10::Device device() const override { return device_; }

  StreamId new_stream() override { return impl_->getStreamFromGlobalPool(device_).id(); }

  StreamId current_stream() override { return impl_->getStream(device_).id(); }

  StreamId exchange_stream(StreamId s) override { return impl_->exchangeStream(stream(s)).id(); }

  std::unique_ptr<Event> record(StreamId s) override {
    return std::make_unique<C10Event>(device_.type(), stream(s));
  }

  bool query(const Event& e) override { return of(e).query(); }

  [[nodiscard]] bool times() const noexcept override { return RED_TORCH_EVENT_TIMING != 0; }

  double elapsed_ms([[maybe_unused]] const Event& from, [[maybe_unused]] const Event& to) override {
#if RED_TORCH_EVENT_TIMING
    return of(from).elapsedTime(of(to));
#else
    throw std::logic_error("this LibTorch cannot time device events (2.6 and later can)");
#endif
  }

  void block(StreamId s, const Event& e) override {
    of(e).block(stream(s));
  }

  at::Tensor host_buffer(const std::vector<std::int64_t>& shape) override {
    return at::empty(shape, at::TensorOptions().dtype(at::kByte).pinned_memory(true));
  }

  at::Tensor to_device(const at::Tensor& host) override {
    return host.to(device_, /*non_blocking=*/true);
  }

  [[nodiscard]] HostTime now() const override {
    return std::chrono::steady_clock::now();
  }

  void pause(std::chrono::nanoseconds d) override {
    std::this_thread::sleep_for(d);
  }

 private:
  [[nodiscard]] c10::Stream stream(StreamId s) const {
    return c10::Stream(c10::Stream::UNSAFE, device_, s);
  }

  c10::Device device_;
  const c10::impl::DeviceGuardImplInterface* impl_;
};

}  // namespace

std::shared_ptr<LaneDevice> make_lane_device(const c10::Device& d) {
  if (d.is_cpu() || !c10::impl::hasDeviceGuardImpl(d.type()))
    throw std::invalid_argument("no lane device for " + d.str());
  return std::make_shared<C10LaneDevice>(d);
}

std::string warn_on_device_sync() {
#if RED_TORCH_CUDA
  c10::cuda::warning_state().set_sync_debug_mode(c10::cuda::SyncDebugMode::L_WARN);
  return "--debug-sync: LibTorch warns on every operation that synchronizes with the GPU";
#else
  return "--debug-sync: this LibTorch has no CUDA; there is no device synchronization to "
         "report";
#endif
}

}  // namespace red::torchb
