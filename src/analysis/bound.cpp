#include "red/analysis/bound.hpp"

#include <algorithm>
#include <array>
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

// The ways of splitting shared encoder runs among jobs (work_bound) that every workload
// has: each gives an upper bound, and the bound is the least of them (more per frame where
// they apply).
constexpr std::size_t kSplits = 3;

// Element by element: `to` raised to `from` (the most over an operation's definitions), or
// `from` added to it (the operations together); `to` grows to `from`'s length.
void raise_to(std::vector<int>& to, const std::vector<int>& from) {
  to.resize(std::max(to.size(), from.size()), 0);
  for (std::size_t i = 0; i < from.size(); ++i) to[i] = std::max(to[i], from[i]);
}
void add_to(std::vector<int>& to, const std::vector<int>& from) {
  to.resize(std::max(to.size(), from.size()), 0);
  for (std::size_t i = 0; i < from.size(); ++i) to[i] += from[i];
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

  // How many jobs of an own-rate operation one encoder run may serve (docs/DESIGN.md,
  // "DynamicMerge"): its releases within γ of the first member or while the frame stays the newest,
  // at most max_inflight. A run on a frame serves one job of each operation the frame triggers.
  //
  // Batches (inter-DAG batching, docs/DESIGN.md, "Batching"). Each batch's lane time is split
  // evenly among the on-time jobs it serves; a job's share is then at least C(b) / J(b), J(b) the
  // most on-time jobs a batch of b can serve, and the least of it over b is what the bound charges.
  // For a batch of unit u to help a job be on time, its latest member's work before u must be done
  // when the batch starts, and its earliest member must finish u (the whole batch, C(b)) and
  // everything after it by its deadline D; so every member was released within D − P_b(u) of the
  // earliest, P_b(u) the longest path through u on mean costs with u at C(b). That is at most
  // floor((D − P_b(u)) / T) + 1 jobs of an operation released every T, none if P_b(u) > D, and
  // never more than its max_inflight.
  const double enc_one = to_ms(mean.encoder());
  auto window = [&](const OperationSpec& op, double path, int i) {
    return WorkModel::on_time_runs(to_ms(resolve_deadline(op, resolve)) - path,
                                   period[static_cast<std::size_t>(i)], op.max_inflight);
  };
  const UnitProfile* enc_prof = p.find("encoder");
  const int enc_top = enc_prof == nullptr ? 0 : std::min(max_batch, enc_prof->max_batch());
  auto mean_ms = [](const UnitProfile* u, int b) { return to_ms(u->at(b).mean); };
  const double lanes = s.device.lanes;
  // A head's profile, null where it has none to batch by; and the largest batch of it.
  auto head_profile = [&](int head) -> const UnitProfile* {
    const UnitProfile* hp = p.find("head/" + s.model.heads[static_cast<std::size_t>(head)]);
    return hp != nullptr && !hp->by_batch.empty() ? hp : nullptr;
  };
  auto top_batch = [max_batch](const UnitProfile* hp) {
    return std::min(max_batch, hp->max_batch());
  };
  // The least lane time of a set of an operation's nodes (encoders aside): plain costs, and
  // the runs of each head in the cheapest batches (a batch holding other jobs' runs as
  // well takes no less).
  auto lane_time = [&](const OperationSpec& op, const std::vector<char>& in) {
    double w = 0;
    std::map<int, int> runs;  // head -> runs
    for (std::size_t x = 0; x < op.nodes.size(); ++x) {
      if (!in[x]) continue;
      const NodeSpec& node = op.nodes[x];
      if (node.is_plain())
        w += to_ms(node.cost->mean);
      else
        ++runs[node.head];
    }
    for (auto [head, m] : runs) {
      const UnitProfile* hp = head_profile(head);
      if (hp == nullptr) {
        w += m * to_ms(mean.head(head));
        continue;
      }
      const int top = top_batch(hp);
      std::vector<double> least(static_cast<std::size_t>(m) + 1, 0.0);  // runs -> lane time
      for (int q = 1; q <= m; ++q) {
        double& best = least[static_cast<std::size_t>(q)];
        best = std::numeric_limits<double>::infinity();
        for (int b = 1; b <= std::min(q, top); ++b)
          best = std::min(best, least[static_cast<std::size_t>(q - b)] + mean_ms(hp, b));
      }
      w += least[static_cast<std::size_t>(m)];
    }
    return w;
  };
  // serve[b][k][n]: the most on-time jobs n frames of sensor k in an encoder batch of b serve.
  std::vector<std::vector<std::vector<int>>> serve(
      static_cast<std::size_t>(enc_top) + 1,
      std::vector<std::vector<int>>(s.sensors.size(),
                                    std::vector<int>(static_cast<std::size_t>(enc_top) + 1, 0)));
  // The jobs one run on sensor k serves on time at most (any batch), and the most runs that
  // may batch usefully (one per frame of a sensor for the operations it triggers, as many
  // as their window holds; the windows of the others).
  std::vector<int> share(s.sensors.size(), 0);
  // By batch size b, with the batch's cost in the path: frames_queued[b][k] for the
  // operations sensor k triggers, the most of their windows; useful[b] all of them.
  std::vector<std::map<int, int>> frames_queued(static_cast<std::size_t>(enc_top) + 1);
  std::vector<int> useful(static_cast<std::size_t>(enc_top) + 1, 0);
  // frames_of[def][b]: for a definition triggered by the sensor it reads, the most frames
  // of it within its window with an encoder batch of b in the path.
  std::map<const OperationSpec*, std::vector<int>> frames_of;
  // on_time[h][b]: the most on-time runs of head h a batch of b holds.
  std::map<int, std::vector<int>> head_on_time;
  for (int i = 0; i < s.operation_count(); ++i) {
    std::map<std::pair<int, int>, std::vector<int>> op_serve;  // (b, sensor) -> by n, max over defs
    std::map<int, std::vector<int>> op_heads;                  // head -> by b, max over defs
    std::map<int, int> op_share;                // sensor -> jobs of this operation one run serves
    std::map<std::pair<int, int>, int> op_own;  // (b, sensor read, not triggering it) -> runs
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
      // In topological order (Kahn's), linear in nodes and edges: a chain of thousands of
      // nodes took a pass over the edges per node, and its ancestor sets a cubic closure.
      std::vector<std::vector<std::size_t>> succ(n), pred(n);
      std::vector<int> in_degree(n, 0);
      for (const EdgeSpec& e : op->edges) {
        const auto from = static_cast<std::size_t>(e.from), to = static_cast<std::size_t>(e.to);
        succ[from].push_back(to);
        pred[to].push_back(from);
        ++in_degree[to];
      }
      std::vector<std::size_t> order;
      order.reserve(n);
      for (std::size_t v = 0; v < n; ++v)
        if (in_degree[v] == 0) order.push_back(v);
      for (std::size_t k = 0; k < order.size(); ++k)
        for (std::size_t w : succ[order[k]])
          if (--in_degree[w] == 0) order.push_back(w);
      for (std::size_t v : order)
        for (std::size_t w : succ[v]) up[w] = std::max(up[w], up[v] + cost[w]);
      for (auto it = order.rbegin(); it != order.rend(); ++it)
        for (std::size_t w : succ[*it]) down[*it] = std::max(down[*it], cost[*it] + down[w]);
      // The work before and after a node takes at least its lane time over the lanes, as
      // well as its longest path: the nodes reachable from v along `adjacent` (v excluded).
      auto reach = [n](std::size_t v, const std::vector<std::vector<std::size_t>>& adjacent) {
        std::vector<char> seen(n, 0);
        std::vector<std::size_t> stack{v};
        while (!stack.empty()) {
          const std::size_t u = stack.back();
          stack.pop_back();
          for (std::size_t w : adjacent[u])
            if (!seen[w]) seen[w] = 1, stack.push_back(w);
        }
        return seen;
      };
      auto before = [&](std::size_t v) {
        const std::vector<char> anc = reach(v, pred);
        std::set<int> encoders;
        if (!op->nodes[v].is_plain()) encoders.insert(op->nodes[v].sensor);
        for (std::size_t x = 0; x < n; ++x)
          if (anc[x] && !op->nodes[x].is_plain()) encoders.insert(op->nodes[x].sensor);
        const double w = lane_time(*op, anc) + enc_one * static_cast<double>(encoders.size());
        return std::max(up[v] - cost[v], w / lanes);
      };
      std::map<int, std::vector<int>> h;     // head -> by b
      std::map<int, double> after_encoder;   // sensor -> the time a job needs after its run
      std::map<int, std::vector<char>> fed;  // sensor -> the nodes that run after its encoder
      for (std::size_t v = 0; v < n; ++v) {
        const NodeSpec& node = op->nodes[v];
        if (node.is_plain()) continue;
        after_encoder[node.sensor] = std::max(after_encoder[node.sensor], down[v]);
        const std::vector<char> desc = reach(v, succ);
        auto& f = fed.try_emplace(node.sensor, n, 0).first->second;
        f[v] = 1;
        for (std::size_t x = 0; x < n; ++x) f[x] = f[x] || desc[x];
        const UnitProfile* hp = head_profile(node.head);
        if (hp == nullptr) continue;
        const int top = top_batch(hp);
        auto& by_b = h[node.head];
        by_b.resize(static_cast<std::size_t>(top) + 1, 0);
        const double around = before(v) + std::max(down[v] - cost[v], lane_time(*op, desc) / lanes);
        for (int b = 1; b <= top; ++b)
          by_b[static_cast<std::size_t>(b)] += window(*op, around + mean_ms(hp, b), i);
      }
      for (auto& [k, f] : fed)
        after_encoder[k] = std::max(after_encoder[k], lane_time(*op, f) / lanes);
      for (const auto& [head, by_b] : h) raise_to(op_heads[head], by_b);
      for (int k : sensors_read(*op)) {
        const auto ku = static_cast<std::size_t>(k);
        // Jobs of this operation one run serves: one (a frame's), or own-rate merges.
        int per_run = 1;
        if (op->trigger_sensor != k) {
          const double span = std::max(to_ms(s.scheduler.gamma), frame_life[ku]);
          const double per = std::floor(span / period[static_cast<std::size_t>(i)]) + 1;
          per_run = static_cast<int>(std::min<double>(op->max_inflight, per));
        }
        op_share[k] = std::max(op_share[k], per_run);
        for (int b = 1; b <= enc_top; ++b) {
          const int w = window(*op, mean_ms(enc_prof, b) + after_encoder[k], i);
          if (op->trigger_sensor == k) {
            int& f = frames_queued[static_cast<std::size_t>(b)][k];
            f = std::max(f, w);
            auto& mine = frames_of[op];
            mine.resize(static_cast<std::size_t>(enc_top) + 1, 0);
            mine[static_cast<std::size_t>(b)] = w;
          } else {
            op_own[{b, k}] = std::max(op_own[{b, k}], w);
          }
          std::vector<int> by_n(static_cast<std::size_t>(b) + 1);
          for (int m = 0; m <= b; ++m) by_n[static_cast<std::size_t>(m)] = std::min(m * per_run, w);
          raise_to(op_serve[{b, k}], by_n);
        }
      }
    }
    for (const auto& [bk, by_n] : op_serve)
      add_to(serve[static_cast<std::size_t>(bk.first)][static_cast<std::size_t>(bk.second)], by_n);
    for (auto [k, c] : op_share) share[static_cast<std::size_t>(k)] += c;
    for (auto [bk, w] : op_own) useful[static_cast<std::size_t>(bk.first)] += w;
    for (const auto& [head, by_b] : op_heads) add_to(head_on_time[head], by_b);
  }
  // Ways to split a batch's time, each giving every on-time job at least the charge below;
  // each gives an upper bound, and the bound is the lowest (kSplits; the third, per frame,
  // is further down).
  //  - Among its on-time jobs: a job's share is at least C(b) / J(b), J(b) the most on-time
  //    jobs a batch of b serves (the best split of b frames among the sensors, a knapsack).
  //    The same charge per sensor read, whatever the sensor.
  //  - Among its runs, C(b) / b each, and a run's among the at most share_k jobs it serves:
  //    per read of sensor k, the least C(b) / b over the useful batch sizes (b frames or
  //    more within the windows with the batch's cost C(b) in the path), / share_k.
  //    Lower where frames of a sensor feeding few operations batch with those of another.
  for (std::size_t b = 1; b < frames_queued.size(); ++b)
    for (auto [k, f] : frames_queued[b]) useful[b] += f;
  double by_jobs = enc_one;
  for (int b = 1; b <= enc_top; ++b) {
    std::vector<int> most(static_cast<std::size_t>(b) + 1, 0);  // items used -> jobs served
    for (std::size_t k = 0; k < s.sensors.size(); ++k) {
      std::vector<int> next = most;
      for (int used = 0; used <= b; ++used)
        for (int m = 1; used + m <= b; ++m)
          next[static_cast<std::size_t>(used + m)] =
              std::max(next[static_cast<std::size_t>(used + m)],
                       most[static_cast<std::size_t>(used)] +
                           serve[static_cast<std::size_t>(b)][k][static_cast<std::size_t>(m)]);
      most = std::move(next);
    }
    const int jobs = *std::max_element(most.begin(), most.end());
    if (jobs > 0) by_jobs = std::min(by_jobs, mean_ms(enc_prof, b) / jobs);
  }
  // A batch of b frames of which fewer than b serve on-time jobs costs each of those more
  // than the batch of those alone would: only batches whose every frame may be useful count.
  double per_run = enc_one;
  for (int b = 2; b <= enc_top; ++b)
    if (useful[static_cast<std::size_t>(b)] >= b)
      per_run = std::min(per_run, mean_ms(enc_prof, b) / b);
  std::array<std::vector<double>, 2> enc_charge{std::vector<double>(s.sensors.size(), by_jobs),
                                                std::vector<double>(s.sensors.size())};
  for (std::size_t k = 0; k < s.sensors.size(); ++k)
    enc_charge[1][k] = per_run / std::max(1, share[k]);

  // A head's charge per run: least over b of C(b) / (on-time runs in a batch of b).
  std::map<int, double> head_cost;
  for (int head = 0; head < static_cast<int>(s.model.heads.size()); ++head) {
    const UnitProfile* hp = head_profile(head);
    if (hp == nullptr) {
      head_cost[head] = 0.0;
      continue;
    }
    double best = mean_ms(hp, 1);
    const auto it = head_on_time.find(head);
    if (it != head_on_time.end())
      for (std::size_t b = 1; b < it->second.size(); ++b) {
        const int on_time = std::min(static_cast<int>(b), it->second[b]);
        if (on_time > 0) best = std::min(best, mean_ms(hp, static_cast<int>(b)) / on_time);
      }
    head_cost[head] = best;
  }

  // Per definition, under each way of splitting: the least lane time a job needs (plain
  // costs, heads and encoder runs as charged above), and whether its least critical path
  // fits its deadline at all.
  struct OpCost {
    std::vector<double> work = std::vector<double>(kSplits);
    double own = 0;      // heads and plain nodes
    std::set<int> read;  // sensors
    bool feasible = true;
  };
  std::map<const OperationSpec*, OpCost> oc;
  for (const auto& defs : all)
    for (const OperationSpec* op : defs) {
      OpCost c;
      for (const NodeSpec& n : op->nodes)
        c.own += n.is_plain() ? to_ms(n.cost->mean) : head_cost.at(n.head);
      c.read = sensors_read(*op);
      for (std::size_t w = 0; w < 2; ++w) {
        c.work[w] = c.own;
        for (int k : c.read) c.work[w] += enc_charge[w][static_cast<std::size_t>(k)];
      }
      c.work[2] = c.work[0];  // the third way, where it does not apply (below): the first
      // Exclude only what no policy can meet even alone: the fine graph's critical path (at most
      // the coarse one), every unit at its least mean over batch sizes. (The coarse path
      // excluded jobs that red meets: on the delivery robot the bound was 0.500 where
      // red-robust met 0.694.)
      const double cp = to_ms(least_critical_path(*op, mean));
      c.feasible = cp <= to_ms(resolve_deadline(*op, resolve));
      oc[op] = c;
    }
  // The third way, per frame (docs/DESIGN.md, "Overload"): where every operation reading sensor k
  // is triggered by it and reads no other sensor, a frame's encoder run, E (per_run: the least
  // share of a batch a frame with on-time jobs pays), serves at most one job of each. The first two
  // ways split E among every job a run could serve, as if every operation's job of each
  // frame were on time; but serving m jobs of a frame costs at least E + the m cheapest
  // jobs' own costs A_m. With the definitions reading k sorted by own cost a, the g
  // cheapest (g the most jobs per lane time, g / (E + A_g)) are each charged (E + A_g) / g
  // and every other its own cost a. That is valid for any set S of a run's on-time jobs:
  // m = |S ∩ G| jobs of the group are charged m (E + A_g) / g ≤ E + A_m ≤ E + A(S ∩ G)
  // (the points (E + A_m, m) lie under the line through (E + A_g, g), the steepest from the
  // origin). Elsewhere the first way's charge stands.
  std::vector<char> by_frame(s.sensors.size(), 1);
  for (const auto& [op, c] : oc)
    for (int k : c.read)
      if (c.read.size() > 1 || op->trigger_sensor != k) by_frame[static_cast<std::size_t>(k)] = 0;
  // Charges way `split` per frame with a run of E: each definition reading a per-frame
  // sensor gets its group's charge or its own cost (the others keep the first way's).
  auto per_frame = [&](double e, std::size_t split) {
    for (auto& [op, c] : oc) c.work[split] = c.work[0];
    for (std::size_t k = 0; k < s.sensors.size(); ++k) {
      if (!by_frame[k]) continue;
      // In the order of `all` (not of `oc`'s pointers), so that ties sort the same every run.
      std::vector<std::pair<double, OpCost*>> items;
      for (const auto& defs : all)
        for (const OperationSpec* op : defs) {
          OpCost& c = oc.at(op);
          if (c.feasible && c.read.count(static_cast<int>(k)) != 0) items.emplace_back(c.own, &c);
        }
      if (items.empty()) continue;
      std::sort(items.begin(), items.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
      std::size_t g = 1;
      double sum = 0, group_sum = items.front().first;
      for (std::size_t m = 1; m <= items.size(); ++m) {
        sum += items[m - 1].first;
        // m / (E + A_m) > g / (E + A_g), without the division.
        if (static_cast<double>(m) * (e + group_sum) > static_cast<double>(g) * (e + sum)) {
          g = m;
          group_sum = sum;
        }
      }
      // Each reads sensor k alone: the group's charge, or its own cost.
      const double charge = (e + group_sum) / static_cast<double>(g);
      for (std::size_t m = 0; m < items.size(); ++m)
        items[m].second->work[split] = m < g ? charge : items[m].first;
    }
  };
  per_frame(per_run, 2);
  // More ways per frame, where every sensor read is read per frame: a larger run E, up to a
  // whole run C(1), where a batch's frames cannot all carry on-time jobs of every operation.
  // A frame j frames before the newest of a batch of b serves on time only the operations
  // whose window holds j + 1 of its frames (frames_of), so the batch's jobs are charged
  // above their own costs at most the sum, over its frames, of the excess (charge − own) of
  // the operations each may serve; the way is valid where that is at most C(b) for every b
  // (the frames of several sensors as they carry the most, a knapsack as for by_jobs).
  std::size_t splits = kSplits;
  bool every_by_frame = enc_prof != nullptr;
  for (const auto& [op, c] : oc)
    for (int k : c.read) every_by_frame = every_by_frame && by_frame[static_cast<std::size_t>(k)];
  for (int e = 1; every_by_frame && e <= enc_top; ++e) {
    const double run = mean_ms(enc_prof, e) / e;
    if (run <= per_run) continue;  // no larger than the third way's
    for (auto& [op, c] : oc) c.work.push_back(0);
    per_frame(run, splits);
    bool valid = true;
    for (int b = 1; valid && b <= enc_top; ++b) {
      std::vector<double> most(static_cast<std::size_t>(b) + 1, 0.0);  // frames -> excess
      for (std::size_t k = 0; k < s.sensors.size(); ++k) {
        // excess[j]: the most a frame of sensor k, j frames before the newest, carries.
        std::vector<double> excess(static_cast<std::size_t>(b), 0.0);
        for (std::size_t j = 0; j < excess.size(); ++j)
          for (const auto& defs : all) {
            double top = 0;  // one job of an operation per frame, of one of its definitions
            for (const OperationSpec* op : defs) {
              const OpCost& c = oc.at(op);
              const auto f = frames_of.find(op);
              if (!c.feasible || op->trigger_sensor != static_cast<int>(k) ||
                  f == frames_of.end() ||
                  f->second[static_cast<std::size_t>(b)] < static_cast<int>(j) + 1)
                continue;
              top = std::max(top, c.work[splits] - c.own);
            }
            excess[j] += top;
          }
        std::vector<double> next = most;
        for (std::size_t used = 0; used < most.size(); ++used) {
          double carried = 0;
          for (std::size_t m = 1; used + m < most.size(); ++m) {
            carried += excess[m - 1];
            next[used + m] = std::max(next[used + m], most[used] + carried);
          }
        }
        most = std::move(next);
      }
      valid = *std::max_element(most.begin(), most.end()) <= mean_ms(enc_prof, b) + 1e-9;
    }
    if (valid) {
      ++splits;
    } else {
      for (auto& [op, c] : oc) c.work.pop_back();
    }
  }

  // The jobs that count, by deadline, with their least lane time under each way of splitting.
  struct Due {
    TimePoint deadline;
    std::vector<double> work;
  };
  std::vector<Due> due;
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
    if (c.feasible) due.push_back({j.deadline, c.work});
  }
  if (released == 0) return 1.0;
  std::sort(due.begin(), due.end(),
            [](const Due& a, const Due& b) { return a.deadline < b.deadline; });
  // Releases stop at the run's end, so the jobs on time that finish after it were in flight
  // then: at most max_inflight of each operation.
  std::int64_t in_flight_at_end = 0;
  for (const auto& defs : all) {
    int most = 0;
    for (const OperationSpec* op : defs) most = std::max(most, op->max_inflight);
    in_flight_at_end += most;
  }
  const TimePoint from = s.warmup;
  std::int64_t fit = std::numeric_limits<std::int64_t>::max();
  for (std::size_t w = 0; w < splits; ++w) {
    // The least-cost jobs first: how many of those counted in `count` fit `capacity` ms.
    std::map<double, std::int64_t> count;
    auto most_that_fit = [&count](double capacity) {
      double used = 0;
      std::int64_t n = 0;
      for (const auto& [c, k] : count) {
        // As many as fit (room / c, rounded either way, then checked), at most all k.
        std::int64_t take =
            c > 0 ? std::min<std::int64_t>(k, static_cast<std::int64_t>((capacity - used) / c) + 1)
                  : k;
        while (take > 0 && used + static_cast<double>(take) * c > capacity) --take;
        used += static_cast<double>(take) * c;
        n += take;
        if (take < k) break;
      }
      return n;
    };
    // Every job counted in lane time is released after `from`: those due by t did all their
    // work in [from, t], and the jobs due later are counted as on time (a demand bound at
    // every deadline).
    const auto total = static_cast<std::int64_t>(due.size());
    for (std::size_t i = 0; i < due.size();) {
      const TimePoint t = due[i].deadline;
      for (; i < due.size() && due[i].deadline == t; ++i) ++count[due[i].work[w]];
      const std::int64_t n = most_that_fit(lanes * to_ms(std::max(t - from, Duration{0})));
      fit = std::min(fit, n + (total - static_cast<std::int64_t>(i)));
    }
    // And at the run's end: those that finish by then fit its lane time, at most the jobs in
    // flight then finish later.
    const std::int64_t by_end = most_that_fit(lanes * to_ms(s.duration - from));
    const std::int64_t due_later =
        total - (std::upper_bound(due.begin(), due.end(), s.duration,
                                  [](TimePoint t, const Due& d) { return t < d.deadline; }) -
                 due.begin());
    fit = std::min(fit, by_end + std::min(in_flight_at_end, due_later));
  }
  // The last deadline's count is at most every job that counts: fit <= due.size() <= released
  // (0 when none counts).
  return static_cast<double>(fit) / static_cast<double>(released);
}

}  // namespace red
