// ScenarioBuilder: scenarios built in code, validated by the loader's rules.

#include "red/scenario/builder.hpp"

#include <gtest/gtest.h>

#include <string>

#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;
using std::chrono::seconds;

ScenarioBuilder two_operations() {
  ScenarioBuilder b("two-ops");
  b.duration(seconds{2}).warmup(milliseconds{100}).seed(3).lanes(2).sensor("camera", 30.0);
  b.operation("drive")
      .trigger("camera")
      .deadline(milliseconds{100})
      .inference("L", "lane", "camera")
      .inference("S", "seg", "camera")
      .edge("L", "S");
  b.operation("post").rate(10.0).deadline(milliseconds{50}).plain("P", milliseconds{2});
  return b;
}

// The same workload, written as a scenario file.
constexpr const char* kTwoOperationsYaml = R"(name: two-ops
duration_s: 2
warmup_s: 0.1
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  camera: {rate_hz: 30}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 100
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
    edges: [[L, S]]
  - name: post
    rate_hz: 10
    deadline_ms: 50
    nodes: {P: {cost_ms: 2}}
)";

TEST(ScenarioBuilder, BuildsWhatTheEquivalentFileLoads) {
  Expected<Scenario> built = two_operations().build();
  ASSERT_TRUE(built) << built.error().to_string();
  Expected<Scenario> loaded = parse_scenario(kTwoOperationsYaml, "");
  ASSERT_TRUE(loaded) << loaded.error().to_string();
  const Scenario& b = *built;
  const Scenario& l = *loaded;

  EXPECT_EQ(b.name, l.name);
  EXPECT_EQ(b.duration, l.duration);
  EXPECT_EQ(b.warmup, l.warmup);
  EXPECT_EQ(b.seed, l.seed);
  EXPECT_EQ(b.device.lanes, l.device.lanes);
  EXPECT_EQ(b.model.heads, l.model.heads);
  ASSERT_EQ(b.sensors.size(), 1u);
  EXPECT_EQ(b.sensors[0].name, "camera");
  EXPECT_DOUBLE_EQ(b.sensors[0].rate_hz, 30.0);
  ASSERT_EQ(b.operation_count(), 2);
  for (int i = 0; i < 2; ++i) {
    const OperationSpec& bo = *b.initial[static_cast<std::size_t>(i)];
    const OperationSpec& lo = *l.initial[static_cast<std::size_t>(i)];
    EXPECT_EQ(b.operation_name(i), l.operation_name(i));
    EXPECT_EQ(bo.trigger_sensor, lo.trigger_sensor);
    EXPECT_DOUBLE_EQ(bo.rate_hz, lo.rate_hz);
    EXPECT_EQ(bo.deadline.fixed, lo.deadline.fixed);
    ASSERT_EQ(bo.nodes.size(), lo.nodes.size());
    for (std::size_t n = 0; n < bo.nodes.size(); ++n) {
      EXPECT_EQ(bo.nodes[n].name, lo.nodes[n].name);
      EXPECT_EQ(bo.nodes[n].head, lo.nodes[n].head);
      EXPECT_EQ(bo.nodes[n].sensor, lo.nodes[n].sensor);
      EXPECT_EQ(bo.nodes[n].cost.has_value(), lo.nodes[n].cost.has_value());
      if (bo.nodes[n].cost) {
        EXPECT_EQ(bo.nodes[n].cost->mean, lo.nodes[n].cost->mean);
      }
    }
    ASSERT_EQ(bo.edges.size(), lo.edges.size());
    for (std::size_t e = 0; e < bo.edges.size(); ++e) {
      EXPECT_EQ(bo.edges[e].from, lo.edges[e].from);
      EXPECT_EQ(bo.edges[e].to, lo.edges[e].to);
    }
  }
  EXPECT_TRUE(b.file.empty());
}

TEST(ScenarioBuilder, KeepsEveryNanosecondOfOddDurations) {
  ScenarioBuilder b("odd");
  b.duration(nanoseconds{1'234'567'891}).sensor("cam", 29.97, nanoseconds{333'333});
  b.operation("op")
      .trigger("cam")
      .deadline(nanoseconds{33'333'333})
      .plain("A", nanoseconds{1'000'001}, nanoseconds{2'500'003})
      .plain("B", nanoseconds{7})
      .node_deadline("A", nanoseconds{12'345'679})
      .edge("A", "B");
  Expected<Scenario> s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_EQ(s->duration, nanoseconds{1'234'567'891});
  EXPECT_EQ(s->sensors[0].phase, nanoseconds{333'333});
  EXPECT_DOUBLE_EQ(s->sensors[0].rate_hz, 29.97);
  const OperationSpec& op = *s->initial[0];
  EXPECT_EQ(op.deadline.fixed, nanoseconds{33'333'333});
  ASSERT_TRUE(op.nodes[0].cost && op.nodes[1].cost);
  EXPECT_EQ(op.nodes[0].cost->mean, nanoseconds{1'000'001});
  EXPECT_EQ(op.nodes[0].cost->p99, nanoseconds{2'500'003});
  EXPECT_EQ(op.nodes[1].cost->mean, nanoseconds{7});
  ASSERT_TRUE(op.nodes[0].deadline.has_value());
  EXPECT_EQ(*op.nodes[0].deadline, nanoseconds{12'345'679});
}

TEST(ScenarioBuilder, SetsTheOptionalKnobs) {
  ScenarioBuilder b("knobs");
  b.heads({"lane", "det"})
      .sync_cost(std::chrono::microseconds{80})
      .queue_depth(2)
      .gamma(milliseconds{20})
      .max_batch(2)
      .qoe_lambda(0.5)
      .sensor("cam", 10.0);
  b.operation("a").trigger("cam").deadline(milliseconds{90}).inference("L", "lane", "cam");
  b.operation("b")
      .rate(5.0)
      .phase(milliseconds{3})
      .deadline_critical_path(1.5)
      .criticality(2)
      .max_inflight(1)
      .depends_on("a")
      .inference("D", "det", "cam");
  b.operation("c").release_count(4).deadline(milliseconds{10}).plain("X", milliseconds{1});
  Expected<Scenario> s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_EQ(s->model.heads, (std::vector<std::string>{"lane", "det"}));
  ASSERT_TRUE(s->device.sync_cost.has_value());
  EXPECT_EQ(*s->device.sync_cost, std::chrono::microseconds{80});
  EXPECT_EQ(s->device.queue_depth, 2);
  EXPECT_EQ(s->scheduler.gamma, milliseconds{20});
  EXPECT_EQ(s->scheduler.max_batch, 2);
  EXPECT_DOUBLE_EQ(s->scheduler.qoe_lambda, 0.5);
  const OperationSpec& ob = *s->initial[1];
  EXPECT_EQ(ob.phase, milliseconds{3});
  ASSERT_TRUE(ob.deadline.critical_path_x.has_value());
  EXPECT_DOUBLE_EQ(*ob.deadline.critical_path_x, 1.5);
  EXPECT_EQ(ob.criticality, 2);
  EXPECT_EQ(ob.max_inflight, 1);
  EXPECT_EQ(ob.depends_on, 0);
  EXPECT_EQ(ob.nodes[0].head, 1);
  ASSERT_TRUE(s->initial[2]->release_count.has_value());
  EXPECT_EQ(*s->initial[2]->release_count, 4);
}

TEST(ScenarioBuilder, OperationReferencesStayValidAsOperationsAreAdded) {
  ScenarioBuilder b("many");
  b.sensor("cam", 10.0);
  OperationBuilder& first = b.operation("op0");
  for (int i = 1; i < 50; ++i)
    b.operation("op" + std::to_string(i))
        .trigger("cam")
        .deadline(milliseconds{50})
        .plain("N", milliseconds{1});
  first.trigger("cam").deadline(milliseconds{70}).plain("N", milliseconds{1});
  Expected<Scenario> s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_EQ(s->operation_count(), 50);
  EXPECT_EQ(s->initial[0]->deadline.fixed, milliseconds{70});
}

/// Builds and expects an error whose message contains `needle`.
void expect_error(const ScenarioBuilder& b, const std::string& needle) {
  Expected<Scenario> s = b.build();
  ASSERT_FALSE(s) << "built although it should fail with: " << needle;
  EXPECT_NE(s.error().message.find(needle), std::string::npos) << s.error().to_string();
  EXPECT_EQ(s.error().file.rfind("scenario builder '", 0), 0u) << s.error().file;
  EXPECT_EQ(s.error().line, 0);
}

TEST(ScenarioBuilder, ReportsBadWorkloadsInTheLoadersWords) {
  {
    ScenarioBuilder b("unknown-head");
    b.sensor("cam", 10.0)
        .operation("op")
        .trigger("cam")
        .deadline(milliseconds{50})
        .inference("X", "nope", "cam");
    expect_error(b, "unknown head 'nope'");
  }
  {
    ScenarioBuilder b("unknown-sensor");
    b.operation("op").trigger("ghost").deadline(milliseconds{50}).plain("X", milliseconds{1});
    expect_error(b, "ghost");
  }
  {
    ScenarioBuilder b("cycle");
    b.operation("op")
        .rate(10.0)
        .deadline(milliseconds{50})
        .plain("A", milliseconds{1})
        .plain("B", milliseconds{1})
        .edge("A", "B")
        .edge("B", "A");
    expect_error(b, "has a cycle");
  }
  {
    ScenarioBuilder b("missing-node");
    b.operation("op")
        .rate(10.0)
        .deadline(milliseconds{50})
        .plain("A", milliseconds{1})
        .edge("A", "Z");
    expect_error(b, "node 'Z'");
  }
  {
    ScenarioBuilder b("duplicate-node");
    b.operation("op")
        .rate(10.0)
        .deadline(milliseconds{50})
        .plain("A", milliseconds{1})
        .plain("A", milliseconds{2});
    expect_error(b, "duplicate");
  }
  {
    ScenarioBuilder b("duplicate-operation");
    b.operation("op").rate(10.0).deadline(milliseconds{50}).plain("A", milliseconds{1});
    b.operation("op").rate(10.0).deadline(milliseconds{50}).plain("A", milliseconds{1});
    Expected<Scenario> s = b.build();
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("duplicate operation name 'op'"), std::string::npos);
    // Line references into the generated text would mislead: they are removed.
    EXPECT_EQ(s.error().message.find("line"), std::string::npos) << s.error().message;
  }
  {
    ScenarioBuilder b("no-deadline");
    b.operation("op").rate(10.0).plain("A", milliseconds{1});
    expect_error(b, "deadline_ms");
  }
  {
    ScenarioBuilder b("no-trigger");
    b.operation("op").deadline(milliseconds{50}).plain("A", milliseconds{1});
    expect_error(b, "needs a trigger");
  }
  {
    ScenarioBuilder b("bad-rate");
    b.sensor("cam", 0.0)
        .operation("op")
        .trigger("cam")
        .deadline(milliseconds{50})
        .plain("A", milliseconds{1});
    expect_error(b, "rate_hz");
  }
  {
    ScenarioBuilder b("bad-cost");
    b.operation("op")
        .rate(10.0)
        .deadline(milliseconds{50})
        .plain("A", milliseconds{3}, milliseconds{1});
    expect_error(b, "must be >= mean_ms");
  }
  {
    ScenarioBuilder b("node-deadline-first");
    b.operation("op").rate(10.0).deadline(milliseconds{50}).node_deadline("A", milliseconds{9});
    expect_error(b, "has no node 'A'");
  }
}

TEST(ScenarioBuilder, YamlOfABuiltScenarioLoadsToTheSameScenario) {
  const ScenarioBuilder b = two_operations();
  Expected<Scenario> again = parse_scenario(b.to_yaml(), "");
  ASSERT_TRUE(again) << again.error().to_string();
  EXPECT_EQ(again->operation_count(), 2);
  EXPECT_EQ(again->initial[0]->edges.size(), 1u);
}

TEST(ScenarioBuilder, BuiltScenarioSimulates) {
  Expected<Scenario> s = two_operations().build();
  ASSERT_TRUE(s) << s.error().to_string();
  Expected<Profile> p = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(p) << p.error().to_string();
  Expected<PolicyRun> run = simulate_policy(*s, *p, "red", s->seed);
  ASSERT_TRUE(run) << run.error().to_string();
  // 2 s at 30 Hz and 10 Hz, less the 0.1 s warm-up: both operations release jobs.
  EXPECT_GT(run->metrics.jobs, 0);
  EXPECT_GT(run->metrics.completed, 0);
}

}  // namespace
}  // namespace red
