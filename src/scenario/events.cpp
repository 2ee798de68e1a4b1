/// \file
/// The scenario loader's timed events (docs/SCENARIOS.md, "Events"): each is read and checked
/// against the workload as it is at the event's time, by replaying the events in order on
/// copies of the operation snapshots.

#include "fields.hpp"
#include "limits.hpp"
#include "loader_impl.hpp"
#include "red/core/file.hpp"
#include "yaml_tree.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

namespace red::loader_detail {

using namespace limits;  // the bounds of every value read (limits.hpp)

namespace {

const char* const kEventKinds[] = {"add_nodes",    "remove_nodes",  "add_edges",
                                   "remove_edges", "add_operation", "remove_operation",
                                   "set_deadline", "set_rate"};

}  // namespace

int Loader::active_index(const std::string& name) const {
  for (std::size_t i = 0; i < current_.size(); ++i)
    if (current_[i] && current_[i]->name == name) return static_cast<int>(i);
  return -1;
}

int Loader::need_active(const Val& v, Duration t) const {
  const std::string name = text(v);
  const int i = active_index(name);
  if (i >= 0) return i;
  const bool existed = std::find(s_.names_.begin(), s_.names_.end(), name) != s_.names_.end();
  std::vector<std::string> active;
  for (const auto& op : current_)
    if (op) active.push_back(op->name);
  fail(v.line,
       fmt::format("{}no operation '{}' in the workload at {} s ({}){}", at(v.what), name, to_s(t),
                   active.empty() ? "no operations are left" : "operations: " + join(active),
                   existed ? "; an earlier event removed it" : ""));
}

namespace {

// An event's time as written (seconds, for its messages) and as a duration.
struct EventTime {
  double s = 0;
  Duration at{0};
};

// The event's at_s: before the end of the scenario (`end`) and not before the previous event
// (`last_at`, on `last_line`), which then become this one's (on `line`).
EventTime event_time(const Val& at_s, int line, Duration end, Duration& last_at, int& last_line) {
  const double t = non_negative(at_s);
  if (t > 1e9) fail(at_s.line, at(at_s.what) + "is too large" + got(at_s.node));
  const Duration when = from_s(t);
  if (when >= end)
    fail(at_s.line, fmt::format("{}event at {} s is not before the end of the scenario "
                                "(duration_s {})",
                                at(at_s.what), t, to_s(end)));
  if (when < last_at)
    fail(at_s.line, fmt::format("{}events out of time order: at_s {} comes after an event at "
                                "{} s (line {})",
                                at(at_s.what), t, to_s(last_at), last_line));
  last_at = when;
  last_line = line;
  return {t, when};
}

// The event's one action: every key but at_s.
const Entry& event_action(const Fields& f, const Val& v) {
  const Entry* action = nullptr;
  for (const auto& e : f.entries()) {
    if (e.key == "at_s") continue;
    if (action)
      fail(e.key_line, fmt::format("{}an event has exactly one action; this one has '{}' and "
                                   "'{}'",
                                   at(v.what), action->key, e.key));
    action = &e;
  }
  if (!action) {
    std::vector<std::string> kinds(std::begin(kEventKinds), std::end(kEventKinds));
    fail(v.line, at(v.what) + "event has no action (one of: " + join(kinds) + ")");
  }
  return *action;
}

// The keys of an action that names an existing operation and changes only it.
Fields change_fields(const std::string& kind, const Val& a) {
  if (kind == "add_nodes") return Fields(a, {"operation", "nodes", "edges"});
  if (kind == "remove_nodes") return Fields(a, {"operation", "nodes"});
  if (kind == "add_edges" || kind == "remove_edges") return Fields(a, {"operation", "edges"});
  if (kind == "set_deadline") return Fields(a, {"operation", "deadline_ms"});
  return Fields(a, {"operation"});  // remove_operation
}

// remove_nodes: the listed nodes of `op` and their edges go; the others keep their order.
void remove_nodes(OperationSpec& op, const Val& list, double t) {
  if (!list.node.is_sequence() || list.node.size() == 0)
    fail(list.line, at(list.what) + "must be a non-empty list of node names" + got(list.node));
  std::vector<bool> removed(op.nodes.size(), false);
  const std::unordered_map<std::string, int> nodes = node_indices(op);
  for (const yaml::Node& item : list.node.items()) {
    const Val iv{item, mark_line(item) ? mark_line(item) : list.line, list.what};
    const std::string name = text(iv);
    const auto found = nodes.find(name);
    const int n = found == nodes.end() ? -1 : found->second;
    if (n < 0)
      fail(iv.line, fmt::format("{}operation '{}' has no node '{}' at {} s (nodes: {})",
                                at(list.what), op.name, name, t, node_names(op)));
    if (removed[static_cast<std::size_t>(n)])
      fail(iv.line, at(list.what) + "node '" + name + "' is listed twice");
    removed[static_cast<std::size_t>(n)] = true;
  }
  std::vector<int> remap(op.nodes.size(), -1);
  std::vector<NodeSpec> kept;
  for (std::size_t n = 0; n < op.nodes.size(); ++n) {
    if (removed[n]) continue;
    remap[n] = static_cast<int>(kept.size());
    kept.push_back(op.nodes[n]);
  }
  std::vector<EdgeSpec> edges;
  for (const auto& e : op.edges) {
    const int from = remap[static_cast<std::size_t>(e.from)];
    const int to = remap[static_cast<std::size_t>(e.to)];
    if (from >= 0 && to >= 0) edges.push_back(EdgeSpec{from, to});
  }
  op.nodes = std::move(kept);
  op.edges = std::move(edges);
}

// remove_edges: each of `gone` must be an edge of `op`.
void remove_edges(OperationSpec& op, const std::vector<ReadEdge>& gone, const Val& a, double t) {
  if (gone.empty()) fail(a.line, at(a.what) + "edges must not be empty");
  for (const auto& g : gone) {
    const auto it = std::find_if(op.edges.begin(), op.edges.end(), [&](const EdgeSpec& x) {
      return x.from == g.edge.from && x.to == g.edge.to;
    });
    if (it == op.edges.end())
      fail(g.line, fmt::format("{}operation '{}' has no edge [{}, {}] at {} s", at(a.what), op.name,
                               op.nodes[static_cast<std::size_t>(g.edge.from)].name,
                               op.nodes[static_cast<std::size_t>(g.edge.to)].name, t));
    op.edges.erase(it);
  }
}

// The edges an event adds to `op`, none of which it has.
void add_edges(OperationSpec& op, const std::vector<ReadEdge>& new_edges, const Val& a) {
  std::set<std::pair<int, int>> seen = edge_set(op);
  for (const auto& e : new_edges) {
    if (!seen.emplace(e.edge.from, e.edge.to).second)
      fail(e.line, fmt::format("{}operation '{}' already has edge [{}, {}]", at(a.what), op.name,
                               op.nodes[static_cast<std::size_t>(e.edge.from)].name,
                               op.nodes[static_cast<std::size_t>(e.edge.to)].name));
    op.edges.push_back(e.edge);
  }
}

}  // namespace

void Loader::add_operation_event(const Val& a, double t, EventSpec& ev) {
  Parsed p = parse_operation(a, a.what);
  if (active_index(p.op.name) >= 0)
    fail(a.line,
         fmt::format("{}an operation named '{}' already exists at {} s", at(a.what), p.op.name, t));
  if (p.depends_on) p.op.depends_on = need_active(*p.depends_on, ev.at);
  const int index = static_cast<int>(current_.size());
  auto snap = std::make_shared<const OperationSpec>(std::move(p.op));
  current_.push_back(snap);
  s_.names_.push_back(snap->name);
  ev.changes.emplace_back(index, std::move(snap));
}

void Loader::set_rate_event(const Val& a, EventSpec& ev) {
  const Fields sr(a, {"operation", "sensor", "rate_hz"});
  const Val* op_name = sr.get("operation");
  const Val* sensor = sr.get("sensor");
  if ((op_name != nullptr) == (sensor != nullptr))
    fail(sr.line(), at(a.what) + "give exactly one of 'operation' or 'sensor'");
  const double rate = loader_detail::rate(sr.need("rate_hz"));
  if (sensor) {
    ev.sensor_rates.emplace_back(sensor_index(*sensor), rate);
    return;
  }
  const int i = need_active(*op_name, ev.at);
  auto op = std::make_shared<OperationSpec>(*current_[static_cast<std::size_t>(i)]);
  if (op->trigger_sensor >= 0 || op->rate_hz <= 0.0)
    fail(op_name->line,
         fmt::format("{}operation '{}' has no own rate_hz to change{}", at(op_name->what), op->name,
                     op->trigger_sensor >= 0 ? " (it follows its trigger sensor; "
                                               "set the sensor's rate)"
                                             : ""));
  op->rate_hz = rate;
  current_[static_cast<std::size_t>(i)] = op;
  ev.changes.emplace_back(i, std::move(op));
}

void Loader::change_operation_event(const Val& v, const Val& a, double t, EventSpec& ev) {
  const Fields af = change_fields(ev.kind, a);
  const int i = need_active(af.need("operation"), ev.at);
  const auto index = static_cast<std::size_t>(i);

  if (ev.kind == "remove_operation") {
    for (const auto& other : current_)
      if (other && other->depends_on == i)
        fail(a.line, fmt::format("{}cannot remove operation '{}': operation '{}' depends on it",
                                 at(a.what), current_[index]->name, other->name));
    current_[index] = nullptr;
    ev.changes.emplace_back(i, nullptr);
    return;
  }

  auto op = std::make_shared<OperationSpec>(*current_[index]);
  std::vector<ReadEdge> new_edges;
  if (ev.kind == "add_nodes") {
    add_nodes(*op, af.need("nodes"));
    if (const Val* e = af.get("edges")) new_edges = read_edges(*op, *e);
  } else if (ev.kind == "remove_nodes") {
    remove_nodes(*op, af.need("nodes"), t);
  } else if (ev.kind == "add_edges") {
    new_edges = read_edges(*op, af.need("edges"));
    if (new_edges.empty()) fail(a.line, at(a.what) + "edges must not be empty");
  } else if (ev.kind == "remove_edges") {
    remove_edges(*op, read_edges(*op, af.need("edges")), a, t);
  } else {  // set_deadline
    op->deadline = parse_deadline(af.need("deadline_ms"));
  }
  add_edges(*op, new_edges, a);
  // A cycle made by an event is reported at the event, where the change was written.
  check_graph(*op, {}, v.line);
  current_[index] = op;
  ev.changes.emplace_back(i, std::move(op));
}

EventSpec Loader::parse_event(const Val& v, Duration& last_at, int& last_line) {
  const Fields f(v, {"at_s", "add_nodes", "remove_nodes", "add_edges", "remove_edges",
                     "add_operation", "remove_operation", "set_deadline", "set_rate"});
  EventSpec ev;
  ev.line = v.line;
  const EventTime t = event_time(f.need("at_s"), v.line, s_.duration, last_at, last_line);
  ev.at = t.at;
  const Entry& action = event_action(f, v);
  ev.kind = action.key;
  const Val& a = action.value;
  if (ev.kind == "add_operation")
    add_operation_event(a, t.s, ev);
  else if (ev.kind == "set_rate")
    set_rate_event(a, ev);
  else
    // Every other action names an existing operation and changes only it.
    change_operation_event(v, a, t.s, ev);
  return ev;
}

void Loader::parse_events(const Val& v) {
  if (!v.node.is_sequence()) fail(v.line, at(v.what) + "must be a list of events" + got(v.node));
  Duration last_at{0};
  int last_line = 0;
  std::size_t k = 0;
  for (const yaml::Node& item : v.node.items()) {
    const Val ev{item, mark_line(item) ? mark_line(item) : v.line,
                 fmt::format("{}[{}]", v.what, k++)};
    s_.events.push_back(parse_event(ev, last_at, last_line));
  }
}

}  // namespace red::loader_detail
