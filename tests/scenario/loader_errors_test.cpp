// Every validation error of docs/SCENARIOS.md: one small file each under tests/data/scenarios/bad/,
// with the exact line reported and a key part of the message.

#include <gtest/gtest.h>

#include <string>

#include "red/scenario/loader.hpp"

namespace red {
namespace {

std::string bad_file(const std::string& name) {
  return std::string(RED_TEST_DATA) + "/scenarios/bad/" + name;
}

/// Loads a bad file and checks the error's file, line and message.
void expect_error(const std::string& name, int line, const std::string& fragment) {
  SCOPED_TRACE(name);
  const std::string path = bad_file(name);
  const Expected<Scenario> s = load_scenario(path);
  ASSERT_FALSE(s.has_value());
  EXPECT_EQ(s.error().file, path);
  EXPECT_EQ(s.error().line, line) << s.error().to_string();
  EXPECT_NE(s.error().message.find(fragment), std::string::npos)
      << "message: " << s.error().message << "\nexpected to contain: " << fragment;
}

TEST(LoaderErrors, UnknownTopLevelKey) {
  expect_error("unknown_key_top.yaml", 8, "unknown key 'event'");
  // The message lists what is allowed.
  expect_error("unknown_key_top.yaml", 8, "allowed: name, duration_s");
}

TEST(LoaderErrors, UnknownKeyInNode) {
  expect_error("unknown_key_node.yaml", 14, "unknown key 'sensr'");
  expect_error("unknown_key_node.yaml", 14, "operations.drive.nodes.S");
}

TEST(LoaderErrors, UnknownKeyInEvent) {
  expect_error("unknown_key_event.yaml", 12, "unknown key 'edge' (allowed: operation, edges)");
}

TEST(LoaderErrors, CycleNamesItsNodes) {
  expect_error("cycle.yaml", 14, "cycle: A -> B -> C -> A");
}

TEST(LoaderErrors, UnknownHead) {
  expect_error("unknown_head.yaml", 12, "unknown head 'depth' (model heads: lane, seg)");
}

TEST(LoaderErrors, UnknownSensor) {
  expect_error("unknown_sensor.yaml", 13, "unknown sensor 'rear_camera' (sensors: camera)");
}

TEST(LoaderErrors, EdgeToMissingNode) {
  expect_error("edge_missing_node.yaml", 12, "refers to node 'Z'");
}

TEST(LoaderErrors, NonPositiveRate) {
  expect_error("nonpositive_rate.yaml", 5, "sensors.lidar.rate_hz: must be > 0, got '0'");
}

TEST(LoaderErrors, NonPositiveDeadline) {
  expect_error("nonpositive_deadline.yaml", 6, "deadline_ms: must be > 0, got '-20'");
}

TEST(LoaderErrors, EventRefersToMissingOperation) {
  expect_error("event_missing_operation.yaml", 10, "no operation 'b'");
  expect_error("event_missing_operation.yaml", 10, "at 2 s (operations: a)");
}

TEST(LoaderErrors, EventRemovesNodeRemovedEarlier) {
  expect_error("event_remove_missing_node.yaml", 15, "operation 'a' has no node 'Y' at 2 s");
}

TEST(LoaderErrors, EventsOutOfTimeOrder) {
  expect_error("events_out_of_order.yaml", 10, "events out of time order");
}

TEST(LoaderErrors, YamlSyntaxError) {
  expect_error("syntax_error.yaml", 8, "YAML syntax error");
}

TEST(LoaderErrors, EmptyFile) {
  expect_error("empty.yaml", 0, "empty");
}

TEST(LoaderErrors, TopLevelNotAMapping) {
  expect_error("top_level_list.yaml", 1, "top level must be a mapping");
}

TEST(LoaderErrors, MissingFile) {
  const std::string path = bad_file("does_not_exist.yaml");
  const Expected<Scenario> s = load_scenario(path);
  ASSERT_FALSE(s.has_value());
  EXPECT_EQ(s.error().file, path);
  EXPECT_EQ(s.error().line, 0);
  EXPECT_NE(s.error().message.find("cannot open"), std::string::npos) << s.error().message;
}

TEST(LoaderErrors, DirectoryIsNotAFile) {
  const Expected<Scenario> s = load_scenario(bad_file(""));
  ASSERT_FALSE(s.has_value());
  EXPECT_NE(s.error().message.find("cannot open"), std::string::npos) << s.error().message;
}

TEST(LoaderErrors, WrongType) {
  expect_error("wrong_type.yaml", 5, "rate_hz: must be a number, got 'fast'");
}

TEST(LoaderErrors, DuplicateNodeName) {
  expect_error("duplicate_node.yaml", 10, "duplicate node name 'X' (first at line 8)");
}

TEST(LoaderErrors, NodeWithHeadAndCost) {
  expect_error("head_and_cost.yaml", 12, "has both a head and a cost");
}

// ---- further rules, checked on inline text --------------------------------------------

/// A valid prefix: one camera, one operation `drive` with L -> S.
constexpr const char* kBase = R"(name: base
duration_s: 10
model: {builtin: mimonet, heads: [lane, seg, det]}
sensors:
  camera: {rate_hz: 15}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 100
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
    edges: [[L, S]]
)";

Error error_of(const std::string& text) {
  const Expected<Scenario> s = parse_scenario(text, "inline.yaml");
  EXPECT_FALSE(s.has_value()) << "expected an error for:\n" << text;
  return s ? Error{} : s.error();
}

void expect_inline(const std::string& text, int line, const std::string& fragment) {
  const Error e = error_of(text);
  EXPECT_EQ(e.file, "inline.yaml");
  EXPECT_EQ(e.line, line) << e.to_string();
  EXPECT_NE(e.message.find(fragment), std::string::npos)
      << "message: " << e.message << "\nexpected to contain: " << fragment;
}

TEST(LoaderErrors, BasePrefixIsValid) {
  const Expected<Scenario> s = parse_scenario(kBase, "inline.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
}

TEST(LoaderErrors, MissingRequiredKeys) {
  expect_inline("name: x\noperations: []\n", 1, "missing required key 'duration_s'");
  expect_inline(std::string(kBase) + "  - name: p\n    rate_hz: 5\n    nodes: {X: {cost_ms: 1}}\n",
                14, "missing required key 'deadline_ms'");
}

TEST(LoaderErrors, OperationNeedsAReleaseRule) {
  expect_inline(
      std::string(kBase) + "  - name: p\n    deadline_ms: 5\n    nodes: {X: {cost_ms: 1}}\n", 14,
      "needs a trigger");
  expect_inline(
      std::string(kBase) +
          "  - name: p\n    trigger: camera\n    rate_hz: 3\n    deadline_ms: 5\n    nodes: {X: "
          "{cost_ms: 1}}\n",
      16, "not both");
}

TEST(LoaderErrors, DuplicateOperationName) {
  expect_inline(std::string(kBase) +
                    "  - name: drive\n    rate_hz: 5\n    deadline_ms: 5\n"
                    "    nodes: {X: {cost_ms: 1}}\n",
                14, "duplicate operation name 'drive' (first at line 7)");
}

TEST(LoaderErrors, DependsOnItselfOrMissing) {
  expect_inline(std::string(kBase) +
                    "  - name: p\n    rate_hz: 5\n    deadline_ms: 5\n"
                    "    depends_on: {operation: p}\n"
                    "    nodes: {X: {cost_ms: 1}}\n",
                17, "cannot depend on itself");
  expect_inline(std::string(kBase) +
                    "  - name: p\n    rate_hz: 5\n    deadline_ms: 5\n"
                    "    depends_on: {operation: q}\n"
                    "    nodes: {X: {cost_ms: 1}}\n",
                17, "no operation named 'q'");
  // The message lists the operations there are, as an unknown sensor's lists the sensors.
  expect_inline(std::string(kBase) +
                    "  - name: p\n    rate_hz: 5\n    deadline_ms: 5\n"
                    "    depends_on: {operation: q}\n"
                    "    nodes: {X: {cost_ms: 1}}\n",
                17, "no operation named 'q' (operations: drive, p)");
}

TEST(LoaderErrors, HeadWithoutModel) {
  expect_inline(
      "name: x\nduration_s: 1\nsensors: {cam: {rate_hz: 1}}\noperations:\n"
      "  - {name: a, trigger: cam, deadline_ms: 5, nodes: {N: {head: lane, sensor: cam}}}\n",
      5, "no model");
}

TEST(LoaderErrors, CostP99BelowMean) {
  expect_inline(
      "name: x\nduration_s: 1\noperations:\n  - name: a\n    rate_hz: 1\n"
      "    deadline_ms: 5\n    nodes:\n      N: {cost: {mean_ms: 4, p99_ms: 3}}\n",
      8, "p99_ms: must be >= mean_ms");
}

TEST(LoaderErrors, WarmupNotBeforeEnd) {
  expect_inline("name: x\nduration_s: 2\nwarmup_s: 2\noperations: []\n", 3,
                "warmup_s: must be less than duration_s");
}

TEST(LoaderErrors, EventAfterEnd) {
  expect_inline(
      std::string(kBase) + "events:\n  - {at_s: 10, remove_operation: {operation: drive}}\n", 15,
      "not before the end");
}

TEST(LoaderErrors, EventWithTwoActionsOrNone) {
  expect_inline(std::string(kBase) +
                    "events:\n  - at_s: 1\n    set_deadline: {operation: drive, deadline_ms: 9}\n"
                    "    remove_operation: {operation: drive}\n",
                17, "exactly one action");
  expect_inline(std::string(kBase) + "events:\n  - {at_s: 1}\n", 15, "no action");
}

TEST(LoaderErrors, EventRefersToRemovedOperation) {
  expect_inline(std::string(kBase) +
                    "events:\n  - {at_s: 1, remove_operation: {operation: drive}}\n"
                    "  - {at_s: 2, set_deadline: {operation: drive, deadline_ms: 9}}\n",
                16, "an earlier event removed it");
}

TEST(LoaderErrors, EventMakesCycle) {
  expect_inline(std::string(kBase) +
                    "events:\n  - {at_s: 1, add_edges: {operation: drive, "
                    "edges: [[S, L]]}}\n",
                15, "cycle: L -> S -> L");
}

TEST(LoaderErrors, EventRemovesMissingEdge) {
  expect_inline(std::string(kBase) +
                    "events:\n  - at_s: 1\n    remove_edges:\n"
                    "      operation: drive\n      edges:\n        - [S, L]\n",
                19, "has no edge [S, L]");
}

TEST(LoaderErrors, EventAddsExistingNodeOrEdge) {
  expect_inline(std::string(kBase) +
                    "events:\n  - at_s: 1\n    add_nodes:\n"
                    "      operation: drive\n      nodes:\n"
                    "        L: {head: lane, sensor: camera}\n",
                19, "already has a node 'L'");
  expect_inline(std::string(kBase) +
                    "events:\n  - {at_s: 1, add_edges: {operation: drive, "
                    "edges: [[L, S]]}}\n",
                15, "already has edge [L, S]");
}

TEST(LoaderErrors, EventAddsExistingOperation) {
  expect_inline(std::string(kBase) +
                    "events:\n  - at_s: 1\n    add_operation:\n"
                    "      {name: drive, rate_hz: 1, deadline_ms: 5, nodes: {X: "
                    "{cost_ms: 1}}}\n",
                17, "already exists");
}

TEST(LoaderErrors, EventRemovesEveryNode) {
  expect_inline(std::string(kBase) +
                    "events:\n  - {at_s: 1, remove_nodes: {operation: drive, "
                    "nodes: [L, S]}}\n",
                15, "would have no nodes");
}

TEST(LoaderErrors, SetRateOnTriggeredOperation) {
  expect_inline(std::string(kBase) +
                    "events:\n  - {at_s: 1, set_rate: {operation: drive, "
                    "rate_hz: 9}}\n",
                15, "has no own rate_hz");
}

TEST(LoaderErrors, RemoveOperationOthersDependOn) {
  expect_inline(std::string(kBase) +
                    "  - {name: p, rate_hz: 5, deadline_ms: 5, depends_on: {operation: drive}, "
                    "nodes: {X: {cost_ms: 1}}}\n"
                    "events:\n  - {at_s: 1, remove_operation: {operation: drive}}\n",
                16, "operation 'p' depends on it");
}

TEST(LoaderErrors, QuotedNumberIsAString) {
  expect_inline("name: x\nduration_s: \"5\"\noperations: []\n", 2, "must be a number");
}

TEST(LoaderErrors, StrTaggedNumberIsAString) {
  std::string text = kBase;
  text.replace(text.find("duration_s: 10"), 14, "duration_s: !!str 10");
  expect_inline(text, 2, "duration_s: must be a number, got the string !!str '10'");
  text = std::string(kBase) + "device: {lanes: !!str 2}\n";
  expect_inline(text, 14, "must be an integer, got the string !!str '2'");
}

TEST(LoaderErrors, IntAndFloatTagsAreNumbers) {
  std::string text = kBase;
  text.replace(text.find("duration_s: 10"), 14, "duration_s: !!float 10");
  text += "device: {lanes: !!int 2}\n";
  const Expected<Scenario> s = parse_scenario(text, "inline.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  EXPECT_EQ(s->device.lanes, 2);
}

TEST(LoaderErrors, DuplicateMappingKey) {
  expect_inline("name: x\nduration_s: 5\nname: y\noperations: []\n", 3, "duplicate key 'name'");
}

TEST(LoaderErrors, NullWhereMappingExpected) {
  expect_inline("name: x\nduration_s: 5\ndevice:\noperations: []\n", 3,
                "device: must be a mapping, got nothing");
}

TEST(LoaderErrors, NegativeSeedAndFractionalLanes) {
  expect_inline("name: x\nduration_s: 5\nseed: -1\noperations: []\n", 3,
                "seed: must be an integer");
  expect_inline("name: x\nduration_s: 5\ndevice: {lanes: 1.5}\noperations: []\n", 3,
                "lanes: must be an integer");
  expect_inline("name: x\nduration_s: 5\ndevice: {queue_depth: 5}\noperations: []\n", 3,
                "device.queue_depth: must be an integer in [1, 4]");
  expect_inline("name: x\nduration_s: 5\ndevice: {queue_depth: 0}\noperations: []\n", 3,
                "device.queue_depth: must be an integer in [1, 4]");
}

TEST(LoaderErrors, ModelNeedsExactlyOneSource) {
  expect_inline("name: x\nduration_s: 5\nmodel: {heads: [a]}\noperations: []\n", 3,
                "exactly one of 'builtin'");
  expect_inline(
      "name: x\nduration_s: 5\nmodel: {builtin: mimonet, heads: [a, a]}\n"
      "operations: []\n",
      3, "duplicate head 'a'");
}

TEST(LoaderErrors, AliasesAndOddInputNeverCrash) {
  // Odd but well-formed YAML: every case must give an Error, not a crash or an exception.
  for (const char* text :
       {"name: [1, 2]\nduration_s: 5\noperations: []\n", "? [a, b]\n: 1\n",
        "name: x\nduration_s: .nan\noperations: []\n",
        "name: x\nduration_s: 1e400\noperations: []\n",
        "name: x\nduration_s: 5\noperations: {a: 1}\n", "name: x\nduration_s: 5\noperations: [1]\n",
        "name: x\nduration_s: 5\noperations:\n  - name: a\n    rate_hz: 1\n"
        "    deadline_ms: 5\n    nodes: {X: {cost_ms: 1}}\n    edges: [X]\n",
        "name: x\nduration_s: 5\nevents: 3\noperations: []\n", "\t\"", "42"}) {
    const Expected<Scenario> s = parse_scenario(text, "odd.yaml");
    EXPECT_FALSE(s.has_value()) << text;
  }
}

}  // namespace
}  // namespace red
