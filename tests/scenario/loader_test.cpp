// A scenario that uses every key parses, and replaying its events yields the right
// snapshots (docs/SCENARIOS.md).

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

constexpr const char* kEverything = R"(name: everything
duration_s: 10
warmup_s: 1
seed: 42
device: {lanes: 2, sync_cost_us: 20}
model: {builtin: mimonet, heads: [lane, seg, steer, det], input: [3, 96, 192]}
profile: profiles/p.json
scheduler: {gamma_ms: 5, estimate: p95, level_cost: sum, max_batch: 3, qoe_lambda: 0.5}
interference: {kind: cpu, intensity: 0.25}
sensors:
  camera: {rate_hz: 30, phase_ms: 2, jitter_ms: 1}
  lidar: {rate_hz: 10}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 120
    criticality: 2
    max_inflight: 3
    nodes:
      L: {head: lane, sensor: camera, deadline_ms: 40}
      S: {head: seg, sensor: camera}
      P: {cost_ms: 1.5}
      C: {head: steer, sensor: camera}
    edges: [[L, S], [S, P], [P, C]]
  - name: plan
    rate_hz: 20
    phase_ms: 3
    deadline_ms: {critical_path_x: 1.5}
    depends_on: {operation: drive, use: latest}
    nodes:
      A: {cost: {mean_ms: 2, p99_ms: 3}}
      B: {cost_ms: 0}
    edges: [[A, B]]
events:
  - {at_s: 1, add_nodes: {operation: drive, nodes: {O: {head: det, sensor: camera}}, edges: [[L, O], [O, C]]}}
  - {at_s: 2, add_edges: {operation: drive, edges: [[L, C]]}}
  - {at_s: 2, remove_edges: {operation: drive, edges: [[S, P]]}}
  - {at_s: 3, set_deadline: {operation: drive, deadline_ms: {critical_path_x: 2}}}
  - {at_s: 3.5, set_rate: {operation: plan, rate_hz: 40}}
  - {at_s: 4, set_rate: {sensor: lidar, rate_hz: 5}}
  - at_s: 5
    add_operation:
      name: burst
      release: {count: 3}
      phase_ms: 10
      deadline_ms: 50
      nodes: {X: {cost_ms: 2}, Y: {cost_ms: 1}}
      edges: [[X, Y]]
  - {at_s: 6, remove_nodes: {operation: drive, nodes: [O, P]}}
  - {at_s: 7, remove_operation: {operation: plan}}
  - {at_s: 8, set_deadline: {operation: drive, deadline_ms: 90}}
)";

/// Node names of a snapshot, in order.
std::vector<std::string> names(const OperationSpec& op) {
  std::vector<std::string> out;
  for (const auto& n : op.nodes) out.push_back(n.name);
  return out;
}

/// Edges of a snapshot as name pairs.
std::vector<std::pair<std::string, std::string>> edges(const OperationSpec& op) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& e : op.edges)
    out.emplace_back(op.nodes[static_cast<std::size_t>(e.from)].name,
                     op.nodes[static_cast<std::size_t>(e.to)].name);
  return out;
}

using Edges = std::vector<std::pair<std::string, std::string>>;
using Names = std::vector<std::string>;

Scenario load_everything() {
  Expected<Scenario> s = parse_scenario(kEverything, "/data/run/everything.yaml");
  EXPECT_TRUE(s.has_value()) << s.error().to_string();
  return s ? std::move(s).value() : Scenario{};
}

TEST(Loader, TopLevelSettings) {
  const Scenario s = load_everything();
  EXPECT_EQ(s.name, "everything");
  EXPECT_EQ(s.file, "/data/run/everything.yaml");
  EXPECT_EQ(s.duration, std::chrono::seconds{10});
  EXPECT_EQ(s.warmup, std::chrono::seconds{1});
  EXPECT_EQ(s.seed, 42U);
  EXPECT_EQ(s.device.lanes, 2);
  ASSERT_TRUE(s.device.sync_cost.has_value());
  EXPECT_EQ(*s.device.sync_cost, std::chrono::microseconds{20});
  EXPECT_EQ(s.model.builtin, "mimonet");
  EXPECT_TRUE(s.model.manifest.empty());
  EXPECT_EQ(s.model.heads, (Names{"lane", "seg", "steer", "det"}));
  EXPECT_EQ(s.model.input, (std::vector<std::int64_t>{3, 96, 192}));
  EXPECT_EQ(s.profile, "/data/run/profiles/p.json");  // relative to the scenario file
  EXPECT_EQ(s.scheduler.gamma, milliseconds{5});
  EXPECT_EQ(s.scheduler.estimate, EstimateKind::P95);
  EXPECT_EQ(s.scheduler.level_cost, LevelCost::Sum);
  EXPECT_EQ(s.scheduler.max_batch, 3);
  EXPECT_DOUBLE_EQ(s.scheduler.qoe_lambda, 0.5);
  ASSERT_TRUE(s.interference.has_value());
  EXPECT_EQ(s.interference->kind, "cpu");
  EXPECT_DOUBLE_EQ(s.interference->intensity, 0.25);
  ASSERT_EQ(s.sensors.size(), 2U);
  EXPECT_EQ(s.sensors[0].name, "camera");
  EXPECT_DOUBLE_EQ(s.sensors[0].rate_hz, 30.0);
  EXPECT_EQ(s.sensors[0].phase, milliseconds{2});
  EXPECT_EQ(s.sensors[0].jitter, milliseconds{1});
  EXPECT_EQ(s.sensors[0].line, 11);
  EXPECT_EQ(s.sensors[1].name, "lidar");
  EXPECT_EQ(s.sensors[1].phase, Duration{0});
}

TEST(Loader, InitialOperations) {
  const Scenario s = load_everything();
  ASSERT_EQ(s.operation_count(), 3);  // drive, plan, and burst added by an event
  EXPECT_EQ(s.operation_name(0), "drive");
  EXPECT_EQ(s.operation_name(1), "plan");
  EXPECT_EQ(s.operation_name(2), "burst");
  ASSERT_NE(s.initial[0], nullptr);
  ASSERT_NE(s.initial[1], nullptr);
  EXPECT_EQ(s.initial[2], nullptr);

  const OperationSpec& drive = *s.initial[0];
  EXPECT_EQ(drive.line, 14);
  EXPECT_EQ(drive.trigger_sensor, 0);
  EXPECT_DOUBLE_EQ(drive.rate_hz, 0.0);
  EXPECT_EQ(drive.deadline.fixed, milliseconds{120});
  EXPECT_FALSE(drive.deadline.critical_path_x.has_value());
  EXPECT_EQ(drive.criticality, 2);
  EXPECT_EQ(drive.max_inflight, 3);
  EXPECT_EQ(drive.depends_on, -1);
  EXPECT_FALSE(drive.release_count.has_value());
  EXPECT_EQ(names(drive), (Names{"L", "S", "P", "C"}));
  EXPECT_EQ(edges(drive), (Edges{{"L", "S"}, {"S", "P"}, {"P", "C"}}));
  const NodeSpec& l = drive.nodes[0];
  EXPECT_EQ(l.head, 0);
  EXPECT_EQ(l.sensor, 0);
  EXPECT_FALSE(l.is_plain());
  EXPECT_FALSE(l.cost.has_value());
  ASSERT_TRUE(l.deadline.has_value());
  EXPECT_EQ(*l.deadline, milliseconds{40});
  EXPECT_EQ(l.line, 20);
  EXPECT_EQ(drive.nodes[1].head, 1);
  EXPECT_FALSE(drive.nodes[1].deadline.has_value());
  const NodeSpec& p = drive.nodes[2];
  EXPECT_TRUE(p.is_plain());
  EXPECT_EQ(p.sensor, -1);
  ASSERT_TRUE(p.cost.has_value());
  EXPECT_EQ(p.cost->mean, std::chrono::microseconds{1500});
  EXPECT_EQ(p.cost->p99, std::chrono::microseconds{1500});
  EXPECT_EQ(drive.nodes[3].head, 2);

  const OperationSpec& plan = *s.initial[1];
  EXPECT_EQ(plan.trigger_sensor, -1);
  EXPECT_DOUBLE_EQ(plan.rate_hz, 20.0);
  EXPECT_EQ(plan.phase, milliseconds{3});
  ASSERT_TRUE(plan.deadline.critical_path_x.has_value());
  EXPECT_DOUBLE_EQ(*plan.deadline.critical_path_x, 1.5);
  EXPECT_EQ(plan.depends_on, 0);
  EXPECT_EQ(plan.max_inflight, 2);
  EXPECT_EQ(plan.criticality, 0);
  ASSERT_TRUE(plan.nodes[0].cost.has_value());
  EXPECT_EQ(plan.nodes[0].cost->mean, milliseconds{2});
  EXPECT_EQ(plan.nodes[0].cost->p99, milliseconds{3});
  EXPECT_EQ(plan.nodes[1].cost->mean, Duration{0});
  EXPECT_EQ(edges(plan), (Edges{{"A", "B"}}));
}

TEST(Loader, EventsResolveToSnapshots) {
  const Scenario s = load_everything();
  ASSERT_EQ(s.events.size(), 10U);
  const auto& ev = s.events;
  for (std::size_t i = 1; i < ev.size(); ++i) EXPECT_LE(ev[i - 1].at, ev[i].at);

  // Each event but set_rate on a sensor changes exactly one operation.
  auto only = [&](std::size_t i, int op) -> const OperationSpec& {
    EXPECT_EQ(ev[i].changes.size(), 1U) << "event " << i;
    EXPECT_EQ(ev[i].changes.at(0).first, op) << "event " << i;
    EXPECT_NE(ev[i].changes.at(0).second, nullptr) << "event " << i;
    return *ev[i].changes.at(0).second;
  };

  EXPECT_EQ(ev[0].kind, "add_nodes");
  EXPECT_EQ(ev[0].at, std::chrono::seconds{1});
  EXPECT_EQ(ev[0].line, 35);
  const OperationSpec& d0 = only(0, 0);
  EXPECT_EQ(names(d0), (Names{"L", "S", "P", "C", "O"}));
  EXPECT_EQ(d0.nodes[4].head, 3);
  EXPECT_EQ(edges(d0), (Edges{{"L", "S"}, {"S", "P"}, {"P", "C"}, {"L", "O"}, {"O", "C"}}));
  EXPECT_EQ(d0.deadline.fixed, milliseconds{120});
  // The snapshot before the event is untouched.
  EXPECT_EQ(names(*s.initial[0]), (Names{"L", "S", "P", "C"}));

  EXPECT_EQ(ev[1].kind, "add_edges");
  EXPECT_EQ(edges(only(1, 0)),
            (Edges{{"L", "S"}, {"S", "P"}, {"P", "C"}, {"L", "O"}, {"O", "C"}, {"L", "C"}}));

  EXPECT_EQ(ev[2].kind, "remove_edges");
  EXPECT_EQ(edges(only(2, 0)), (Edges{{"L", "S"}, {"P", "C"}, {"L", "O"}, {"O", "C"}, {"L", "C"}}));

  EXPECT_EQ(ev[3].kind, "set_deadline");
  const OperationSpec& d3 = only(3, 0);
  ASSERT_TRUE(d3.deadline.critical_path_x.has_value());
  EXPECT_DOUBLE_EQ(*d3.deadline.critical_path_x, 2.0);
  EXPECT_EQ(names(d3), (Names{"L", "S", "P", "C", "O"}));

  EXPECT_EQ(ev[4].kind, "set_rate");
  EXPECT_EQ(ev[4].at, std::chrono::milliseconds{3500});
  const OperationSpec& p4 = only(4, 1);
  EXPECT_DOUBLE_EQ(p4.rate_hz, 40.0);
  EXPECT_EQ(p4.depends_on, 0);
  EXPECT_TRUE(ev[4].sensor_rates.empty());

  EXPECT_EQ(ev[5].kind, "set_rate");
  EXPECT_TRUE(ev[5].changes.empty());
  ASSERT_EQ(ev[5].sensor_rates.size(), 1U);
  EXPECT_EQ(ev[5].sensor_rates[0].first, 1);
  EXPECT_DOUBLE_EQ(ev[5].sensor_rates[0].second, 5.0);

  EXPECT_EQ(ev[6].kind, "add_operation");
  EXPECT_EQ(ev[6].line, 41);
  const OperationSpec& b6 = only(6, 2);
  EXPECT_EQ(b6.name, "burst");
  ASSERT_TRUE(b6.release_count.has_value());
  EXPECT_EQ(*b6.release_count, 3);
  EXPECT_EQ(b6.trigger_sensor, -1);
  EXPECT_DOUBLE_EQ(b6.rate_hz, 0.0);
  EXPECT_EQ(b6.phase, milliseconds{10});
  EXPECT_EQ(b6.deadline.fixed, milliseconds{50});
  EXPECT_EQ(edges(b6), (Edges{{"X", "Y"}}));

  EXPECT_EQ(ev[7].kind, "remove_nodes");
  const OperationSpec& d7 = only(7, 0);
  EXPECT_EQ(names(d7), (Names{"L", "S", "C"}));
  EXPECT_EQ(edges(d7), (Edges{{"L", "S"}, {"L", "C"}}));
  EXPECT_DOUBLE_EQ(d7.deadline.critical_path_x.value_or(0.0), 2.0);  // kept from event 3
  EXPECT_EQ(d7.nodes[2].head, 2);                                    // C is still steer

  EXPECT_EQ(ev[8].kind, "remove_operation");
  ASSERT_EQ(ev[8].changes.size(), 1U);
  EXPECT_EQ(ev[8].changes[0].first, 1);
  EXPECT_EQ(ev[8].changes[0].second, nullptr);

  EXPECT_EQ(ev[9].kind, "set_deadline");
  const OperationSpec& d9 = only(9, 0);
  EXPECT_EQ(d9.deadline.fixed, milliseconds{90});
  EXPECT_FALSE(d9.deadline.critical_path_x.has_value());
  EXPECT_EQ(names(d9), (Names{"L", "S", "C"}));
}

TEST(Loader, ResolvesPathsRelativeToTheFile) {
  // A valid text labelled with a relative file name keeps a relative directory.
  const Expected<Scenario> s = parse_scenario(
      "name: x\nduration_s: 1\nprofile: ../p.json\n"
      "model: {manifest: m/model.yaml, heads: [a]}\noperations: []\n",
      "scen/dir/s.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  EXPECT_EQ(s->profile, "scen/p.json");
  EXPECT_EQ(s->model.manifest, "scen/dir/m/model.yaml");
  EXPECT_TRUE(s->model.builtin.empty());
  EXPECT_EQ(s->model.input, (std::vector<std::int64_t>{3, 192, 384}));  // default
  // Absolute paths stay as they are; no file label leaves relative paths alone.
  const Expected<Scenario> a =
      parse_scenario("name: x\nduration_s: 1\nprofile: /abs/p.json\noperations: []\n", "s.yaml");
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->profile, "/abs/p.json");
  const Expected<Scenario> r =
      parse_scenario("name: x\nduration_s: 1\nprofile: p.json\noperations: []\n", "");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->profile, "p.json");
}

TEST(Loader, Defaults) {
  const Expected<Scenario> s = parse_scenario(
      "name: d\nduration_s: 2\noperations:\n  - {name: a, rate_hz: 5, deadline_ms: 10, nodes: "
      "{X: {cost_ms: 1}}}\n",
      "d.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  EXPECT_EQ(s->warmup, Duration{0});
  EXPECT_EQ(s->seed, 1U);
  EXPECT_EQ(s->device.lanes, 1);
  EXPECT_FALSE(s->device.sync_cost.has_value());
  EXPECT_FALSE(s->interference.has_value());
  EXPECT_TRUE(s->profile.empty());
  EXPECT_EQ(s->scheduler.estimate, EstimateKind::P99);
  EXPECT_EQ(s->scheduler.level_cost, LevelCost::Max);
  EXPECT_EQ(s->scheduler.max_batch, 4);
  EXPECT_EQ(s->scheduler.gamma, milliseconds{100});
  EXPECT_TRUE(s->events.empty());
  ASSERT_EQ(s->operation_count(), 1);
  EXPECT_EQ(s->initial[0]->max_inflight, 2);
  EXPECT_TRUE(s->initial[0]->edges.empty());
}

// Every policy option (option_keys(), the keys of --with) may be set in the scheduler section,
// with the value describe() prints for red-robust: miss_gate was refused there once.
TEST(Loader, SchedulerSectionTakesEveryPolicyOption) {
  // ",key=value,…,": a key is found whole (`rank` is not found in `path_rank`).
  const std::string all = "," + describe(*preset_options("red-robust")) + ",";
  for (const std::string& key : option_keys()) {
    SCOPED_TRACE(key);
    const std::size_t at = all.find("," + key + "=");
    ASSERT_NE(at, std::string::npos) << all;
    const std::size_t from = at + key.size() + 2;
    const std::string value = all.substr(from, all.find(',', from) - from);
    const Expected<Scenario> s = parse_scenario(
        "name: o\nduration_s: 1\nscheduler: {" + key + ": \"" + value +
            "\"}\noperations:\n  - {name: a, rate_hz: 5, deadline_ms: 10, nodes: {X: {cost_ms: "
            "1}}}\n",
        "o.yaml");
    ASSERT_TRUE(s.has_value()) << s.error().to_string();
    EXPECT_EQ(s->scheduler.policy_with, key + "=" + value);
  }
}

TEST(Loader, DependsOnAnOperationDefinedLater) {
  const Expected<Scenario> s = parse_scenario(R"(name: fwd
duration_s: 2
operations:
  - {name: b, rate_hz: 33, deadline_ms: 30, depends_on: {operation: a}, nodes: {X: {cost_ms: 1}}}
  - {name: a, rate_hz: 30, deadline_ms: 30, nodes: {Y: {cost_ms: 1}}}
)",
                                              "fwd.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  EXPECT_EQ(s->initial[0]->depends_on, 1);
  EXPECT_EQ(s->initial[1]->depends_on, -1);
}

TEST(Loader, DependsOnCycleIsAnError) {
  const Expected<Scenario> s = parse_scenario(R"(name: dcycle
duration_s: 2
operations:
  - {name: b, rate_hz: 33, deadline_ms: 30, depends_on: {operation: a}, nodes: {X: {cost_ms: 1}}}
  - {name: a, rate_hz: 30, deadline_ms: 30, depends_on: {operation: b}, nodes: {Y: {cost_ms: 1}}}
)",
                                              "dcycle.yaml");
  ASSERT_FALSE(s.has_value());
  EXPECT_EQ(s.error().line, 4);
  EXPECT_NE(s.error().message.find("depends_on forms a cycle"), std::string::npos);
}

TEST(Loader, CountReleaseNeedsNoTrigger) {
  const Expected<Scenario> s = parse_scenario(R"(name: oneshot
duration_s: 2
operations:
  - name: g
    release: {count: 1}
    deadline_ms: 500
    nodes: {A: {cost_ms: 3}, B: {cost_ms: 4}, C: {cost_ms: 5}}
    edges: [[A, C], [B, C]]
)",
                                              "oneshot.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const OperationSpec& g = *s->initial[0];
  EXPECT_EQ(g.release_count, 1);
  EXPECT_EQ(g.trigger_sensor, -1);
  EXPECT_DOUBLE_EQ(g.rate_hz, 0.0);
}

TEST(Loader, ReAddedOperationGetsANewIndex) {
  const Expected<Scenario> s = parse_scenario(R"(name: readd
duration_s: 10
operations:
  - {name: a, rate_hz: 10, deadline_ms: 50, nodes: {X: {cost_ms: 1}}}
events:
  - {at_s: 1, remove_operation: {operation: a}}
  - {at_s: 2, add_operation: {name: a, rate_hz: 5, deadline_ms: 80, nodes: {Y: {cost_ms: 2}}}}
  - {at_s: 3, set_rate: {operation: a, rate_hz: 7}}
)",
                                              "readd.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  ASSERT_EQ(s->operation_count(), 2);
  EXPECT_EQ(s->operation_name(0), "a");
  EXPECT_EQ(s->operation_name(1), "a");
  EXPECT_EQ(s->initial[1], nullptr);
  EXPECT_EQ(s->events[1].changes.at(0).first, 1);
  // Later events refer to the operation present at their time.
  EXPECT_EQ(s->events[2].changes.at(0).first, 1);
  EXPECT_DOUBLE_EQ(s->events[2].changes.at(0).second->rate_hz, 7.0);
  EXPECT_EQ(names(*s->events[2].changes.at(0).second), (Names{"Y"}));
}

TEST(Loader, SameTimeEventsApplyInFileOrder) {
  const Expected<Scenario> s = parse_scenario(R"(name: same
duration_s: 10
operations:
  - {name: a, rate_hz: 10, deadline_ms: 50, nodes: {X: {cost_ms: 1}}}
events:
  - {at_s: 1, add_nodes: {operation: a, nodes: {Y: {cost_ms: 1}}, edges: [[X, Y]]}}
  - {at_s: 1, remove_nodes: {operation: a, nodes: [X]}}
)",
                                              "same.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const OperationSpec& last = *s->events[1].changes.at(0).second;
  EXPECT_EQ(names(last), (Names{"Y"}));
  EXPECT_TRUE(last.edges.empty());
}

}  // namespace
}  // namespace red
