#include "red/torch/torch_backend.hpp"

#include <ATen/ATen.h>
#include <c10/core/Event.h>
#include <c10/core/InferenceMode.h>
#include <c10/core/Stream.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>
#include <c10/util/Exception.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "red/core/rng.hpp"
#include "red/torch/model.hpp"
#include "unit_timer.hpp"  // RED_TORCH_EVENT_TIMING

namespace red::torchb {

namespace {

// Frames and encoder outputs are kept per (sensor, frame) for a bounded window: the
// scheduler only runs units on recent frames (max_inflight bounds the jobs in flight).
constexpr std::size_t kKeepFrames = 32;

template <typename V>
class Window {
 public:
  void put(int sensor, std::uint64_t frame, V v) {
    std::lock_guard lock(mu_);
    const auto key = std::make_pair(sensor, frame);
    if (map_.emplace(key, std::move(v)).second) order_.push_back(key);
    while (order_.size() > kKeepFrames) {
      map_.erase(order_.front());
      order_.pop_front();
    }
  }
  /// The newest frame id stored for a sensor, if any.
  bool newest(int sensor, std::uint64_t& frame) const {
    std::lock_guard lock(mu_);
    bool found = false;
    for (const auto& [key, v] : map_)
      if (key.first == sensor && (!found || key.second > frame)) {
        frame = key.second;
        found = true;
      }
    return found;
  }
  void clear() {
    std::lock_guard lock(mu_);
    map_.clear();
    order_.clear();
  }
  bool get(int sensor, std::uint64_t frame, V& out) const {
    std::lock_guard lock(mu_);
    auto it = map_.find({sensor, frame});
    if (it == map_.end()) return false;
    out = it->second;
    return true;
  }

 private:
  mutable std::mutex mu_;
  std::map<std::pair<int, std::uint64_t>, V> map_;
  std::deque<std::pair<int, std::uint64_t>> order_;
};

// A frame's model input: a tensor made at once (a synthetic frame, or pixels given with the
// call), or a received frame whose pixels and tensor are made when the encoder first asks
// for them (docs/ROS2.md: a DDS frame is released first, converted later; LazyFrame). Thread-safe:
// the first lane to ask converts, others wait for it.
struct FrameInput {
  std::shared_ptr<const LazyFrame> lazy;
  std::once_flag once;
  at::Tensor tensor;
};

// A unit enqueued on an asynchronous lane and not yet waited for (TorchBackend::wait()).
struct Pending {
  // The lane's stream on a GPU; none for the CPU stand-in, whose unit ran on enqueue.
  std::optional<c10::Stream> stream;
  // Device events around the unit: what wait() synchronizes and times (only with a LibTorch
  // whose c10::Event can synchronize and time, RED_TORCH_EVENT_TIMING).
  std::optional<c10::Event> start;
  std::optional<c10::Event> end;
  // Every tensor the unit reads or writes, held until the device is done with it: the host
  // may drop a frame or an encoder output (made on another lane's stream) while the unit
  // still reads it, and the caching allocator would hand its block to that stream again.
  std::vector<at::Tensor> keep;
  UnitDone done;  // the CPU stand-in: how the unit ended
};

class TorchBackend final : public Backend {
 public:
  TorchBackend(const Scenario& s, std::unique_ptr<Model> model, std::vector<int> head_map,
               bool asynchronous)
      : scenario_(s),
        model_(std::move(model)),
        head_map_(std::move(head_map)),
        name_("torch " + model_->device().str()),
        on_device_(!model_->device().is_cpu() &&
                   c10::impl::hasDeviceGuardImpl(model_->device().type())),
        asynchronous_(on_device_ || asynchronous) {}

  ~TorchBackend() override { drain_pending(); }
  TorchBackend(const TorchBackend&) = delete;
  TorchBackend& operator=(const TorchBackend&) = delete;

  [[nodiscard]] std::string_view name() const noexcept override { return name_; }

  // A GPU lane is a stream: units are enqueued on it and waited for (docs/DESIGN.md,
  // "Synchronization"). On the CPU only when asked (make_torch_backend's stand-in for tests).
  [[nodiscard]] bool asynchronous() const noexcept override { return asynchronous_; }

  // On a GPU every lane runs on its own stream from the device's pool (docs/DESIGN.md,
  // "Synchronization": one lane per CUDA stream), set as the lane thread's current stream.
  // Device-generic c10 interface: it builds against a CPU-only LibTorch and uses CUDA when the
  // LibTorch has it.
  void init_lane(int /*lane*/) override {
    const c10::Device device = model_->device();
    if (device.is_cpu() || !c10::impl::hasDeviceGuardImpl(device.type())) return;
    const auto* impl = c10::impl::getDeviceGuardImpl(device.type());
    lane_stream_ = impl->getStreamFromGlobalPool(device);
    impl->exchangeStream(*lane_stream_);
  }

  // Before the run, every shape the run can use, once: the shared encoder on a batch of
  // each size from one to the largest (merged encoder runs cat frames into one batch) and
  // every head on that encoder's output (batched heads), or each full network in separate
  // mode. LibTorch's thread pools, its kernels' pages, the allocator's blocks for each
  // size and the heap's high-water mark are then in place, so that the run's first batch of
  // a new size is not slower than the next, and memory reached in one policy's run is
  // already reached before the first (a compare's policies then start level).
  void warm_up(int /*lane*/) noexcept override {
    try {
      c10::InferenceMode guard;
      if (!scenario_.sensors.empty()) (void)synthetic_frame(0, 0);  // the frame pool, once
      const int largest = std::max(1, scenario_.scheduler.max_batch);
      for (int batch = 1; batch <= largest; ++batch) {
        const at::Tensor input = model_->make_input(batch, scenario_.seed);
        if (model_->separate()) {
          for (int h : head_map_) model_->full(h, input);
          continue;
        }
        const Features f = model_->encode(input);
        for (int h : head_map_) model_->head(h, f);
      }
      if (lane_stream_)
        c10::impl::getDeviceGuardImpl(lane_stream_->device_type())
            ->synchronizeStream(*lane_stream_);
    } catch (...) {
      // A failure shows again, with its reason, when the run's first unit fails.
    }
  }

  // Between policies: the frames and encoder outputs of the run that ended go (each
  // lane's last output went with its handler thread), and so do units a lane enqueued and
  // never waited for, once the device has finished them.
  void end_run() override {
    drain_pending();
    frames_.clear();
    features_.clear();
  }

  // A synthetic camera frame: one of the sensor's pool of frames made before the run, on the
  // model's device (deterministic pixels for (sensor, frame)). Releasing a frame then makes
  // no tensor and copies nothing to the device on the camera's thread, so the camera never
  // waits for device work (a GPU's queue) and keeps the sensors' rates at any load.
  void on_frame(int sensor, std::uint64_t frame) override {
    auto input = std::make_shared<FrameInput>();
    input->tensor = synthetic_frame(sensor, frame);
    frames_.put(sensor, frame, std::move(input));
  }

  void on_external_frame(int sensor, std::uint64_t frame, const FrameView& px) override {
    const auto& in = scenario_.model.input;  // C, H, W
    if ((px.data == nullptr && !px.lazy) || in.size() != 3 || px.height != in[1] ||
        px.width != in[2] || (px.channels != 1 && px.channels != 3)) {
      on_frame(sensor, frame);  // not at the model's size: a synthetic frame instead
      return;
    }
    auto input = std::make_shared<FrameInput>();
    if (px.lazy) {
      input->lazy = px.lazy;  // converted by the encoder that first reads it (frame())
    } else {
      c10::InferenceMode guard;
      input->tensor = to_tensor(px);
    }
    frames_.put(sensor, frame, std::move(input));
  }

  void run(int /*lane*/, const Dispatch& d) override {
    translated([&] {
      c10::InferenceMode guard;
      execute(d, nullptr);
      // Kernels are queued asynchronously on a GPU: the unit ends when its stream drains.
      if (lane_stream_) synchronize(*lane_stream_);
    });
  }

  // On a GPU: the unit's kernels are queued on the lane's stream between two events, and
  // the tensors it touches are kept until wait() has seen it end. Throws what run() throws
  // when the unit cannot be queued (a frame gone, a missing encoder output, an allocation).
  // The CPU stand-in runs the unit here and keeps how it ended for wait(): it never throws.
  void enqueue(int lane, const Dispatch& d) override {
    Pending p;
    if (!on_device_) {
      const auto started = std::chrono::steady_clock::now();
      p.done = outcome([&] {
        c10::InferenceMode guard;
        execute(d, nullptr);
      });
      p.done.started = started;
      p.done.ended = std::chrono::steady_clock::now();
    } else {
      const c10::Device device = model_->device();
      p.stream = lane_stream_ ? *lane_stream_
                              : c10::impl::getDeviceGuardImpl(device.type())->getStream(device);
      translated([&] {
        c10::InferenceMode guard;
#if RED_TORCH_EVENT_TIMING
        // BACKEND_DEFAULT: events that time (LibTorch's own default disables timing).
        p.start.emplace(device.type(), c10::EventFlag::BACKEND_DEFAULT);
        p.end.emplace(device.type(), c10::EventFlag::BACKEND_DEFAULT);
        p.start->record(*p.stream);
#endif
        try {
          execute(d, &p.keep);
        } catch (...) {
          // Kernels queued before the failure may read the tensors kept so far: they go
          // only once the stream has run those kernels. The unit's own failure is thrown.
          try {
            synchronize(*p.stream);
          } catch (...) {  // NOLINT(bugprone-empty-catch): the first failure is the reason
          }
          throw;
        }
#if RED_TORCH_EVENT_TIMING
        p.end->record(*p.stream);
#endif
      });
    }
    std::lock_guard lock(pending_mu_);
    pending_[lane].push_back(std::move(p));
  }

  // The lane's oldest enqueued unit: waits for its end event (or, with an older LibTorch,
  // for the lane's stream, so also for the units behind it) and reports how it ended; a
  // device error seen here is the unit's failure, not a throw. Its tensors go after.
  UnitDone wait(int lane) override {
    std::optional<Pending> p;
    {
      std::lock_guard lock(pending_mu_);
      auto it = pending_.find(lane);
      if (it != pending_.end() && !it->second.empty()) {
        p.emplace(std::move(it->second.front()));
        it->second.pop_front();
      }
    }
    if (!p) {  // a caller's mistake; reported as the unit's failure rather than thrown
      UnitDone none;
      none.status = UnitStatus::Failed;
      none.reason = "no unit enqueued on lane " + std::to_string(lane);
      return none;
    }
    if (!p->stream) return p->done;  // the CPU stand-in: it ran on enqueue
    UnitDone done = outcome([&] { finish(*p); });
    done.ended = std::chrono::steady_clock::now();
#if RED_TORCH_EVENT_TIMING
    if (done.status == UnitStatus::Completed) {
      try {
        const std::chrono::duration<double, std::milli> ms(p->start->elapsedTime(*p->end));
        done.started =
            done.ended - std::chrono::duration_cast<std::chrono::steady_clock::duration>(ms);
      } catch (...) {  // NOLINT(bugprone-empty-catch): no device time; started stays unknown
      }
    }
#endif
    return done;
  }

 private:
  // Runs fn, turning LibTorch's exceptions into the runtime's (docs/DESIGN.md, "Synchronization"):
  // out of memory into OutOfMemoryError, any other c10::Error into a runtime_error naming LibTorch.
  // Others (the backend's own runtime_errors) pass unchanged.
  template <typename F>
  static void translated(F&& fn) {
    try {
      std::forward<F>(fn)();
    } catch (const c10::OutOfMemoryError& e) {
      throw OutOfMemoryError(e.what_without_backtrace());
    } catch (const std::bad_alloc&) {
      throw OutOfMemoryError("host allocation failed");
    } catch (const c10::Error& e) {
      throw std::runtime_error(std::string("LibTorch: ") + e.what_without_backtrace());
    }
  }

  // How a unit running fn ended, as wait() reports it: the status and reason of what run()
  // would have thrown. Times are left to the caller.
  template <typename F>
  static UnitDone outcome(F&& fn) {
    UnitDone done;
    try {
      translated(std::forward<F>(fn));
    } catch (const OutOfMemoryError& e) {
      done.status = UnitStatus::OutOfMemory;
      done.reason = e.what();
    } catch (const std::exception& e) {
      done.status = UnitStatus::Failed;
      done.reason = e.what();
    } catch (...) {
      done.status = UnitStatus::Failed;
      done.reason = "unknown exception";
    }
    return done;
  }

  static void synchronize(const c10::Stream& stream) {
    c10::impl::getDeviceGuardImpl(stream.device_type())->synchronizeStream(stream);
  }

  // Waits until the device has run an enqueued unit (a GPU entry). Throws c10::Error.
  static void finish(const Pending& p) {
#if RED_TORCH_EVENT_TIMING
    p.end->synchronize();
#else
    // c10::Event cannot synchronize before LibTorch 2.6: the stream drains instead.
    synchronize(*p.stream);
#endif
  }

  // Lets go of every unit still enqueued on any lane, after the device has run it (their
  // lanes' threads may be gone: the FIFOs are the backend's, not thread-locals).
  void drain_pending() noexcept {
    std::map<int, std::deque<Pending>> left;
    {
      std::lock_guard lock(pending_mu_);
      left.swap(pending_);
    }
    for (auto& [lane, units] : left)
      for (const Pending& p : units) {
        if (!p.stream) continue;
        try {
          finish(p);
        } catch (...) {  // NOLINT(bugprone-empty-catch): no one waits for its outcome now
        }
      }
  }

  // A received frame's pixels, HWC uint8 -> 1 x C x H x W in [0, 1] on the model's device.
  at::Tensor to_tensor(const FrameView& px) const {
    const auto& in = scenario_.model.input;  // C, H, W
    at::Tensor t =
        at::from_blob(const_cast<std::uint8_t*>(px.data), {px.height, px.width, px.channels},
                      at::TensorOptions().dtype(at::kByte))
            .permute({2, 0, 1})
            .to(at::kFloat)
            .div_(255.0);
    if (px.channels != in[0]) t = t.mean(0, true).expand({in[0], in[1], in[2]});
    return t.unsqueeze(0).contiguous().to(model_->device());
  }

  at::Tensor synthetic_frame(int sensor, std::uint64_t frame) {
    std::call_once(pool_once_, [this] {
      c10::InferenceMode guard;
      pool_.resize(scenario_.sensors.size());
      for (std::size_t s = 0; s < pool_.size(); ++s)
        for (std::uint64_t i = 0; i < kPoolFrames; ++i)
          pool_[s].push_back(model_->make_input(
              1, hash_combine(hash_combine(scenario_.seed, static_cast<std::uint64_t>(s)), i)));
    });
    return pool_[static_cast<std::size_t>(sensor)][frame % kPoolFrames];
  }

  at::Tensor frame(int sensor, std::uint64_t id) const {
    std::shared_ptr<FrameInput> input;
    if (!frames_.get(sensor, id, input))
      throw std::runtime_error("frame " + std::to_string(id) + " of sensor " +
                               scenario_.sensors[static_cast<std::size_t>(sensor)].name +
                               " is no longer in memory");
    // A received frame is converted here, once, by the first unit that reads it; the
    // received pixels go as soon as the tensor exists.
    std::call_once(input->once, [&] {
      if (!input->lazy) return;
      input->tensor = to_tensor(input->lazy->pixels());
      input->lazy.reset();
    });
    return input->tensor;
  }

  Features features(int sensor, std::uint64_t id) const {
    Features f;
    if (!features_.get(sensor, id, f))
      throw std::runtime_error("encoder output of frame " + std::to_string(id) +
                               " is not available");
    return f;
  }

  int model_head(int scenario_head) const {
    return head_map_[static_cast<std::size_t>(scenario_head)];
  }

  static void spin(Duration t) {
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::duration_cast<std::chrono::steady_clock::duration>(t);
    while (std::chrono::steady_clock::now() < until) {
    }
  }

  // Runs one unit. With `keep`, every tensor it reads or writes (frames, encoder outputs,
  // its own outputs) is appended there, for an enqueued unit to hold until it has ended.
  void execute(const Dispatch& d, std::vector<at::Tensor>* keep) {
    const auto hold = [keep](const at::Tensor& t) {
      if (keep) keep->push_back(t);
    };
    const auto hold_all = [keep](const std::vector<at::Tensor>& ts) {
      if (keep) keep->insert(keep->end(), ts.begin(), ts.end());
    };
    switch (d.kind) {
      case UnitKind::Encoder: {
        // One encoder run per task (a distinct frame); a batch runs as one tensor batch
        // and every merged member reads the same output.
        // A batch may hold frames of different sensors (one encoder for all of them).
        std::vector<at::Tensor> inputs;
        std::vector<std::pair<int, std::uint64_t>> ids;
        for (std::size_t t = 0; t + 1 < d.task_begin.size(); ++t) {
          const Member& m = d.members[static_cast<std::size_t>(d.task_begin[t])];
          const int sensor = m.graph->units[static_cast<std::size_t>(m.unit)].sensor;
          inputs.push_back(frame(sensor, m.frame));
          ids.emplace_back(sensor, m.frame);
        }
        const Features f = model_->encode(inputs.size() == 1 ? inputs.front() : at::cat(inputs, 0));
        hold_all(inputs);
        hold_all(f);
        for (std::size_t i = 0; i < ids.size(); ++i) {
          Features one;
          for (const at::Tensor& x : f)
            one.push_back(ids.size() == 1 ? x : x.narrow(0, static_cast<std::int64_t>(i), 1));
          features_.put(ids[i].first, ids[i].second, std::move(one));
        }
        return;
      }
      case UnitKind::Head: {
        std::vector<Features> parts;
        for (const Member& m : d.members) {
          const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
          parts.push_back(features(ru.sensor, m.frame));
        }
        Features batch = parts.front();
        if (parts.size() > 1) {
          for (std::size_t k = 0; k < batch.size(); ++k) {
            std::vector<at::Tensor> xs;
            for (const Features& p : parts) xs.push_back(p[k]);
            batch[k] = at::cat(xs, 0);
          }
        }
        last_ = model_->head(model_head(d.head), batch);
        for (const Features& p : parts) hold_all(p);
        hold_all(batch);
        hold(last_);
        return;
      }
      case UnitKind::Coarse: {
        const Member& m = d.members.front();
        const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
        const at::Tensor input = frame(ru.sensor, m.frame);
        last_ = model_->full(model_head(ru.head), input);
        hold(input);
        hold(last_);
        return;
      }
      case UnitKind::Mono: {
        // The whole job as one unit: the encoder once per sensor, then every node.
        const Member& m = d.members.front();
        const RefinedGraph& g = *m.graph;
        std::map<int, Features> enc;
        for (int sensor : g.sensors) {
          // The member carries the first sensor's frame; other sensors use their newest.
          std::uint64_t id = m.frame;
          if (sensor != g.sensors.front() && !frames_.newest(sensor, id))
            throw std::runtime_error("no frame yet from sensor " +
                                     scenario_.sensors[static_cast<std::size_t>(sensor)].name);
          const at::Tensor input = frame(sensor, id);
          enc[sensor] = model_->encode(input);
          hold(input);
          hold_all(enc[sensor]);
        }
        for (int n : g.units.front().produces) {
          const NodeSpec& ns = g.spec->nodes[static_cast<std::size_t>(n)];
          if (ns.is_plain()) {
            spin(ns.cost->mean);
          } else {
            last_ = model_->head(model_head(ns.head), enc[ns.sensor]);
            hold(last_);
          }
        }
        return;
      }
      case UnitKind::Plain: {
        const Member& m = d.members.front();
        spin(m.graph->spec->nodes[static_cast<std::size_t>(m.node)].cost->mean);
        return;
      }
    }
  }

  const Scenario& scenario_;
  std::unique_ptr<Model> model_;
  std::vector<int> head_map_;  // scenario head index -> model head index
  std::string name_;
  const bool on_device_;     // a GPU: units are queued on lane streams (lane_stream_)
  const bool asynchronous_;  // asynchronous(): on_device_, or the CPU stand-in
  // Each lane's enqueued units, oldest first (enqueue(), wait()). By lane rather than
  // thread-local: end_run() lets go of what a lane's thread left.
  std::mutex pending_mu_;
  std::map<int, std::deque<Pending>> pending_;
  static constexpr std::uint64_t kPoolFrames = 4;  // synthetic frames per sensor
  std::once_flag pool_once_;
  std::vector<std::vector<at::Tensor>> pool_;  // per sensor, made once (synthetic_frame)
  Window<std::shared_ptr<FrameInput>> frames_;
  Window<Features> features_;
  thread_local static at::Tensor last_;  // keeps the latest output alive until the next
  thread_local static std::optional<c10::Stream> lane_stream_;  // this lane's GPU stream
};

thread_local at::Tensor TorchBackend::last_;
thread_local std::optional<c10::Stream> TorchBackend::lane_stream_;

}  // namespace

Expected<std::unique_ptr<Backend>> make_torch_backend(const Scenario& s, const std::string& device,
                                                      int threads, bool asynchronous) {
  ModelOptions o;
  o.heads = s.model.heads;
  o.input = s.model.input;
  o.device = device;
  o.threads = threads;
  o.manifest = s.model.manifest;
  o.seed = s.seed;
  auto model = Model::create(o);
  if (!model) return model.error();
  std::vector<int> head_map;
  for (const std::string& h : s.model.heads) {
    const int i = (*model)->head_index(h);
    if (i < 0) return Error{s.file, 0, "the model has no head '" + h + "'"};
    head_map.push_back(i);
  }
  return std::unique_ptr<Backend>(std::make_unique<TorchBackend>(
      s, std::move(model.value()), std::move(head_map), asynchronous));
}

}  // namespace red::torchb
