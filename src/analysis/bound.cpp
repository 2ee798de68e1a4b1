#include "red/analysis/bound.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/metrics/metrics.hpp"
#include "red/sim/run.hpp"

namespace red {
namespace {

// The least mean cost per item of `unit` in a batch of at most `limit` items (§3 inter-DAG
// batching: a batch of b costs C(b), so each of its items needs C(b) / b of the lane).
double per_item_ms(const Profile& p, const std::string& unit, int limit) {
  const UnitProfile* u = p.find(unit);
  if (u == nullptr || u->by_batch.empty()) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  const int top = std::clamp(limit, 1, u->max_batch());
  for (int b = 1; b <= top; ++b) best = std::min(best, to_ms(u->at(b).mean) / b);
  return best;
}

// Every definition an operation has during the run: the initial one and those events give.
std::vector<std::vector<const OperationSpec*>> snapshots(const Scenario& s) {
  std::vector<std::vector<const OperationSpec*>> v(static_cast<std::size_t>(s.operation_count()));
  for (int i = 0; i < s.operation_count(); ++i)
    if (const auto& op = s.initial[static_cast<std::size_t>(i)])
      v[static_cast<std::size_t>(i)].push_back(op.get());
  for (const EventSpec& e : s.events)
    for (const auto& [i, op] : e.changes)
      if (op) v[static_cast<std::size_t>(i)].push_back(op.get());
  return v;
}

// The definition of operation `i` in force at `t` (the last event at or before t wins).
const OperationSpec* snapshot_at(const Scenario& s, int i, TimePoint t) {
  const OperationSpec* op = s.initial[static_cast<std::size_t>(i)].get();
  for (const EventSpec& e : s.events) {
    if (TimePoint{e.at} > t) break;
    for (const auto& [k, snap] : e.changes)
      if (k == i) op = snap.get();
  }
  return op;
}

std::set<int> sensors_read(const OperationSpec& op) {
  std::set<int> v;
  for (const NodeSpec& n : op.nodes)
    if (!n.is_plain() && n.sensor >= 0) v.insert(n.sensor);
  return v;
}

}  // namespace

double work_bound(const Scenario& s, const Profile& p) {
  // The releases are the same for every policy (same frames, same own-rate ticks; a release
  // skipped at max_inflight is counted as released): take them from a FIFO run.
  auto r = simulate_policy(s, p, "fifo", s.seed, {}, false);
  if (!r) throw std::runtime_error(r.error().to_string());
  const auto all = snapshots(s);
  const int max_batch = std::max(1, s.scheduler.max_batch);
  const CostModel mean{&p, &s.model, EstimateKind::Mean};

  // Slowest period of each sensor over the run (rate changes by events included): the
  // longest a frame stays the newest one, jitter added.
  std::vector<double> frame_life(s.sensors.size(), 0.0);
  for (std::size_t k = 0; k < s.sensors.size(); ++k) {
    double hz = s.sensors[k].rate_hz;
    for (const EventSpec& e : s.events)
      for (const auto& [i, rate] : e.sensor_rates)
        if (static_cast<std::size_t>(i) == k) hz = std::min(hz, rate);
    frame_life[k] = 1000.0 / hz + to_ms(s.sensors[k].jitter);
  }
  // Shortest release period of an operation over its definitions (ms; +inf if none).
  auto fastest_period = [&](int i) {
    double t = std::numeric_limits<double>::infinity();
    for (const OperationSpec* op : all[static_cast<std::size_t>(i)]) {
      double hz = op->rate_hz;
      if (op->trigger_sensor >= 0) {
        hz = s.sensors[static_cast<std::size_t>(op->trigger_sensor)].rate_hz;
        for (const EventSpec& e : s.events)
          for (const auto& [k, rate] : e.sensor_rates)
            if (k == op->trigger_sensor) hz = std::max(hz, rate);
      }
      if (hz > 0) t = std::min(t, 1000.0 / hz);
    }
    return t;
  };

  // How many jobs one encoder run on sensor k can serve at most (DynamicMerge, §3): one per
  // operation triggered by k's frames (the same frame); of an operation sampling k's newest
  // frame, every release within γ of the first member or while the frame stays the newest,
  // at most max_inflight of them.
  std::vector<double> share(s.sensors.size(), 0.0);
  // How many runs of a unit can be batched usefully. For a batch of unit u to help a job
  // be on time, its latest member's work before u must be done when the batch starts, and
  // its earliest member must finish u and everything after it by its deadline D; so every
  // member was released within D − P(u) of the earliest, P(u) the longest path through u on
  // mean costs (the encoder first for an inference node). That is at most
  // floor((D − P(u)) / T) + 1 jobs of an operation released every T, and never more than
  // its max_inflight. Encoder runs: one per frame of a sensor for the operations it
  // triggers, one per job for the others.
  const CostModel resolve{&p, &s.model, s.scheduler.estimate};
  const double enc_one = to_ms(mean.encoder());
  auto batchable = [&](const OperationSpec& op, double path, int i) {
    const double d = to_ms(resolve_deadline(op, resolve));
    if (path > d) return 1;
    const double in_window = std::floor((d - path) / fastest_period(i)) + 1;
    return static_cast<int>(std::min<double>(op.max_inflight, in_window));
  };
  int enc_queued = 0;
  std::map<int, int> head_queued;
  std::map<int, int> frames_queued;  // sensor -> frames whose triggered jobs may batch
  for (int i = 0; i < s.operation_count(); ++i) {
    std::map<int, int> count;  // sensor -> jobs of this operation one run may serve
    std::map<int, int> heads;  // head -> its runs of this operation that may batch
    std::map<int, int> own;    // sensor read, not triggering it -> encoder runs that may batch
    for (const OperationSpec* op : all[static_cast<std::size_t>(i)]) {
      // Longest paths on mean costs into (up) and out of (down) each node, itself included.
      const std::size_t n = op->nodes.size();
      std::vector<double> cost(n), up(n), down(n);
      for (std::size_t v = 0; v < n; ++v) {
        const NodeSpec& node = op->nodes[v];
        cost[v] = node.is_plain() ? to_ms(node.cost->mean) : to_ms(mean.head(node.head));
        up[v] = cost[v] + (node.is_plain() ? 0.0 : enc_one);
        down[v] = cost[v];
      }
      for (std::size_t round = 0; round < n; ++round)
        for (const EdgeSpec& e : op->edges) {
          const auto from = static_cast<std::size_t>(e.from), to = static_cast<std::size_t>(e.to);
          up[to] = std::max(up[to], up[from] + cost[to]);
          down[from] = std::max(down[from], cost[from] + down[to]);
        }
      std::map<int, int> h;
      std::map<int, double> after_encoder;  // sensor -> longest path from a node reading it
      for (std::size_t v = 0; v < n; ++v) {
        const NodeSpec& node = op->nodes[v];
        if (node.is_plain()) continue;
        h[node.head] += batchable(*op, up[v] + down[v] - cost[v], i);
        after_encoder[node.sensor] = std::max(after_encoder[node.sensor], down[v]);
      }
      for (auto [head, c] : h) heads[head] = std::max(heads[head], c);
      for (int k : sensors_read(*op)) {
        const int w = batchable(*op, enc_one + after_encoder[k], i);
        int c = 1;
        if (op->trigger_sensor == k) {
          frames_queued[k] = std::max(frames_queued[k], w);
        } else {
          own[k] = std::max(own[k], w);
          const double span =
              std::max(to_ms(s.scheduler.gamma), frame_life[static_cast<std::size_t>(k)]);
          const double per = std::floor(span / fastest_period(i)) + 1;
          c = static_cast<int>(std::min<double>(op->max_inflight, per));
        }
        count[k] = std::max(count[k], c);
      }
    }
    for (auto [k, c] : count) share[static_cast<std::size_t>(k)] += c;
    for (auto [k, w] : own) enc_queued += w;
    for (auto [head, c] : heads) head_queued[head] += c;
  }
  for (auto [k, f] : frames_queued) enc_queued += f;
  const double enc = per_item_ms(p, "encoder", std::min(max_batch, enc_queued));
  std::map<int, double> head_cost;
  for (auto [head, q] : head_queued)
    head_cost[head] = per_item_ms(p, "head/" + s.model.heads[static_cast<std::size_t>(head)],
                                  std::min(max_batch, q));

  // Per definition: the least lane time a job needs (plain costs, heads at their cheapest
  // batch, an encoder run per sensor read at its cheapest batch and shared as widely as
  // merging allows), and whether its coarse critical path fits its deadline at all.
  struct OpCost {
    double work = 0;
    bool feasible = true;
  };
  std::map<const OperationSpec*, OpCost> oc;
  for (const auto& defs : all)
    for (const OperationSpec* op : defs) {
      OpCost c;
      for (const NodeSpec& n : op->nodes)
        c.work += n.is_plain() ? to_ms(n.cost->mean) : head_cost[n.head];
      for (int k : sensors_read(*op))
        c.work += enc / std::max(1.0, share[static_cast<std::size_t>(k)]);
      // A fine-graph critical path is at most the coarse one; exclude only what no policy
      // can meet even alone.
      const double cp = to_ms(coarse_critical_path(*op, mean));
      const double deadline =
          to_ms(resolve_deadline(*op, CostModel{&p, &s.model, s.scheduler.estimate}));
      c.feasible = cp <= deadline;
      oc[op] = c;
    }

  std::vector<double> costs;
  std::int64_t released = 0;
  for (const JobRow& j : r->jobs) {
    ++released;
    const OperationSpec* op = snapshot_at(s, j.operation, j.release);
    if (op == nullptr) continue;
    const OpCost& c = oc[op];
    if (c.feasible) costs.push_back(c.work);
  }
  if (released == 0) return 1.0;
  std::sort(costs.begin(), costs.end());
  const double capacity = s.device.lanes * to_ms(s.duration - s.warmup);
  double used = 0;
  std::int64_t fit = 0;
  for (double c : costs) {
    if (used + c > capacity) break;
    used += c;
    ++fit;
  }
  return static_cast<double>(fit) / static_cast<double>(released);
}

}  // namespace red
