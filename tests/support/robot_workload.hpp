#pragma once
/// \file
/// Seeded robot workloads (issue 37): what robots run, as scenarios for the simulator.
/// Several sensors at different rates and phases; operations triggered by a sensor or
/// sampling the newest frames at their own rate; MIMONet inference nodes beside plain
/// nodes (fusion, planning); `depends_on` across operations; criticality levels; events
/// that add and remove operations and nodes and change rates and deadlines mid-run. The
/// rates are sized on a profile's mean costs so that the necessary work fills the lanes at
/// rate_scale 1; rate_scale then sets the load. Deterministic for a seed (std::mt19937_64,
/// integer and real draws in a fixed order). Shared by tests/sched/robot_workload_test.cpp
/// and bench/grid/load_grid.cpp (--robots). Options::shared_encoder (issue 52) draws another
/// family instead: several operations sharing one sensor's encoder and its heads, and a
/// critical operation that joins and leaves (shared_workload_yaml).

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red::robot {

/// What one workload may hold.
struct Options {
  /// Simulated time, in frames of the fastest sensor at load 1 (the rates follow the
  /// profile's costs, so a slow model's workload runs longer); events fall inside it, the
  /// first tenth is warm-up.
  double frames = 60;
  int max_lanes = 2;  ///< 1 .. max_lanes lanes
  /// Shared-encoder mode (issue 52; off by default, so a seed's workload stays as it was):
  /// several operations read one sensor ("front") at different rates and phases, some
  /// triggered by its frames, some sampling the newest frame at their own rate, with their
  /// own deadlines; their heads are drawn from a common pool (so a head batches across
  /// jobs of different operations); a critical operation (criticality 2, above every other)
  /// joins by an event and leaves by a later one. Now and then a second sensor ("rear")
  /// with an operation of its own. See shared_workload_yaml.
  bool shared_encoder = false;
};

namespace detail {

inline double mean_ms(const Profile& p, const std::string& unit) {
  const UnitProfile* u = p.find(unit);
  return u != nullptr ? to_ms(u->at(1).mean) : 1.0;
}

inline std::string num(double x) {
  return fmt::format("{:.4g}", x);
}

// Node `v` of an operation, at indent `in`: an inference node (a head on a sensor) or a plain one.
inline std::string node_yaml(const std::string& in, std::size_t v, const char* head,
                             const char* sensor, double cost_ms) {
  if (head != nullptr)
    return fmt::format("{}  N{}: {{head: {}, sensor: {}}}\n", in, v, head, sensor);
  return fmt::format("{}  N{}: {{cost: {{mean_ms: {:.3f}, p99_ms: {:.3f}}}}}\n", in, v, cost_ms,
                     cost_ms * 1.3);
}

// The coarse critical path (ms) of an operation's nodes (`head` >= 0: an inference node, which runs
// its sensor's encoder, `enc` ms, and its head; else `cost_ms`), nodes in topological order.
template <class NodeT, class HeadMs>
double coarse_cp_ms(const std::vector<NodeT>& nodes, const std::vector<std::pair<int, int>>& edges,
                    double enc, const HeadMs& head_ms) {
  std::vector<double> finish(nodes.size(), 0.0);
  double cp = 0;
  for (std::size_t v = 0; v < nodes.size(); ++v) {
    double start = 0;
    for (auto [a, b] : edges)
      if (b == static_cast<int>(v)) start = std::max(start, finish[static_cast<std::size_t>(a)]);
    const NodeT& n = nodes[v];
    finish[v] = start + (n.head >= 0 ? enc + head_ms(n.head) : n.cost_ms);
    cp = std::max(cp, finish[v]);
  }
  return cp;
}

// An operation's `edges:` line at indent `in`, empty when it has none.
inline std::string edges_yaml(const std::string& in,
                              const std::vector<std::pair<int, int>>& edges) {
  if (edges.empty()) return {};
  std::string o = in + "edges: [";
  for (std::size_t e = 0; e < edges.size(); ++e)
    o += fmt::format("{}[N{}, N{}]", e ? ", " : "", edges[e].first, edges[e].second);
  return o + "]\n";
}

}  // namespace detail

/// The YAML of shared-encoder robot workload `seed` (Options::shared_encoder) at rate_scale 1,
/// sized like workload_yaml: the necessary work (one encoder run per frame of a sensor that
/// a triggered operation reads, one per job of an own-rate operation, heads and plain nodes
/// per job; the critical operation weighted by the share of the run it is present) fills
/// the lanes at rate_scale 1.
inline std::string shared_workload_yaml(std::uint64_t seed, const Profile& profile,
                                        const Options& opt) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 52);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  auto real = [&](double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng); };
  auto chance = [&](int percent) { return pick(0, 99) < percent; };
  static const char* const kHeads[] = {"lane", "seg", "steer", "det"};
  static const double kRates[] = {10, 12.5, 15, 20, 25, 30};
  // Own rates as fractions of the sensor's: sampling the newest frame every frame, every
  // other one, or slower, never faster than frames arrive.
  static const double kFractions[] = {0.25, 1.0 / 3, 0.5, 2.0 / 3, 0.75, 1.0};
  const double enc = detail::mean_ms(profile, "encoder");
  auto head_ms = [&](int h) { return detail::mean_ms(profile, std::string("head/") + kHeads[h]); };

  const int lanes = pick(1, std::max(1, opt.max_lanes));
  double front_hz = kRates[pick(0, 5)];
  const bool rear = chance(35);
  double rear_hz = rear ? kRates[pick(0, 5)] * real(0.4, 0.8) : 0;

  struct Node {
    int head = -1;       // an inference node
    double cost_ms = 0;  // a plain node
  };
  struct Op {
    std::string name, sensor = "front";
    bool triggered = true;  // else its own rate, sampling the newest frame
    double rate = 0;        // own rate (relative, scaled below)
    double deadline_periods = 1;
    std::vector<Node> nodes;
    std::vector<std::pair<int, int>> edges;
    int criticality = 0, max_inflight = 0;
    double cp_ms = 0, heads_ms = 0, plain_ms = 0;
  };
  // The pool every operation on the front sensor draws its heads from: a common head that
  // most operations run (so that head batches across jobs of different operations), and
  // the others now and then.
  const int common = pick(0, 3);
  auto make_op = [&](const std::string& name, bool force_common, double d_lo, double d_hi) {
    Op op;
    op.name = name;
    std::vector<int> heads;
    if (force_common || chance(65)) heads.push_back(common);
    const int more = pick(heads.empty() ? 1 : 0, 2);
    for (int i = 0; i < more; ++i) {
      const int h = pick(0, 3);
      if (std::find(heads.begin(), heads.end(), h) == heads.end()) heads.push_back(h);
    }
    for (int h : heads) {
      op.nodes.push_back(Node{h, 0});
      op.heads_ms += head_ms(h);
    }
    const int infer = static_cast<int>(heads.size());
    // A head refining another's output now and then; a plain node (tracking, planning)
    // after the heads half the time.
    if (infer > 1 && chance(30)) op.edges.emplace_back(0, 1);
    if (chance(50)) {
      Node n;
      n.cost_ms = real(0.3, 0.1 * enc + 0.5);
      op.nodes.push_back(n);
      op.plain_ms += n.cost_ms;
      for (int v = 0; v < infer; ++v)
        if (v == 0 || chance(50)) op.edges.emplace_back(v, infer);
    }
    op.cp_ms = detail::coarse_cp_ms(op.nodes, op.edges, enc, head_ms);
    op.deadline_periods = real(d_lo, d_hi);
    if (chance(20)) op.max_inflight = pick(1, 3);
    return op;
  };

  // 3–5 operations on the front sensor: the first triggered by it, the second at its own
  // rate (so both kinds always share the encoder), the rest either; the first two run the
  // common head.
  const int nops = pick(3, 5);
  std::vector<Op> ops;
  for (int k = 0; k < nops; ++k) {
    Op op = make_op(fmt::format("op{}", k), k < 2, 0.7, 2.0);
    op.triggered = k == 0 || (k > 1 && chance(50));
    if (!op.triggered) op.rate = front_hz * kFractions[pick(0, 5)];
    op.criticality = chance(35) ? 1 : 0;
    ops.push_back(std::move(op));
  }
  if (rear) {
    Op op = make_op("rear_watch", false, 0.8, 2.0);
    op.sensor = "rear";
    op.criticality = chance(35) ? 1 : 0;
    ops.push_back(std::move(op));
  }
  // The critical operation (an obstacle ahead): on the front sensor, triggered or at its own
  // rate, with the common head, a tight deadline; present from `from` to `to` of the run.
  Op crit = make_op("critical", true, 0.6, 1.2);
  crit.triggered = chance(50);
  if (!crit.triggered) crit.rate = front_hz * kFractions[pick(2, 5)];
  crit.criticality = 2;
  crit.max_inflight = 0;
  const double from = real(0.15, 0.4), to = real(0.6, 0.9);

  auto op_rate = [&](const Op& op) {
    if (!op.triggered) return op.rate;
    return op.sensor == "rear" ? rear_hz : front_hz;
  };
  double work = 0;  // ms per second
  bool front_encoded = false;
  auto add_work = [&](const Op& op, double weight) {
    const double hz = op_rate(op);
    work += weight * hz * (op.heads_ms + op.plain_ms);
    if (op.heads_ms <= 0) return;
    if (!op.triggered) {
      work += weight * hz * enc;
    } else if (op.sensor == "rear") {
      work += weight * rear_hz * enc;
    } else if (!front_encoded) {
      work += front_hz * enc;  // the frames are encoded while any triggered operation runs
      front_encoded = true;
    }
  };
  for (const Op& op : ops) add_work(op, 1.0);
  add_work(crit, to - from);
  const double scale = lanes * 1000.0 / std::max(work, 1e-3);
  front_hz = std::clamp(front_hz * scale, 0.01, 1000.0);
  rear_hz = std::clamp(rear_hz * scale, 0.01, 1000.0);
  for (Op& op : ops)
    if (!op.triggered) op.rate = std::clamp(op.rate * scale, 0.01, 1000.0);
  if (!crit.triggered) crit.rate = std::clamp(crit.rate * scale, 0.01, 1000.0);

  const double duration_s = opt.frames / front_hz;
  std::string y = fmt::format(
      "name: robot-shared-{}\nduration_s: {}\nwarmup_s: {}\nseed: {}\ndevice: {{lanes: {}}}\n"
      "model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}\nsensors:\n",
      seed, detail::num(duration_s), detail::num(duration_s / 10), seed % 1000 + 1, lanes);
  y += fmt::format("  front: {{rate_hz: {:.5g}, phase_ms: {:.2f}}}\n", front_hz, real(0, 30));
  if (rear)
    y += fmt::format("  rear: {{rate_hz: {:.5g}, phase_ms: {:.2f}}}\n", rear_hz, real(0, 30));
  // Deadline: its periods (drawn above), never below 1.3 × the coarse critical path.
  auto op_yaml = [&](const Op& op, const std::string& indent) {
    std::string o = indent + "name: " + op.name + "\n";
    const std::string in(indent.size(), ' ');
    if (op.triggered)
      o += fmt::format("{}trigger: {}\n", in, op.sensor);
    else
      o += fmt::format("{}rate_hz: {:.5g}\n{}phase_ms: {:.2f}\n", in, op.rate, in,
                       real(0, 1000.0 / op.rate));
    o += fmt::format("{}deadline_ms: {:.2f}\n", in,
                     std::max(1000.0 / op_rate(op) * op.deadline_periods, 1.3 * op.cp_ms));
    if (op.criticality > 0) o += fmt::format("{}criticality: {}\n", in, op.criticality);
    if (op.max_inflight > 0) o += fmt::format("{}max_inflight: {}\n", in, op.max_inflight);
    o += in + "nodes:\n";
    for (std::size_t v = 0; v < op.nodes.size(); ++v) {
      const Node& n = op.nodes[v];
      o += detail::node_yaml(in, v, n.head >= 0 ? kHeads[n.head] : nullptr, op.sensor.c_str(),
                             n.cost_ms);
    }
    return o + detail::edges_yaml(in, op.edges);
  };
  y += "operations:\n";
  for (const Op& op : ops) y += op_yaml(op, "  - ");
  y += fmt::format("events:\n  - at_s: {:.3f}\n    add_operation:\n{}", duration_s * from,
                   op_yaml(crit, "      "));
  y += fmt::format("  - at_s: {:.3f}\n    remove_operation: {{operation: critical}}\n",
                   duration_s * to);
  return y;
}

/// The YAML of robot workload `seed` at rate_scale 1, sized on `profile`'s mean costs (its
/// `encoder` and `head/<name>` units; the heads are lane, seg, steer and det). With
/// Options::shared_encoder, shared_workload_yaml's workload instead.
inline std::string workload_yaml(std::uint64_t seed, const Profile& profile,
                                 const Options& opt = {}) {
  if (opt.shared_encoder) return shared_workload_yaml(seed, profile, opt);
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + 37);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  auto real = [&](double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng); };
  auto chance = [&](int percent) { return pick(0, 99) < percent; };
  static const char* const kHeads[] = {"lane", "seg", "steer", "det"};
  static const char* const kSensors[] = {"front", "rear", "left", "right"};
  static const double kRates[] = {10, 12.5, 15, 20, 25, 30};
  const double enc = detail::mean_ms(profile, "encoder");
  auto head_ms = [&](int h) { return detail::mean_ms(profile, std::string("head/") + kHeads[h]); };

  const int lanes = pick(1, std::max(1, opt.max_lanes));
  const int nsensors = pick(2, 4);
  std::vector<double> sensor_rate(static_cast<std::size_t>(nsensors));
  for (double& r : sensor_rate) r = kRates[pick(0, 5)];

  struct Node {
    int head = -1, sensor = -1;  // an inference node
    double cost_ms = 0;          // a plain node
  };
  struct Op {
    std::string name;
    int trigger = -1;  // else its own rate
    double rate = 0;   // own rate (relative, scaled below)
    std::vector<Node> nodes;
    std::vector<std::pair<int, int>> edges;
    int criticality = 0, depends_on = -1, max_inflight = 0;
    double cp_ms = 0, heads_ms = 0, plain_ms = 0;
    std::vector<int> sensors;  // read by its inference nodes
  };
  auto make_op = [&](const std::string& name, int index) {
    Op op;
    op.name = name;
    if (chance(75)) {
      op.trigger = pick(0, nsensors - 1);
    } else {
      op.rate = kRates[pick(0, 5)] / 2;
    }
    // Perception: 1–3 inference nodes, mostly on the trigger sensor (sometimes a fused
    // second sensor); then 0–2 plain nodes (tracking, fusion, planning) after them.
    const int infer = pick(1, 3);
    for (int i = 0; i < infer; ++i) {
      Node n;
      n.head = pick(0, 3);
      n.sensor = op.trigger >= 0 && chance(80) ? op.trigger : pick(0, nsensors - 1);
      op.nodes.push_back(n);
      if (std::find(op.sensors.begin(), op.sensors.end(), n.sensor) == op.sensors.end())
        op.sensors.push_back(n.sensor);
      op.heads_ms += head_ms(n.head);
    }
    const int plain = pick(0, 2);
    for (int i = 0; i < plain; ++i) {
      Node n;
      n.cost_ms = real(0.3, 0.15 * enc + 0.5);
      op.nodes.push_back(n);
      op.plain_ms += n.cost_ms;
    }
    // Edges: every plain node after some inference node (or the previous plain node); a
    // head feeding another head now and then (a head that refines another's output).
    for (int v = infer; v < infer + plain; ++v) {
      op.edges.emplace_back(pick(0, v - 1), v);
      if (v > 0 && chance(40)) {
        const int from = pick(0, v - 1);
        if (std::find(op.edges.begin(), op.edges.end(), std::make_pair(from, v)) == op.edges.end())
          op.edges.emplace_back(from, v);
      }
    }
    if (infer > 1 && chance(25)) op.edges.emplace_back(0, 1);
    // Coarse critical path: an inference node runs its sensor's encoder and its head.
    op.cp_ms = detail::coarse_cp_ms(op.nodes, op.edges, enc, head_ms);
    const int c = pick(0, 99);
    op.criticality = c < 55 ? 0 : c < 85 ? 1 : 2;
    if (index > 0 && chance(25)) op.depends_on = pick(0, index - 1);
    if (chance(20)) op.max_inflight = pick(1, 3);
    return op;
  };

  const int nops = pick(2, 4);
  std::vector<Op> ops;
  for (int k = 0; k < nops; ++k) ops.push_back(make_op(fmt::format("op{}", k), k));
  // An operation that joins mid-run (an obstacle seen, a door to open): often critical.
  const bool joins = chance(70);
  Op extra = make_op("joined", nops);
  extra.depends_on = -1;
  if (chance(60)) extra.criticality = std::max(extra.criticality, 1);

  // Rates: the necessary work at the relative rates (one encoder run per frame of a sensor
  // that a triggered operation reads; an own-rate job counts its encoders; heads and plain
  // nodes per job), scaled to fill the lanes at rate_scale 1.
  auto op_rate = [&](const Op& op) {
    return op.trigger >= 0 ? sensor_rate[static_cast<std::size_t>(op.trigger)] : op.rate;
  };
  std::vector<char> encoded(sensor_rate.size(), 0);
  double work = 0;  // ms per second
  auto add_work = [&](const Op& op, double weight) {
    const double hz = op_rate(op);
    work += weight * hz * (op.heads_ms + op.plain_ms);
    for (int s : op.sensors) {
      const auto si = static_cast<std::size_t>(s);
      if (op.trigger == s) {
        if (encoded[si] == 0) work += weight * sensor_rate[si] * enc;
        encoded[si] = 1;
      } else {
        work += weight * hz * enc;
      }
    }
  };
  for (const Op& op : ops) add_work(op, 1.0);
  if (joins) add_work(extra, 0.5);  // present about half the run
  const double scale = lanes * 1000.0 / std::max(work, 1e-3);
  for (double& r : sensor_rate) r = std::clamp(r * scale, 0.01, 1000.0);
  for (Op& op : ops)
    if (op.trigger < 0) op.rate = std::clamp(op.rate * scale, 0.01, 1000.0);
  if (extra.trigger < 0) extra.rate = std::clamp(extra.rate * scale, 0.01, 1000.0);

  const double fastest = *std::max_element(sensor_rate.begin(), sensor_rate.end());
  const double duration_s = opt.frames / fastest;
  std::string y = fmt::format(
      "name: robot-{}\nduration_s: {}\nwarmup_s: {}\nseed: {}\ndevice: {{lanes: {}}}\n"
      "model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}\nsensors:\n",
      seed, detail::num(duration_s), detail::num(duration_s / 10), seed % 1000 + 1, lanes);
  for (int i = 0; i < nsensors; ++i)
    y += fmt::format("  {}: {{rate_hz: {:.5g}, phase_ms: {:.2f}}}\n", kSensors[i],
                     sensor_rate[static_cast<std::size_t>(i)], real(0, 30));
  // Deadline: 0.8–2 periods of its rate, never below 1.3 × the coarse critical path.
  auto deadline_of = [&](const Op& op) {
    return std::max(1000.0 / op_rate(op) * real(0.8, 2.0), 1.3 * op.cp_ms);
  };
  auto op_yaml = [&](const Op& op, const std::string& indent, bool with_depends) {
    std::string o = indent + "name: " + op.name + "\n";
    const std::string in(indent.size(), ' ');
    if (op.trigger >= 0)
      o += fmt::format("{}trigger: {}\n", in, kSensors[op.trigger]);
    else
      o += fmt::format("{}rate_hz: {:.5g}\n{}phase_ms: {:.2f}\n", in, op.rate, in, real(0, 20));
    o += fmt::format("{}deadline_ms: {:.2f}\n", in, deadline_of(op));
    if (op.criticality > 0) o += fmt::format("{}criticality: {}\n", in, op.criticality);
    if (op.max_inflight > 0) o += fmt::format("{}max_inflight: {}\n", in, op.max_inflight);
    if (with_depends && op.depends_on >= 0)
      o += fmt::format("{}depends_on: {{operation: op{}, use: latest}}\n", in, op.depends_on);
    o += in + "nodes:\n";
    for (std::size_t v = 0; v < op.nodes.size(); ++v) {
      const Node& n = op.nodes[v];
      o += detail::node_yaml(in, v, n.head >= 0 ? kHeads[n.head] : nullptr,
                             n.head >= 0 ? kSensors[n.sensor] : nullptr, n.cost_ms);
    }
    return o + detail::edges_yaml(in, op.edges);
  };
  y += "operations:\n";
  for (const Op& op : ops) y += op_yaml(op, "  - ", true);

  // Events, in time order: an operation joins and leaves; a node joins op0 and leaves; a
  // sensor (or an own-rate operation) changes rate; an operation's deadline changes.
  struct Event {
    double at;
    std::string yaml;
  };
  std::vector<Event> ev;
  const double d = duration_s;
  if (joins) {
    const double from = d * real(0.2, 0.45), to = d * real(0.6, 0.9);
    std::string add = "    add_operation:\n" + op_yaml(extra, "      ", false);
    ev.push_back({from, add});
    ev.push_back({to, "    remove_operation: {operation: joined}\n"});
  }
  if (chance(50)) {
    const Op& op0 = ops.front();
    const int h = pick(0, 3);
    const int s = op0.trigger >= 0 ? op0.trigger : pick(0, nsensors - 1);
    const std::string node = chance(50)
                                 ? fmt::format("{{head: {}, sensor: {}}}", kHeads[h], kSensors[s])
                                 : fmt::format("{{cost_ms: {:.3f}}}", real(0.3, 0.1 * enc + 0.5));
    ev.push_back(
        {d * real(0.15, 0.4),
         fmt::format("    add_nodes: {{operation: op0, nodes: {{X: {}}}, edges: [[N0, X]]}}\n",
                     node)});
    ev.push_back({d * real(0.5, 0.7), "    remove_nodes: {operation: op0, nodes: [X]}\n"});
  }
  if (chance(50)) {
    const int s = pick(0, nsensors - 1);
    ev.push_back({d * real(0.3, 0.8),
                  fmt::format("    set_rate: {{sensor: {}, rate_hz: {:.5g}}}\n", kSensors[s],
                              sensor_rate[static_cast<std::size_t>(s)] * real(0.6, 1.4))});
  }
  for (const Op& op : ops)
    if (op.trigger < 0 && chance(40)) {
      ev.push_back(
          {d * real(0.3, 0.8), fmt::format("    set_rate: {{operation: {}, rate_hz: {:.5g}}}\n",
                                           op.name, op.rate * real(0.6, 1.4))});
      break;
    }
  if (chance(50)) {
    const Op& op = ops[static_cast<std::size_t>(pick(0, nops - 1))];
    ev.push_back({d * real(0.3, 0.8),
                  fmt::format("    set_deadline: {{operation: {}, deadline_ms: {:.2f}}}\n", op.name,
                              std::max(1.3 * op.cp_ms, deadline_of(op) * real(0.7, 1.3)))});
  }
  std::stable_sort(ev.begin(), ev.end(),
                   [](const Event& a, const Event& b) { return a.at < b.at; });
  if (!ev.empty()) {
    y += "events:\n";
    for (const Event& e : ev) y += fmt::format("  - at_s: {:.3f}\n{}", e.at, e.yaml);
  }
  return y;
}

/// Robot workload `seed` as a scenario at `load` (rate_scale).
inline Scenario workload(std::uint64_t seed, const Profile& profile, double load,
                         const Options& opt = {}) {
  const std::string yaml = workload_yaml(seed, profile, opt);
  auto s = parse_scenario(yaml, fmt::format("robot-{}.yaml", seed));
  if (!s)
    throw std::runtime_error("robot workload does not parse: " + s.error().to_string() + "\n" +
                             yaml);
  if (auto err = apply_override(*s, "rate_scale", load))
    throw std::runtime_error("rate_scale: " + err->to_string());
  return std::move(s).value();
}

}  // namespace red::robot
