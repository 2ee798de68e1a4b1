/// \file
/// The scenario loader (docs/SCENARIOS.md). Parsing and validation throw a private Failure that the
/// two public entry points turn into an Error, so a scenario is either complete or absent.
/// Events are resolved by replaying them in order on copies of the operation snapshots;
/// every rule is checked against the workload as it is at the event's time.
///
/// Its parts: this file keeps the top-level load order (device, model, scheduler, sensors,
/// operations and their graphs) and the public entry points; fields.cpp reads and checks typed
/// values (fields.hpp); events.cpp reads the timed events; overrides.cpp applies `--set`
/// (apply_override). loader_impl.hpp declares the Loader they share.

#include "red/scenario/loader.hpp"
#include "fields.hpp"
#include "limits.hpp"
#include "loader_impl.hpp"
#include "red/core/file.hpp"
#include "red/scenario/estimate.hpp"
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

namespace red {
namespace loader_detail {

using namespace limits;  // the bounds of every value read (limits.hpp)

// ---- graph checks --------------------------------------------------------------------

/// A cycle of node indices (first == last), or empty when the graph is acyclic.
std::vector<int> find_cycle(const OperationSpec& op) {
  const std::size_t n = op.nodes.size();
  std::vector<std::vector<int>> succ(n);
  for (const auto& e : op.edges) succ[static_cast<std::size_t>(e.from)].push_back(e.to);
  // Iterative DFS with colours: 0 unseen, 1 on the stack, 2 done.
  std::vector<int> colour(n, 0);
  std::vector<int> parent(n, -1);
  for (std::size_t root = 0; root < n; ++root) {
    if (colour[root] != 0) continue;
    std::vector<std::pair<int, std::size_t>> stack{{static_cast<int>(root), 0}};
    colour[root] = 1;
    while (!stack.empty()) {
      auto& [u, next] = stack.back();
      const auto& out = succ[static_cast<std::size_t>(u)];
      if (next == out.size()) {
        colour[static_cast<std::size_t>(u)] = 2;
        stack.pop_back();
        continue;
      }
      const int w = out[next++];
      const auto wi = static_cast<std::size_t>(w);
      if (colour[wi] == 1) {
        std::vector<int> cycle{w};
        for (int x = u; x != w; x = parent[static_cast<std::size_t>(x)]) cycle.push_back(x);
        cycle.push_back(w);
        std::reverse(cycle.begin(), cycle.end());
        return cycle;
      }
      if (colour[wi] == 0) {
        colour[wi] = 1;
        parent[wi] = u;
        stack.emplace_back(w, 0);
      }
    }
  }
  return {};
}

std::string cycle_text(const OperationSpec& op, const std::vector<int>& cycle) {
  std::string out;
  for (int i : cycle)
    out += (out.empty() ? "" : " -> ") + op.nodes[static_cast<std::size_t>(i)].name;
  return out;
}

std::string node_names(const OperationSpec& op) {
  std::vector<std::string> names;
  for (const auto& n : op.nodes) names.push_back(n.name);
  return join(names);
}

/// Node name -> index of an operation, made once per read so that reading n nodes and e
/// edges costs O(n + e), not O(n * e) (a 50,000-node chain took 47 s to validate).
std::unordered_map<std::string, int> node_indices(const OperationSpec& op) {
  std::unordered_map<std::string, int> index;
  index.reserve(op.nodes.size());
  for (std::size_t i = 0; i < op.nodes.size(); ++i)
    index.emplace(op.nodes[i].name, static_cast<int>(i));
  return index;
}

/// The edges of an operation as a set, to find a duplicate in O(log e).
std::set<std::pair<int, int>> edge_set(const OperationSpec& op) {
  std::set<std::pair<int, int>> edges;
  for (const EdgeSpec& e : op.edges) edges.emplace(e.from, e.to);
  return edges;
}

std::string Loader::resolve_path(const std::string& p) const {
  const std::filesystem::path path(p);
  if (path.is_absolute() || file_.empty()) return p;
  const std::filesystem::path dir = std::filesystem::path(file_).parent_path();
  if (dir.empty()) return p;
  return (dir / path).lexically_normal().string();
}

void Loader::parse_device(const Val& v) {
  const Fields f(v, {"lanes", "sync_cost_us", "queue_depth"});
  if (const Val* x = f.get("lanes")) s_.device.lanes = static_cast<int>(integer(*x, 1, kMaxLanes));
  if (const Val* x = f.get("queue_depth"))
    s_.device.queue_depth = static_cast<int>(integer(*x, 1, kMaxQueueDepth));
  if (const Val* x = f.get("sync_cost_us")) {
    const double us = non_negative(*x);
    s_.device.sync_cost = ms_value(*x, us / 1e3);
  }
}

void Loader::parse_model(const Val& v) {
  const Fields f(v, {"builtin", "manifest", "heads", "input"});
  const Val* builtin = f.get("builtin");
  const Val* manifest = f.get("manifest");
  if ((builtin != nullptr) == (manifest != nullptr))
    fail(f.line(), at(v.what) + "give exactly one of 'builtin' (mimonet) or 'manifest' (a path)");
  if (builtin) {
    const std::string b = text(*builtin);
    if (b != "mimonet")
      fail(builtin->line,
           at(builtin->what) + "unknown built-in model '" + b + "' (known: mimonet)");
    s_.model.builtin = b;
    s_.model.manifest.clear();
  } else {
    s_.model.builtin.clear();
    s_.model.manifest = resolve_path(text(*manifest));
    s_.model.manifest_line = manifest->line;
  }
  s_.model.line = f.line();
  const Val& heads = f.need("heads");
  if (!heads.node.is_sequence() || heads.node.size() == 0)
    fail(heads.line, at(heads.what) + "must be a non-empty list of head names" + got(heads.node));
  s_.model.heads.clear();
  s_.model.head_lines.clear();
  for (const yaml::Node& h : heads.node.items()) {
    const Val hv{h, mark_line(h) ? mark_line(h) : heads.line, heads.what};
    const std::string name = text(hv);
    if (s_.model.head_index(name) >= 0)
      fail(hv.line, at(heads.what) + "duplicate head '" + name + "'");
    s_.model.heads.push_back(name);
    s_.model.head_lines.push_back(hv.line);
  }
  if (const Val* input = f.get("input")) {
    if (!input->node.is_sequence() || input->node.size() != 3)
      fail(input->line, at(input->what) + "must be [C, H, W]" + got(input->node));
    s_.model.input.clear();
    s_.model.input_line = input->line;
    for (const yaml::Node& d : input->node.items())
      s_.model.input.push_back(integer(Val{d, mark_line(d), input->what}, 1, 1 << 20));
  }
  have_model_ = true;
}

void Loader::parse_scheduler(const Val& v) {
  // The knobs read here, then every other key as the file writes it: the policy options,
  // which the policy layer reads and checks (check_policy_options, red/sched/policy.hpp).
  const std::vector<std::string>& own = scheduler_keys();
  std::vector<std::string> allowed = own;
  for (const Entry& e : entries_of(v))
    if (std::find(own.begin(), own.end(), e.key) == own.end()) allowed.push_back(e.key);
  const Fields f(v, allowed);
  auto& sc = s_.scheduler;
  for (const Entry& e : f.entries()) {
    if (std::find(own.begin(), own.end(), e.key) != own.end()) continue;
    OptionText o{e.key, e.value.what, {}, {}, e.key_line, e.value.line};
    try {
      o.value = text(e.value);
      sc.policy_with += (sc.policy_with.empty() ? "" : ",") + o.key + "=" + o.value;
    } catch (const Failure& bad) {  // reported by the policy layer, after an unknown key
      o.problem = bad.message;
    }
    sc.policy_options.push_back(std::move(o));
  }
  if (const Val* x = f.get("gamma_ms")) sc.gamma = ms_value(*x, non_negative(*x));
  if (const Val* x = f.get("estimate")) {
    const std::string e = text(*x);
    std::string names;
    bool known = false;
    for (const auto& [name, kind] : kEstimateKinds) {
      names += (names.empty() ? "" : ", ") + std::string(name);
      if (e == name) {
        sc.estimate = kind;
        known = true;
      }
    }
    if (!known) fail(x->line, at(x->what) + "must be one of " + names + got(x->node));
  }
  if (const Val* x = f.get("level_cost")) {
    const std::string l = text(*x);
    if (l == "max")
      sc.level_cost = LevelCost::Max;
    else if (l == "sum")
      sc.level_cost = LevelCost::Sum;
    else
      fail(x->line, at(x->what) + "must be max or sum" + got(x->node));
  }
  if (const Val* x = f.get("max_batch")) sc.max_batch = small_int(*x, 1);
  if (const Val* x = f.get("qoe_lambda")) sc.qoe_lambda = positive(*x);
  if (const Val* x = f.get("online_costs")) sc.online_costs = boolean(*x);
}

void Loader::parse_interference(const Val& v) {
  const Fields f(v, {"kind", "intensity"});
  InterferenceSpec in;
  if (const Val* x = f.get("kind")) {
    in.kind = text(*x);
    if (in.kind != "cpu") fail(x->line, at(x->what) + "must be cpu" + got(x->node));
  }
  if (const Val* x = f.get("intensity")) {
    in.intensity = number(*x);
    if (in.intensity < 0.0 || in.intensity > 1.0)
      fail(x->line, at(x->what) + "must be in [0, 1]" + got(x->node));
  }
  s_.interference = in;
}

void Loader::parse_sensors(const Val& v) {
  for (const auto& e : entries_of(v, "sensor")) {
    const Fields f(e.value, {"rate_hz", "phase_ms", "jitter_ms", "topic"});
    SensorSpec sensor;
    sensor.name = e.key;
    sensor.line = e.key_line;
    sensor.rate_hz = rate(f.need("rate_hz"));
    if (const Val* x = f.get("phase_ms")) sensor.phase = ms_value(*x, non_negative(*x));
    if (const Val* x = f.get("jitter_ms")) sensor.jitter = ms_value(*x, non_negative(*x));
    if (const Val* x = f.get("topic")) sensor.topic = ros_topic(*x);
    s_.sensors.push_back(std::move(sensor));
  }
}

int Loader::sensor_index(const Val& v) const {
  const std::string name = text(v);
  for (std::size_t i = 0; i < s_.sensors.size(); ++i)
    if (s_.sensors[i].name == name) return static_cast<int>(i);
  std::vector<std::string> names;
  for (const auto& s : s_.sensors) names.push_back(s.name);
  fail(v.line, fmt::format("{}unknown sensor '{}' ({})", at(v.what), name,
                           names.empty() ? "no sensors are defined" : "sensors: " + join(names)));
}

DeadlineSpec Loader::parse_deadline(const Val& v) const {
  DeadlineSpec d;
  d.line = v.line;
  if (v.node.is_map()) {
    const Fields f(v, {"critical_path_x"});
    const Val& x = f.need("critical_path_x");
    d.critical_path_x = positive(x);
    if (*d.critical_path_x < kMinCriticalPathX || *d.critical_path_x > kMaxCriticalPathX)
      fail(x.line, at(x.what) +
                       fmt::format("must lie in [{:g}, {:g}] (times the critical path)",
                                   kMinCriticalPathX, kMaxCriticalPathX) +
                       got(x.node));
  } else {
    d.fixed = deadline_value(v);
  }
  return d;
}

Duration Loader::deadline_value(const Val& v) const {
  const Duration d = ms_value(v, positive(v));
  if (d < kMinDeadline)
    fail(v.line, at(v.what) + "is too small: a deadline is at least 0.001 ms (1 us)" + got(v.node));
  return d;
}

NodeSpec Loader::parse_node(const Entry& entry) const {
  const Val& v = entry.value;
  // Problems of the node as a whole are reported where it is named.
  const int line = entry.key_line;
  const Fields f(v, {"head", "sensor", "cost_ms", "cost", "deadline_ms", "topic"});
  NodeSpec n;
  n.name = entry.key;
  n.line = line;
  const Val* head = f.get("head");
  const Val* sensor = f.get("sensor");
  const Val* cost_ms = f.get("cost_ms");
  const Val* cost = f.get("cost");
  if (head && (cost_ms || cost))
    fail(line, at(v.what) +
                   "has both a head and a cost: a node is an inference (head, sensor) or a "
                   "plain task (cost_ms or cost), not both");
  if (cost_ms && cost) fail(line, at(v.what) + "give cost_ms or cost, not both");
  if (head || sensor) {
    if (!head) fail(line, at(v.what) + "has a sensor but no head (an inference node needs both)");
    if (!sensor) fail(line, at(v.what) + "has a head but no sensor (an inference node needs both)");
    const std::string h = text(*head);
    if (!have_model_)
      fail(head->line, at(head->what) + "node uses head '" + h + "' but the scenario has no model");
    n.head = s_.model.head_index(h);
    if (n.head < 0)
      fail(head->line, fmt::format("{}unknown head '{}' (model heads: {})", at(head->what), h,
                                   join(s_.model.heads)));
    n.sensor = sensor_index(*sensor);
    if (const Val* t = f.get("topic")) n.topic = ros_topic(*t);
  } else if (cost_ms) {
    const Duration c = ms_value(*cost_ms, non_negative(*cost_ms));
    n.cost = PlainCost{c, c};
  } else if (cost) {
    const Fields c(*cost, {"mean_ms", "p99_ms"});
    const Val& mean = c.need("mean_ms");
    const Val& p99 = c.need("p99_ms");
    const double mean_ms = non_negative(mean);
    const double p99_ms = non_negative(p99);
    if (p99_ms < mean_ms) fail(p99.line, at(p99.what) + "must be >= mean_ms" + got(p99.node));
    n.cost = PlainCost{ms_value(mean, mean_ms), ms_value(p99, p99_ms)};
  } else {
    fail(line,
         at(v.what) + "needs head and sensor (an inference node) or cost_ms / cost (a plain task)");
  }
  if (const Val* d = f.get("deadline_ms")) n.deadline = deadline_value(*d);
  return n;
}

void Loader::add_nodes(OperationSpec& op, const Val& v) const {
  const auto entries = entries_of(v, "node name");
  if (entries.empty()) fail(v.line, at(v.what) + "must name at least one node");
  std::unordered_map<std::string, int> index = node_indices(op);
  for (const auto& e : entries) {
    if (!index.emplace(e.key, static_cast<int>(op.nodes.size())).second)
      fail(e.key_line,
           fmt::format("{}operation '{}' already has a node '{}'", at(v.what), op.name, e.key));
    op.nodes.push_back(parse_node(e));
  }
}

std::vector<ReadEdge> Loader::read_edges(const OperationSpec& op, const Val& v) const {
  if (!v.node.is_sequence())
    fail(v.line, at(v.what) + "must be a list of [from, to] pairs" + got(v.node));
  std::vector<ReadEdge> out;
  const std::unordered_map<std::string, int> index = node_indices(op);
  const auto find = [&index](const std::string& name) {
    const auto it = index.find(name);
    return it == index.end() ? -1 : it->second;
  };
  for (const yaml::Node& item : v.node.items()) {
    const int line = mark_line(item) ? mark_line(item) : v.line;
    if (!item.is_sequence() || item.size() != 2 || !item.items()[0].is_scalar() ||
        !item.items()[1].is_scalar())
      fail(line, at(v.what) + "each edge must be a [from, to] pair of node names" + got(item));
    const std::string from = item.items()[0].scalar();
    const std::string to = item.items()[1].scalar();
    ReadEdge e{EdgeSpec{find(from), find(to)}, line};
    for (const auto& [idx, name] : {std::pair{e.edge.from, from}, std::pair{e.edge.to, to}})
      if (idx < 0)
        fail(line, fmt::format("{}edge [{}, {}] refers to node '{}', which operation '{}' does "
                               "not have (nodes: {})",
                               at(v.what), from, to, name, op.name, node_names(op)));
    out.push_back(e);
  }
  return out;
}

void Loader::check_graph(const OperationSpec& op, const std::vector<ReadEdge>& edges,
                         int fallback_line) const {
  if (op.nodes.empty())
    fail(fallback_line, "operation '" + op.name +
                            "' would have no nodes (remove the operation "
                            "with remove_operation instead)");
  const std::vector<int> cycle = find_cycle(op);
  if (cycle.empty()) return;
  // Report the edge on the cycle written last in the file: the one that closes it.
  int line = 0;
  for (std::size_t i = 0; i + 1 < cycle.size(); ++i)
    for (const auto& e : edges)
      if (e.edge.from == cycle[i] && e.edge.to == cycle[i + 1]) line = std::max(line, e.line);
  fail(line ? line : fallback_line,
       "operation '" + op.name + "' has a cycle: " + cycle_text(op, cycle));
}

Loader::Parsed Loader::parse_operation(const Val& v, const std::string& named_base) {
  // Name the operation in messages as soon as its name is known.
  Val named = v;
  if (const yaml::Node name = v.node.find("name"); name.is_scalar())
    named.what = named_base + "." + name.scalar();
  const Fields f(named, {"name", "trigger", "rate_hz", "phase_ms", "release", "deadline_ms",
                         "criticality", "max_inflight", "depends_on", "nodes", "edges"});
  Parsed p;
  OperationSpec& op = p.op;
  op.line = v.line;
  op.name = text(f.need("name"));
  const Val* trigger = f.get("trigger");
  const Val* rate = f.get("rate_hz");
  const Val* release = f.get("release");
  if (trigger && rate)
    fail(rate->line, at(named.what) + "give trigger (a sensor) or rate_hz, not both");
  if (trigger) op.trigger_sensor = sensor_index(*trigger);
  if (rate) op.rate_hz = loader_detail::rate(*rate);
  if (release) {
    const Fields r(*release, {"count"});
    op.release_count = static_cast<int>(integer(r.need("count"), 1, kMaxReleaseCount));
  }
  if (!trigger && !rate && !release)
    fail(f.line(),
         at(named.what) + "needs a trigger (a sensor name), rate_hz, or release: {count: N}");
  if (const Val* x = f.get("phase_ms")) op.phase = ms_value(*x, non_negative(*x));
  op.deadline = parse_deadline(f.need("deadline_ms"));
  if (const Val* x = f.get("criticality"))
    op.criticality = static_cast<int>(
        integer(*x, std::numeric_limits<int>::min(), std::numeric_limits<int>::max()));
  if (const Val* x = f.get("max_inflight")) op.max_inflight = small_int(*x, 1);
  if (const Val* x = f.get("depends_on")) {
    const Fields d(*x, {"operation", "use"});
    p.depends_on = d.need("operation");
    if (const Val* use = d.get("use"); use && text(*use) != "latest")
      fail(use->line, at(use->what) + "must be latest" + got(use->node));
    if (text(*p.depends_on) == op.name)
      fail(p.depends_on->line, at(p.depends_on->what) + "an operation cannot depend on itself");
  }
  add_nodes(op, f.need("nodes"));
  std::vector<ReadEdge> edges;
  if (const Val* x = f.get("edges")) edges = read_edges(op, *x);
  std::set<std::pair<int, int>> seen = edge_set(op);
  for (const auto& e : edges) {
    if (!seen.emplace(e.edge.from, e.edge.to).second)
      fail(e.line, fmt::format("{}edge [{}, {}] is listed twice", at(named.what),
                               op.nodes[static_cast<std::size_t>(e.edge.from)].name,
                               op.nodes[static_cast<std::size_t>(e.edge.to)].name));
    op.edges.push_back(e.edge);
  }
  check_graph(op, edges, f.line());
  return p;
}

Scenario Loader::run(const yaml::Node& root) {
  const Fields top(Val{root, mark_line(root), ""},
                   {"name", "duration_s", "warmup_s", "seed", "device", "model", "profile",
                    "scheduler", "interference", "sensors", "operations", "events"});
  s_.file = file_;
  s_.name = text(top.need("name"));
  const Val& duration = top.need("duration_s");
  const double duration_s = positive(duration);
  if (duration_s > 1e9) fail(duration.line, "duration_s: is too large" + got(duration.node));
  s_.duration = from_s(duration_s);
  if (const Val* x = top.get("warmup_s")) {
    const double warmup_s = non_negative(*x);
    if (warmup_s >= duration_s)
      fail(x->line,
           fmt::format("warmup_s: must be less than duration_s ({}){}", duration_s, got(x->node)));
    s_.warmup = from_s(warmup_s);
  }
  if (const Val* x = top.get("seed"))
    s_.seed = static_cast<std::uint64_t>(integer(*x, 0, std::numeric_limits<std::int64_t>::max()));
  if (const Val* x = top.get("device")) parse_device(*x);
  if (const Val* x = top.get("model")) parse_model(*x);
  if (const Val* x = top.get("profile")) {
    s_.profile = resolve_path(text(*x));
    s_.profile_line = x->line;
  }
  if (const Val* x = top.get("scheduler")) parse_scheduler(*x);
  if (const Val* x = top.get("interference")) parse_interference(*x);
  if (const Val* x = top.get("sensors")) parse_sensors(*x);

  const Val& ops = top.need("operations");
  if (!ops.node.is_sequence())
    fail(ops.line, "operations: must be a list of operations" + got(ops.node));
  std::vector<Parsed> parsed;
  std::size_t k = 0;
  for (const yaml::Node& item : ops.node.items()) {
    const Val v{item, mark_line(item) ? mark_line(item) : ops.line,
                fmt::format("operations[{}]", k++)};
    Parsed p = parse_operation(v, "operations");
    for (const auto& q : parsed)
      if (q.op.name == p.op.name)
        fail(p.op.line,
             fmt::format("duplicate operation name '{}' (first at line {})", p.op.name, q.op.line));
    parsed.push_back(std::move(p));
  }
  // depends_on may name an operation defined later in the list.
  for (auto& p : parsed) {
    if (!p.depends_on) continue;
    const std::string target = text(*p.depends_on);
    std::vector<std::string> names;
    for (std::size_t i = 0; i < parsed.size(); ++i) {
      if (parsed[i].op.name == target) p.op.depends_on = static_cast<int>(i);
      names.push_back(parsed[i].op.name);
    }
    if (p.op.depends_on < 0)
      fail(p.depends_on->line, fmt::format("{}no operation named '{}' (operations: {})",
                                           at(p.depends_on->what), target, join(names)));
  }
  // A cycle of "wait for the newest job of" would deadlock the operations on it.
  for (std::size_t i = 0; i < parsed.size(); ++i) {
    int j = parsed[i].op.depends_on;
    for (std::size_t steps = 0; j >= 0 && steps <= parsed.size(); ++steps) {
      if (j == static_cast<int>(i))
        fail(parsed[i].depends_on->line,
             "depends_on forms a cycle through operation '" + parsed[i].op.name + "'");
      j = parsed[static_cast<std::size_t>(j)].op.depends_on;
    }
  }
  for (auto& p : parsed) {
    auto snap = std::make_shared<const OperationSpec>(std::move(p.op));
    s_.names_.push_back(snap->name);
    current_.push_back(snap);
    s_.initial.push_back(std::move(snap));
  }
  if (const Val* x = top.get("events")) parse_events(*x);
  s_.initial.resize(s_.names_.size());  // operations added by events start absent
  if (auto e = check_size(s_)) fail(0, e->message);
  return std::move(s_);
}

}  // namespace loader_detail

using loader_detail::Failure;
using loader_detail::got;
using loader_detail::Loader;
using loader_detail::mark_line;

const std::vector<std::string>& scheduler_keys() {
  static const std::vector<std::string> keys{"gamma_ms",  "estimate",   "level_cost",
                                             "max_batch", "qoe_lambda", "online_costs"};
  return keys;
}

Expected<Scenario> parse_scenario(const std::string& yaml_text, const std::string& file) {
  // YAML is UTF-8 text, and every name read here reaches UTF-8 outputs (summary.json).
  if (auto e = check_utf8(yaml_text, file)) return *e;
  try {
    auto doc = yaml::parse(yaml_text, limits::kMaxNesting);
    if (!doc) return Error{file, doc.error().line, doc.error().message};
    if (const int second = second_yaml_document_line(yaml_text); second > 0)
      return Error{file, second,
                   "a second YAML document: a scenario file holds one (remove the '---' "
                   "and what follows, or split it into two files)"};
    const yaml::Node root = doc->root();
    if (!root || root.is_null())
      return Error{file, 0,
                   "the file is empty (a scenario is a mapping with name, duration_s "
                   "and operations)"};
    if (!root.is_map())
      return Error{
          file, mark_line(root),
          "the top level must be a mapping (name, duration_s, operations, ...)" + got(root)};
    return Loader(file).run(root);
  } catch (const Failure& f) {
    return Error{file, f.line, f.message};
  } catch (const std::exception& e) {
    return Error{file, 0, std::string("cannot load the scenario: ") + e.what()};
  } catch (...) {
    return Error{file, 0, "cannot load the scenario: unknown error"};
  }
}

Expected<Scenario> load_scenario(const std::string& path) {
  auto text = read_file(path);
  if (!text) return text.error();
  return parse_scenario(text.value(), path);
}

}  // namespace red
