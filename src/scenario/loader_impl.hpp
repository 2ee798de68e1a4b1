#pragma once
/// \file
/// The scenario loader's state and steps, shared by its parts: loader.cpp (the top-level load
/// order, device, model, scheduler, sensors, operations and their graphs) and events.cpp (the
/// timed events, replayed on the workload). Internal to the loader.

#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "fields.hpp"
#include "red/scenario/scenario.hpp"

namespace red::loader_detail {

// ---- graph checks --------------------------------------------------------------------

/// A cycle of node indices (first == last), or empty when the graph is acyclic.
std::vector<int> find_cycle(const OperationSpec& op);

std::string cycle_text(const OperationSpec& op, const std::vector<int>& cycle);

std::string node_names(const OperationSpec& op);

/// Node name -> index of an operation, made once per read so that reading n nodes and e
/// edges costs O(n + e), not O(n * e) (a 50,000-node chain took 47 s to validate).
std::unordered_map<std::string, int> node_indices(const OperationSpec& op);

/// The edges of an operation as a set, to find a duplicate in O(log e).
std::set<std::pair<int, int>> edge_set(const OperationSpec& op);

/// An edge as read from the file, resolved to node indices.
struct ReadEdge {
  EdgeSpec edge;
  int line = 0;
};

// ---- the loader ----------------------------------------------------------------------

class Loader {
 public:
  explicit Loader(std::string file) : file_(std::move(file)) {}

  Scenario run(const yaml::Node& root);

 private:
  /// An operation as parsed, before depends_on is resolved to an index.
  struct Parsed {
    OperationSpec op;
    std::optional<Val> depends_on;  ///< the operation name to wait for
  };

  std::string resolve_path(const std::string& p) const;
  void parse_device(const Val& v);
  void parse_model(const Val& v);
  void parse_scheduler(const Val& v);
  void parse_interference(const Val& v);
  void parse_sensors(const Val& v);
  int sensor_index(const Val& v) const;
  Parsed parse_operation(const Val& v, const std::string& named_base);
  NodeSpec parse_node(const Entry& entry) const;
  void add_nodes(OperationSpec& op, const Val& v) const;
  std::vector<ReadEdge> read_edges(const OperationSpec& op, const Val& v) const;
  DeadlineSpec parse_deadline(const Val& v) const;
  /// A fixed deadline in ms (deadline_ms), within [1 us, 1e12 ms].
  Duration deadline_value(const Val& v) const;
  void check_graph(const OperationSpec& op, const std::vector<ReadEdge>& edges,
                   int fallback_line) const;
  int active_index(const std::string& name) const;
  int need_active(const Val& v, Duration t) const;
  void parse_events(const Val& v);
  EventSpec parse_event(const Val& v, Duration& last_at, int& last_line);
  /// The actions of an event (events.cpp), each applied to the workload at `ev.at` (`t`
  /// seconds, as written) and recorded in `ev`: add_operation; set_rate; every other, which
  /// names an existing operation and changes only it.
  void add_operation_event(const Val& a, double t, EventSpec& ev);
  void set_rate_event(const Val& a, EventSpec& ev);
  void change_operation_event(const Val& v, const Val& a, double t, EventSpec& ev);

  std::string file_;
  Scenario s_;
  bool have_model_ = false;
  /// The workload during replay: snapshot by operation index, null when not present.
  std::vector<std::shared_ptr<const OperationSpec>> current_;
};

}  // namespace red::loader_detail
