// Profile quality (docs/CLI.md, "Profile quality"): the judging of a profile's figures and
// of the machine that measured them, the `quality` field's JSON round trip, old profiles without
// it, and the default thread count of `red profile`.

#include "red/profile/quality.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include <nlohmann/json.hpp>

#include "red/profile/profile.hpp"

namespace red {
namespace {

using std::chrono::microseconds;

LatencyStats stats(double p50_ms, double max_ms, double mean_ms) {
  LatencyStats s;
  s.min = from_ms(p50_ms * 0.9);
  s.mean = from_ms(mean_ms);
  s.p50 = from_ms(p50_ms);
  s.p95 = from_ms(std::min(max_ms, p50_ms * 1.1));
  s.p99 = from_ms(max_ms);
  s.max = from_ms(max_ms);
  s.samples = 30;
  return s;
}

/// An encoder whose cost grows with the batch and a head, both with a tight spread.
Profile clean_profile() {
  Profile p;
  p.source = "measured";
  p.device = "cpu (2 threads)";
  for (int b = 1; b <= 3; ++b) {
    p.units["encoder"].by_batch.push_back(stats(10.0 * b, 12.0 * b, 10.2 * b));
    p.units["head/lane"].by_batch.push_back(stats(0.5 + 0.1 * b, 0.7 + 0.1 * b, 0.55 + 0.1 * b));
  }
  return p;
}

MachineState quiet_machine() {
  MachineState m;
  m.online_cpus = 4;
  m.threads = 2;
  m.load1_before = 0.3;
  m.load1_after = 2.1;
  m.other_busy_cpus = 0.2;
  m.process_cpu_s = 20;
  m.wall_s = 11;
  return m;
}

double figure(const QualityFinding& f, const std::string& key) {
  for (const auto& [k, v] : f.figures)
    if (k == key) return v;
  ADD_FAILURE() << "no figure " << key << " in finding " << f.kind;
  return -1;
}

TEST(ProfileQuality, CleanProfileOnQuietMachineHasNoFinding) {
  const MachineState m = quiet_machine();
  const Quality q = assess_quality(clean_profile(), &m);
  EXPECT_TRUE(q.findings.empty());
  EXPECT_EQ(q.verdict, "good");
  EXPECT_TRUE(q.has_machine);
  EXPECT_TRUE(quality_lines(q, 5).empty());
}

TEST(ProfileQuality, LargeSpreadIsFound) {
  Profile p = clean_profile();
  // The issue's case: a max 30x the p50.
  p.units["encoder"].by_batch[1] = stats(20.0, 600.0, 21.0);
  const auto f = judge_profile(p, nullptr);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].kind, "spread");
  EXPECT_EQ(f[0].unit, "encoder");
  EXPECT_EQ(f[0].batch, 2);
  EXPECT_DOUBLE_EQ(figure(f[0], "max_over_p50"), 30.0);
  EXPECT_NE(f[0].message.find("30.0x"), std::string::npos) << f[0].message;
  EXPECT_FALSE(f[0].advice.empty());
}

TEST(ProfileQuality, SpreadOfATinyUnitUnderTheFloorIsNotFound) {
  Profile p = clean_profile();
  // 6x, but 0.5 ms in all: one preemption of a sub-millisecond unit.
  p.units["head/lane"].by_batch[0] = stats(0.1, 0.6, 0.12);
  EXPECT_TRUE(judge_profile(p, nullptr).empty());
  QualityThresholds t;
  t.spread_floor_ms = 0.1;
  EXPECT_EQ(judge_profile(p, nullptr, t).size(), 1U);
}

TEST(ProfileQuality, BatchCostingLessThanASmallerOneIsFound) {
  Profile p = clean_profile();
  // The issue's case: batch 1 15.2 ms, batch 2 6.9 ms.
  p.units["encoder"].by_batch[0] = stats(15.0, 16.0, 15.2);
  p.units["encoder"].by_batch[1] = stats(6.8, 7.5, 6.9);
  const auto f = judge_profile(p, nullptr);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].kind, "non_monotone");
  EXPECT_EQ(f[0].unit, "encoder");
  EXPECT_EQ(f[0].batch, 2);
  EXPECT_DOUBLE_EQ(figure(f[0], "mean_ms_batch_b"), 15.2);
  EXPECT_DOUBLE_EQ(figure(f[0], "mean_ms_next_batch"), 6.9);
}

TEST(ProfileQuality, PerFrameCostFallingIsFine) {
  Profile p = clean_profile();
  // Batch 2 costs less per frame (9 / 2 < 10) but more in all; batch 3 within the tolerance.
  p.units["encoder"].by_batch[0] = stats(10.0, 11.0, 10.0);
  p.units["encoder"].by_batch[1] = stats(14.0, 15.0, 14.0);
  p.units["encoder"].by_batch[2] = stats(13.5, 15.0, 13.5);
  EXPECT_TRUE(judge_profile(p, nullptr).empty());
}

TEST(ProfileQuality, OversubscribedMachineIsFound) {
  MachineState m = quiet_machine();
  m.online_cpus = 2;
  m.threads = 2;
  m.other_busy_cpus = 1.0;  // one core busy with something else
  const Quality q = assess_quality(clean_profile(), &m);
  ASSERT_EQ(q.findings.size(), 1U);
  EXPECT_EQ(q.findings[0].kind, "oversubscribed");
  EXPECT_TRUE(q.findings[0].unit.empty());
  EXPECT_EQ(q.verdict, "suspect");
  EXPECT_DOUBLE_EQ(figure(q.findings[0], "threads"), 2);
  EXPECT_NE(q.findings[0].advice.find("--threads 1"), std::string::npos) << q.findings[0].advice;
  // One thread on the core left is not oversubscribed.
  m.threads = 1;
  EXPECT_TRUE(judge_profile(clean_profile(), &m).empty());
}

TEST(ProfileQuality, OversubscriptionFallsBackToTheLoadAverage) {
  MachineState m = quiet_machine();
  m.online_cpus = 2;
  m.threads = 2;
  m.other_busy_cpus = -1;  // /proc/stat not readable
  m.load1_before = 1.2;
  const auto f = judge_profile(clean_profile(), &m);
  ASSERT_EQ(f.size(), 1U);
  EXPECT_EQ(f[0].kind, "oversubscribed");
  EXPECT_NE(f[0].message.find("1-minute load"), std::string::npos) << f[0].message;
}

TEST(ProfileQuality, LinesAreCapped) {
  Profile p = clean_profile();
  for (int b = 0; b < 3; ++b) p.units["encoder"].by_batch[static_cast<std::size_t>(b)].max *= 40;
  const Quality q = assess_quality(p, nullptr);
  ASSERT_EQ(q.findings.size(), 3U);
  const auto lines = quality_lines(q, 2);
  ASSERT_EQ(lines.size(), 3U);
  EXPECT_NE(lines[2].find("1 more"), std::string::npos) << lines[2];
}

TEST(ProfileQuality, JsonRoundTrip) {
  Profile p = clean_profile();
  p.units["encoder"].by_batch[1] = stats(20.0, 600.0, 21.0);
  MachineState m = quiet_machine();
  m.online_cpus = 2;
  m.other_busy_cpus = 1.25;
  p.quality = assess_quality(p, &m);
  ASSERT_EQ(p.quality->findings.size(), 2U);
  const std::string text = profile_to_json(p);
  auto back = parse_profile(text, "q.json");
  ASSERT_TRUE(back.has_value()) << back.error().to_string();
  ASSERT_TRUE(back->quality.has_value());
  const Quality& q = *back->quality;
  EXPECT_EQ(q.verdict, "suspect");
  ASSERT_TRUE(q.has_machine);
  EXPECT_EQ(q.machine.online_cpus, 2);
  EXPECT_EQ(q.machine.threads, 2);
  EXPECT_DOUBLE_EQ(q.machine.other_busy_cpus, 1.25);
  EXPECT_DOUBLE_EQ(q.machine.load1_after, 2.1);
  EXPECT_DOUBLE_EQ(q.machine.wall_s, 11);
  ASSERT_EQ(q.findings.size(), 2U);
  for (std::size_t i = 0; i < q.findings.size(); ++i) {
    const QualityFinding& a = p.quality->findings[i];
    const QualityFinding& b = q.findings[i];
    EXPECT_EQ(a.unit, b.unit);
    EXPECT_EQ(a.batch, b.batch);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.message, b.message);
    EXPECT_EQ(a.advice, b.advice);
    ASSERT_EQ(a.figures.size(), b.figures.size());
    for (const auto& [key, v] : a.figures) EXPECT_NEAR(figure(b, key), v, 1e-3) << key;
  }
  // Written again, the same document (figures may come back in another key order).
  EXPECT_EQ(nlohmann::json::parse(profile_to_json(*back)), nlohmann::json::parse(text));
}

TEST(ProfileQuality, ProfileWithoutQualityStillLoads) {
  // A profile as written before the quality field.
  const std::string old = R"json({"schema": 1, "source": "measured", "device": "cpu (2 threads)",
    "units": {"encoder": [{"batch": 1, "samples": 30, "min_us": 9000, "mean_us": 10000,
      "p50_us": 10000, "p95_us": 11000, "p99_us": 12000, "max_us": 12000}]}})json";
  auto p = parse_profile(old, "old.json");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_FALSE(p->quality.has_value());
  EXPECT_EQ(profile_to_json(*p).find("\"quality\""), std::string::npos);
}

TEST(ProfileQuality, BadQualityFieldIsAnErrorWithALine) {
  const std::string text = R"json({"schema": 1,
  "quality": {"verdict": "fine"},
  "units": {"encoder": [{"batch": 1, "samples": 30, "min_us": 9000, "mean_us": 10000,
      "p50_us": 10000, "p95_us": 11000, "p99_us": 12000, "max_us": 12000}]}})json";
  auto p = parse_profile(text, "bad.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("quality.verdict"), std::string::npos) << p.error().message;
  EXPECT_EQ(p.error().line, 2);
}

TEST(ProfileQuality, DefaultThreadsLeaveBusyCoresAlone) {
  EXPECT_EQ(default_profile_threads(2, 0.1), 2);
  EXPECT_EQ(default_profile_threads(2, 1.0), 1);  // one core busy: the other one
  EXPECT_EQ(default_profile_threads(2, 3.5), 1);  // never fewer than one
  EXPECT_EQ(default_profile_threads(16, 4.4), 12);
  EXPECT_EQ(default_profile_threads(4, -1), 4);
}

TEST(ProfileQuality, MachineBetweenTwoSnapshots) {
  CpuSnapshot a;
  a.ok = true;
  a.busy_cpu_s = 100;
  a.process_cpu_s = 1;
  a.load1 = 0.5;
  a.wall_s = 1000;
  CpuSnapshot b = a;
  b.busy_cpu_s = 130;    // 30 CPU-seconds busy in 10 s
  b.process_cpu_s = 21;  // 20 of them this process's
  b.load1 = 2.5;
  b.wall_s = 1010;
  const MachineState m = machine_between(a, b, 2);
  EXPECT_EQ(m.threads, 2);
  EXPECT_GE(m.online_cpus, 1);
  EXPECT_DOUBLE_EQ(m.other_busy_cpus, 1.0);
  EXPECT_DOUBLE_EQ(m.process_cpu_s, 20);
  EXPECT_DOUBLE_EQ(m.wall_s, 10);
  EXPECT_DOUBLE_EQ(m.load1_before, 0.5);
  EXPECT_DOUBLE_EQ(m.load1_after, 2.5);
  b.ok = false;  // no /proc/stat: unknown, not zero
  EXPECT_LT(machine_between(a, b, 2).other_busy_cpus, 0);
}

}  // namespace
}  // namespace red
