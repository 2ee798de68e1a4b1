// Calibration (docs/FIDELITY.md): the fit recovers a known model of a real run from its unit
// rows, the profile keeps it through JSON, and the simulator replays it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "red/calibrate/calibrate.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/scenario/builder.hpp"

namespace red {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

Scenario scenario(int lanes) {
  ScenarioBuilder b("calib");
  b.duration(std::chrono::seconds{6}).lanes(lanes).sensor("camera", 20.0);
  b.operation("drive")
      .trigger("camera")
      .deadline(milliseconds{60})
      .inference("L", "lane", "camera")
      .inference("S", "seg", "camera");
  auto s = b.build();
  EXPECT_TRUE(s.has_value());
  return *s;
}

/// A small deterministic spread around 1.
double noise(int i) {
  return 1.0 + 0.04 * std::sin(0.7 * i);
}

Duration ms(double v) {
  return from_ms(v);
}

UnitRow row(int lane, TimePoint start, Duration dur, UnitKind kind, int head, bool round_trip,
            TimePoint decided) {
  UnitRow r;
  r.lane = lane;
  r.decided = decided;
  r.start = start;
  r.end = start + dur;
  r.kind = kind;
  r.head = head;
  r.round_trip = round_trip;
  r.jobs = "drive#1:L";
  return r;
}

// Run A: one lane, encoder (10 ms) then the lane head (2 ms), the machine 1.5x slower
// between 2 s and 4 s. Encoders follow a 20 us round trip, heads a 5 us direct hand-off.
CalibrationRun run_a(const Scenario& s) {
  CalibrationRun run{"edf", {}, {}, false, {}};
  const int lane_head = 0;
  TimePoint t{0};
  for (int i = 0; i < 120; ++i) {
    const double f =
        (t >= TimePoint{std::chrono::seconds{2}} && t < TimePoint{std::chrono::seconds{4}}) ? 1.5
                                                                                            : 1.0;
    const TimePoint decided = t;
    const TimePoint enc_start = t + microseconds{20};
    run.units.push_back(
        row(0, enc_start, ms(10.0 * f * noise(i)), UnitKind::Encoder, -1, true, decided));
    const TimePoint head_start = run.units.back().end + microseconds{5};
    run.units.push_back(row(0, head_start, ms(2.0 * f * noise(i + 50)), UnitKind::Head, lane_head,
                            false, run.units.back().end));
    t = run.units.back().end + milliseconds{30};
  }
  (void)s;
  run.handoff_us = {4.0, 5.0, 6.0, 5.0, 900.0};  // local decisions (on-demand)
  return run;
}

// Run B: two lanes computing at once, each unit 1.3x slower than alone.
CalibrationRun run_b() {
  CalibrationRun run{"red", {}, {}, false, {}};
  for (int lane = 0; lane < 2; ++lane) {
    TimePoint t{milliseconds{lane * 3}};
    for (int i = 0; i < 60; ++i) {
      run.units.push_back(
          row(lane, t, ms(10.0 * 1.3 * noise(i + lane)), UnitKind::Encoder, -1, true, t));
      t = run.units.back().end;
    }
  }
  run.handoff_us = {18.0, 20.0, 25.0, 7000.0};  // round trips (per-edge); 7 ms: not a hand-off
  run.round_trips = true;
  return run;
}

TEST(Calibrate, RecoversTimeAndLaneFactorsResidualsAndHandOffs) {
  const Scenario s = scenario(2);
  const Profile iso = default_profile();
  auto p = calibrate_profile(iso, s, {run_a(s), run_b()});
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  ASSERT_TRUE(p->calibration.has_value());
  const Calibration& c = *p->calibration;
  EXPECT_EQ(p->source, "calibrated");
  EXPECT_EQ(c.policies, (std::vector<std::string>{"edf", "red"}));
  // Lane factor: units started beside a busy lane ran 1.3x.
  ASSERT_EQ(c.lane_factors.size(), 2u);
  EXPECT_DOUBLE_EQ(c.lane_factors[0], 1.0);
  EXPECT_NEAR(c.lane_factors[1], 1.3, 0.05);
  // Time factors: about 1 outside the slow stretch, about 1.5 in it.
  ASSERT_FALSE(c.factors.empty());
  const auto [lo, hi] = std::minmax_element(c.factors.begin(), c.factors.end());
  EXPECT_NEAR(*lo, 1.0, 0.06);
  EXPECT_NEAR(*hi, 1.5, 0.08);
  // Residual of the encoder: about its 10 ms spread, the factors divided out.
  const std::vector<Duration>* enc = c.table("encoder", 1);
  ASSERT_NE(enc, nullptr);
  ASSERT_EQ(enc->size(), 201u);
  EXPECT_NEAR(to_ms(table_quantile(*enc, 0.5)), 10.0, 0.4);
  // (Run B's first unit on lane 0 started alone but ran at 1.3x: the one outlier.)
  EXPECT_GE(to_ms(enc->front()), 9.0);
  EXPECT_LE(to_ms(table_quantile(*enc, 0.95)), 11.0);
  // In-run statistics replace the isolated ones for what the runs measured.
  const LatencyStats& e1 = p->find("encoder")->at(1);
  EXPECT_EQ(e1.samples, 240);
  EXPECT_GT(to_ms(e1.mean), 11.0);  // slow stretch and busy lanes included
  EXPECT_EQ(p->find("head/lane")->at(1).samples, 120);
  EXPECT_EQ(p->find("head/seg")->at(1).samples, iso.find("head/seg")->at(1).samples);
  // Batch sizes never seen are scaled by the unit's in-run / isolated ratio.
  const double ratio = to_ms(e1.mean) / to_ms(iso.find("encoder")->at(1).mean);
  EXPECT_NEAR(to_ms(p->find("encoder")->at(2).mean), ratio * to_ms(iso.find("encoder")->at(2).mean),
              0.01);
  // Hand-offs: the medians of what the runtime timed, local and round trip apart.
  EXPECT_EQ(c.handoff, microseconds{5});
  EXPECT_EQ(p->sync_round_trip, microseconds{20});
  // The table says how the run departs from the isolated profile.
  const std::string table = calibration_table(iso, *p);
  EXPECT_NE(table.find("encoder"), std::string::npos);
  EXPECT_NE(table.find("lane factor"), std::string::npos);
}

TEST(Calibrate, ARareOutlierStaysRareInTheDraws) {
  // 400 encoder runs of about 10 ms on one lane, alone, at a steady pace, and one of 30 ms:
  // the residual's draws must be slow as often as the runs were (1 in 401), and its mean
  // the runs' mean, not a tail spread from the 95th percentile up to the outlier.
  const Scenario s = scenario(1);
  CalibrationRun run{"edf", {}, {}, false, {}};
  TimePoint t{0};
  double sum = 0;
  for (int i = 0; i <= 400; ++i) {
    const double d = i == 200 ? 30.0 : 10.0 * noise(i);
    sum += d;
    run.units.push_back(row(0, t, ms(d), UnitKind::Encoder, -1, true, t));
    t = run.units.back().end + milliseconds{5};
  }
  auto p = calibrate_profile(default_profile(), s, {run});
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const std::vector<Duration>* enc = p->calibration->table("encoder", 1);
  ASSERT_NE(enc, nullptr);
  EXPECT_NEAR(to_ms(enc->back()), 30.0, 1.5);  // the outlier is kept (the factor divides it)
  int slow = 0;
  double drawn = 0;
  constexpr int kDraws = 10000;
  for (int i = 0; i < kDraws; ++i) {
    const double v = to_ms(table_quantile(*enc, (i + 0.5) / kDraws));
    drawn += v;
    if (v > 11.0) ++slow;  // every run but the outlier took at most 10.4 ms
  }
  EXPECT_LE(slow, kDraws / 100);  // 0.25 % of runs; 21 quantiles drew 5 % here
  EXPECT_NEAR(drawn / kDraws, sum / 401.0, 0.01 * sum / 401.0);
}

TEST(Calibrate, SurvivesJsonRoundTrip) {
  const Scenario s = scenario(2);
  auto p = calibrate_profile(default_profile(), s, {run_a(s), run_b()});
  ASSERT_TRUE(p.has_value());
  auto back = parse_profile(profile_to_json(*p), "p.json");
  ASSERT_TRUE(back.has_value()) << back.error().to_string();
  ASSERT_TRUE(back->calibration.has_value());
  const Calibration& a = *p->calibration;
  const Calibration& b = *back->calibration;
  EXPECT_EQ(a.policies, b.policies);
  EXPECT_EQ(a.block, b.block);
  EXPECT_EQ(a.run_blocks, b.run_blocks);
  ASSERT_EQ(a.factors.size(), b.factors.size());
  for (std::size_t i = 0; i < a.factors.size(); ++i) EXPECT_NEAR(a.factors[i], b.factors[i], 1e-9);
  EXPECT_EQ(a.handoff, b.handoff);
  ASSERT_EQ(a.residual.size(), b.residual.size());
  const auto& ta = *a.table("encoder", 1);
  const auto& tb = *b.table("encoder", 1);
  ASSERT_EQ(ta.size(), tb.size());
  for (std::size_t i = 0; i < ta.size(); ++i) EXPECT_LE(std::abs((ta[i] - tb[i]).count()), 1);
}

TEST(Calibrate, RejectsBadCalibrationJson) {
  auto text = profile_to_json(default_profile());
  auto with = [&](const std::string& cal) {
    std::string t = text;
    t.insert(t.rfind('}'), ",\n  \"calibration\": " + cal + "\n");
    return parse_profile(t, "p.json");
  };
  EXPECT_TRUE(with(R"({"factors": [1.0, 1.2]})").has_value());
  auto e1 = with(R"({"factors": [1.0, -1]})");
  ASSERT_FALSE(e1.has_value());
  EXPECT_NE(e1.error().message.find("calibration.factors"), std::string::npos);
  auto e2 = with(R"({"residual": {"encoder": [[3, 2]]}})");
  ASSERT_FALSE(e2.has_value());
  EXPECT_NE(e2.error().message.find("must not decrease"), std::string::npos);
  auto e3 = with(R"({"bogus": 1})");
  ASSERT_FALSE(e3.has_value());
  EXPECT_NE(e3.error().message.find("unknown key 'bogus'"), std::string::npos);
  auto e4 = with(R"({"block_ms": 0})");
  ASSERT_FALSE(e4.has_value());
}

TEST(Calibrate, TooFewUnitsIsAnError) {
  const Scenario s = scenario(1);
  auto p = calibrate_profile(default_profile(), s, {CalibrationRun{"edf", {}, {}, false, {}}});
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("too few"), std::string::npos);
}

TEST(Calibrate, FactorReplayIsDeterministicAndMeasured) {
  Calibration c;
  c.factors = {1.0, 1.1, 1.6, 0.9};
  c.block = milliseconds{100};
  c.run_blocks = 3;
  for (int i = 0; i < 200; ++i) {
    const TimePoint t{milliseconds{i * 37}};
    const double f = c.factor_at(t, 7);
    EXPECT_EQ(f, c.factor_at(t, 7));
    EXPECT_NE(std::find(c.factors.begin(), c.factors.end(), f), c.factors.end());
  }
  // Within one run of blocks, consecutive blocks replay consecutive measured factors.
  const double f0 = c.factor_at(TimePoint{milliseconds{0}}, 3);
  const double f1 = c.factor_at(TimePoint{milliseconds{100}}, 3);
  const auto i0 = std::find(c.factors.begin(), c.factors.end(), f0) - c.factors.begin();
  EXPECT_EQ(f1, c.factors[static_cast<std::size_t>((i0 + 1) % 4)]);
}

TEST(Calibrate, SimulatorReplaysTheCalibration) {
  const Scenario s = scenario(1);
  const Profile iso = default_profile();
  auto p = calibrate_profile(iso, s, {run_a(s)});
  ASSERT_TRUE(p.has_value());
  auto a = simulate_policy(s, *p, "edf", 1);
  auto b = simulate_policy(s, *p, "edf", 1);
  ASSERT_TRUE(a.has_value() && b.has_value());
  EXPECT_EQ(a->metrics.latency.mean, b->metrics.latency.mean);  // deterministic
  // Without the time factor's slow stretch the same profile is faster on average.
  Profile flat = *p;
  Calibration no_stretch = *p->calibration;
  no_stretch.factors.assign(1, 1.0);
  flat.calibration.emplace(std::move(no_stretch));
  auto c = simulate_policy(s, flat, "edf", 1);
  ASSERT_TRUE(c.has_value());
  EXPECT_GT(a->metrics.latency.mean, c->metrics.latency.mean);
  // Every simulated unit lies within the residual's range times the factors measured.
  const auto& fs = p->calibration->factors;
  const double fmax = *std::max_element(fs.begin(), fs.end());
  const double fmin = *std::min_element(fs.begin(), fs.end());
  const auto& enc = *p->calibration->table("encoder", 1);
  for (const UnitRow& u : c->units)
    if (u.kind == UnitKind::Encoder) {
      EXPECT_GE((u.end - u.start).count(), enc.front().count() - 1);
      EXPECT_LE((u.end - u.start).count(), enc.back().count() + 1);
    }
  for (const UnitRow& u : a->units)
    if (u.kind == UnitKind::Encoder) {
      EXPECT_GE(to_ms(u.end - u.start), to_ms(enc.front()) * fmin - 1e-3);
      EXPECT_LE(to_ms(u.end - u.start), to_ms(enc.back()) * fmax + 1e-3);
    }
}

}  // namespace
}  // namespace red
