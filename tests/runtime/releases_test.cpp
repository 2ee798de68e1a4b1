// Frames offered by the sensors against frames released (RuntimeReport::frames_offered,
// frames_released, release_late_us): every nominal capture time of the measured window is
// either released or counted as not released, and a camera that falls behind is reported,
// not hidden. Structural assertions only: the counts of nominal capture times are exact,
// and the slow camera sleeps longer per frame than the sensors' frames come (30 ms against
// one every 18.75 ms on average), so it cannot keep up on any machine.

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "red/metrics/metrics.hpp"
#include "red/report/report.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

constexpr const char* kScenario = R"(
name: releases
duration_s: 0.6
warmup_s: 0.1
seed: 3
device: {lanes: 1}
model: {builtin: mimonet, heads: [lane, steer], input: [3, 192, 384]}
sensors:
  front: {rate_hz: 40}
  rear: {rate_hz: 25, phase_ms: 4}
operations:
  - name: drive
    trigger: front
    deadline_ms: 60
    nodes:
      L: {head: lane, sensor: front}
      C: {head: steer, sensor: front}
    edges: [[L, C]]
  - name: watch
    trigger: rear
    deadline_ms: 80
    nodes:
      R: {head: steer, sensor: rear}
)";

// The synthetic backend, with a camera hook that takes `frame_cost` per frame: a camera
// thread held up before each release, as one that made tensors or waited for a device was.
class SlowCamera final : public Backend {
 public:
  SlowCamera(const Scenario& s, const Profile& p, Duration frame_cost)
      : inner_(s, p, 1, options()), frame_cost_(frame_cost) {}
  [[nodiscard]] std::string_view name() const noexcept override { return "slow camera"; }
  void run(int lane, const Dispatch& d) override { inner_.run(lane, d); }
  void on_frame(int /*sensor*/, std::uint64_t /*frame*/) override {
    std::this_thread::sleep_for(frame_cost_);
  }

 private:
  static SyntheticBackend::Options options() {
    SyntheticBackend::Options o;
    o.time_scale = 0.05;
    return o;
  }
  SyntheticBackend inner_;
  Duration frame_cost_;
};

struct Outcome {
  RuntimeReport report;
  PolicyMetrics metrics;
};

Outcome run_with(Duration frame_cost) {
  auto s = parse_scenario(kScenario, "releases.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  const Profile p = default_profile();
  SlowCamera backend(*s, p, frame_cost);
  RuntimeOptions ro;
  ro.realtime = false;
  ro.watchdog_x = 0.0;
  Runtime rt(*s, p, make_policy("red"), backend, ro);
  MetricsCollector metrics(*s, 1.0);
  rt.add_observer(&metrics);
  Outcome r;
  r.report = rt.run();
  r.metrics = metrics.summarize("red", r.report.end);
  return r;
}

// Nominal capture times in [0.1 s, 0.6 s): front at 40 Hz from 0 (0.100 .. 0.575: 20),
// rear at 25 Hz from 4 ms (0.124 .. 0.564: 12).
constexpr std::uint64_t kOffered = 20 + 12;

TEST(RuntimeReleases, EveryOfferedFrameIsReleasedOrCounted) {
  const Outcome r = run_with(Duration{0});
  EXPECT_EQ(r.report.frames_offered, kOffered);
  EXPECT_LE(r.report.frames_released, r.report.frames_offered);
  EXPECT_GT(r.report.frames_released, 0U);
  EXPECT_EQ(r.report.release_late_us.size(), r.report.frames_released)
      << "one lateness per released frame";
  EXPECT_LE(r.report.frames_behind, r.report.frames_released);
  for (double us : r.report.release_late_us) EXPECT_GE(us, 0.0) << "never before capture";
}

TEST(RuntimeReleases, ACameraThatFallsBehindIsCountedNotHidden) {
  // 30 ms per frame against 53 frames a second: at most 20 frames get through in the 0.6 s
  // (those of the measured window ever later), the rest of the 32 are offered and never
  // released.
  const Outcome r = run_with(std::chrono::milliseconds{30});
  EXPECT_EQ(r.report.frames_offered, kOffered);
  EXPECT_LT(r.report.frames_released, r.report.frames_offered);
  EXPECT_GT(r.report.frames_behind, 0U);
  PolicyMetrics m;
  m.name = "red";
  m.releases = PolicyMetrics::Releases{static_cast<std::int64_t>(r.report.frames_offered),
                                       static_cast<std::int64_t>(r.report.frames_released),
                                       static_cast<std::int64_t>(r.report.frames_behind),
                                       0.0,
                                       0.0,
                                       percentile(r.report.release_late_us, 1.0) / 1000};
  EXPECT_GE(m.releases->late_max_ms, 25.0) << "the late frames were more than a period late";
  const auto warning = releases_warning(m);
  ASSERT_TRUE(warning.has_value());
  EXPECT_NE(warning->find("fell behind"), std::string::npos) << *warning;
  EXPECT_NE(releases_table({m}).find("offered"), std::string::npos);
}

TEST(RuntimeReleases, AKeptUpRunHasNoWarning) {
  PolicyMetrics m;
  m.name = "edf";
  EXPECT_FALSE(releases_warning(m).has_value()) << "a simulation has no release figures";
  EXPECT_TRUE(releases_table({m}).empty());
  m.releases = PolicyMetrics::Releases{100, 100, 0, 0.05, 0.2, 0.3};
  EXPECT_FALSE(releases_warning(m).has_value());
  m.releases->released = 99;
  EXPECT_TRUE(releases_warning(m).has_value()) << "one frame never released is a shortfall";
}

}  // namespace
}  // namespace red
