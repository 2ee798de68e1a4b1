/// \file
/// The scenario loader's timed events (docs/SCENARIOS.md, "Events"): each is read and checked
/// against the workload as it is at the event's time, by replaying the events in order on
/// copies of the operation snapshots.

#include "fields.hpp"
#include "limits.hpp"
#include "loader_impl.hpp"
#include "red/core/file.hpp"
#include "red/sched/policy.hpp"
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

EventSpec Loader::parse_event(const Val& v, Duration& last_at, int& last_line) {
  const Fields f(v, {"at_s", "add_nodes", "remove_nodes", "add_edges", "remove_edges",
                     "add_operation", "remove_operation", "set_deadline", "set_rate"});
  EventSpec ev;
  ev.line = v.line;
  const Val& at_s = f.need("at_s");
  const double t = non_negative(at_s);
  if (t > 1e9) fail(at_s.line, at(at_s.what) + "is too large" + got(at_s.node));
  ev.at = from_s(t);
  if (ev.at >= s_.duration)
    fail(at_s.line, fmt::format("{}event at {} s is not before the end of the scenario "
                                "(duration_s {})",
                                at(at_s.what), t, to_s(s_.duration)));
  if (ev.at < last_at)
    fail(at_s.line, fmt::format("{}events out of time order: at_s {} comes after an event at "
                                "{} s (line {})",
                                at(at_s.what), t, to_s(last_at), last_line));
  last_at = ev.at;
  last_line = v.line;

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
  ev.kind = action->key;
  const Val& a = action->value;

  if (ev.kind == "add_operation") {
    Parsed p = parse_operation(a, a.what);
    if (active_index(p.op.name) >= 0)
      fail(a.line, fmt::format("{}an operation named '{}' already exists at {} s", at(a.what),
                               p.op.name, t));
    if (p.depends_on) p.op.depends_on = need_active(*p.depends_on, ev.at);
    const int index = static_cast<int>(current_.size());
    auto snap = std::make_shared<const OperationSpec>(std::move(p.op));
    current_.push_back(snap);
    s_.names_.push_back(snap->name);
    ev.changes.emplace_back(index, std::move(snap));
    return ev;
  }
  if (ev.kind == "set_rate") {
    const Fields sr(a, {"operation", "sensor", "rate_hz"});
    const Val* op_name = sr.get("operation");
    const Val* sensor = sr.get("sensor");
    if ((op_name != nullptr) == (sensor != nullptr))
      fail(sr.line(), at(a.what) + "give exactly one of 'operation' or 'sensor'");
    const double rate = loader_detail::rate(sr.need("rate_hz"));
    if (sensor) {
      ev.sensor_rates.emplace_back(sensor_index(*sensor), rate);
      return ev;
    }
    const int i = need_active(*op_name, ev.at);
    auto op = std::make_shared<OperationSpec>(*current_[static_cast<std::size_t>(i)]);
    if (op->trigger_sensor >= 0 || op->rate_hz <= 0.0)
      fail(op_name->line, fmt::format("{}operation '{}' has no own rate_hz to change{}",
                                      at(op_name->what), op->name,
                                      op->trigger_sensor >= 0 ? " (it follows its trigger sensor; "
                                                                "set the sensor's rate)"
                                                              : ""));
    op->rate_hz = rate;
    current_[static_cast<std::size_t>(i)] = op;
    ev.changes.emplace_back(i, std::move(op));
    return ev;
  }

  // Every other action names an existing operation and changes only it.
  const Fields af = [&] {
    if (ev.kind == "add_nodes") return Fields(a, {"operation", "nodes", "edges"});
    if (ev.kind == "remove_nodes") return Fields(a, {"operation", "nodes"});
    if (ev.kind == "add_edges" || ev.kind == "remove_edges")
      return Fields(a, {"operation", "edges"});
    if (ev.kind == "set_deadline") return Fields(a, {"operation", "deadline_ms"});
    return Fields(a, {"operation"});  // remove_operation
  }();
  const int i = need_active(af.need("operation"), ev.at);
  const auto index = static_cast<std::size_t>(i);

  if (ev.kind == "remove_operation") {
    for (const auto& other : current_)
      if (other && other->depends_on == i)
        fail(a.line, fmt::format("{}cannot remove operation '{}': operation '{}' depends on it",
                                 at(a.what), current_[index]->name, other->name));
    current_[index] = nullptr;
    ev.changes.emplace_back(i, nullptr);
    return ev;
  }

  auto op = std::make_shared<OperationSpec>(*current_[index]);
  std::vector<ReadEdge> new_edges;
  if (ev.kind == "add_nodes") {
    add_nodes(*op, af.need("nodes"));
    if (const Val* e = af.get("edges")) new_edges = read_edges(*op, *e);
  } else if (ev.kind == "remove_nodes") {
    const Val& list = af.need("nodes");
    if (!list.node.is_sequence() || list.node.size() == 0)
      fail(list.line, at(list.what) + "must be a non-empty list of node names" + got(list.node));
    std::vector<bool> removed(op->nodes.size(), false);
    const std::unordered_map<std::string, int> nodes = node_indices(*op);
    for (const yaml::Node& item : list.node.items()) {
      const Val iv{item, mark_line(item) ? mark_line(item) : list.line, list.what};
      const std::string name = text(iv);
      const auto found = nodes.find(name);
      const int n = found == nodes.end() ? -1 : found->second;
      if (n < 0)
        fail(iv.line, fmt::format("{}operation '{}' has no node '{}' at {} s (nodes: {})",
                                  at(list.what), op->name, name, t, node_names(*op)));
      if (removed[static_cast<std::size_t>(n)])
        fail(iv.line, at(list.what) + "node '" + name + "' is listed twice");
      removed[static_cast<std::size_t>(n)] = true;
    }
    std::vector<int> remap(op->nodes.size(), -1);
    std::vector<NodeSpec> kept;
    for (std::size_t n = 0; n < op->nodes.size(); ++n) {
      if (removed[n]) continue;
      remap[n] = static_cast<int>(kept.size());
      kept.push_back(op->nodes[n]);
    }
    std::vector<EdgeSpec> edges;
    for (const auto& e : op->edges) {
      const int from = remap[static_cast<std::size_t>(e.from)];
      const int to = remap[static_cast<std::size_t>(e.to)];
      if (from >= 0 && to >= 0) edges.push_back(EdgeSpec{from, to});
    }
    op->nodes = std::move(kept);
    op->edges = std::move(edges);
  } else if (ev.kind == "add_edges") {
    new_edges = read_edges(*op, af.need("edges"));
    if (new_edges.empty()) fail(a.line, at(a.what) + "edges must not be empty");
  } else if (ev.kind == "remove_edges") {
    const auto gone = read_edges(*op, af.need("edges"));
    if (gone.empty()) fail(a.line, at(a.what) + "edges must not be empty");
    for (const auto& g : gone) {
      const auto it = std::find_if(op->edges.begin(), op->edges.end(), [&](const EdgeSpec& x) {
        return x.from == g.edge.from && x.to == g.edge.to;
      });
      if (it == op->edges.end())
        fail(g.line, fmt::format("{}operation '{}' has no edge [{}, {}] at {} s", at(a.what),
                                 op->name, op->nodes[static_cast<std::size_t>(g.edge.from)].name,
                                 op->nodes[static_cast<std::size_t>(g.edge.to)].name, t));
      op->edges.erase(it);
    }
  } else {  // set_deadline
    op->deadline = parse_deadline(af.need("deadline_ms"));
  }
  std::set<std::pair<int, int>> seen = edge_set(*op);
  for (const auto& e : new_edges) {
    if (!seen.emplace(e.edge.from, e.edge.to).second)
      fail(e.line, fmt::format("{}operation '{}' already has edge [{}, {}]", at(a.what), op->name,
                               op->nodes[static_cast<std::size_t>(e.edge.from)].name,
                               op->nodes[static_cast<std::size_t>(e.edge.to)].name));
    op->edges.push_back(e.edge);
  }
  // A cycle made by an event is reported at the event, where the change was written.
  check_graph(*op, {}, v.line);
  current_[index] = op;
  ev.changes.emplace_back(i, std::move(op));
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
