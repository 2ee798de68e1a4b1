#include "red/torch/torch_backend.hpp"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>
#include <c10/util/Exception.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "device_lanes.hpp"
#include "red/core/rng.hpp"
#include "red/graph/refine.hpp"
#include "red/torch/lane_device.hpp"
#include "red/torch/model.hpp"
#include "settle.hpp"

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
// call on the CPU), or pixels whose tensor is made when the encoder first asks for it: a
// received frame converted later (docs/ROS2.md: a DDS frame is released first; LazyFrame), or
// on a device, pixels copied to host memory the device copies from without blocking.
// Thread-safe: the first lane to ask converts, others wait for it; on a device, other lanes'
// streams wait for the conversion's `ready` event.
struct FrameInput {
  std::shared_ptr<const LazyFrame> lazy;
  at::Tensor host;  // 8-bit H x W x C pixels in pinned memory (a device), kept with the frame
  std::once_flag once;
  at::Tensor tensor;
  std::shared_ptr<LaneDevice::Event> ready;  // the conversion's end (a device)
  LaneDevice::StreamId stream = 0;           // the stream it was converted on
};

// An encoder's output for one frame, with the event after which it exists on the device and
// the stream it was made on (a head on another lane's stream waits for it).
struct Output {
  Features features;
  std::shared_ptr<LaneDevice::Event> ready;
  LaneDevice::StreamId stream = 0;
};

// What a unit hands to later units once it is queued: an encoder's output per frame.
struct Published {
  int sensor = 0;
  std::uint64_t frame = 0;
  Features features;
};

class TorchBackend final : public Backend {
 public:
  TorchBackend(const Scenario& s, std::unique_ptr<Model> model, std::vector<int> head_map,
               bool asynchronous, std::shared_ptr<LaneDevice> device)
      : scenario_(s),
        model_(std::move(model)),
        head_map_(std::move(head_map)),
        name_("torch " + model_->device().str()),
        lanes_(device ? std::make_unique<DeviceLanes>(std::move(device)) : nullptr),
        asynchronous_(lanes_ != nullptr || asynchronous) {}

  ~TorchBackend() override = default;  // lanes_ waits for what the device still runs
  TorchBackend(const TorchBackend&) = delete;
  TorchBackend& operator=(const TorchBackend&) = delete;

  [[nodiscard]] std::string_view name() const noexcept override { return name_; }

  // A GPU lane is a stream: units are enqueued on it and waited for (docs/DESIGN.md,
  // "Synchronization"). On the CPU only when asked (make_torch_backend's stand-in for tests).
  [[nodiscard]] bool asynchronous() const noexcept override { return asynchronous_; }

  // On a device every lane runs on a stream of its own from the device's pool (docs/DESIGN.md,
  // "Synchronization": one lane per CUDA stream), this backend's whatever thread calls, made
  // current for each of its calls; and gets its reference event (unit times).
  void init_lane(int lane) override {
    if (!lanes_) return;
    try {
      lanes_->init(lane);
    } catch (...) {  // NOLINT(bugprone-empty-catch): tried again, and reported, by the first unit
    }
  }

  // Before the run, every shape the run can use: the shared encoder on a batch of each size
  // from one to the largest (merged encoder runs cat frames into one batch) and every head on
  // that encoder's output (batched heads), or each full network in separate mode. In the
  // backend's first run each is called until its time settles (settle.hpp: TorchScript's
  // profiling executor optimizes on a later call, a GPU loads kernels); later runs call each
  // once. LibTorch's thread pools, its kernels' pages, the allocator's blocks for each size and
  // the heap's high-water mark are then in place, so that the run's first batch of a new size
  // is not slower than the next, and memory reached in one policy's run is already reached
  // before the first (a compare's policies then start level).
  void warm_up(int lane) noexcept override {
    try {
      c10::InferenceMode guard;
      std::optional<DeviceLanes::Current> current;
      if (lanes_) current.emplace(*lanes_, lane);
      if (!scenario_.sensors.empty()) (void)synthetic_frame(0, 0);  // the frame pool, once
      SettleRule rule;
      if (ran_.load(std::memory_order_acquire)) rule.max_calls = 1;
      const auto warm = [&](const std::function<void()>& fn) {
        (void)warm_until_settled([&] { return time_call(lane, fn); }, rule);
      };
      const int largest = std::max(1, scenario_.scheduler.max_batch);
      for (int batch = 1; batch <= largest; ++batch) {
        const at::Tensor input = model_->make_input(batch, scenario_.seed);
        if (model_->separate()) {
          for (int h : head_map_) warm([&] { (void)model_->full(h, input); });
          continue;
        }
        Features f;
        warm([&] { f = model_->encode(input); });
        for (int h : head_map_) warm([&] { (void)model_->head(h, f); });
      }
    } catch (...) {
      // A failure shows again, with its reason, when the run's first unit fails.
    }
  }

  // Between policies: the frames and encoder outputs of the run that ended go, and so do
  // units a lane enqueued and never waited for, once the device has finished them.
  void end_run() override {
    ran_.store(true, std::memory_order_release);
    if (lanes_) lanes_->drain();
    {
      std::lock_guard lock(lanes_mu_);
      cpu_done_.clear();
      last_.clear();
    }
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

  // Pixels given with the call: on the CPU made a tensor at once; on a device copied to host
  // memory the device copies from without blocking (a memcpy on the caller's thread), and
  // converted on the device by the first unit that reads them (frame()).
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
    } else if (lanes_) {
      input->host = host_copy(px);
    } else {
      c10::InferenceMode guard;
      input->tensor = to_tensor(px);
    }
    frames_.put(sensor, frame, std::move(input));
  }

  void run(int lane, const Dispatch& d) override {
    if (!lanes_) {
      translated([&] {
        c10::InferenceMode guard;
        std::vector<Published> published;
        execute(
            d, lane, nullptr, [] {}, published);
        publish(published, nullptr, 0);
      });
      return;
    }
    // On a device: queued on the lane's stream, then waited for (polling) like any unit.
    enqueue(lane, d);
    UnitDone done = lanes_->wait(lane);
    if (done.device_lost) throw DeviceLostError(done.reason);
    if (done.status != UnitStatus::Completed) throw std::runtime_error(done.reason);
  }

  // On a device: the unit's inputs are made ready on the lane's stream (a received frame's
  // copy and conversion, waits for other lanes' events), then its kernels are queued between
  // two events, and every tensor it touches is kept until it has ended. A plain unit is host
  // work, run and timed on the host by wait() once the units before it have ended. Throws
  // what run() throws when the unit cannot be queued (a frame gone, a missing encoder output,
  // an allocation), DeviceLostError once the device is lost. The CPU stand-in runs the unit
  // here and keeps how it ended for wait(): it never throws.
  void enqueue(int lane, const Dispatch& d) override {
    if (!lanes_) {
      UnitDone done;
      const auto started = std::chrono::steady_clock::now();
      done = outcome([&] {
        c10::InferenceMode guard;
        std::vector<Published> published;
        execute(
            d, lane, nullptr, [] {}, published);
        publish(published, nullptr, 0);
      });
      done.started = started;
      done.ended = std::chrono::steady_clock::now();
      std::lock_guard lock(lanes_mu_);
      cpu_done_[lane].push_back(std::move(done));
      return;
    }
    lanes_->sweep();
    if (std::string lost = lanes_->lost(); !lost.empty()) throw DeviceLostError(lost);
    DeviceLanes::Unit u;
    u.what = std::string(to_string(d.kind)) + " unit";
    if (d.kind == UnitKind::Plain) {
      u.host_work = plain_cost(d.members.front());
      lanes_->push(lane, std::move(u));
      return;
    }
    std::vector<Published> published;
    try {
      translated([&] {
        c10::InferenceMode guard;
        lanes_->renew(lane);
        const DeviceLanes::Current current(*lanes_, lane);
        execute(
            d, lane, &u.keep, [&] { u.start = lanes_->record(lane); }, published);
        u.end = lanes_->record(lane);
      });
    } catch (const std::exception& e) {
      // Kernels queued before the failure may read the tensors kept so far: they go once
      // the stream has run them. A fault that sticks to the device stops the run.
      lanes_->retire(lane, std::move(u.keep));
      if (dynamic_cast<const OutOfMemoryError*>(&e) == nullptr &&
          lanes_->check_lost(lane, u.what, e.what()))
        throw DeviceLostError(lanes_->lost());
      throw;
    }
    publish(published, u.end, lanes_->stream(lane));
    lanes_->push(lane, std::move(u));
  }

  // The lane's oldest enqueued unit: how it ended, with its times from the device's events
  // on the host's clock (DeviceLanes::wait, polling); a device error seen here is the unit's
  // failure, not a throw. Its tensors go after.
  UnitDone wait(int lane) override {
    if (lanes_) return lanes_->wait(lane);
    std::lock_guard lock(lanes_mu_);
    auto& done = cpu_done_[lane];
    if (done.empty()) {  // a caller's mistake; reported as the unit's failure rather than thrown
      UnitDone none;
      none.status = UnitStatus::Failed;
      none.reason = "no unit enqueued on lane " + std::to_string(lane);
      return none;
    }
    UnitDone u = std::move(done.front());
    done.pop_front();
    return u;
  }

  [[nodiscard]] bool ready(int lane) override { return !lanes_ || lanes_->ready(lane); }

  void abandon(int lane) override {
    if (lanes_) {
      lanes_->abandon(lane);
      return;
    }
    (void)wait(lane);  // the CPU stand-in's unit ran on enqueue
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

  // One call of fn, with the device's work it queued, on the host's clock (warm-up).
  Duration time_call(int lane, const std::function<void()>& fn) {
    if (!lanes_) {
      const auto t0 = std::chrono::steady_clock::now();
      fn();
      return std::chrono::duration_cast<Duration>(std::chrono::steady_clock::now() - t0);
    }
    const auto t0 = lanes_->device().now();
    fn();
    lanes_->finish(lane);
    return std::chrono::duration_cast<Duration>(lanes_->device().now() - t0);
  }

  // 8-bit pixels in host memory the device copies from without blocking.
  at::Tensor host_copy(const FrameView& px) const {
    at::Tensor h = lanes_->device().host_buffer({px.height, px.width, px.channels});
    std::memcpy(h.data_ptr(), px.data,
                static_cast<std::size_t>(px.height) * static_cast<std::size_t>(px.width) *
                    static_cast<std::size_t>(px.channels));
    return h;
  }

  // 8-bit H x W x C pixels -> 1 x C x H x W in [0, 1], where `pixels` is.
  at::Tensor convert(const at::Tensor& pixels) const {
    const auto& in = scenario_.model.input;  // C, H, W
    at::Tensor t = pixels.permute({2, 0, 1}).to(at::kFloat).div_(255.0);
    if (t.size(0) != in[0]) t = t.mean(0, true).expand({in[0], in[1], in[2]});
    return t.unsqueeze(0).contiguous();
  }

  // A received frame's pixels on the CPU, then on the model's device (a CPU model).
  at::Tensor to_tensor(const FrameView& px) const {
    const at::Tensor pixels =
        at::from_blob(const_cast<std::uint8_t*>(px.data), {px.height, px.width, px.channels},
                      at::TensorOptions().dtype(at::kByte));
    return convert(pixels).to(model_->device());
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

  // A frame's tensor for a unit on `lane`. A received frame is converted here, once, by the
  // first unit that reads it: on a device its pixels are copied on the lane's stream from
  // pinned memory without blocking and converted there, and a unit on another lane's stream
  // waits for that (the `ready` event).
  at::Tensor frame(int sensor, std::uint64_t id, int lane, std::vector<at::Tensor>* keep) {
    std::shared_ptr<FrameInput> input;
    if (!frames_.get(sensor, id, input))
      throw std::runtime_error("frame " + std::to_string(id) + " of sensor " +
                               scenario_.sensors[static_cast<std::size_t>(sensor)].name +
                               " is no longer in memory");
    std::call_once(input->once, [&] {
      if (input->tensor.defined()) return;
      if (!lanes_) {
        input->tensor = to_tensor(input->lazy->pixels());
        input->lazy.reset();  // the received pixels go as soon as the tensor exists
        return;
      }
      if (!input->host.defined()) input->host = host_copy(input->lazy->pixels());
      input->tensor = convert(lanes_->device().to_device(input->host));
      input->ready = lanes_->record(lane);
      input->stream = lanes_->stream(lane);
      input->lazy.reset();
    });
    if (lanes_ && input->ready) lanes_->block(lane, input->ready, input->stream);
    if (keep && input->host.defined()) keep->push_back(input->host);
    return input->tensor;
  }

  // An encoder output for a unit on `lane`; on a device the lane's stream waits for it when
  // another lane's stream made it (the scheduler's order alone does not order two streams).
  Features features(int sensor, std::uint64_t id, int lane) {
    Output o;
    if (!features_.get(sensor, id, o))
      throw std::runtime_error("encoder output of frame " + std::to_string(id) +
                               " is not available");
    if (lanes_ && o.ready) lanes_->block(lane, o.ready, o.stream);
    return o.features;
  }

  // Encoder outputs become available to later units once their unit is queued, with its end
  // event on a device.
  void publish(std::vector<Published>& published, const std::shared_ptr<LaneDevice::Event>& end,
               LaneDevice::StreamId stream) {
    for (Published& p : published)
      features_.put(p.sensor, p.frame, Output{std::move(p.features), end, stream});
  }

  int model_head(int scenario_head) const {
    return head_map_[static_cast<std::size_t>(scenario_head)];
  }

  Duration plain_cost(const Member& m) const {
    return m.graph->spec->nodes[static_cast<std::size_t>(m.node)].cost->mean;
  }

  // A plain task's work: the host spins for its cost.
  void spin(Duration t) const {
    if (lanes_) {
      lanes_->spin(t);
      return;
    }
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::duration_cast<std::chrono::steady_clock::duration>(t);
    while (std::chrono::steady_clock::now() < until) {
    }
  }

  void keep_last(int lane, const at::Tensor& t) {
    std::lock_guard lock(lanes_mu_);
    last_[lane] = t;
  }

  // Runs one unit on `lane`. Its inputs are gathered first (frames converted, waits for other
  // lanes' events queued), then `inputs_ready` is called (an enqueued unit's start event),
  // then the model runs. With `keep`, every tensor it reads or writes (frames, encoder
  // outputs, its own outputs) is appended there, for an enqueued unit to hold until it has
  // ended. An encoder's outputs go to `published`.
  void execute(const Dispatch& d, int lane, std::vector<at::Tensor>* keep,
               const std::function<void()>& inputs_ready, std::vector<Published>& published) {
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
          inputs.push_back(frame(sensor, m.frame, lane, keep));
          ids.emplace_back(sensor, m.frame);
        }
        inputs_ready();
        const Features f = model_->encode(inputs.size() == 1 ? inputs.front() : at::cat(inputs, 0));
        hold_all(inputs);
        hold_all(f);
        for (std::size_t i = 0; i < ids.size(); ++i) {
          Features one;
          for (const at::Tensor& x : f)
            one.push_back(ids.size() == 1 ? x : x.narrow(0, static_cast<std::int64_t>(i), 1));
          published.push_back({ids[i].first, ids[i].second, std::move(one)});
        }
        return;
      }
      case UnitKind::Head: {
        std::vector<Features> parts;
        for (const Member& m : d.members) {
          const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
          parts.push_back(features(ru.sensor, m.frame, lane));
        }
        inputs_ready();
        Features batch = parts.front();
        if (parts.size() > 1) {
          for (std::size_t k = 0; k < batch.size(); ++k) {
            std::vector<at::Tensor> xs;
            for (const Features& p : parts) xs.push_back(p[k]);
            batch[k] = at::cat(xs, 0);
          }
        }
        const at::Tensor out = model_->head(model_head(d.head), batch);
        keep_last(lane, out);
        for (const Features& p : parts) hold_all(p);
        hold_all(batch);
        hold(out);
        return;
      }
      case UnitKind::Coarse: {
        const Member& m = d.members.front();
        const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
        const at::Tensor input = frame(ru.sensor, m.frame, lane, keep);
        inputs_ready();
        const at::Tensor out = model_->full(model_head(ru.head), input);
        keep_last(lane, out);
        hold(input);
        hold(out);
        return;
      }
      case UnitKind::Mono: {
        // The whole job as one unit: the encoder once per sensor, then every node.
        const Member& m = d.members.front();
        const RefinedGraph& g = *m.graph;
        std::map<int, at::Tensor> inputs;
        for (int sensor : g.sensors) {
          // The member carries the first sensor's frame; other sensors use their newest.
          std::uint64_t id = m.frame;
          if (sensor != g.sensors.front() && !frames_.newest(sensor, id))
            throw std::runtime_error("no frame yet from sensor " +
                                     scenario_.sensors[static_cast<std::size_t>(sensor)].name);
          inputs[sensor] = frame(sensor, id, lane, keep);
        }
        inputs_ready();
        std::map<int, Features> enc;
        for (const auto& [sensor, input] : inputs) {
          enc[sensor] = model_->encode(input);
          hold(input);
          hold_all(enc[sensor]);
        }
        for (int n : g.units.front().produces) {
          const NodeSpec& ns = g.spec->nodes[static_cast<std::size_t>(n)];
          if (ns.is_plain()) {
            spin(ns.cost->mean);  // host work between the kernels it queued
          } else {
            const at::Tensor out = model_->head(model_head(ns.head), enc[ns.sensor]);
            keep_last(lane, out);
            hold(out);
          }
        }
        return;
      }
      case UnitKind::Plain: {
        inputs_ready();
        spin(plain_cost(d.members.front()));
        return;
      }
    }
  }

  const Scenario& scenario_;
  std::unique_ptr<Model> model_;
  std::vector<int> head_map_;  // scenario head index -> model head index
  std::string name_;
  // On a device (or its stand-in in tests): each lane's stream, its queued units and their
  // times (device_lanes.hpp). Null on the CPU.
  std::unique_ptr<DeviceLanes> lanes_;
  const bool asynchronous_;       // asynchronous(): a device, or the CPU stand-in
  std::atomic<bool> ran_{false};  // a run ended: later warm-ups call each shape once
  std::mutex lanes_mu_;
  // The CPU stand-in: each lane's units, run on enqueue, not yet waited for (oldest first).
  std::map<int, std::deque<UnitDone>> cpu_done_;
  // Each lane's latest output, kept until its next (by lane: one backend, many threads).
  std::map<int, at::Tensor> last_;
  static constexpr std::uint64_t kPoolFrames = 4;  // synthetic frames per sensor
  std::once_flag pool_once_;
  std::vector<std::vector<at::Tensor>> pool_;  // per sensor, made once (synthetic_frame)
  Window<std::shared_ptr<FrameInput>> frames_;
  Window<Output> features_;
};

}  // namespace

Expected<std::unique_ptr<Backend>> make_torch_backend(const Scenario& s, const std::string& device,
                                                      int threads, bool asynchronous,
                                                      std::shared_ptr<LaneDevice> lanes) {
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
  const c10::Device on = (*model)->device();
  if (!lanes && !on.is_cpu() && c10::impl::hasDeviceGuardImpl(on.type()))
    lanes = make_lane_device(on);
  return std::unique_ptr<Backend>(std::make_unique<TorchBackend>(
      s, std::move(model.value()), std::move(head_map), asynchronous, std::move(lanes)));
}

}  // namespace red::torchb
