#pragma once
/// \file
/// Building a Scenario in code, for programs that embed RED and have no scenario file.
/// The builder names things (sensors, heads, nodes, operations) as a file does, and
/// build() validates the result by the very rules of load_scenario() (it goes through the
/// same loader), so a built Scenario carries every invariant a loaded one does.
///
///     red::ScenarioBuilder b("two-ops");
///     b.duration(std::chrono::seconds{2}).lanes(2).sensor("camera", 30.0);
///     b.operation("drive").trigger("camera").deadline(std::chrono::milliseconds{100})
///         .inference("L", "lane", "camera").inference("S", "seg", "camera").edge("L", "S");
///     b.operation("post").rate(10.0).deadline(std::chrono::milliseconds{50})
///         .plain("P", std::chrono::milliseconds{2});
///     red::Expected<red::Scenario> s = b.build();
///     if (!s) { std::cerr << s.error().to_string() << '\n'; return 2; }
///
/// Workload events (docs/DESIGN.md, "Task model") are not covered: a scenario with events comes
/// from a file.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// One operation (a DAG task) of a ScenarioBuilder. Obtained from
/// ScenarioBuilder::operation(); stays valid as long as its builder.
class OperationBuilder {
 public:
  /// Released on every frame of `sensor`.
  OperationBuilder& trigger(std::string sensor);
  /// Released at its own rate (Hz), sampling the newest frames.
  OperationBuilder& rate(double hz);
  /// Offset of the first own-rate release.
  OperationBuilder& phase(Duration d);
  /// Releases exactly `count` jobs (a one-shot DAG), then stops.
  OperationBuilder& release_count(int count);
  /// Relative end-to-end deadline.
  OperationBuilder& deadline(Duration d);
  /// End-to-end deadline as a multiple of the coarse critical path (from the profile).
  OperationBuilder& deadline_critical_path(double factor);
  /// Higher criticality survives overload longer.
  OperationBuilder& criticality(int c);
  /// Releases beyond this many unfinished jobs are skipped.
  OperationBuilder& max_inflight(int n);
  /// Waits for the newest job of `operation` ("use: latest").
  OperationBuilder& depends_on(std::string operation);
  /// An inference node: model head `head` on the frames of `sensor`.
  OperationBuilder& inference(std::string node, std::string head, std::string sensor);
  /// A plain compute node with a deterministic cost.
  OperationBuilder& plain(std::string node, Duration cost);
  /// A plain compute node with a mean and a 99th-percentile cost (p99 >= mean).
  OperationBuilder& plain(std::string node, Duration mean, Duration p99);
  /// Per-node override of its level's deadline budget (docs/DESIGN.md, "Intermediate deadlines");
  /// the node must exist already.
  OperationBuilder& node_deadline(const std::string& node, Duration d);
  /// A precedence edge between two nodes of this operation.
  OperationBuilder& edge(std::string from, std::string to);

 private:
  friend class ScenarioBuilder;
  struct Node {
    std::string name, head, sensor;
    std::optional<Duration> mean, p99, deadline;
  };
  explicit OperationBuilder(std::string name) : name_(std::move(name)) {}

  std::string name_;
  std::optional<std::string> trigger_, depends_on_;
  std::optional<double> rate_hz_, critical_path_x_;
  std::optional<Duration> phase_, deadline_;
  std::optional<int> release_count_, criticality_, max_inflight_;
  std::vector<Node> nodes_;
  std::vector<std::pair<std::string, std::string>> edges_;
  std::vector<std::string> misuse_;  ///< builder misuse found early, reported by build()
};

/// Builds a validated Scenario in code (see the file comment for an example). Defaults
/// are a file's: 10 s, no warm-up, seed 1, one lane, the built-in MIMONet with heads
/// lane, seg, steer and det, the default scheduler knobs.
class ScenarioBuilder {
 public:
  /// A scenario named `name`.
  explicit ScenarioBuilder(std::string name);
  ~ScenarioBuilder();
  /// Moves the whole builder; references from operation() stay valid.
  ScenarioBuilder(ScenarioBuilder&&) noexcept;
  /// Moves the whole builder; references from operation() stay valid.
  ScenarioBuilder& operator=(ScenarioBuilder&&) noexcept;
  ScenarioBuilder(const ScenarioBuilder&) = delete;
  ScenarioBuilder& operator=(const ScenarioBuilder&) = delete;

  /// How long releases go on (> 0).
  ScenarioBuilder& duration(Duration d);
  /// Start of the measured window (< duration).
  ScenarioBuilder& warmup(Duration d);
  /// Seed of every random choice (jitter, sampled costs).
  ScenarioBuilder& seed(std::uint64_t s);
  /// Number of executor lanes (>= 1).
  ScenarioBuilder& lanes(int n);
  /// Cost of one synchronizer round trip, instead of the profile's.
  ScenarioBuilder& sync_cost(Duration d);
  /// Units a lane holds at once (device.queue_depth, 1–4).
  ScenarioBuilder& queue_depth(int n);
  /// Head names of the built-in MIMONet the inference nodes use.
  ScenarioBuilder& heads(std::vector<std::string> names);
  /// Profile file to use (empty: the built-in default).
  ScenarioBuilder& profile(std::string path);
  /// DynamicMerge window γ (docs/DESIGN.md, "DynamicMerge").
  ScenarioBuilder& gamma(Duration d);
  /// Largest inter-DAG batch.
  ScenarioBuilder& max_batch(int n);
  /// λ of the QoE score (docs/DESIGN.md, "Metrics").
  ScenarioBuilder& qoe_lambda(double lambda);
  /// A sensor (camera) with its rate, first-frame phase and jitter.
  ScenarioBuilder& sensor(std::string name, double rate_hz, Duration phase = Duration{0},
                          Duration jitter = Duration{0});
  /// Adds an operation named `name` and returns it for configuration. The reference stays
  /// valid as long as this builder.
  OperationBuilder& operation(std::string name);

  /// The validated Scenario, or an Error naming the problem (file "scenario builder
  /// '<name>'", line 0, message as load_scenario() words it). Never throws for bad input.
  [[nodiscard]] Expected<Scenario> build() const;
  /// The same workload as scenario-file YAML (what build() validates), e.g. to save it.
  [[nodiscard]] std::string to_yaml() const;

 private:
  struct Data;
  std::unique_ptr<Data> d_;
};

}  // namespace red
