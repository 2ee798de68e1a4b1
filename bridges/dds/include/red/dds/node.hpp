#pragma once
/// \file
/// `red node` (docs/ROS2.md): RED as one ROS 2-compatible node on Cyclone DDS. Each sensor of the
/// scenario is a subscribed sensor_msgs/Image topic whose frame arrivals are the releases;
/// the real runtime schedules the scenario's operations under a policy on a backend; each
/// inference node of a finished job publishes its output with the header of the frame it
/// was computed on; a DiagnosticArray reports every operation once a period.
///
///     red::dds::NodeOptions o;
///     auto node = red::dds::Node::make(scenario, profile, backend, o);
///     node.value()->run();  // until stop() or o.duration

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/dds/image.hpp"
#include "red/dds/ros.hpp"
#include "red/dds/security.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/backend.hpp"
#include "red/runtime/runtime.hpp"
#include "red/scenario/scenario.hpp"

namespace red::dds {

/// The policy `red node` runs when none is given (the one place to change it).
inline constexpr const char* kDefaultNodePolicy = "red-robust";

/// What a node publishes for a head: by head name, `steer` a Twist (Velocity; and a
/// TwistStamped with the frame's header on `<topic>/stamped`, since Twist has none), `det`
/// a Detection2DArray, any other head a mono8 mask Image.
enum class OutputKind : std::uint8_t { Mask, Velocity, Detections };
OutputKind output_kind(const std::string& head) noexcept;

/// The ROS 2 topics of a node, after remapping.
struct NodeTopics {
  std::vector<std::string> sensors;  ///< per sensor: /<sensor>/image_raw
  /// (operation, node name): /red/<operation>/<node>, every node any snapshot has.
  std::map<std::pair<int, std::string>, std::string> nodes;
  /// (operation, node name): the head it runs (-1: a plain node, nothing published).
  std::map<std::pair<int, std::string>, int> heads;
  std::string diagnostics = "/diagnostics";
};

/// Default topic names for `s` with `remaps` applied.
NodeTopics node_topics(const Scenario& s, const Remaps& remaps);

/// Options of a node.
struct NodeOptions {
  std::string policy = kDefaultNodePolicy;
  int domain = 0;
  std::string config;  ///< Cyclone DDS XML or file:// URI; empty: loopback only
  /// Exchange samples with the host's other processes through iceoryx shared memory
  /// (Domain::open; RouDi must run).
  bool shared_memory = false;
  /// DDS Security with this SROS2 enclave (resolve_security()); none: an open participant.
  std::optional<Enclave> security;
  QosSettings qos;
  Remaps remaps;
  std::optional<Duration> duration;  ///< stop releasing after this long; none: until stop()
  bool realtime = false;             ///< SCHED_FIFO, affinity, mlockall (as `red run`)
  /// The runtime's watchdog: a unit's limit in × its profiled p99 (0: off; RuntimeOptions).
  double watchdog_x = RuntimeOptions{}.watchdog_x;
  Duration diagnostics_period = std::chrono::seconds{1};
  /// A sensor with no frame for this many expected periods is reported silent.
  double silent_periods = 3.0;
};

/// Counters of a node, for its summary and tests.
struct NodeCounters {
  std::uint64_t frames = 0;    ///< images received and accepted
  std::uint64_t released = 0;  ///< of those, handed to the runtime as releases
  std::array<std::uint64_t, kRejectKinds> rejected{};                    ///< by Reject
  std::uint64_t masks = 0, twists = 0, detections = 0, diagnostics = 0;  ///< published
  std::uint64_t jobs_without_output = 0;  ///< ended dropped/skipped/failed: nothing published
  /// With DDS Security: remote participants refused (authentication) and remote endpoints
  /// refused (access control), from Cyclone DDS's log and discovery trace
  /// (security_refusals()).
  std::uint64_t refused_participants = 0, refused_endpoints = 0;
};

class Node {
 public:
  /// Opens the domain and every endpoint. `scenario`, `profile` and `backend` must outlive
  /// the node. Error: unknown policy, DDS failure (named).
  static Expected<std::unique_ptr<Node>> make(const Scenario& scenario, const Profile& profile,
                                              Backend& backend, NodeOptions options);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  /// Adds an observer of the runtime (metrics, trace), before run(); not owned.
  void add_observer(Observer* o);
  /// Receives, schedules and publishes until stop() or the duration; then in-flight jobs
  /// drain. Blocks. Returns the runtime's report.
  RuntimeReport run();
  /// Ends the run (thread-safe; e.g. from a signal watcher).
  void stop();
  /// A snapshot of the counters (thread-safe).
  [[nodiscard]] NodeCounters counters() const;
  /// Where a frame's time goes in the node (μs, the newest 16384 of each; thread-safe).
  struct Timings {
    /// Header stamp -> taken from the DDS reader (wall clocks: the sender's and this one).
    std::vector<double> transport_us;
    /// Taken from the DDS reader -> handed to the runtime (checked, pixels moved out of the
    /// sample, kept for the outputs; push_frame() called). Not converted: that happens after
    /// the release. The runtime's RuntimeReport::frame_release_us goes on to the release.
    std::vector<double> intake_us;
    /// As intake_us, for released frames only, the first 16384 in release order.
    std::vector<double> released_intake_us;
    /// Per element of released_intake_us: taken -> the frame's job released, when the
    /// runtime released it on the receiving thread (inside push_frame(), the usual case);
    /// NaN when it was posted to the global synchronizer, whose part is then the report's
    /// frame_release_us[i] (received -> released = released_intake_us[i] + that).
    std::vector<double> taken_released_us;
    /// Released on the receiving thread -> push_frame() returned: the rest of the runtime's
    /// round there (the scheduling decision, waking lanes), after the release; it delays
    /// only the next frame's take.
    std::vector<double> after_release_us;
    /// A job ended -> its last output written to DDS (queue, computing, serializing).
    std::vector<double> publish_us;
    /// Of publish_us, for each output the publishing thread waited for (a job's first):
    /// queued at the job's end -> taken by that thread, its wake-up (on a VM, that of an
    /// idle virtual CPU).
    std::vector<double> publish_wake_us;
  };
  [[nodiscard]] Timings timings() const;
  /// The topics in use.
  [[nodiscard]] const NodeTopics& topics() const;

 private:
  struct Impl;
  explicit Node(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace red::dds
