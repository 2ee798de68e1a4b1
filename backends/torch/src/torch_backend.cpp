#include "red/torch/torch_backend.hpp"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>
#include <c10/core/Stream.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>
#include <c10/util/Exception.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "red/core/rng.hpp"
#include "red/torch/model.hpp"

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
// for them (§14: a DDS frame is released first, converted later; LazyFrame). Thread-safe:
// the first lane to ask converts, others wait for it.
struct FrameInput {
  std::shared_ptr<const LazyFrame> lazy;
  std::once_flag once;
  at::Tensor tensor;
};

class TorchBackend final : public Backend {
 public:
  TorchBackend(const Scenario& s, std::unique_ptr<Model> model, std::vector<int> head_map)
      : scenario_(s),
        model_(std::move(model)),
        head_map_(std::move(head_map)),
        name_("torch " + model_->device().str()) {}

  [[nodiscard]] std::string_view name() const noexcept override { return name_; }

  // On a GPU every lane runs on its own stream from the device's pool (§6: one lane per
  // CUDA stream), set as the lane thread's current stream. Device-generic c10 interface:
  // it builds against a CPU-only LibTorch and uses CUDA when the LibTorch has it.
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
  // lane's last output went with its handler thread).
  void end_run() override {
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
    try {
      c10::InferenceMode guard;
      execute(d);
      // Kernels are queued asynchronously on a GPU: the unit ends when its stream drains.
      if (lane_stream_)
        c10::impl::getDeviceGuardImpl(lane_stream_->device_type())
            ->synchronizeStream(*lane_stream_);
    } catch (const c10::OutOfMemoryError& e) {
      throw OutOfMemoryError(e.what_without_backtrace());
    } catch (const std::bad_alloc&) {
      throw OutOfMemoryError("host allocation failed");
    } catch (const c10::Error& e) {
      throw std::runtime_error(std::string("LibTorch: ") + e.what_without_backtrace());
    }
  }

 private:
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

  void execute(const Dispatch& d) {
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
        return;
      }
      case UnitKind::Coarse: {
        const Member& m = d.members.front();
        const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
        last_ = model_->full(model_head(ru.head), frame(ru.sensor, m.frame));
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
          enc[sensor] = model_->encode(frame(sensor, id));
        }
        for (int n : g.units.front().produces) {
          const NodeSpec& ns = g.spec->nodes[static_cast<std::size_t>(n)];
          if (ns.is_plain())
            spin(ns.cost->mean);
          else
            last_ = model_->head(model_head(ns.head), enc[ns.sensor]);
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
                                                      int threads) {
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
  return std::unique_ptr<Backend>(
      std::make_unique<TorchBackend>(s, std::move(model.value()), std::move(head_map)));
}

}  // namespace red::torchb
