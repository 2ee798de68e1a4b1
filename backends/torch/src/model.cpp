#include "red/torch/model.hpp"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>
#include <c10/core/InferenceMode.h>
#include <c10/util/Exception.h>
#include <torch/cuda.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <charconv>
#include <stdexcept>
#include <utility>

#include "internal.hpp"
#include "red/core/assert.hpp"

namespace red::torchb {

namespace detail {

std::string describe(const std::exception& e) {
  // c10::Error carries a C++ backtrace after the message; what_without_backtrace() drops
  // it. TorchScript runtime errors put the useful line last ("RuntimeError: ..."), after
  // a TorchScript traceback, so prefer such a line when there is one.
  const auto* c10e = dynamic_cast<const c10::Error*>(&e);
  const std::string text = c10e != nullptr ? c10e->what_without_backtrace() : e.what();
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    const auto first = line.find_first_not_of(" \t");
    if (first != std::string::npos) lines.push_back(line.substr(first));
    start = end + 1;
  }
  if (lines.empty()) return "unknown error";
  for (auto it = lines.rbegin(); it != lines.rend(); ++it) {
    if (it->rfind("RuntimeError: ", 0) == 0) return it->substr(14);
  }
  return lines.front();
}

std::string shape_string(const std::vector<std::int64_t>& shape) {
  std::string s = "[";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) s += ',';
    s += std::to_string(shape[i]);
  }
  return s + "]";
}

}  // namespace detail

namespace {

void retain_freed_memory() {
#if defined(__GLIBC__)
  // Fixed thresholds also switch off glibc's dynamic threshold adjustment. Blocks up to
  // 32 MiB (the largest glibc accepts) come from the heap and are reused across forward
  // passes; freed heap memory is only trimmed past 1 GiB.
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

}  // namespace

const std::vector<std::string>& builtin_heads() {
  static const std::vector<std::string> kHeads{"lane", "seg", "steer", "det"};
  return kHeads;
}

Expected<c10::Device> parse_device(const std::string& text) {
  if (text == "cpu") return c10::Device(c10::kCPU);
  if (text == "cuda" || text.rfind("cuda:", 0) == 0) {
    int index = 0;
    if (text.size() > 5) {
      const char* first = text.data() + 5;
      const char* last = text.data() + text.size();
      auto [ptr, ec] = std::from_chars(first, last, index);
      if (ec != std::errc{} || ptr != last || index < 0) {
        return Error{"", 0, "bad device '" + text + "' (expected cpu, cuda or cuda:N)"};
      }
    }
    if (!torch::cuda::is_available()) {
      return Error{"", 0,
                   "device '" + text + "' asked for, but this LibTorch has no CUDA support " +
                       "or sees no GPU"};
    }
    // device_count() is size_t up to LibTorch 2.6 and c10::DeviceIndex later.
    const auto visible = static_cast<std::size_t>(torch::cuda::device_count());
    if (static_cast<std::size_t>(index) >= visible) {
      return Error{
          "", 0,
          "device '" + text + "': only " + std::to_string(visible) + " CUDA device(s) visible"};
    }
    return c10::Device(c10::kCUDA, static_cast<c10::DeviceIndex>(index));
  }
  return Error{"", 0, "unknown device '" + text + "' (expected cpu, cuda or cuda:N)"};
}

Expected<std::unique_ptr<Model>> Model::create(const ModelOptions& options) {
  try {
    auto device = parse_device(options.device);
    if (!device) return device.error();
    if (options.threads < 0) {
      return Error{"", 0, "threads must be >= 0, not " + std::to_string(options.threads)};
    }
    if (options.threads > 0) at::set_num_threads(options.threads);
    if (options.retain_freed_memory) retain_freed_memory();
    if (!options.manifest.empty()) return detail::create_script_model(options, *device);

    std::vector<std::string> heads = options.heads.empty() ? builtin_heads() : options.heads;
    for (std::size_t i = 0; i < heads.size(); ++i) {
      const auto& known = builtin_heads();
      if (std::find(known.begin(), known.end(), heads[i]) == known.end()) {
        return Error{"", 0,
                     "unknown head '" + heads[i] +
                         "' for the built-in model (expected lane, seg, steer or det)"};
      }
      if (std::find(heads.begin(), heads.begin() + static_cast<std::ptrdiff_t>(i), heads[i]) !=
          heads.begin() + static_cast<std::ptrdiff_t>(i)) {
        return Error{"", 0, "head '" + heads[i] + "' listed twice"};
      }
    }
    const auto& in = options.input;
    if (in.size() != 3 || in[0] < 1 || in[1] < 32 || in[2] < 32 || in[1] % 16 != 0 ||
        in[2] % 16 != 0) {
      return Error{"", 0,
                   "bad input shape " + detail::shape_string(in) +
                       " for the built-in model (expected C,H,W with C >= 1 and H, W " +
                       "multiples of 16, at least 32)"};
    }
    return detail::create_mimonet(options, heads, *device);
  } catch (const std::exception& e) {
    return Error{options.manifest, 0, "cannot create the model: " + detail::describe(e)};
  }
}

Model::Model(std::vector<std::string> heads, std::vector<std::int64_t> input, bool separate,
             c10::Device device, std::string label)
    : heads_(std::move(heads)),
      input_(std::move(input)),
      separate_(separate),
      device_(device),
      label_(std::move(label)) {}

Model::~Model() = default;

int Model::head_index(const std::string& name) const noexcept {
  for (std::size_t i = 0; i < heads_.size(); ++i) {
    if (heads_[i] == name) return static_cast<int>(i);
  }
  return -1;
}

at::Tensor Model::make_input(int batch, std::uint64_t seed) const {
  if (batch < 1) throw std::invalid_argument("batch must be >= 1, not " + std::to_string(batch));
  at::Generator gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  std::vector<std::int64_t> shape{batch};
  shape.insert(shape.end(), input_.begin(), input_.end());
  // Made on the CPU from a CPU generator so that a seed gives the same frame everywhere.
  at::Tensor x = at::rand(shape, gen, at::TensorOptions().dtype(at::kFloat));
  return x.to(device_);
}

void Model::check_input(const at::Tensor& input) const {
  bool ok = input.defined() && input.dim() == 4 && input.size(0) >= 1;
  for (std::size_t i = 0; ok && i < 3; ++i) {
    ok = input.size(static_cast<std::int64_t>(i) + 1) == input_[i];
  }
  if (!ok) {
    const std::vector<std::int64_t> got =
        input.defined() ? input.sizes().vec() : std::vector<std::int64_t>{};
    throw std::invalid_argument("input " + detail::shape_string(got) + " does not match " + label_ +
                                " (expected [B," + std::to_string(input_[0]) + "," +
                                std::to_string(input_[1]) + "," + std::to_string(input_[2]) + "])");
  }
  if (input.device() != device_) {
    throw std::invalid_argument("input on " + input.device().str() + ", model on " + device_.str());
  }
}

Features Model::encode(const at::Tensor& input) {
  if (separate_) throw std::logic_error("encode() has no shared encoder in separate mode");
  check_input(input);
  c10::InferenceMode guard;
  return do_encode(input);
}

at::Tensor Model::head(int h, const Features& features) {
  RED_ASSERT(h >= 0 && h < static_cast<int>(heads_.size()));
  if (separate_) throw std::logic_error("head() has no shared features in separate mode");
  c10::InferenceMode guard;
  return do_head(h, features);
}

at::Tensor Model::full(int h, const at::Tensor& input) {
  RED_ASSERT(h >= 0 && h < static_cast<int>(heads_.size()));
  check_input(input);
  c10::InferenceMode guard;
  if (separate_) return do_separate(h, input);
  return do_head(h, do_encode(input));
}

std::int64_t Model::parameter_bytes() const {
  std::int64_t total = encoder_cost().parameter_bytes;
  for (std::size_t h = 0; h < heads_.size(); ++h) {
    total += head_cost(static_cast<int>(h)).parameter_bytes;
  }
  return total;
}

}  // namespace red::torchb
