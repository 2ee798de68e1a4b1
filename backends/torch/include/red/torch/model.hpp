#pragma once
/// \file
/// A multi-task network on LibTorch (docs/DESIGN.md, "Built-in model"): one shared encoder unit and
/// named head units. Either the built-in MIMONet (seeded random weights: compute and memory are
/// real, the outputs are not meaningful) or a user model given as TorchScript files listed in a
/// model manifest (docs/MODELS.md).
///
///     red::torchb::ModelOptions o;                 // built-in MIMONet, four heads, CPU
///     auto m = red::torchb::Model::create(o);
///     if (!m) { std::cerr << m.error().to_string() << '\n'; return 2; }
///     at::Tensor x = (*m)->make_input(/*batch=*/2, /*seed=*/7);
///     red::torchb::Features f = (*m)->encode(x);   // the shared encoder, once
///     at::Tensor lane = (*m)->head((*m)->head_index("lane"), f);
///
/// Thread safety: create() is not thread-safe (it reseeds LibTorch's global generator
/// and may set process-wide settings: LibTorch's thread count, the C allocator's). Inference calls
/// (make_input, encode, head, full) only read the model and may run concurrently on one Model from
/// several threads (for TorchScript models this relies on torch::jit::Module::forward being
/// re-entrant, as LibTorch documents for inference). They allocate and are not real-time safe.

#include <ATen/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "red/core/expected.hpp"

namespace red::torchb {

/// What to load and where to run it.
struct ModelOptions {
  /// Heads to build, in this order; empty: every head of the model (built-in: lane, seg,
  /// steer, det; manifest: the manifest's heads in file order). Unknown names are errors.
  std::vector<std::string> heads;
  /// Input shape (C, H, W) of the built-in model; H and W multiples of 16. Ignored for a
  /// manifest (its `input` key gives the shape).
  std::vector<std::int64_t> input{3, 192, 384};
  /// Separate mode (docs/DESIGN.md, "Task model", the paper's "traditional DNNs"): one full network
  /// per head, each with its own copy of the encoder.
  bool separate = false;
  /// Seed of the built-in model's random weights (deterministic for a given seed).
  std::uint64_t seed = 1;
  /// "cpu", "cuda" or "cuda:N".
  std::string device = "cpu";
  /// Intra-op threads for LibTorch (a process-wide setting); 0 leaves LibTorch's default.
  int threads = 0;
  /// Path of a model manifest (YAML); empty selects the built-in MIMONet.
  std::string manifest;
  /// Keep memory that inference frees inside the process rather than handing it back to
  /// the kernel after every forward pass (glibc: fixes M_MMAP_THRESHOLD at 32 MiB and
  /// M_TRIM_THRESHOLD at 1 GiB; a process-wide setting). Without it, every frame's
  /// activations land on fresh pages: thousands of page faults per frame on the CPU
  /// (measured: ~4500 per encoder + seg pass at [3,192,384]), and a slower, noisier
  /// unit. Resident memory then stays at its high-water mark.
  bool retain_freed_memory = true;
};

/// The encoder's output: multi-scale feature maps (built-in: strides 4, 8 and 16), or
/// what a TorchScript encoder returned (one tensor, or the elements of its tuple/list).
using Features = std::vector<at::Tensor>;

/// Size and work of one unit for one frame (batch 1), without timing anything.
struct UnitCost {
  std::int64_t parameter_bytes = 0;  ///< parameters and buffers
  /// Multiply-adds of convolutions and fully connected layers for one frame; -1 where
  /// unknown (TorchScript models).
  std::int64_t multiply_adds = -1;
};

/// One loaded multi-task model (shared or separate mode). Create with Model::create().
class Model {
 public:
  /// Builds the built-in MIMONet (options.manifest empty) or loads the TorchScript model
  /// of a manifest, moves it to options.device and checks it with one forward pass of a
  /// batch-1 input. Errors (bad manifest, unreadable or invalid TorchScript file, a model
  /// that rejects its input or throws, unknown head or device) name the file and line;
  /// no LibTorch exception escapes.
  static Expected<std::unique_ptr<Model>> create(const ModelOptions& options);

  virtual ~Model();
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  /// Head names, indexed by head number.
  [[nodiscard]] const std::vector<std::string>& heads() const noexcept { return heads_; }
  /// The number of `name`, or -1 if the model has no such head.
  [[nodiscard]] int head_index(const std::string& name) const noexcept;
  /// Input shape (C, H, W) of one frame.
  [[nodiscard]] const std::vector<std::int64_t>& input_shape() const noexcept { return input_; }
  /// True in separate mode: head h is then a full network with its own encoder.
  [[nodiscard]] bool separate() const noexcept { return separate_; }
  /// Where the model's parameters live and inference runs.
  [[nodiscard]] const c10::Device& device() const noexcept { return device_; }
  /// A label for reports, e.g. "mimonet [3,192,384]" or "mynet.yaml [3,128,256]".
  [[nodiscard]] const std::string& label() const noexcept { return label_; }

  /// A synthetic camera frame batch [batch, C, H, W] with values in [0, 1) on the model's
  /// device; deterministic for a given seed. Throws std::invalid_argument if batch < 1.
  [[nodiscard]] at::Tensor make_input(int batch, std::uint64_t seed) const;

  /// Runs the shared encoder on a whole batch [B, C, H, W]. Throws std::invalid_argument
  /// on a wrong input shape or device, std::logic_error in separate mode (there is no
  /// shared encoder), and whatever the model throws (c10::Error).
  Features encode(const at::Tensor& input);
  /// Runs head h on (batched) features from encode(). Throws std::logic_error in
  /// separate mode and what the model throws. h must be a valid head number.
  at::Tensor head(int h, const Features& features);
  /// The coarse unit: encoder then head h on the same input; in separate mode, the full
  /// network h. Throws like encode().
  at::Tensor full(int h, const at::Tensor& input);

  /// Bytes of every parameter and buffer of the model (separate mode: of all networks).
  [[nodiscard]] std::int64_t parameter_bytes() const;
  /// The encoder's size and work (separate mode: summed over every encoder copy).
  [[nodiscard]] virtual UnitCost encoder_cost() const = 0;
  /// Head h's size and work (without any encoder).
  [[nodiscard]] virtual UnitCost head_cost(int h) const = 0;

 protected:
  Model(std::vector<std::string> heads, std::vector<std::int64_t> input, bool separate,
        c10::Device device, std::string label);

  virtual Features do_encode(const at::Tensor& input) = 0;
  virtual at::Tensor do_head(int h, const Features& features) = 0;
  /// Separate mode only: the full network h.
  virtual at::Tensor do_separate(int h, const at::Tensor& input) = 0;

 private:
  void check_input(const at::Tensor& input) const;

  std::vector<std::string> heads_;
  std::vector<std::int64_t> input_;
  bool separate_ = false;
  c10::Device device_;
  std::string label_;
};

/// The built-in head names, in their default order.
const std::vector<std::string>& builtin_heads();

/// Parses "cpu", "cuda" or "cuda:N"; CUDA must be available in this LibTorch build.
Expected<c10::Device> parse_device(const std::string& text);

}  // namespace red::torchb
