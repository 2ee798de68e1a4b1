#pragma once
/// \file
/// The overload grid (docs/DESIGN.md, "Overload"): seeded random DAG task sets — chains, fork-joins
/// and wide DAGs of plain-cost nodes or MIMONet inference nodes, on 1, 2 or 4 lanes — sized to a
/// target utilization of the necessary work, and the yardsticks a policy is judged by at each load:
/// the on-time fraction, the work bound (the most jobs that fit the lane time when the cheapest are
/// admitted first, jobs whose critical path exceeds the deadline excluded) and the wasted lane
/// time. Shared by tests/sched/overload_test.cpp and bench/load_grid.cpp. Deterministic for a seed.

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "red/analysis/bound.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red::grid {

enum class Shape : std::uint8_t { Chain, ForkJoin, Wide };
enum class Nodes : std::uint8_t { Plain, Mimonet };

inline const char* to_string(Shape s) {
  return s == Shape::Chain ? "chain" : s == Shape::ForkJoin ? "fork-join" : "wide";
}
inline const char* to_string(Nodes n) {
  return n == Nodes::Plain ? "plain" : "mimonet";
}

/// One task set of the grid, at utilization 1 (rate_scale then sets the load).
struct SetSpec {
  std::uint64_t seed = 1;
  int lanes = 1;
  Shape shape = Shape::Chain;
  Nodes nodes = Nodes::Plain;
  double duration_s = 4.0;
  double warmup_s = 0.5;
};

namespace detail {

inline double mean_ms(const Profile& p, const std::string& unit) {
  const UnitProfile* u = p.find(unit);
  return u != nullptr ? to_ms(u->at(1).mean) : 1.0;
}

}  // namespace detail

/// The YAML of a random task set whose necessary work (plain costs; for MIMONet one
/// encoder run per camera frame plus the heads) fills `lanes` lanes exactly at
/// rate_scale 1, on the mean costs of `profile`.
inline std::string set_yaml(const SetSpec& spec, const Profile& profile) {
  std::mt19937_64 rng(spec.seed * 0x9E3779B97F4A7C15ULL + 17);
  auto pick = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  auto real = [&](double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(rng); };
  static const char* const kHeads[] = {"lane", "seg", "steer", "det"};
  const bool mimo = spec.nodes == Nodes::Mimonet;
  const double enc = detail::mean_ms(profile, "encoder");
  const int cameras = mimo ? pick(1, 2) : 0;
  const int ops = pick(2, 4);

  struct Op {
    std::vector<std::string> node_yaml;
    std::vector<std::pair<int, int>> edges;
    double work = 0;   // mean ms of necessary work per job (encoders aside)
    double cp = 0;     // coarse critical path, mean ms
    int camera = -1;   // MIMONet: the camera it is triggered by
    double share = 0;  // its part of the utilization
  };
  std::vector<Op> all(static_cast<std::size_t>(ops));
  for (Op& op : all) {
    int n = 0;
    std::vector<std::pair<int, int>> e;
    switch (spec.shape) {
      case Shape::Chain:
        n = pick(2, 5);
        for (int i = 0; i + 1 < n; ++i) e.emplace_back(i, i + 1);
        break;
      case Shape::ForkJoin: {
        const int width = pick(2, 4);
        n = width + 2;
        for (int i = 1; i <= width; ++i) {
          e.emplace_back(0, i);
          e.emplace_back(i, n - 1);
        }
        break;
      }
      case Shape::Wide:
        n = pick(4, 8);
        for (int to = 1; to < n; ++to)
          for (int from = 0; from < to; ++from)
            if (pick(0, 99) < 25) e.emplace_back(from, to);
        break;
    }
    std::vector<double> cost(static_cast<std::size_t>(n));
    op.camera = mimo ? pick(0, cameras - 1) : -1;
    for (int i = 0; i < n; ++i) {
      std::string y;
      if (mimo) {
        const int h = pick(0, 3);
        cost[static_cast<std::size_t>(i)] =
            detail::mean_ms(profile, std::string("head/") + kHeads[h]);
        y = fmt::format("N{}: {{head: {}, sensor: cam{}}}", i, kHeads[h], op.camera);
      } else {
        const double mean = real(1.0, 8.0);
        cost[static_cast<std::size_t>(i)] = mean;
        y = fmt::format("N{}: {{cost: {{mean_ms: {:.3f}, p99_ms: {:.3f}}}}}", i, mean, mean * 1.3);
      }
      op.node_yaml.push_back(y);
      op.work += cost[static_cast<std::size_t>(i)];
    }
    // Coarse critical path on mean costs (a coarse inference node runs encoder + head).
    std::vector<double> finish(static_cast<std::size_t>(n), 0.0);
    for (int i = 0; i < n; ++i) {
      double start = 0;
      for (auto [f, t] : e)
        if (t == i) start = std::max(start, finish[static_cast<std::size_t>(f)]);
      finish[static_cast<std::size_t>(i)] =
          start + cost[static_cast<std::size_t>(i)] + (mimo ? enc : 0);
      op.cp = std::max(op.cp, finish[static_cast<std::size_t>(i)]);
    }
    op.edges = e;
    op.share = real(0.5, 1.5);
  }
  double total_share = 0;
  for (const Op& op : all) total_share += op.share;

  std::string y = fmt::format(
      "name: grid-{}-{}-{}-l{}\nduration_s: {}\nwarmup_s: {}\nseed: {}\n"
      "device: {{lanes: {}, sync_cost_us: 0}}\n",
      to_string(spec.nodes), to_string(spec.shape), spec.seed, spec.lanes, spec.duration_s,
      spec.warmup_s, spec.seed, spec.lanes);
  std::vector<double> rate(all.size());
  if (mimo) {
    y += "model: {builtin: mimonet, heads: [lane, seg, steer, det]}\nsensors:\n";
    // A camera's frame costs one encoder run and the heads of every operation it triggers.
    for (int c = 0; c < cameras; ++c) {
      double per_frame = 0, share = 0;
      for (const Op& op : all)
        if (op.camera == c) {
          per_frame += op.work;
          share += op.share;
        }
      if (share == 0) {
        y += fmt::format("  cam{}: {{rate_hz: 1}}\n", c);
        continue;
      }
      per_frame += enc;
      const double hz = share / total_share * spec.lanes * 1000.0 / per_frame;
      y += fmt::format("  cam{}: {{rate_hz: {:.4f}, phase_ms: {:.3f}}}\n", c, hz, real(0, 5));
      for (std::size_t i = 0; i < all.size(); ++i)
        if (all[i].camera == c) rate[i] = hz;
    }
  } else {
    for (std::size_t i = 0; i < all.size(); ++i)
      rate[i] = all[i].share / total_share * spec.lanes * 1000.0 / all[i].work;
  }
  y += "operations:\n";
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Op& op = all[i];
    // Deadline: 0.8–1.5 periods, never below 1.3 × the coarse critical path.
    const double period_ms = 1000.0 / rate[i];
    const double d = std::max(period_ms * real(0.8, 1.5), 1.3 * op.cp);
    y += fmt::format("  - name: op{}\n", i);
    if (mimo)
      y += fmt::format("    trigger: cam{}\n", op.camera);
    else
      y += fmt::format("    rate_hz: {:.4f}\n    phase_ms: {:.3f}\n", rate[i], real(0, period_ms));
    y += fmt::format("    deadline_ms: {:.3f}\n    max_inflight: 4\n    nodes:\n", d);
    for (const std::string& n : op.node_yaml) y += "      " + n + "\n";
    if (!op.edges.empty()) {
      y += "    edges: [";
      for (std::size_t k = 0; k < op.edges.size(); ++k)
        y += fmt::format("{}[N{}, N{}]", k ? ", " : "", op.edges[k].first, op.edges[k].second);
      y += "]\n";
    }
  }
  return y;
}

/// A grid set as a scenario at `load` (rate_scale).
inline Scenario set_scenario(const SetSpec& spec, const Profile& profile, double load) {
  const std::string yaml = set_yaml(spec, profile);
  auto s = parse_scenario(yaml, "grid.yaml");
  if (!s)
    throw std::runtime_error("grid scenario does not parse: " + s.error().to_string() + "\n" +
                             yaml);
  if (auto err = apply_override(*s, "rate_scale", load))
    throw std::runtime_error("rate_scale: " + err->to_string());
  return std::move(s).value();
}

/// What one policy achieved at one grid point.
struct Point {
  double on_time = 0;  ///< met / released (after warm-up)
  double wasted = 0;   ///< lane time on jobs then dropped / busy lane time
  std::int64_t released = 0, met = 0, completed = 0, dropped = 0, skipped = 0, unfinished = 0;
};

/// Simulates `policy` on `s` (seed = the scenario's).
inline Point evaluate(const Scenario& s, const Profile& p, const std::string& policy) {
  auto r = simulate_policy(s, p, policy, s.seed, {}, false);
  if (!r) throw std::runtime_error(r.error().to_string());
  const PolicyMetrics& m = r->metrics;
  Point pt;
  pt.released = m.jobs;
  pt.met = m.met;
  pt.completed = m.completed;
  pt.dropped = m.dropped - m.skipped;
  pt.skipped = m.skipped;
  pt.unfinished = m.unfinished;
  pt.on_time = m.on_time;
  pt.wasted = m.wasted_lane_fraction;
  return pt;
}

/// The work bound (docs/DESIGN.md, "Overload"): of the jobs released after warm-up in the run of
/// `s`, the largest share that fits the lanes' time when the cheapest are admitted first
/// (red/analysis/bound.hpp, the same figure `red analyze` reports).
inline double work_bound(const Scenario& s, const Profile& p) {
  return red::work_bound(s, p);
}

/// The grid's sets: every (lanes, shape, nodes) combination, `per_cell` seeds each.
inline std::vector<SetSpec> grid_sets(int per_cell, double duration_s = 4.0) {
  std::vector<SetSpec> v;
  std::uint64_t seed = 1;
  for (int lanes : {1, 2, 4})
    for (Shape sh : {Shape::Chain, Shape::ForkJoin, Shape::Wide})
      for (Nodes n : {Nodes::Plain, Nodes::Mimonet})
        for (int k = 0; k < per_cell; ++k) {
          SetSpec s;
          s.seed = seed++;
          s.lanes = lanes;
          s.shape = sh;
          s.nodes = n;
          s.duration_s = duration_s;
          v.push_back(s);
        }
  return v;
}

}  // namespace red::grid
