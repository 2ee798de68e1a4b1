#include "red/analysis/bound.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

#include "red/analysis/workload.hpp"
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
  const int max_batch = std::max(1, s.scheduler.max_batch);
  const CostModel mean{&p, &s.model, EstimateKind::Mean};
  const CostModel resolve{&p, &s.model, s.scheduler.estimate};

  // The workload of each phase of the measured run (red/analysis/workload.hpp): every
  // definition an operation has, and each sensor's slowest and fastest rate.
  const auto phases = phase_workloads(s, TimePoint{s.duration});
  const auto ops = static_cast<std::size_t>(s.operation_count());
  std::vector<std::vector<const OperationSpec*>> all(ops);
  std::vector<double> slowest_hz(s.sensors.size(), std::numeric_limits<double>::infinity());
  std::vector<double> fastest_hz(s.sensors.size(), 0.0);
  for (const PhaseWorkload& ph : phases) {
    for (std::size_t i = 0; i < ops; ++i) {
      const OperationSpec* op = ph.ops[i].get();
      if (op != nullptr && std::find(all[i].begin(), all[i].end(), op) == all[i].end())
        all[i].push_back(op);
    }
    for (std::size_t k = 0; k < s.sensors.size(); ++k) {
      slowest_hz[k] = std::min(slowest_hz[k], ph.sensor_rate[k]);
      fastest_hz[k] = std::max(fastest_hz[k], ph.sensor_rate[k]);
    }
  }
  // The longest a frame stays the newest one (ms), jitter added.
  std::vector<double> frame_life(s.sensors.size());
  for (std::size_t k = 0; k < s.sensors.size(); ++k)
    frame_life[k] = 1000.0 / slowest_hz[k] + to_ms(s.sensors[k].jitter);
  // Shortest release period of each operation over its definitions (ms; +inf if none).
  std::vector<double> period(ops, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < ops; ++i)
    for (const OperationSpec* op : all[i]) {
      const double hz = op->trigger_sensor >= 0
                            ? fastest_hz[static_cast<std::size_t>(op->trigger_sensor)]
                            : op->rate_hz;
      if (hz > 0) period[i] = std::min(period[i], 1000.0 / hz);
    }

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
  const double enc_one = to_ms(mean.encoder());
  auto batchable = [&](const OperationSpec& op, double path, int i) {
    const double d = to_ms(resolve_deadline(op, resolve));
    if (path > d) return 1;
    const double in_window = std::floor((d - path) / period[static_cast<std::size_t>(i)]) + 1;
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
          const double per = std::floor(span / period[static_cast<std::size_t>(i)]) + 1;
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
        c.work += n.is_plain() ? to_ms(n.cost->mean) : head_cost.at(n.head);
      for (int k : sensors_read(*op))
        c.work += enc / std::max(1.0, share[static_cast<std::size_t>(k)]);
      // A fine-graph critical path is at most the coarse one; exclude only what no policy
      // can meet even alone.
      const double cp = to_ms(coarse_critical_path(*op, mean));
      c.feasible = cp <= to_ms(resolve_deadline(*op, resolve));
      oc[op] = c;
    }

  std::vector<double> costs;
  std::int64_t released = 0;
  for (const JobRow& j : r->jobs) {
    ++released;
    // The definition in force at its release: that of the last phase begun by then.
    auto ph = std::upper_bound(phases.begin(), phases.end(), j.release,
                               [](TimePoint t, const PhaseWorkload& w) { return t < w.span.from; });
    if (ph != phases.begin()) --ph;
    const OperationSpec* op = ph->ops[static_cast<std::size_t>(j.operation)].get();
    if (op == nullptr) continue;
    const OpCost& c = oc.at(op);
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
