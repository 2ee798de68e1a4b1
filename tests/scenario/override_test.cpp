// apply_override: the `key=value` overrides of `red sweep --set` and the CLI.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "red/scenario/loader.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

constexpr const char* kScenario = R"(name: ov
duration_s: 10
warmup_s: 1
model: {builtin: mimonet, heads: [lane, det]}
sensors:
  camera: {rate_hz: 20}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 100
    nodes:
      L: {head: lane, sensor: camera, deadline_ms: 40}
  - name: tick
    rate_hz: 10
    deadline_ms: {critical_path_x: 1.5}
    nodes: {X: {cost_ms: 1}}
events:
  - {at_s: 2, set_deadline: {operation: drive, deadline_ms: 200}}
  - {at_s: 3, set_deadline: {operation: tick, deadline_ms: {critical_path_x: 2}}}
  - {at_s: 4, set_rate: {sensor: camera, rate_hz: 40}}
  - {at_s: 5, set_rate: {operation: tick, rate_hz: 30}}
)";

Scenario scenario() {
  Expected<Scenario> s = parse_scenario(kScenario, "ov.yaml");
  EXPECT_TRUE(s.has_value()) << s.error().to_string();
  return s ? std::move(s).value() : Scenario{};
}

const OperationSpec& changed(const Scenario& s, std::size_t event) {
  return *s.events.at(event).changes.at(0).second;
}

TEST(Override, DeadlineScaleReachesEveryDeadline) {
  Scenario s = scenario();
  const Scenario before = s;
  ASSERT_FALSE(apply_override(s, "deadline_scale", 1.5).has_value());
  EXPECT_EQ(s.initial[0]->deadline.fixed, milliseconds{150});
  EXPECT_EQ(s.initial[0]->nodes[0].deadline, milliseconds{60});
  EXPECT_DOUBLE_EQ(s.initial[1]->deadline.critical_path_x.value_or(0), 2.25);
  EXPECT_EQ(changed(s, 0).deadline.fixed, milliseconds{300});
  EXPECT_DOUBLE_EQ(changed(s, 1).deadline.critical_path_x.value_or(0), 3.0);
  // Snapshots are immutable and may be shared: the old scenario is unchanged.
  EXPECT_EQ(before.initial[0]->deadline.fixed, milliseconds{100});
  EXPECT_EQ(changed(before, 0).deadline.fixed, milliseconds{200});
  EXPECT_TRUE(apply_override(s, "deadline_scale", 0.0).has_value());
  EXPECT_TRUE(apply_override(s, "deadline_scale", -1.0).has_value());
}

TEST(Override, RateScaleReachesSensorsOperationsAndEvents) {
  Scenario s = scenario();
  ASSERT_FALSE(apply_override(s, "rate_scale", 2.0).has_value());
  EXPECT_DOUBLE_EQ(s.sensors[0].rate_hz, 40.0);
  EXPECT_DOUBLE_EQ(s.initial[0]->rate_hz, 0.0);  // triggered: no own rate
  EXPECT_DOUBLE_EQ(s.initial[1]->rate_hz, 20.0);
  EXPECT_DOUBLE_EQ(s.events[2].sensor_rates.at(0).second, 80.0);
  EXPECT_DOUBLE_EQ(changed(s, 3).rate_hz, 60.0);
  EXPECT_TRUE(apply_override(s, "rate_scale", 0.0).has_value());
}

TEST(Override, SchedulerDeviceAndRunKeys) {
  Scenario s = scenario();
  ASSERT_FALSE(apply_override(s, "qoe_lambda", 0.01).has_value());
  EXPECT_DOUBLE_EQ(s.scheduler.qoe_lambda, 0.01);
  ASSERT_FALSE(apply_override(s, "gamma_ms", 7.5).has_value());
  EXPECT_EQ(s.scheduler.gamma, std::chrono::microseconds{7500});
  ASSERT_FALSE(apply_override(s, "lanes", 3).has_value());
  EXPECT_EQ(s.device.lanes, 3);
  ASSERT_FALSE(apply_override(s, "queue_depth", 2).has_value());
  EXPECT_EQ(s.device.queue_depth, 2);
  ASSERT_FALSE(apply_override(s, "duration_s", 6).has_value());
  EXPECT_EQ(s.duration, std::chrono::seconds{6});
  ASSERT_FALSE(apply_override(s, "seed", 99).has_value());
  EXPECT_EQ(s.seed, 99U);
}

TEST(Override, BadValuesLeaveTheScenarioUnchanged) {
  Scenario s = scenario();
  struct Case {
    const char* key;
    double value;
  };
  for (const Case c :
       {Case{"qoe_lambda", 0}, Case{"gamma_ms", -1}, Case{"lanes", 0}, Case{"lanes", 1.5},
        Case{"queue_depth", 0}, Case{"queue_depth", 5}, Case{"queue_depth", 1.5},
        Case{"duration_s", 0}, Case{"duration_s", 1}, Case{"seed", -1}, Case{"seed", 0.5},
        Case{"rate_scale", std::numeric_limits<double>::quiet_NaN()},
        Case{"deadline_scale", std::numeric_limits<double>::infinity()}}) {
    SCOPED_TRACE(c.key);
    const auto e = apply_override(s, c.key, c.value);
    ASSERT_TRUE(e.has_value());
    EXPECT_NE(e->message.find(c.key), std::string::npos) << e->message;
  }
  EXPECT_DOUBLE_EQ(s.scheduler.qoe_lambda, 1.0);
  EXPECT_EQ(s.device.lanes, 1);
  EXPECT_EQ(s.duration, std::chrono::seconds{10});
  EXPECT_EQ(s.seed, 1U);
  EXPECT_DOUBLE_EQ(s.sensors[0].rate_hz, 20.0);
}

// A user shortening a run expects the events past its new end to be left out, with a
// warning naming them, not a refusal.
TEST(Override, ShorterDurationLeavesOutLaterEventsWithAWarning) {
  Scenario s = scenario();
  std::vector<std::string> warnings;
  ASSERT_FALSE(apply_override(s, "duration_s", 4.5, &warnings).has_value());
  EXPECT_EQ(s.duration, std::chrono::milliseconds{4500});
  ASSERT_EQ(s.events.size(), 3U);
  EXPECT_EQ(s.events.back().at, std::chrono::seconds{4});
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("leaves out 1 event(s) at or after 4.5 s (line(s) 21)"),
            std::string::npos)
      << warnings[0];
  // An event exactly at the new end is left out too; no warning when none is.
  warnings.clear();
  ASSERT_FALSE(apply_override(s, "duration_s", 3, &warnings).has_value());
  EXPECT_EQ(s.events.size(), 1U);
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("2 event(s)"), std::string::npos) << warnings[0];
  warnings.clear();
  ASSERT_FALSE(apply_override(s, "duration_s", 2.5, &warnings).has_value());
  EXPECT_TRUE(warnings.empty());
}

TEST(Override, UnknownKeyIsNamed) {
  Scenario s = scenario();
  const auto e = apply_override(s, "deadline_scael", 1.0);
  ASSERT_TRUE(e.has_value());
  EXPECT_NE(e->message.find("unknown key 'deadline_scael'"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("deadline_scale"), std::string::npos) << e->message;
}

}  // namespace
}  // namespace red
