// A user's multi-task model: TorchScript encoder and head files named by a manifest.

#include <ATen/ATen.h>
#include <ATen/core/ivalue.h>
#include <c10/core/InferenceMode.h>
#include <torch/script.h>

#include <algorithm>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "internal.hpp"
#include "red/torch/manifest.hpp"

namespace red::torchb::detail {
namespace {

std::int64_t module_bytes(const torch::jit::Module& m) {
  std::int64_t total = 0;
  for (const at::Tensor& t : m.parameters()) {
    total += t.numel() * static_cast<std::int64_t>(t.element_size());
  }
  for (const at::Tensor& t : m.buffers()) {
    total += t.numel() * static_cast<std::int64_t>(t.element_size());
  }
  return total;
}

/// What an encoder returned, as features and the form to hand them to a head in.
struct Converted {
  Features features;
  FeatureForm form = FeatureForm::Tensor;
};

std::optional<Converted> to_features(const c10::IValue& v) {
  Converted c;
  if (v.isTensor()) {
    c.features.push_back(v.toTensor());
    c.form = FeatureForm::Tensor;
    return c;
  }
  if (v.isTuple()) {
    c.form = FeatureForm::Tuple;
    for (const auto& e : v.toTupleRef().elements()) {
      if (!e.isTensor()) return std::nullopt;
      c.features.push_back(e.toTensor());
    }
    return c;
  }
  if (v.isList()) {
    c.form = FeatureForm::List;
    for (const c10::IValue& e : v.toListRef()) {
      if (!e.isTensor()) return std::nullopt;
      c.features.push_back(e.toTensor());
    }
    return c;
  }
  return std::nullopt;
}

c10::IValue to_ivalue(const Features& f, FeatureForm form) {
  switch (form) {
    case FeatureForm::Tensor:
      if (f.size() != 1) throw std::invalid_argument("this model's heads take one tensor");
      return c10::IValue(f[0]);
    case FeatureForm::Tuple:
      return c10::IValue(c10::ivalue::Tuple::create(std::vector<c10::IValue>(f.begin(), f.end())));
    case FeatureForm::List:
      return c10::IValue(c10::List<at::Tensor>(f));
  }
  throw std::logic_error("unknown feature form");
}

class ScriptModel final : public Model {
 public:
  ScriptModel(std::vector<std::string> heads, std::vector<std::int64_t> input, bool separate,
              const c10::Device& device, std::string label, FeatureForm form,
              std::vector<torch::jit::Module> encoders,
              std::vector<torch::jit::Module> head_modules)
      : Model(std::move(heads), std::move(input), separate, device, std::move(label)),
        form_(form),
        encoders_(std::move(encoders)),
        heads_(std::move(head_modules)) {
    encoder_cost_.multiply_adds = -1;
    for (const auto& e : encoders_) encoder_cost_.parameter_bytes += module_bytes(e);
    for (const auto& h : heads_) head_costs_.push_back(UnitCost{module_bytes(h), -1});
  }

  UnitCost encoder_cost() const override { return encoder_cost_; }
  UnitCost head_cost(int h) const override { return head_costs_.at(static_cast<std::size_t>(h)); }

 protected:
  Features do_encode(const at::Tensor& input) override { return run_encoder(encoders_[0], input); }

  at::Tensor do_head(int h, const Features& features) override {
    return run_head(heads_[static_cast<std::size_t>(h)], features);
  }

  at::Tensor do_separate(int h, const at::Tensor& input) override {
    const auto i = static_cast<std::size_t>(h);
    return run_head(heads_[i], run_encoder(encoders_[i], input));
  }

 private:
  Features run_encoder(torch::jit::Module& encoder, const at::Tensor& input) const {
    auto c = to_features(encoder.forward({input}));
    if (!c || c->form != form_) throw std::runtime_error("the encoder changed its output form");
    return std::move(c->features);
  }

  at::Tensor run_head(torch::jit::Module& head, const Features& features) const {
    c10::IValue out = head.forward({to_ivalue(features, form_)});
    if (!out.isTensor()) throw std::runtime_error("a head returned " + out.tagKind());
    return out.toTensor();
  }

  FeatureForm form_;
  std::vector<torch::jit::Module> encoders_;  // shared: one; separate: one per head
  std::vector<torch::jit::Module> heads_;
  UnitCost encoder_cost_;
  std::vector<UnitCost> head_costs_;
};

class Loader {
 public:
  Loader(const Manifest& m, const c10::Device& device) : m_(m), device_(device) {}

  Expected<torch::jit::Module> load(const ManifestFile& f) const {
    try {
      torch::jit::Module module = torch::jit::load(f.path, device_);
      module.eval();
      return module;
    } catch (const std::exception& e) {
      std::string why = describe(e);
      if (why.find("constants.pkl") != std::string::npos) {
        why += " (a torch.save() file? save TorchScript with torch.jit.script(m).save(path))";
      }
      return Error{m_.file, f.line,
                   "'" + f.path + "' is not a loadable TorchScript module: " + why};
    }
  }

  /// Runs encoder and heads once on a batch-1 frame: the form the encoder returns, or an
  /// error naming the manifest line of the part that failed.
  Expected<FeatureForm> probe(
      torch::jit::Module& encoder,
      const std::vector<std::pair<const ManifestFile*, torch::jit::Module*>>& heads) const {
    std::vector<std::int64_t> shape{1};
    shape.insert(shape.end(), m_.input.begin(), m_.input.end());
    const at::Tensor x = at::zeros(shape, at::TensorOptions().device(device_));
    c10::InferenceMode guard;
    c10::IValue out;
    try {
      out = encoder.forward({x});
    } catch (const std::exception& e) {
      return Error{m_.file, m_.encoder.line,
                   "encoder '" + m_.encoder.path + "' fails on an input " + shape_string(shape) +
                       ": " + describe(e)};
    }
    auto c = to_features(out);
    if (!c) {
      return Error{m_.file, m_.encoder.line,
                   "encoder '" + m_.encoder.path + "' returns " + out.tagKind() +
                       "; expected a tensor or a tuple or list of tensors"};
    }
    if (m_.outputs && *m_.outputs != c->form) {
      return Error{m_.file, m_.outputs_line,
                   std::string("outputs: ") + to_string(*m_.outputs) + " declared, but encoder '" +
                       m_.encoder.path + "' returns a " + to_string(c->form)};
    }
    const c10::IValue features = to_ivalue(c->features, c->form);
    for (const auto& [file, module] : heads) {
      c10::IValue y;
      try {
        y = module->forward({features});
      } catch (const std::exception& e) {
        return Error{m_.file, file->line,
                     "head '" + file->name + "' ('" + file->path +
                         "') fails on the encoder's output: " + describe(e)};
      }
      if (!y.isTensor()) {
        return Error{m_.file, file->line,
                     "head '" + file->name + "' ('" + file->path + "') returns " + y.tagKind() +
                         "; expected a tensor"};
      }
    }
    return c->form;
  }

 private:
  const Manifest& m_;
  c10::Device device_;
};

}  // namespace

Expected<std::unique_ptr<Model>> create_script_model(const ModelOptions& options,
                                                     const c10::Device& device) {
  auto manifest = load_manifest(options.manifest);
  if (!manifest) return manifest.error();
  const Manifest& m = *manifest;

  std::vector<const ManifestFile*> chosen;
  if (options.heads.empty()) {
    for (const auto& h : m.heads) chosen.push_back(&h);
  } else {
    for (const auto& name : options.heads) {
      auto it = std::find_if(m.heads.begin(), m.heads.end(),
                             [&](const ManifestFile& f) { return f.name == name; });
      if (it == m.heads.end()) {
        std::string have;
        for (const auto& h : m.heads) have += (have.empty() ? "" : ", ") + h.name;
        return Error{m.file, 0, "no head '" + name + "' in the manifest (it has " + have + ")"};
      }
      if (std::find(chosen.begin(), chosen.end(), &*it) != chosen.end()) {
        return Error{"", 0, "head '" + name + "' listed twice"};
      }
      chosen.push_back(&*it);
    }
  }

  const Loader loader(m, device);
  std::vector<torch::jit::Module> heads;
  for (const ManifestFile* f : chosen) {
    auto module = loader.load(*f);
    if (!module) return module.error();
    heads.push_back(std::move(*module));
  }
  // Separate mode: every head gets its own encoder, loaded from the file again.
  std::vector<torch::jit::Module> encoders;
  const std::size_t copies = options.separate ? chosen.size() : 1;
  for (std::size_t i = 0; i < copies; ++i) {
    auto module = loader.load(m.encoder);
    if (!module) return module.error();
    encoders.push_back(std::move(*module));
  }

  FeatureForm form = FeatureForm::Tensor;
  for (std::size_t n = 0; n < encoders.size(); ++n) {
    std::vector<std::pair<const ManifestFile*, torch::jit::Module*>> fed;
    for (std::size_t h = 0; h < heads.size(); ++h) {
      if (!options.separate || h == n) fed.emplace_back(chosen[h], &heads[h]);
    }
    auto probed = loader.probe(encoders[n], fed);
    if (!probed) return probed.error();
    form = *probed;
  }

  std::vector<std::string> names;
  for (const ManifestFile* f : chosen) names.push_back(f->name);
  std::string label = std::filesystem::path(m.file).filename().string() + " " +
                      shape_string(m.input) + (options.separate ? " separate" : "");
  return std::unique_ptr<Model>(
      std::make_unique<ScriptModel>(std::move(names), m.input, options.separate, device,
                                    std::move(label), form, std::move(encoders), std::move(heads)));
}

}  // namespace red::torchb::detail
