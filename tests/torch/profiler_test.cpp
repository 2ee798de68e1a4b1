// The profiler fills every unit, batch size and memory figure. Small options keep it fast;
// no assertion depends on how long anything took (only on orderings that always hold).

#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "red/torch/profiler.hpp"

namespace red::torchb {
namespace {

void expect_ordered(const LatencyStats& s, int runs, const std::string& where) {
  EXPECT_EQ(s.samples, runs) << where;
  EXPECT_GT(s.min.count(), 0) << where;
  EXPECT_LE(s.min, s.p50) << where;
  EXPECT_LE(s.p50, s.p95) << where;
  EXPECT_LE(s.p95, s.p99) << where;
  EXPECT_LE(s.p99, s.max) << where;
  EXPECT_LE(s.min, s.mean) << where;
  EXPECT_LE(s.mean, s.max) << where;
}

TEST(Profiler, FillsEveryUnitAndMemory) {
  ModelOptions m;
  m.input = {3, 64, 128};
  m.heads = {"lane", "steer"};
  ProfileOptions o;
  o.warmup = 1;
  o.runs = 3;
  o.max_batch = 2;
  o.coarse_max_batch = 2;
  std::vector<std::string> progress;
  auto p = profile_model(m, o, [&](const std::string& s) { progress.push_back(s); });
  ASSERT_TRUE(p) << p.error().to_string();
  EXPECT_FALSE(progress.empty());
  EXPECT_EQ(p->source, "measured");
  EXPECT_EQ(p->model, "mimonet [3,64,128]");
  EXPECT_EQ(p->device.rfind("cpu (", 0), 0U) << p->device;
  EXPECT_GT(p->profile_wall_s, 0.0);

  const std::vector<std::string> names{"encoder",       "head/lane",    "head/steer",
                                       "coarse/lane",   "coarse/steer", "separate/lane",
                                       "separate/steer"};
  EXPECT_EQ(p->units.size(), names.size());
  for (const auto& name : names) {
    const UnitProfile* u = p->find(name);
    ASSERT_NE(u, nullptr) << name;
    ASSERT_EQ(u->max_batch(), 2) << name;
    for (int b = 1; b <= 2; ++b) expect_ordered(u->at(b), 3, name + " batch " + std::to_string(b));
  }

  ASSERT_TRUE(p->shared_memory && p->separate_memory);
  EXPECT_GT(p->shared_memory->parameter_bytes, 0);
  EXPECT_GT(p->shared_memory->peak_activation_bytes, 0);
  EXPECT_GT(p->shared_memory->resident_bytes, 0);
  EXPECT_GT(p->separate_memory->parameter_bytes, p->shared_memory->parameter_bytes);
  EXPECT_GT(p->separate_memory->peak_activation_bytes, 0);
  EXPECT_EQ(p->sync_round_trip, Profile{}.sync_round_trip);  // left to the runtime
}

TEST(Profiler, CoarseUnitsDefaultToBatchOneAndSeparateCanBeSkipped) {
  ModelOptions m;
  m.input = {3, 32, 64};
  m.heads = {"det"};
  ProfileOptions o;
  o.warmup = 0;
  o.runs = 1;
  o.max_batch = 3;
  o.separate = false;
  auto p = profile_model(m, o);
  ASSERT_TRUE(p) << p.error().to_string();
  EXPECT_EQ(p->find("encoder")->max_batch(), 3);
  EXPECT_EQ(p->find("head/det")->max_batch(), 3);
  EXPECT_EQ(p->find("coarse/det")->max_batch(), 1);
  EXPECT_EQ(p->find("separate/det"), nullptr);
  EXPECT_FALSE(p->separate_memory.has_value());
}

TEST(Profiler, BadOptionsAndModelsAreErrors) {
  ProfileOptions o;
  o.runs = 0;
  EXPECT_FALSE(profile_model(ModelOptions{}, o));
  ModelOptions m;
  m.heads = {"radar"};
  auto p = profile_model(m, ProfileOptions{});
  ASSERT_FALSE(p);
  EXPECT_NE(p.error().message.find("radar"), std::string::npos);
}

TEST(PeakAllocatedBytes, SeesTensorsAllocatedInside) {
  const c10::Device cpu(c10::kCPU);
  const std::int64_t peak = peak_allocated_bytes(cpu, [] {
    const at::Tensor a = at::ones({1024, 256});  // 1 MiB
    const at::Tensor b = at::ones({1024, 512});  // 2 MiB, both alive
  });
  EXPECT_GE(peak, 3 * 1024 * 1024);
  EXPECT_LT(peak, 4 * 1024 * 1024);
  EXPECT_EQ(peak_allocated_bytes(cpu, [] {}), 0);
}

TEST(ResidentBytes, Positive) {
  EXPECT_GT(resident_bytes(), 0);
}

}  // namespace
}  // namespace red::torchb
