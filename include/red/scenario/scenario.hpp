#pragma once
/// \file
/// The workload model of a scenario file (docs/DESIGN.md, "Task model", docs/SCENARIOS.md), with
/// every name resolved to an index. A Scenario is produced only by load_scenario(), which validates
/// it completely; the scheduler and the simulator may therefore rely on every invariant documented
/// here. The one exception is the policy options of the scheduler section, kept as the file writes
/// them (SchedulerSpec::policy_options): the policy layer checks them (check_policy_options in
/// red/sched/policy.hpp), which every command that loads a scenario file calls.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "red/core/time.hpp"

namespace red {

/// Which execution-time statistic stands for a unit's cost c(x) in deadline arithmetic
/// (docs/DESIGN.md, "Intermediate deadlines").
enum class EstimateKind : std::uint8_t { Mean, P95, P99, Max };

/// How the cost of one DAG level is formed from its units (docs/DESIGN.md, "Intermediate
/// deadlines").
enum class LevelCost : std::uint8_t {
  Max,  ///< L_h = max cost at height h (the paper's rule, parallel lanes)
  Sum,  ///< L_h = sum of costs at height h (one serial lane)
};

/// A camera-like input stream.
struct SensorSpec {
  std::string name;
  double rate_hz = 0.0;  ///< > 0
  Duration phase{0};     ///< time of the first frame
  Duration jitter{0};    ///< each frame is late by a uniform amount in [0, jitter]
  std::string topic;     ///< ROS 2 topic of `red node` (docs/ROS2.md), or empty for the default
  int line = 0;          ///< line in the scenario file, for messages
};

/// Execution time of a plain compute node, in place of a profiled head.
struct PlainCost {
  Duration mean{0};
  Duration p99{0};  ///< == mean for a deterministic cost
};

/// One node of an operation's DAG: an inference (a head on a sensor's frame) or a plain
/// compute task with its own cost.
struct NodeSpec {
  std::string name;
  int head = -1;                  ///< index into ModelSpec::heads, or -1 for a plain node
  int sensor = -1;                ///< index into Scenario::sensors for an inference node, else -1
  std::optional<PlainCost> cost;  ///< set exactly when head == -1
  std::optional<Duration> deadline;  ///< per-node override of its level's budget (docs/DESIGN.md,
                                     ///< "Intermediate deadlines")
  std::string topic;  ///< ROS 2 topic of its output in `red node` (docs/ROS2.md), or empty: default
  int line = 0;

  [[nodiscard]] bool is_plain() const noexcept { return head < 0; }
};

/// A precedence edge between two nodes of one operation, by node index.
struct EdgeSpec {
  int from = 0;
  int to = 0;
};

/// How an operation's relative end-to-end deadline is given.
struct DeadlineSpec {
  Duration fixed{0};                      ///< used when critical_path_x is not set
  std::optional<double> critical_path_x;  ///< multiple of the coarse critical path (profile)
  int line = 0;  ///< where the file gives it (`deadline_ms:`, or set_deadline's); 0: built in code
};

/// A DAG task τ (docs/DESIGN.md, "Task model"). One snapshot of its definition; events produce new
/// snapshots.
struct OperationSpec {
  std::string name;
  int trigger_sensor = -1;  ///< released on every frame of this sensor, or -1
  double rate_hz = 0.0;     ///< own release rate sampling the newest frames (if no trigger)
  Duration phase{0};        ///< offset of the first own-rate release
  std::optional<int> release_count;  ///< release exactly this many jobs, then stop
  DeadlineSpec deadline;
  int criticality = 0;
  int max_inflight = 2;  ///< releases beyond this many unfinished jobs are skipped (docs/DESIGN.md,
                         ///< "max_inflight")
  int depends_on = -1;   ///< operation whose newest job must finish first ("use: latest")
  std::vector<NodeSpec> nodes;
  std::vector<EdgeSpec> edges;
  int line = 0;

  /// Index of the node named `node_name`, or -1.
  [[nodiscard]] int node_index(const std::string& node_name) const noexcept {
    for (std::size_t i = 0; i < nodes.size(); ++i)
      if (nodes[i].name == node_name) return static_cast<int>(i);
    return -1;
  }
};

/// The multi-task network the inference nodes run.
struct ModelSpec {
  std::string builtin = "mimonet";  ///< name of a built-in model, or empty
  std::string manifest;             ///< path of a user model manifest (docs/MODELS.md), or empty
  std::vector<std::string> heads;   ///< head names; NodeSpec::head indexes this
  std::vector<std::int64_t> input{3, 192, 384};  ///< C, H, W
  // Where the scenario file says it (0: not given, or a scenario built in code), for
  // check_model()'s and resolve_profile()'s messages.
  int line = 0;                 ///< the `model:` block
  int manifest_line = 0;        ///< `manifest:`
  std::vector<int> head_lines;  ///< each of `heads`, by index
  int input_line = 0;           ///< `input:`; 0 when the scenario gives none

  [[nodiscard]] int head_index(const std::string& name) const noexcept {
    for (std::size_t i = 0; i < heads.size(); ++i)
      if (heads[i] == name) return static_cast<int>(i);
    return -1;
  }
};

/// A model input's shape as text, "[3,128,256]" (ModelSpec::input; a profile's model label).
inline std::string shape_label(const std::vector<std::int64_t>& input) {
  std::string s = "[";
  for (std::size_t i = 0; i < input.size(); ++i) s += (i > 0 ? "," : "") + std::to_string(input[i]);
  return s + "]";
}

/// Executors and what a synchronization round trip costs on them.
/// Most units a lane holds at once (DeviceSpec::queue_depth).
inline constexpr int kMaxQueueDepth = 4;

struct DeviceSpec {
  int lanes = 1;
  std::optional<Duration> sync_cost;  ///< overrides the profile's measured round trip
  /// Units a lane holds at once (the running one and those enqueued behind it, 1–4); unset:
  /// 2 with a profile measured on a GPU, else 1 (SchedulerConfig::queue_depth).
  std::optional<int> queue_depth;
};

/// One `key: value` of a scenario's `scheduler:` section that is not one of its own knobs
/// (a policy option, or a key no one takes), as the file writes it.
struct OptionText {
  std::string key;
  std::string what;     ///< its path in the file, for messages: "scheduler.drop"
  std::string value;    ///< the value's text; empty when it is not a non-empty string
  std::string problem;  ///< why the value is not text: the whole message, path first
  int key_line = 0;     ///< the key's line (an unknown key is named there)
  int line = 0;         ///< the value's line (a bad value is named there)
};

/// Scheduler knobs a scenario may set; presets (docs/DESIGN.md, "Policies") fill the rest.
struct SchedulerSpec {
  /// DynamicMerge window γ (docs/DESIGN.md, "DynamicMerge").
  Duration gamma = std::chrono::milliseconds{100};
  EstimateKind estimate = EstimateKind::P99;
  LevelCost level_cost = LevelCost::Max;
  int max_batch = 4;
  double qoe_lambda = 1.0;
  /// Policy options the scenario sets for every policy run on it ("key=value,…", as
  /// `policy_options` writes them, in file order: graph, deadlines, reassign, … — ablations,
  /// docs/DESIGN.md, "Overload"). The policy layer reads and checks them
  /// (red::check_policy_options in red/sched/policy.hpp).
  std::string policy_with;
  /// Every key of the section other than the knobs above (scheduler_keys()), as the file
  /// writes it, in file order: what `policy_with` holds, with the lines to name in an error.
  std::vector<OptionText> policy_options;
  /// Online cost estimates (docs/DESIGN.md, "Online costs"): unset, the driver's default
  /// (on for real runs; in the simulator only where it draws costs from another profile).
  std::optional<bool> online_costs;
};

/// Background load during a run (the ROS 2 case study's interference).
struct InterferenceSpec {
  std::string kind = "cpu";
  double intensity = 0.0;  ///< 0 (none) .. 1 (one busy thread per core)
};

/// A timed change of the workload (docs/DESIGN.md, "Task model" events). The loader resolves each
/// event into the operation snapshots it produces, so applying it at run time swaps definitions
/// only.
struct EventSpec {
  Duration at{0};
  int line = 0;
  std::string kind;  ///< add_nodes, remove_nodes, add_edges, remove_edges, add_operation,
                     ///< remove_operation, set_deadline, set_rate
  /// Operations whose definition changes: (operation index, new snapshot or null when the
  /// operation leaves the workload).
  std::vector<std::pair<int, std::shared_ptr<const OperationSpec>>> changes;
  /// Sensor rate changes: (sensor index, new rate).
  std::vector<std::pair<int, double>> sensor_rates;
};

/// A validated scenario.
struct Scenario {
  std::string name;
  std::string file;  ///< path it was loaded from
  Duration duration{std::chrono::seconds{10}};
  Duration warmup{0};
  std::uint64_t seed = 1;
  DeviceSpec device;
  ModelSpec model;
  std::string profile;   ///< profile path, resolved relative to the scenario file, or empty
  int profile_line = 0;  ///< line of `profile:` (0: none, or a scenario built in code)
  SchedulerSpec scheduler;
  std::optional<InterferenceSpec> interference;
  std::vector<SensorSpec> sensors;
  /// Every operation that ever exists, in scenario order (operations added by events
  /// come after the initial ones). `initial[i]` is the definition at t = 0, or null for
  /// an operation that an event adds later.
  std::vector<std::shared_ptr<const OperationSpec>> initial;
  std::vector<EventSpec> events;  ///< in time order

  [[nodiscard]] int operation_count() const noexcept { return static_cast<int>(initial.size()); }
  /// Name of operation i (from whichever snapshot defines it).
  [[nodiscard]] const std::string& operation_name(int i) const {
    return names_[static_cast<std::size_t>(i)];
  }
  std::vector<std::string> names_;  ///< operation names, by index (filled by the loader)
};

}  // namespace red
