// User models: TorchScript modules exported by PyTorch (export_modules.py) give the same
// outputs through RED; bad manifests and bad files are errors naming file and line.

#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <torch/script.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "red/torch/manifest.hpp"
#include "red/torch/model.hpp"

namespace red::torchb {
namespace {

namespace fs = std::filesystem;

const std::string kModules = RED_TORCH_TEST_MODULES;

#define REQUIRE_MODULES()                                                                  \
  do {                                                                                     \
    if (kModules.empty()) GTEST_SKIP() << "no Python with PyTorch to export test modules"; \
  } while (false)

std::string module_path(const std::string& name) {
  return kModules + "/" + name;
}

/// A scratch directory of its own for one test.
std::string scratch(const std::string& test) {
  const fs::path dir = fs::path(RED_TORCH_TEST_SCRATCH) / test;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

struct Reference {
  at::Tensor input;
  std::map<std::string, at::Tensor> outputs;
};

Reference load_reference(const std::string& variant) {
  torch::jit::Module ref = torch::jit::load(module_path("reference_" + variant + ".pt"));
  Reference r;
  r.input = ref.attr("input").toTensor();
  for (const char* head : {"mask", "value"}) {
    r.outputs[head] = ref.attr(std::string("out_") + head).toTensor();
  }
  return r;
}

class ScriptModelMatchesPyTorch : public ::testing::TestWithParam<std::string> {};

TEST_P(ScriptModelMatchesPyTorch, SameOutputsAsPyTorch) {
  REQUIRE_MODULES();
  const std::string variant = GetParam();
  ModelOptions o;
  o.manifest = module_path(variant + ".yaml");
  auto created = Model::create(o);
  ASSERT_TRUE(created) << created.error().to_string();
  Model& m = **created;
  EXPECT_EQ(m.heads(), (std::vector<std::string>{"mask", "value"}));
  EXPECT_EQ(m.input_shape(), (std::vector<std::int64_t>{3, 64, 128}));
  EXPECT_EQ(m.label(), variant + ".yaml [3,64,128]");
  EXPECT_GT(m.encoder_cost().parameter_bytes, 0);
  EXPECT_EQ(m.encoder_cost().multiply_adds, -1);

  const Reference ref = load_reference(variant);
  const Features f = m.encode(ref.input);
  for (int h = 0; h < 2; ++h) {
    const std::string& name = m.heads()[static_cast<std::size_t>(h)];
    const at::Tensor& want = ref.outputs.at(name);
    const at::Tensor got = m.head(h, f);
    ASSERT_EQ(got.sizes(), want.sizes()) << name;
    EXPECT_TRUE(at::allclose(got, want, 1e-5, 1e-6))
        << name << ": max difference " << (got - want).abs().max().item<float>();
    EXPECT_TRUE(at::allclose(m.full(h, ref.input), want, 1e-5, 1e-6)) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Forms, ScriptModelMatchesPyTorch,
                         ::testing::Values("scripted", "traced", "list", "tensor"));

TEST(ScriptModel, SeparateModeLoadsOneEncoderPerHead) {
  REQUIRE_MODULES();
  ModelOptions o;
  o.manifest = module_path("scripted.yaml");
  auto shared = Model::create(o);
  o.separate = true;
  auto separate = Model::create(o);
  ASSERT_TRUE(shared && separate);
  EXPECT_EQ((*separate)->encoder_cost().parameter_bytes,
            2 * (*shared)->encoder_cost().parameter_bytes);
  const Reference ref = load_reference("scripted");
  EXPECT_TRUE(at::allclose((*separate)->full(1, ref.input), ref.outputs.at("value"), 1e-5, 1e-6));
  EXPECT_THROW((void)(*separate)->encode(ref.input), std::logic_error);
}

TEST(ScriptModel, HeadSubset) {
  REQUIRE_MODULES();
  ModelOptions o;
  o.manifest = module_path("traced.yaml");
  o.heads = {"value"};
  auto m = Model::create(o);
  ASSERT_TRUE(m) << m.error().to_string();
  EXPECT_EQ((*m)->heads(), (std::vector<std::string>{"value"}));
  o.heads = {"lane"};
  auto bad = Model::create(o);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("no head 'lane'"), std::string::npos);
}

TEST(ScriptModel, WrongInputShapeThrowsAtInference) {
  REQUIRE_MODULES();
  ModelOptions o;
  o.manifest = module_path("scripted.yaml");
  auto m = Model::create(o);
  ASSERT_TRUE(m);
  EXPECT_THROW((void)(*m)->encode(at::zeros({1, 3, 32, 32})), std::invalid_argument);
}

// --- Bad manifests: every error names the manifest and the line of the problem. ---

struct BadCase {
  const char* name;
  const char* yaml;  // {M} is replaced by the modules directory
  int line;
  const char* message_part;
};

void PrintTo(const BadCase& c, std::ostream* os) {
  *os << c.name;
}

std::string expand(std::string text) {
  for (auto p = text.find("{M}"); p != std::string::npos; p = text.find("{M}")) {
    text.replace(p, 3, kModules);
  }
  return text;
}

class BadManifest : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadManifest, ErrorNamesFileAndLine) {
  REQUIRE_MODULES();
  const BadCase& c = GetParam();
  const std::string dir = scratch(std::string("bad_manifest_") + c.name);
  write(dir, "garbage.pt", "this is not a zip archive\n");
  const std::string path = write(dir, "model.yaml", expand(c.yaml));
  ModelOptions o;
  o.manifest = path;
  auto m = Model::create(o);
  ASSERT_FALSE(m) << c.name;
  const Error& e = m.error();
  EXPECT_EQ(e.file, path) << e.to_string();
  EXPECT_EQ(e.line, c.line) << e.to_string();
  EXPECT_NE(e.message.find(c.message_part), std::string::npos) << e.to_string();
  EXPECT_EQ(e.to_string().rfind(path + ":" + std::to_string(c.line) + ": ", 0), 0U)
      << e.to_string();
}

const BadCase kBadCases[] = {
    {"unknown_key",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n"
     "input: [3, 64, 128]\nencodr: x.pt\n",
     4, "unknown key 'encodr'"},
    {"not_a_mapping", "- encoder\n- heads\n", 1, "must be a mapping"},
    {"missing_encoder_file",
     "heads: {mask: {M}/scripted_mask.pt}\nencoder: nowhere.pt\ninput: [3, 64, 128]\n", 2,
     "encoder file 'nowhere.pt' not found"},
    {"missing_head_file",
     "encoder: {M}/scripted_encoder.pt\nheads:\n  mask: {M}/scripted_mask.pt\n"
     "  lane: lane.pt\ninput: [3, 64, 128]\n",
     4, "head 'lane' file 'lane.pt' not found"},
    {"bad_input_shape",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n\n"
     "input: [3, 64]\n",
     4, "input must be [C, H, W]"},
    {"negative_input",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n"
     "input: [3, -64, 128]\n",
     3, "input must be [C, H, W]"},
    {"missing_key", "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n", 1,
     "missing key 'input'"},
    {"empty_heads", "encoder: {M}/scripted_encoder.pt\nheads: {}\ninput: [3, 64, 128]\n", 2,
     "heads must be a non-empty mapping"},
    {"bad_head_name",
     "encoder: {M}/scripted_encoder.pt\nheads:\n  head/1: {M}/scripted_mask.pt\n"
     "input: [3, 64, 128]\n",
     3, "bad head name 'head/1'"},
    {"bad_outputs",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n"
     "input: [3, 64, 128]\noutputs: dict\n",
     4, "outputs must be tensor, tuple or list"},
    {"yaml_syntax", "encoder: {M}/scripted_encoder.pt\nheads: [unclosed\ninput: [3, 64, 128]\n", 3,
     "YAML syntax error"},
    {"corrupt_pt",
     "encoder: {M}/scripted_encoder.pt\nheads:\n  mask: garbage.pt\ninput: [3, 64, 128]\n", 3,
     "is not a loadable TorchScript module"},
    {"state_dict_not_torchscript",
     "encoder: {M}/state_dict.pt\nheads: {mask: {M}/scripted_mask.pt}\ninput: [3, 64, 128]\n", 1,
     "is not a loadable TorchScript module"},
    {"encoder_rejects_input",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n"
     "input: [1, 64, 128]\n",
     1, "fails on an input [1,1,64,128]"},
    {"head_rejects_features",
     "encoder: {M}/list_encoder.pt\nheads:\n  value: {M}/list_value.pt\n"
     "  mask: {M}/tensor_mask.pt\ninput: [3, 64, 128]\n",
     4, "head 'mask'"},
    {"declared_form_differs",
     "encoder: {M}/scripted_encoder.pt\nheads: {mask: {M}/scripted_mask.pt}\n"
     "input: [3, 64, 128]\noutputs: list\n",
     4, "outputs: list declared, but encoder"},
};

INSTANTIATE_TEST_SUITE_P(Cases, BadManifest, ::testing::ValuesIn(kBadCases),
                         [](const ::testing::TestParamInfo<BadCase>& param) {
                           return std::string(param.param.name);
                         });

TEST(Manifest, MissingManifestFile) {
  ModelOptions o;
  o.manifest = "/nonexistent/model.yaml";
  auto m = Model::create(o);
  ASSERT_FALSE(m);
  EXPECT_EQ(m.error().file, "/nonexistent/model.yaml");
  EXPECT_NE(m.error().message.find("cannot open"), std::string::npos);
}

TEST(Manifest, RelativePathsResolveAgainstTheManifest) {
  REQUIRE_MODULES();
  auto m = load_manifest(module_path("traced.yaml"));
  ASSERT_TRUE(m) << m.error().to_string();
  EXPECT_EQ(m->encoder.path, module_path("traced_encoder.pt"));
  EXPECT_EQ(m->encoder.line, 2);
  ASSERT_EQ(m->heads.size(), 2U);
  EXPECT_EQ(m->heads[0].name, "mask");
  EXPECT_EQ(m->heads[1].line, 5);
  EXPECT_FALSE(m->outputs.has_value());
  EXPECT_EQ(m->input, (std::vector<std::int64_t>{3, 64, 128}));
}

}  // namespace
}  // namespace red::torchb
