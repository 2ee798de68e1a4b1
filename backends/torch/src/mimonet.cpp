// The built-in MIMONet (docs/DESIGN.md, "Built-in model"): a shared convolutional encoder with
// feature maps at strides 4, 8 and 16, and four heads shaped like the paper's task models (Table
// 1): lane (ENet-like light decoder to a 1-channel mask), seg (UNet-like decoder with skips), steer
// (PilotNet-like convolutions and fully connected layers to one value) and det (YOLO-like grid
// head). Weights are seeded random; compute and memory are real, outputs are not meaningful.
//
// Sizing (`red profile`, 2 intra-op threads on a 2-core x86 CPU, input [3,192,384],
// batch 1): encoder about 13 ms, encoder + four heads about 19 ms, the encoder about
// 70 % of it; by multiply-adds the encoder is 81 % (1.93 G of 2.40 G).
// Upsampling is nearest-neighbour with a 3x3 convolution rather than a transposed
// convolution: LibTorch's CPU ConvTranspose2d is several times slower than the
// equivalent work, which would have made the heads dominate.

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>
#include <torch/nn/init.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/batchnorm.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>
#include <torch/utils.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "internal.hpp"
#include "red/core/rng.hpp"

namespace red::torchb::detail {
namespace {

// Channel widths of the encoder's stages (strides 2, 4, 8, 16) and the blocks per stage.
constexpr std::int64_t kStem = 32;
constexpr std::int64_t kWidth4 = 64;
constexpr std::int64_t kWidth8 = 144;
constexpr std::int64_t kWidth16 = 288;
constexpr int kBlocks8 = 3;
constexpr int kBlocks16 = 5;
constexpr std::int64_t kSegClasses = 8;  // UNet-like segmentation classes
constexpr std::int64_t kDetClasses = 3;  // KITTI-like: car, pedestrian, cyclist
constexpr std::int64_t kDetAnchors = 3;  // YOLO anchors per grid cell

// Multiply-adds are counted into this while set (only while measuring, on one thread);
// the forward passes themselves keep no state, so inference can run concurrently.
thread_local std::int64_t* t_mac_counter = nullptr;

class MacScope {
 public:
  explicit MacScope(std::int64_t* counter) : previous_(t_mac_counter) { t_mac_counter = counter; }
  ~MacScope() { t_mac_counter = previous_; }
  MacScope(const MacScope&) = delete;
  MacScope& operator=(const MacScope&) = delete;

 private:
  std::int64_t* previous_;
};

/// Convolution, then (unless `plain`) batch norm and ReLU.
class ConvBlockImpl : public torch::nn::Module {
 public:
  ConvBlockImpl(std::int64_t in, std::int64_t out, std::int64_t kernel, std::int64_t stride = 1,
                bool plain = false)
      : plain_(plain), macs_per_output_(in * kernel * kernel) {
    conv_ = register_module("conv", torch::nn::Conv2d(torch::nn::Conv2dOptions(in, out, kernel)
                                                          .stride(stride)
                                                          .padding(kernel / 2)
                                                          .bias(plain)));
    torch::nn::init::kaiming_normal_(conv_->weight, 0.0, torch::kFanIn, torch::kReLU);
    if (!plain_) bn_ = register_module("bn", torch::nn::BatchNorm2d(out));
  }

  at::Tensor forward(const at::Tensor& x) {
    at::Tensor y = conv_->forward(x);
    if (!plain_) y = bn_->forward(y).relu_();
    if (t_mac_counter != nullptr) *t_mac_counter += y[0].numel() * macs_per_output_;
    return y;
  }

 private:
  bool plain_;
  std::int64_t macs_per_output_;
  torch::nn::Conv2d conv_{nullptr};
  torch::nn::BatchNorm2d bn_{nullptr};
};
TORCH_MODULE(ConvBlock);

/// Fully connected layer, optionally followed by ReLU.
class DenseImpl : public torch::nn::Module {
 public:
  DenseImpl(std::int64_t in, std::int64_t out, bool relu) : relu_(relu), macs_(in * out) {
    fc_ = register_module("fc", torch::nn::Linear(in, out));
  }

  at::Tensor forward(const at::Tensor& x) {
    at::Tensor y = fc_->forward(x);
    if (relu_) y = at::relu_(y);
    if (t_mac_counter != nullptr) *t_mac_counter += macs_;
    return y;
  }

 private:
  bool relu_;
  std::int64_t macs_;
  torch::nn::Linear fc_{nullptr};
};
TORCH_MODULE(Dense);

/// Blocks run in sequence.
class StageImpl : public torch::nn::Module {
 public:
  explicit StageImpl(std::vector<ConvBlock> blocks) : blocks_(std::move(blocks)) {
    for (std::size_t i = 0; i < blocks_.size(); ++i) register_module(std::to_string(i), blocks_[i]);
  }

  at::Tensor forward(at::Tensor x) {
    for (auto& b : blocks_) x = b->forward(x);
    return x;
  }

 private:
  std::vector<ConvBlock> blocks_;
};
TORCH_MODULE(Stage);

Stage make_stage(std::int64_t in, std::int64_t out, int blocks) {
  std::vector<ConvBlock> list;
  list.emplace_back(in, out, 3, 2);
  for (int i = 1; i < blocks; ++i) list.emplace_back(out, out, 3);
  return Stage(std::move(list));
}

at::Tensor upsample2(const at::Tensor& x) {
  return at::upsample_nearest2d(x, {x.size(2) * 2, x.size(3) * 2});
}

at::Tensor resize_to(const at::Tensor& x, std::int64_t h, std::int64_t w) {
  return at::upsample_bilinear2d(x, {h, w}, /*align_corners=*/false);
}

/// The shared encoder: feature maps at strides 4, 8 and 16.
class EncoderImpl : public torch::nn::Module {
 public:
  explicit EncoderImpl(std::int64_t channels) {
    stem_ = register_module("stem", Stage(std::vector<ConvBlock>{ConvBlock(channels, kStem, 3, 2),
                                                                 ConvBlock(kStem, kStem, 3)}));
    s4_ = register_module("s4", make_stage(kStem, kWidth4, 2));
    s8_ = register_module("s8", make_stage(kWidth4, kWidth8, kBlocks8));
    s16_ = register_module("s16", make_stage(kWidth8, kWidth16, kBlocks16));
  }

  Features forward(const at::Tensor& x) {
    at::Tensor f4 = s4_->forward(stem_->forward(x));
    at::Tensor f8 = s8_->forward(f4);
    at::Tensor f16 = s16_->forward(f8);
    return {std::move(f4), std::move(f8), std::move(f16)};
  }

 private:
  Stage stem_{nullptr}, s4_{nullptr}, s8_{nullptr}, s16_{nullptr};
};

/// A head: takes the encoder's features, returns the task's output.
class HeadImpl : public torch::nn::Module {
 public:
  virtual at::Tensor forward(const Features& f) = 0;
};

/// ENet-like lane detection: a light decoder from stride 16 to a full-size 1-channel mask.
class LaneHead final : public HeadImpl {
 public:
  LaneHead() {
    reduce_ = register_module("reduce", ConvBlock(kWidth16, 32, 1));
    up1_ = register_module("up1", ConvBlock(32, 16, 3));
    up2_ = register_module("up2", ConvBlock(16, 16, 3));
    out_ = register_module("out", ConvBlock(16, 1, 1, 1, /*plain=*/true));
  }

  at::Tensor forward(const Features& f) override {
    at::Tensor x = reduce_->forward(f[2]);
    x = up2_->forward(upsample2(up1_->forward(upsample2(x))));
    return resize_to(out_->forward(x), f[0].size(2) * 4, f[0].size(3) * 4);
  }

 private:
  ConvBlock reduce_{nullptr}, up1_{nullptr}, up2_{nullptr}, out_{nullptr};
};

/// UNet-like segmentation: upsampling decoder with skip connections from strides 8 and 4.
class SegHead final : public HeadImpl {
 public:
  SegHead() {
    up1_ = register_module("up1", ConvBlock(kWidth16, 64, 3));
    merge1_ = register_module("merge1", ConvBlock(64 + kWidth8, 64, 3));
    up2_ = register_module("up2", ConvBlock(64, 32, 3));
    merge2_ = register_module("merge2", ConvBlock(32 + kWidth4, 32, 3));
    out_ = register_module("out", ConvBlock(32, kSegClasses, 1, 1, /*plain=*/true));
  }

  at::Tensor forward(const Features& f) override {
    // Up-steps convolve at the low resolution, then upsample (the work of UNet's 2x2
    // up-convolution), and merge with the skip connection at the high one.
    at::Tensor x = merge1_->forward(at::cat({upsample2(up1_->forward(f[2])), f[1]}, 1));
    x = merge2_->forward(at::cat({upsample2(up2_->forward(x)), f[0]}, 1));
    return resize_to(out_->forward(x), f[0].size(2) * 4, f[0].size(3) * 4);
  }

 private:
  ConvBlock up1_{nullptr}, merge1_{nullptr}, up2_{nullptr}, merge2_{nullptr}, out_{nullptr};
};

/// PilotNet-like steering: strided convolutions, then fully connected 100-50-10-1.
class SteerHead final : public HeadImpl {
 public:
  SteerHead() {
    conv1_ = register_module("conv1", ConvBlock(kWidth16, 48, 3, 2));
    conv2_ = register_module("conv2", ConvBlock(48, 64, 3, 2));
    fc1_ = register_module("fc1", Dense(64 * 2 * 4, 100, true));
    fc2_ = register_module("fc2", Dense(100, 50, true));
    fc3_ = register_module("fc3", Dense(50, 10, true));
    fc4_ = register_module("fc4", Dense(10, 1, false));
  }

  at::Tensor forward(const Features& f) override {
    at::Tensor x = conv2_->forward(conv1_->forward(f[2]));
    x = at::adaptive_avg_pool2d(x, {2, 4}).flatten(1);
    return fc4_->forward(fc3_->forward(fc2_->forward(fc1_->forward(x))));
  }

 private:
  ConvBlock conv1_{nullptr}, conv2_{nullptr};
  Dense fc1_{nullptr}, fc2_{nullptr}, fc3_{nullptr}, fc4_{nullptr};
};

/// YOLO-like detection: a grid head at stride 16 with (5 + classes) * anchors channels.
class DetHead final : public HeadImpl {
 public:
  DetHead() {
    conv1_ = register_module("conv1", ConvBlock(kWidth16, 128, 3));
    conv2_ = register_module("conv2", ConvBlock(128, 128, 1));
    out_ = register_module("out",
                           ConvBlock(128, (5 + kDetClasses) * kDetAnchors, 1, 1, /*plain=*/true));
  }

  at::Tensor forward(const Features& f) override {
    return out_->forward(conv2_->forward(conv1_->forward(f[2])));
  }

 private:
  ConvBlock conv1_{nullptr}, conv2_{nullptr}, out_{nullptr};
};

std::shared_ptr<HeadImpl> make_head(const std::string& name) {
  if (name == "lane") return std::make_shared<LaneHead>();
  if (name == "seg") return std::make_shared<SegHead>();
  if (name == "steer") return std::make_shared<SteerHead>();
  return std::make_shared<DetHead>();  // names are checked by Model::create
}

// Every component has its own seed, derived from the model seed and its name, so a head's
// weights do not depend on which other heads are built, and separate mode's heads equal
// the shared model's.
std::uint64_t component_seed(std::uint64_t seed, const std::string& component) {
  return hash_combine(seed, hash_name(component));
}

std::int64_t tensor_bytes(const std::vector<at::Tensor>& tensors) {
  std::int64_t total = 0;
  for (const auto& t : tensors) total += t.numel() * static_cast<std::int64_t>(t.element_size());
  return total;
}

std::int64_t module_bytes(const torch::nn::Module& m) {
  return tensor_bytes(m.parameters()) + tensor_bytes(m.buffers());
}

/// One encoder and the heads it feeds (shared mode: all; separate mode: one).
struct Network {
  std::shared_ptr<EncoderImpl> encoder;
  std::vector<std::shared_ptr<HeadImpl>> heads;
};

class MimoNet final : public Model {
 public:
  MimoNet(const ModelOptions& options, std::vector<std::string> heads, const c10::Device& device)
      : Model(std::move(heads), options.input, options.separate, device,
              "mimonet " + shape_string(options.input) + (options.separate ? " separate" : "")) {
    const auto& names = this->heads();
    const std::size_t networks = separate() ? names.size() : 1;
    for (std::size_t n = 0; n < networks; ++n) {
      Network net;
      // Each separate network has its own encoder copy with its own weights.
      torch::manual_seed(component_seed(
          options.seed, separate() ? "encoder/" + names[n] : std::string("encoder")));
      net.encoder = std::make_shared<EncoderImpl>(options.input[0]);
      for (std::size_t h = 0; h < names.size(); ++h) {
        if (separate() && h != n) continue;
        torch::manual_seed(component_seed(options.seed, "head/" + names[h]));
        net.heads.push_back(make_head(names[h]));
      }
      net.encoder->to(device);
      net.encoder->eval();
      for (auto& head : net.heads) {
        head->to(device);
        head->eval();
      }
      nets_.push_back(std::move(net));
    }
    measure_costs();
  }

  UnitCost encoder_cost() const override { return encoder_cost_; }
  UnitCost head_cost(int h) const override { return head_costs_.at(static_cast<std::size_t>(h)); }

 protected:
  Features do_encode(const at::Tensor& input) override { return nets_[0].encoder->forward(input); }

  at::Tensor do_head(int h, const Features& features) override {
    check_features(features);
    return nets_[0].heads[static_cast<std::size_t>(h)]->forward(features);
  }

  at::Tensor do_separate(int h, const at::Tensor& input) override {
    Network& net = nets_[static_cast<std::size_t>(h)];
    return net.heads[0]->forward(net.encoder->forward(input));
  }

 private:
  static void check_features(const Features& f) {
    if (f.size() != 3 || f[0].dim() != 4 || f[1].dim() != 4 || f[2].dim() != 4) {
      throw std::invalid_argument("the built-in heads take the encoder's 3 feature maps");
    }
  }

  // Runs every unit once on a batch-1 frame, counting multiply-adds; this also checks that
  // the network runs at all on the requested input before create() returns.
  void measure_costs() {
    const at::Tensor x = make_input(1, 0);
    c10::InferenceMode guard;
    head_costs_.assign(heads().size(), UnitCost{});
    encoder_cost_ = UnitCost{0, 0};
    for (std::size_t n = 0; n < nets_.size(); ++n) {
      Network& net = nets_[n];
      std::int64_t encoder_macs = 0;
      Features f;
      {
        MacScope scope(&encoder_macs);
        f = net.encoder->forward(x);
      }
      encoder_cost_.parameter_bytes += module_bytes(*net.encoder);
      encoder_cost_.multiply_adds += encoder_macs;
      for (std::size_t i = 0; i < net.heads.size(); ++i) {
        const std::size_t h = separate() ? n : i;
        std::int64_t macs = 0;
        {
          MacScope scope(&macs);
          (void)net.heads[i]->forward(f);
        }
        head_costs_[h] = UnitCost{module_bytes(*net.heads[i]), macs};
      }
    }
  }

  std::vector<Network> nets_;
  UnitCost encoder_cost_;
  std::vector<UnitCost> head_costs_;
};

}  // namespace

Expected<std::unique_ptr<Model>> create_mimonet(const ModelOptions& options,
                                                const std::vector<std::string>& heads,
                                                const c10::Device& device) {
  return std::unique_ptr<Model>(std::make_unique<MimoNet>(options, heads, device));
}

}  // namespace red::torchb::detail
