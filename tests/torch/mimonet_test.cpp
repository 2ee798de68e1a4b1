// The built-in MIMONet: shapes, determinism, cost split and separate mode. No timing.

#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "red/torch/model.hpp"

namespace red::torchb {
namespace {

std::unique_ptr<Model> make(const ModelOptions& o) {
  auto m = Model::create(o);
  if (!m) ADD_FAILURE() << m.error().to_string();
  return m ? std::move(*m) : nullptr;
}

/// One shared model for the tests that only read it (creating one costs a forward pass).
Model& shared_model() {
  static std::unique_ptr<Model> m = make(ModelOptions{});
  return *m;
}

std::vector<std::int64_t> expected_shape(const std::string& head, std::int64_t batch) {
  if (head == "lane") return {batch, 1, 192, 384};
  if (head == "seg") return {batch, 8, 192, 384};
  if (head == "steer") return {batch, 1};
  return {batch, (5 + 3) * 3, 12, 24};  // det: (5 + classes) * anchors on the stride-16 grid
}

TEST(MimoNet, DefaultHeadsInPaperOrder) {
  const Model& m = shared_model();
  EXPECT_EQ(m.heads(), (std::vector<std::string>{"lane", "seg", "steer", "det"}));
  EXPECT_EQ(m.head_index("seg"), 1);
  EXPECT_EQ(m.head_index("nope"), -1);
  EXPECT_EQ(m.input_shape(), (std::vector<std::int64_t>{3, 192, 384}));
  EXPECT_FALSE(m.separate());
  EXPECT_TRUE(m.device().is_cpu());
  EXPECT_EQ(m.label(), "mimonet [3,192,384]");
}

class MimoNetBatch : public ::testing::TestWithParam<int> {};

TEST_P(MimoNetBatch, EncoderFeaturesAndHeadShapes) {
  Model& m = shared_model();
  const int batch = GetParam();
  const at::Tensor x = m.make_input(batch, 3);
  const Features f = m.encode(x);
  ASSERT_EQ(f.size(), 3U);  // strides 4, 8, 16
  EXPECT_EQ(f[0].sizes().vec(), (std::vector<std::int64_t>{batch, 64, 48, 96}));
  EXPECT_EQ(f[1].sizes().vec(), (std::vector<std::int64_t>{batch, 144, 24, 48}));
  EXPECT_EQ(f[2].sizes().vec(), (std::vector<std::int64_t>{batch, 288, 12, 24}));
  for (int h = 0; h < 4; ++h) {
    const std::string& name = m.heads()[static_cast<std::size_t>(h)];
    const at::Tensor y = m.head(h, f);
    EXPECT_EQ(y.sizes().vec(), expected_shape(name, batch)) << name;
    EXPECT_TRUE(at::isfinite(y).all().item<bool>()) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Batches, MimoNetBatch, ::testing::Values(1, 3));

TEST(MimoNet, FullEqualsEncoderThenHead) {
  Model& m = shared_model();
  const at::Tensor x = m.make_input(2, 11);
  const Features f = m.encode(x);
  for (int h = 0; h < 4; ++h) {
    EXPECT_TRUE(at::allclose(m.full(h, x), m.head(h, f))) << m.heads()[static_cast<std::size_t>(h)];
  }
}

TEST(MimoNet, BatchedEqualsOneByOne) {
  Model& m = shared_model();
  const at::Tensor x = m.make_input(3, 5);
  const Features f = m.encode(x);
  const int steer = m.head_index("steer");
  const at::Tensor batched = m.head(steer, f);
  for (int i = 0; i < 3; ++i) {
    const at::Tensor one = m.full(steer, x.slice(0, i, i + 1));
    EXPECT_TRUE(at::allclose(batched.slice(0, i, i + 1), one, 1e-4, 1e-5));
  }
}

TEST(MimoNet, SeededWeightsAreDeterministic) {
  ModelOptions o;
  o.heads = {"steer", "lane"};
  auto a = make(o);
  auto b = make(o);
  o.seed = 2;
  auto c = make(o);
  ASSERT_TRUE(a && b && c);
  const at::Tensor x = a->make_input(1, 9);
  EXPECT_TRUE(at::equal(x, b->make_input(1, 9)));
  EXPECT_FALSE(at::equal(x, b->make_input(1, 10)));
  EXPECT_TRUE(at::equal(a->full(0, x), b->full(0, x)));
  EXPECT_FALSE(at::equal(a->full(0, x), c->full(0, x)));
  // A head's weights do not depend on which other heads are built.
  EXPECT_TRUE(at::equal(a->full(0, x), shared_model().full(shared_model().head_index("steer"), x)));
}

TEST(MimoNet, HeadSubsetInGivenOrder) {
  ModelOptions o;
  o.heads = {"det", "lane"};
  auto m = make(o);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->heads(), (std::vector<std::string>{"det", "lane"}));
  EXPECT_EQ(m->full(0, m->make_input(1, 1)).sizes().vec(), expected_shape("det", 1));
}

TEST(MimoNet, EncoderDominatesTheWork) {
  // docs/DESIGN.md, "Built-in model": the encoder must dominate the cost, as in the paper. Checked
  // on multiply-adds and parameters, not on time.
  const Model& m = shared_model();
  const UnitCost enc = m.encoder_cost();
  std::int64_t head_macs = 0;
  std::int64_t head_bytes = 0;
  for (int h = 0; h < 4; ++h) {
    const UnitCost c = m.head_cost(h);
    EXPECT_GT(c.multiply_adds, 0);
    EXPECT_GT(c.parameter_bytes, 0);
    EXPECT_LT(c.multiply_adds, enc.multiply_adds / 2);
    head_macs += c.multiply_adds;
    head_bytes += c.parameter_bytes;
  }
  const double mac_share =
      static_cast<double>(enc.multiply_adds) / static_cast<double>(enc.multiply_adds + head_macs);
  EXPECT_GT(mac_share, 0.6);
  EXPECT_LT(mac_share, 0.85);
  EXPECT_GT(enc.parameter_bytes, 2 * head_bytes);
  EXPECT_EQ(m.parameter_bytes(), enc.parameter_bytes + head_bytes);
}

TEST(MimoNet, SeparateModeHasFourEncoders) {
  ModelOptions o;
  o.separate = true;
  auto s = make(o);
  ASSERT_TRUE(s);
  const Model& m = shared_model();
  EXPECT_TRUE(s->separate());
  EXPECT_EQ(s->heads(), m.heads());
  EXPECT_EQ(s->encoder_cost().parameter_bytes, 4 * m.encoder_cost().parameter_bytes);
  EXPECT_EQ(s->encoder_cost().multiply_adds, 4 * m.encoder_cost().multiply_adds);
  for (int h = 0; h < 4; ++h) {
    EXPECT_EQ(s->head_cost(h).parameter_bytes, m.head_cost(h).parameter_bytes);
  }
  // docs/DESIGN.md, "Performance targets" target: shared ≤ 0.5x the parameters of four separate
  // networks.
  EXPECT_LT(static_cast<double>(m.parameter_bytes()),
            0.5 * static_cast<double>(s->parameter_bytes()));

  const at::Tensor x = s->make_input(1, 4);
  for (int h = 0; h < 4; ++h) {
    const std::string& name = s->heads()[static_cast<std::size_t>(h)];
    EXPECT_EQ(s->full(h, x).sizes().vec(), expected_shape(name, 1)) << name;
  }
  EXPECT_THROW((void)s->encode(x), std::logic_error);
}

TEST(MimoNet, ConcurrentCallsOnOneModel) {
  // Inference only reads the model: lanes may share one Model (model.hpp).
  ModelOptions o;
  o.input = {3, 64, 128};
  auto m = make(o);
  ASSERT_TRUE(m);
  const at::Tensor x = m->make_input(2, 8);
  std::vector<at::Tensor> want;
  for (int h = 0; h < 4; ++h) want.push_back(m->full(h, x));
  std::vector<std::vector<at::Tensor>> got(4);
  std::vector<std::thread> threads;
  for (int h = 0; h < 4; ++h) {
    threads.emplace_back([&, h] {
      for (int i = 0; i < 3; ++i) got[static_cast<std::size_t>(h)].push_back(m->full(h, x));
    });
  }
  for (auto& t : threads) t.join();
  for (std::size_t h = 0; h < 4; ++h) {
    for (const auto& y : got[h]) EXPECT_TRUE(at::allclose(y, want[h], 1e-5, 1e-6)) << h;
  }
}

TEST(MimoNet, WrongInputThrows) {
  Model& m = shared_model();
  EXPECT_THROW((void)m.encode(at::zeros({1, 3, 96, 384})), std::invalid_argument);
  EXPECT_THROW((void)m.encode(at::zeros({3, 192, 384})), std::invalid_argument);
  EXPECT_THROW((void)m.full(0, at::Tensor()), std::invalid_argument);
  EXPECT_THROW((void)m.make_input(0, 1), std::invalid_argument);
}

TEST(MimoNet, OtherInputSizes) {
  ModelOptions o;
  o.input = {1, 64, 96};
  auto m = make(o);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->label(), "mimonet [1,64,96]");
  const Features f = m->encode(m->make_input(2, 1));
  EXPECT_EQ(m->head(m->head_index("seg"), f).sizes().vec(),
            (std::vector<std::int64_t>{2, 8, 64, 96}));
  EXPECT_EQ(m->head(m->head_index("steer"), f).sizes().vec(), (std::vector<std::int64_t>{2, 1}));
}

TEST(MimoNet, BadOptionsAreErrors) {
  auto expect_error = [](const ModelOptions& o, const std::string& part) {
    auto m = Model::create(o);
    ASSERT_FALSE(m) << part;
    EXPECT_NE(m.error().message.find(part), std::string::npos) << m.error().to_string();
  };
  ModelOptions o;
  o.heads = {"lane", "radar"};
  expect_error(o, "unknown head 'radar'");
  o.heads = {"lane", "lane"};
  expect_error(o, "listed twice");
  o = ModelOptions{};
  o.input = {3, 100, 384};
  expect_error(o, "bad input shape [3,100,384]");
  o.input = {3, 192};
  expect_error(o, "bad input shape");
  o = ModelOptions{};
  o.device = "tpu";
  expect_error(o, "unknown device 'tpu'");
  o.device = "cuda:x";
  expect_error(o, "bad device");
  o = ModelOptions{};
  o.threads = -1;
  expect_error(o, "threads");
}

TEST(ParseDevice, CpuAndCuda) {
  auto cpu = parse_device("cpu");
  ASSERT_TRUE(cpu);
  EXPECT_TRUE(cpu->is_cpu());
  auto cuda = parse_device("cuda:0");
  if (cuda) {
    EXPECT_TRUE(cuda->is_cuda());  // only on a CUDA build with a GPU
  } else {
    EXPECT_NE(cuda.error().message.find("cuda"), std::string::npos);
  }
}

}  // namespace
}  // namespace red::torchb
