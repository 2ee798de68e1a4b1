#include "red/torch/profiler.hpp"

#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <c10/core/Allocator.h>
#include <c10/core/impl/DeviceGuardImplInterface.h>
#include <c10/util/ThreadLocalDebugInfo.h>
#include <torch/cuda.h>
#include <torch/version.h>
#include <unistd.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <fstream>
#include <functional>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "internal.hpp"
#include "red/profile/quality.hpp"
#include "red/runtime/wakeup_latency.hpp"
#include "unit_timer.hpp"

namespace red::torchb {

namespace {

using Clock = std::chrono::steady_clock;

// The allocator's running totals in c10's memory-reporting hook: int64_t up to LibTorch
// 1.13, size_t from 2.0 on.
#if TORCH_VERSION_MAJOR >= 2
using ReportedTotal = std::size_t;
#else
using ReportedTotal = std::int64_t;
#endif

/// Receives every allocation and free that LibTorch's allocators report on this thread
/// while installed as the thread's PROFILER_STATE debug info, and keeps the peak sum.
class PeakMeter final : public c10::MemoryReportingInfoBase {
 public:
  explicit PeakMeter(c10::DeviceType type) : type_(type) {}

  void reportMemoryUsage(void* /*ptr*/, std::int64_t alloc_size, ReportedTotal /*total_allocated*/,
                         ReportedTotal /*total_reserved*/, c10::Device device) override {
    if (device.type() != type_) return;
    live_ += alloc_size;
    peak_ = std::max(peak_, live_);
  }
  [[nodiscard]] bool memoryProfilingEnabled() const override { return true; }
  [[nodiscard]] std::int64_t peak() const noexcept { return peak_; }

 private:
  c10::DeviceType type_;
  std::int64_t live_ = 0;
  std::int64_t peak_ = 0;
};

/// The value at quantile q of sorted samples (nearest rank).
Duration nearest_rank(const std::vector<Duration>& sorted, double q) {
  const auto n = static_cast<double>(sorted.size());
  auto rank = static_cast<std::size_t>(std::ceil(q * n));
  rank = std::clamp<std::size_t>(rank, 1, sorted.size());
  return sorted[rank - 1];
}

LatencyStats summarize(std::vector<Duration> samples) {
  std::sort(samples.begin(), samples.end());
  LatencyStats s;
  s.samples = static_cast<int>(samples.size());
  s.min = samples.front();
  s.max = samples.back();
  const Duration total = std::accumulate(samples.begin(), samples.end(), Duration{0});
  s.mean = total / static_cast<std::int64_t>(samples.size());
  s.p50 = nearest_rank(samples, 0.50);
  s.p95 = nearest_rank(samples, 0.95);
  s.p99 = nearest_rank(samples, 0.99);
  return s;
}

/// The median of samples [first, last) (upper median for an even count).
Duration median_of(std::deque<Duration>::const_iterator first,
                   std::deque<Duration>::const_iterator last) {
  std::vector<Duration> v(first, last);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

class Profiler {
 public:
  Profiler(const ProfileOptions& options, const ProgressFn& progress)
      : options_(options), progress_(progress) {}

  /// Warms fn up (options.warmup untimed runs at least), then times options.runs runs of it.
  /// While the first `window` timed runs are slower than the rest by more than the
  /// tolerance (the unit was still cold: a GPU's first calls of a shape choose and load
  /// kernels, clocks ramp up), they count as warm-up and as many more are timed, up to
  /// warmup_max warm-up runs. A warm CPU unit thus costs no more runs than before.
  LatencyStats measure(const std::function<void()>& fn) {
    for (int i = 0; i < options_.warmup; ++i) fn();
    sync();
    int warmed = options_.warmup;
    std::deque<Duration> samples;
    for (int i = 0; i < options_.runs; ++i) samples.push_back(timer_.time(fn));
    const int w = window();
    // Cold: the first w timed runs are slower than the rest by more than the tolerance.
    const auto cold = [&] {
      const auto first = samples.begin() + w;
      const double head = static_cast<double>(median_of(samples.begin(), first).count());
      const double rest = static_cast<double>(median_of(first, samples.end()).count());
      return head > (1.0 + options_.tolerance) * rest;
    };
    while (w > 0 && cold()) {
      if (warmed + w > options_.warmup_max) {
        ++unstable_;
        break;
      }
      for (int i = 0; i < w; ++i) {
        samples.pop_front();
        samples.push_back(timer_.time(fn));
      }
      warmed += w;
    }
    LatencyStats s = summarize({samples.begin(), samples.end()});
    s.warmup_runs = warmed;
    return s;
  }

  /// On a GPU: keeps the device busy with fn for options.device_warmup_s before anything is
  /// measured (clocks up from idle, kernels loaded). Returns the seconds spent; 0 on a CPU.
  double warm_device(const std::function<void()>& fn) {
    if (!timer_.on_device() || options_.device_warmup_s <= 0) return 0.0;
    const auto start = Clock::now();
    const auto until = start + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(options_.device_warmup_s));
    while (Clock::now() < until) {
      fn();
      sync();
    }
    return std::chrono::duration<double>(Clock::now() - start).count();
  }

  void say(const std::string& message) const {
    if (progress_) progress_(message);
  }

  void set_device(const c10::Device& d) {
    timer_ = UnitTimer(
        d.is_cpu() || !c10::impl::hasDeviceGuardImpl(d.type()) ? nullptr : make_lane_device(d));
  }

  /// How the units were measured, for the profile.
  [[nodiscard]] Measurement measurement(double device_warmup_s) const {
    Measurement m;
    m.timing = timer_.method();
    m.warmup_min = options_.warmup;
    m.warmup_max = std::max(options_.warmup, options_.warmup_max);
    m.tolerance = options_.tolerance;
    m.window = window();
    m.device_warmup_s = std::round(device_warmup_s * 1000) / 1000;
    m.unstable = unstable_;
    return m;
  }

 private:
  void sync() const { timer_.sync(); }
  /// Timed runs compared at a time: a third of them at most; none without a warm-up.
  [[nodiscard]] int window() const {
    return options_.warmup > 0 ? std::min(options_.window, options_.runs / 3) : 0;
  }

  ProfileOptions options_;
  const ProgressFn& progress_;
  UnitTimer timer_;
  int unstable_ = 0;
};

void release_freed_memory() {
#if defined(__GLIBC__)
  // Hands freed heap pages back to the kernel so the next resident figure is not
  // inflated by the previous model's memory.
  malloc_trim(0);
#endif
}

std::string device_label(const c10::Device& d) {
  if (d.is_cpu()) {
    const int n = at::get_num_threads();
    return "cpu (" + std::to_string(n) + (n == 1 ? " thread)" : " threads)");
  }
  return d.str();
}

}  // namespace

std::int64_t resident_bytes() noexcept {
  std::ifstream statm("/proc/self/statm");
  long long size = 0;
  long long resident = 0;
  if (!(statm >> size >> resident)) return 0;
  const long page = sysconf(_SC_PAGESIZE);
  return page > 0 ? static_cast<std::int64_t>(resident) * page : 0;
}

std::int64_t peak_allocated_bytes(const c10::Device& device, const std::function<void()>& fn) {
  auto meter = std::make_shared<PeakMeter>(device.type());
  {
    c10::DebugInfoGuard guard(c10::DebugInfoKind::PROFILER_STATE, meter);
    fn();
  }
  return meter->peak();
}

Expected<Profile> profile_model(const ModelOptions& model, const ProfileOptions& options,
                                const ProgressFn& progress) {
  if (options.warmup < 0 || options.runs < 1 || options.max_batch < 1 ||
      options.coarse_max_batch < 1 || options.warmup_max < 0 || options.window < 0 ||
      !(options.tolerance >= 0) ||
      !(options.device_warmup_s >= 0 && options.device_warmup_s <= 600)) {
    return Error{"", 0,
                 "profile options: need warmup >= 0, warmup_max >= 0, window >= 0, tolerance "
                 ">= 0, device_warmup_s in [0, 600], runs >= 1, max_batch >= 1 and "
                 "coarse_max_batch >= 1"};
  }
  const auto wall_start = Clock::now();
  Profiler prof(options, progress);
  // Measured with idle cores polling, as a real run holds them (red/runtime/wakeup_latency.hpp):
  // the profile's times are then those of the machine state its runs meet.
  const WakeupLatencyHold wakeup = WakeupLatencyHold::zero();
  prof.say(wakeup.report());
  const int coarse_batches = std::min(options.coarse_max_batch, options.max_batch);
  std::string stage = "creating the model";
  try {
    ModelOptions shared_options = model;
    shared_options.separate = false;
    auto created = Model::create(shared_options);
    if (!created) return created.error();
    std::unique_ptr<Model> m = std::move(*created);
    prof.set_device(m->device());

    Profile p;
    p.source = "measured";
    p.device = device_label(m->device());
    p.model = m->label();
    // The machine around the measuring (quality.hpp): other processes' CPU time over it.
    const CpuSnapshot machine_before = cpu_snapshot();
    const int n_heads = static_cast<int>(m->heads().size());
    prof.say("profiling " + p.model + " on " + p.device + ": " + std::to_string(options.runs) +
             " runs per unit and batch size, timed by " + prof.measurement(0).timing +
             ", after at least " + std::to_string(options.warmup) +
             " warm-up runs and until the time is stable");

    // Memory of the shared model: one frame (batch 1) through the encoder and every head, keeping
    // every head's output until the frame is done (as a runtime would).
    MemoryStats shared_mem;
    shared_mem.parameter_bytes = m->parameter_bytes();
    shared_mem.resident_bytes = resident_bytes();
    {
      stage = "measuring the shared model's activations";
      const at::Tensor x = m->make_input(1, 1);
      shared_mem.peak_activation_bytes = peak_allocated_bytes(m->device(), [&] {
        const Features f = m->encode(x);
        std::vector<at::Tensor> outputs;
        for (int h = 0; h < n_heads; ++h) outputs.push_back(m->head(h, f));
      });
    }
    p.shared_memory = shared_mem;

    double device_warmup_s = 0;
    {
      stage = "warming the device up";
      const at::Tensor x = m->make_input(1, 1);
      device_warmup_s = prof.warm_device([&] {
        const Features f = m->encode(x);
        for (int h = 0; h < n_heads; ++h) (void)m->head(h, f);
      });
    }

    for (int b = 1; b <= options.max_batch; ++b) {
      const at::Tensor x = m->make_input(b, static_cast<std::uint64_t>(b));
      stage = "measuring encoder at batch " + std::to_string(b);
      prof.say(stage);
      p.units["encoder"].by_batch.push_back(prof.measure([&] { (void)m->encode(x); }));
      const Features f = m->encode(x);
      for (int h = 0; h < n_heads; ++h) {
        const std::string& name = m->heads()[static_cast<std::size_t>(h)];
        stage = "measuring head/" + name + " at batch " + std::to_string(b);
        prof.say(stage);
        p.units["head/" + name].by_batch.push_back(prof.measure([&] { (void)m->head(h, f); }));
      }
      if (b > coarse_batches) continue;
      for (int h = 0; h < n_heads; ++h) {
        const std::string& name = m->heads()[static_cast<std::size_t>(h)];
        stage = "measuring coarse/" + name + " at batch " + std::to_string(b);
        prof.say(stage);
        p.units["coarse/" + name].by_batch.push_back(prof.measure([&] { (void)m->full(h, x); }));
      }
    }
    m.reset();
    release_freed_memory();

    if (options.separate) {
      stage = "creating the separate networks";
      prof.say(stage);
      ModelOptions separate_options = model;
      separate_options.separate = true;
      auto sep_created = Model::create(separate_options);
      if (!sep_created) return sep_created.error();
      std::unique_ptr<Model> s = std::move(*sep_created);
      MemoryStats sep_mem;
      sep_mem.parameter_bytes = s->parameter_bytes();
      sep_mem.resident_bytes = resident_bytes();
      {
        stage = "measuring the separate networks' activations";
        const at::Tensor x = s->make_input(1, 1);
        sep_mem.peak_activation_bytes = peak_allocated_bytes(s->device(), [&] {
          std::vector<at::Tensor> outputs;
          for (int h = 0; h < n_heads; ++h) outputs.push_back(s->full(h, x));
        });
      }
      p.separate_memory = sep_mem;
      for (int b = 1; b <= coarse_batches; ++b) {
        const at::Tensor x = s->make_input(b, static_cast<std::uint64_t>(b));
        for (int h = 0; h < n_heads; ++h) {
          const std::string& name = s->heads()[static_cast<std::size_t>(h)];
          stage = "measuring separate/" + name + " at batch " + std::to_string(b);
          prof.say(stage);
          p.units["separate/" + name].by_batch.push_back(
              prof.measure([&] { (void)s->full(h, x); }));
        }
      }
    }
    p.measurement = prof.measurement(device_warmup_s);
    const MachineState machine =
        machine_between(machine_before, cpu_snapshot(), at::get_num_threads());
    p.quality = assess_quality(p, &machine);
    p.profile_wall_s = std::chrono::duration<double>(Clock::now() - wall_start).count();
    prof.say("profile done in " + std::to_string(p.profile_wall_s) + " s");
    return p;
  } catch (const std::exception& e) {
    return Error{model.manifest, 0, "profiling failed while " + stage + ": " + detail::describe(e)};
  }
}

}  // namespace red::torchb
