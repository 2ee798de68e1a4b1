#pragma once
/// \file
/// Offline profiling (docs/DESIGN.md, "Profiles"): measures every unit of a model on its device and
/// fills a red::Profile that the simulator and the runtime read.
///
///     red::torchb::ModelOptions m;  m.threads = 2;
///     auto p = red::torchb::profile_model(m, {}, [](const std::string& s) { std::cerr << s; });
///     if (p) std::cout << red::profile_to_json(*p);

#include <functional>
#include <string>

#include "red/core/expected.hpp"
#include "red/profile/profile.hpp"
#include "red/torch/model.hpp"

namespace red::torchb {

/// How much to measure.
struct ProfileOptions {
  /// Untimed runs at least before the timed ones, per unit and batch size. Then the unit is
  /// warm when its time is stable: while the first `window` timed runs are slower than the
  /// rest by more than `tolerance`, they count as warm-up and as many more are timed, up to
  /// `warmup_max` warm-up runs. 0: no warm-up at all.
  int warmup = 3;
  int warmup_max = 60;
  double tolerance = 0.10;
  int window = 3;
  /// On a GPU, the device kept busy this long before the first unit is measured (clocks up,
  /// kernels chosen and loaded); 0 on the CPU.
  double device_warmup_s = 1.0;
  int runs = 30;      ///< timed runs per unit and batch size (LatencyStats::samples)
  int max_batch = 4;  ///< `encoder` and `head/<h>` are measured at batch sizes 1..max_batch
  /// `coarse/<h>` and `separate/<h>` are measured at batch sizes 1..min(this, max_batch).
  /// Default 1: the policies that run coarse units (fifo, edf, mono) never batch them
  /// (batching, docs/DESIGN.md "Batching", applies to fine units only), and it keeps the whole
  /// profile within its time budget.
  int coarse_max_batch = 1;
  /// Also build and measure separate mode (docs/DESIGN.md, "Task model").
  bool separate = true;
};

/// Progress messages, one line each (without a trailing newline).
using ProgressFn = std::function<void(const std::string&)>;

/// Profiles the model that `model` describes (its `separate` field is ignored: the shared
/// model is always measured, and separate mode too when options.separate). Fills units
/// `encoder`, `head/<h>`, `coarse/<h>` and `separate/<h>`, the memory figures, device,
/// model label and wall time; sync_round_trip keeps its default (the runtime measures it).
/// Errors: the model's creation errors (file and line), bad options, or a model that
/// throws while being measured.
Expected<Profile> profile_model(const ModelOptions& model, const ProfileOptions& options,
                                const ProgressFn& progress = {});

/// Bytes resident in memory for this process now (/proc/self/statm), or 0 if unknown.
std::int64_t resident_bytes() noexcept;

/// The largest sum of live bytes that the model's device allocator handed out on the
/// calling thread while `fn` ran (tensors allocated before `fn` are not counted). Uses
/// c10's memory-reporting hook (MemoryReportingInfoBase), which LibTorch's CPU allocator
/// and CUDA caching allocator both call; allocations made inside kernels by other
/// allocators (oneDNN scratch space) and on worker threads are not seen.
std::int64_t peak_allocated_bytes(const c10::Device& device, const std::function<void()>& fn);

}  // namespace red::torchb
