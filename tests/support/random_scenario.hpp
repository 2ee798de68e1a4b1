#pragma once
/// \file
/// Test support: random DAG scenarios, emitted as YAML text for parse_scenario, so the
/// whole path (loader, refinement, scheduler, simulator) is exercised. Deterministic for a
/// seed (std::mt19937_64 and integer draws only).

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace red::test {

/// What the generator may put in a scenario.
struct RandomScenarioOptions {
  double duration_s = 2.0;
  bool plain_nodes = true;  ///< occasionally a plain node with its own cost
  bool events = false;      ///< add_nodes / remove_nodes / set_rate events
  bool depends_on = false;  ///< occasionally `depends_on: {use: latest}`
  bool jitter = true;       ///< sensor phases and jitter
  bool knobs = true;        ///< random γ, estimate, level cost, max_batch, overrides
  double max_load = 2.0;    ///< upper end of the coarse utilization target (per lane)
};

namespace detail {

/// Approximate p99 of the built-in default profile (ms); used only to size rates and
/// deadlines so that most jobs can complete.
inline double approx_head_ms(int head) {
  static constexpr double kHeads[] = {3.6, 4.8, 0.75, 5.4};  // lane, seg, steer, det
  return kHeads[head];
}
inline constexpr double kApproxEncoderMs = 14.0;

inline std::string num(double x) {
  return fmt::format("{:.4g}", x);
}

}  // namespace detail

/// A random scenario: 1–2 sensors at different rates, 1–3 operations (triggered by a
/// sensor or sampling the newest frames at their own rate), 2–7 nodes each (inference
/// nodes with random heads and sensors, occasionally a plain node), random forward edges,
/// 1–3 lanes, deadlines a few times the coarse work.
inline std::string random_scenario_yaml(std::uint64_t seed, const RandomScenarioOptions& o = {}) {
  std::mt19937_64 rng(seed);
  auto pick = [&](int lo, int hi) {  // inclusive
    return std::uniform_int_distribution<int>(lo, hi)(rng);
  };
  auto chance = [&](int percent) { return pick(0, 99) < percent; };
  static const char* const kHeads[] = {"lane", "seg", "steer", "det"};

  const int lanes = pick(1, 3);
  const int nsensors = pick(1, 2);
  // Relative sensor rates; scaled below to the load target.
  std::vector<double> sensor_rate;
  for (int i = 0; i < nsensors; ++i) {
    double r = 0;
    do r = static_cast<double>(pick(8, 30));
    while (i > 0 && r == sensor_rate.front());
    sensor_rate.push_back(r);
  }

  struct Node {
    std::string name;
    int head = -1, sensor = -1;
    double cost_ms = 0, p99_ms = 0;  // plain nodes
    // Per-node deadline overrides (docs/DESIGN.md, "Intermediate deadlines").
    bool deadline_override = false;
  };
  struct Op {
    int trigger = -1;
    double rate = 0, phase_ms = 0;
    std::vector<Node> nodes;
    std::vector<std::pair<int, int>> edges;
    double work_ms = 0, cp_ms = 0;
    int max_inflight = 0, criticality = 0, depends_on = -1;
  };
  const int nops = pick(1, 3);
  std::vector<Op> ops(static_cast<std::size_t>(nops));
  for (int k = 0; k < nops; ++k) {
    Op& op = ops[static_cast<std::size_t>(k)];
    if (chance(50)) {
      op.trigger = pick(0, nsensors - 1);
    } else {
      op.rate = static_cast<double>(pick(6, 30));
      if (o.jitter && chance(30)) op.phase_ms = static_cast<double>(pick(1, 20));
    }
    const int n = pick(2, 7);
    std::vector<double> cost(static_cast<std::size_t>(n));
    for (int v = 0; v < n; ++v) {
      Node nd;
      nd.name = fmt::format("n{}", v);
      if (o.plain_nodes && chance(15)) {
        nd.cost_ms = static_cast<double>(pick(5, 40)) / 10.0;
        nd.p99_ms = chance(50) ? nd.cost_ms : nd.cost_ms * 1.5;
        cost[static_cast<std::size_t>(v)] = nd.p99_ms;
      } else {
        nd.head = pick(0, 3);
        nd.sensor = pick(0, nsensors - 1);
        cost[static_cast<std::size_t>(v)] =
            detail::kApproxEncoderMs + detail::approx_head_ms(nd.head);
      }
      op.nodes.push_back(nd);
    }
    const int density = pick(15, 50);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b)
        if (chance(density)) op.edges.emplace_back(a, b);
    // Coarse work and critical path (nodes are in topological order by index).
    std::vector<double> finish(static_cast<std::size_t>(n), 0.0);
    for (int v = 0; v < n; ++v) {
      double start = 0;
      for (auto [a, b] : op.edges)
        if (b == v) start = std::max(start, finish[static_cast<std::size_t>(a)]);
      finish[static_cast<std::size_t>(v)] = start + cost[static_cast<std::size_t>(v)];
      op.cp_ms = std::max(op.cp_ms, finish[static_cast<std::size_t>(v)]);
      op.work_ms += cost[static_cast<std::size_t>(v)];
    }
    if (o.knobs && chance(15)) {
      // docs/DESIGN.md, "Intermediate deadlines" per-node override on a random node: a share of the
      // end-to-end deadline.
      op.nodes[static_cast<std::size_t>(pick(0, n - 1))].deadline_override = true;
    }
    if (chance(20)) op.max_inflight = pick(1, 3);
    op.criticality = chance(20) ? pick(0, 2) : 0;
    if (o.depends_on && k > 0 && chance(35)) op.depends_on = k - 1;
  }

  // Scale every rate so the coarse utilization lands in [0.25, max_load] per lane.
  double load = 0;  // per second, at the relative rates
  for (const Op& op : ops)
    load += (op.trigger >= 0 ? sensor_rate[static_cast<std::size_t>(op.trigger)] : op.rate) *
            op.work_ms / 1000.0;
  const double target =
      lanes * (0.25 + (o.max_load - 0.25) * static_cast<double>(pick(0, 100)) / 100.0);
  const double scale = std::min(1.0, target / load);
  for (double& r : sensor_rate) r = std::max(1.0, std::round(r * scale * 10.0) / 10.0);
  if (nsensors == 2 && sensor_rate[0] == sensor_rate[1]) sensor_rate[1] += 0.5;
  for (Op& op : ops)
    if (op.rate > 0) op.rate = std::max(1.0, std::round(op.rate * scale * 10.0) / 10.0);

  std::string y;
  y += fmt::format("name: random-{}\n", seed);
  y += fmt::format("duration_s: {}\n", detail::num(o.duration_s));
  if (chance(50)) y += fmt::format("warmup_s: {}\n", detail::num(o.duration_s / 10.0));
  y += fmt::format("seed: {}\n", seed % 1000);
  y += fmt::format("device: {{lanes: {}}}\n", lanes);
  y += "model: {builtin: mimonet, heads: [lane, seg, steer, det]}\n";
  if (o.knobs) {
    static const char* const kEstimates[] = {"mean", "p95", "p99", "max"};
    y += fmt::format("scheduler: {{gamma_ms: {}, estimate: {}, level_cost: {}, max_batch: {}}}\n",
                     pick(0, 30), kEstimates[pick(0, 3)], chance(70) ? "max" : "sum", pick(1, 4));
  }
  y += "sensors:\n";
  for (int i = 0; i < nsensors; ++i) {
    y += fmt::format("  cam{}: {{rate_hz: {}", i,
                     detail::num(sensor_rate[static_cast<std::size_t>(i)]));
    if (o.jitter && chance(30)) y += fmt::format(", phase_ms: {}", pick(1, 15));
    if (o.jitter && chance(30)) y += fmt::format(", jitter_ms: {}", pick(1, 5));
    y += "}\n";
  }
  y += "operations:\n";
  for (int k = 0; k < nops; ++k) {
    const Op& op = ops[static_cast<std::size_t>(k)];
    y += fmt::format("  - name: op{}\n", k);
    if (op.trigger >= 0) {
      y += fmt::format("    trigger: cam{}\n", op.trigger);
    } else {
      y += fmt::format("    rate_hz: {}\n", detail::num(op.rate));
      if (op.phase_ms > 0) y += fmt::format("    phase_ms: {}\n", detail::num(op.phase_ms));
    }
    // Generous: a few times the coarse critical path, at least the coarse work.
    const double deadline =
        std::max(op.work_ms, op.cp_ms * static_cast<double>(pick(20, 40)) / 10.0) + 10.0;
    y += fmt::format("    deadline_ms: {}\n", detail::num(std::round(deadline)));
    if (op.max_inflight > 0) y += fmt::format("    max_inflight: {}\n", op.max_inflight);
    if (op.criticality > 0) y += fmt::format("    criticality: {}\n", op.criticality);
    if (op.depends_on >= 0)
      y += fmt::format("    depends_on: {{operation: op{}, use: latest}}\n", op.depends_on);
    y += "    nodes:\n";
    // Nodes in a shuffled file order: refinement must not rely on it being topological.
    std::vector<std::size_t> order(op.nodes.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t i : order) {
      const Node& nd = op.nodes[i];
      y += fmt::format("      {}: {{", nd.name);
      if (nd.head >= 0)
        y += fmt::format("head: {}, sensor: cam{}", kHeads[nd.head], nd.sensor);
      else if (nd.p99_ms == nd.cost_ms)
        y += fmt::format("cost_ms: {}", detail::num(nd.cost_ms));
      else
        y += fmt::format("cost: {{mean_ms: {}, p99_ms: {}}}", detail::num(nd.cost_ms),
                         detail::num(nd.p99_ms));
      if (nd.deadline_override)
        y += fmt::format(", deadline_ms: {}", detail::num(std::round(deadline / 3)));
      y += "}\n";
    }
    if (!op.edges.empty()) {
      y += "    edges: [";
      for (std::size_t e = 0; e < op.edges.size(); ++e)
        y += fmt::format("{}[n{}, n{}]", e == 0 ? "" : ", ", op.edges[e].first, op.edges[e].second);
      y += "]\n";
    }
  }
  if (o.events) {
    // A node joins op0 for the middle third of the run (docs/DESIGN.md, "Task model" environmental
    // dynamics), and a sensor changes rate.
    const Op& op0 = ops.front();
    const int from = pick(0, static_cast<int>(op0.nodes.size()) - 1);
    y += "events:\n";
    y += fmt::format(
        "  - {{at_s: {}, add_nodes: {{operation: op0, nodes: {{x: {{head: {}, sensor: cam{}}}}}, "
        "edges: [[n{}, x]]}}}}\n",
        detail::num(o.duration_s / 3.0), kHeads[pick(0, 3)], pick(0, nsensors - 1), from);
    y += fmt::format("  - {{at_s: {}, remove_nodes: {{operation: op0, nodes: [x]}}}}\n",
                     detail::num(2.0 * o.duration_s / 3.0));
    if (chance(50))
      y += fmt::format("  - {{at_s: {}, set_rate: {{sensor: cam0, rate_hz: {}}}}}\n",
                       detail::num(0.8 * o.duration_s),
                       detail::num(std::max(1.0, sensor_rate.front() * 0.75)));
  }
  return y;
}

}  // namespace red::test
