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
#include "red/metrics/policy_run.hpp"

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

// A unit's mean cost in a batch of b (ms).
double mean_ms(const UnitProfile* u, int b) {
  return to_ms(u->at(b).mean);
}

// What every step of the bound reads: the scenario and its costs, and the workload of each
// phase of the measured run (red/analysis/workload.hpp): every definition an operation has,
// how long a frame stays the newest and how often each operation is released.
struct BoundInput {
  const Scenario& s;
  const Profile& p;
  int max_batch;
  CostModel mean;
  CostModel resolve;
  std::vector<PhaseWorkload> phases;
  std::vector<std::vector<const OperationSpec*>> all;  // by operation: its definitions
  std::vector<double> frame_life;  // by sensor: the longest a frame stays the newest (ms)
  std::vector<double> period;      // by operation: the shortest release period (ms; +inf if none)
  double enc_one = 0;              // an encoder run alone (ms)
  const UnitProfile* enc_prof = nullptr;
  int enc_top = 0;  // the largest encoder batch
  double lanes = 0;

  // The most on-time jobs of definition `op` of operation i whose releases a batch may gather
  // with `path` ms of the job's work in its path (the windows, below).
  int window(const OperationSpec& op, double path, int i) const {
    return WorkModel::on_time_runs(to_ms(resolve_deadline(op, resolve)) - path,
                                   period[static_cast<std::size_t>(i)], op.max_inflight);
  }
  // A head's profile, null where it has none to batch by; and the largest batch of it.
  const UnitProfile* head_profile(int head) const {
    const UnitProfile* hp = p.find("head/" + s.model.heads[static_cast<std::size_t>(head)]);
    return hp != nullptr && !hp->by_batch.empty() ? hp : nullptr;
  }
  int top_batch(const UnitProfile* hp) const { return std::min(max_batch, hp->max_batch()); }
  double lane_time(const OperationSpec& op, const std::vector<char>& in) const;
};

BoundInput bound_input(const Scenario& s, const Profile& p) {
  BoundInput in{s,
                p,
                std::max(1, s.scheduler.max_batch),
                CostModel{&p, &s.model, EstimateKind::Mean},
                CostModel{&p, &s.model, s.scheduler.estimate},
                phase_workloads(s, TimePoint{s.duration}),
                {},
                {},
                {}};
  // Every definition an operation has, and each sensor's slowest and fastest rate.
  const auto ops = static_cast<std::size_t>(s.operation_count());
  in.all.resize(ops);
  std::vector<double> slowest_hz(s.sensors.size(), std::numeric_limits<double>::infinity());
  std::vector<double> fastest_hz(s.sensors.size(), 0.0);
  for (const PhaseWorkload& ph : in.phases) {
    for (std::size_t i = 0; i < ops; ++i) {
      const OperationSpec* op = ph.ops[i].get();
      if (op != nullptr && std::find(in.all[i].begin(), in.all[i].end(), op) == in.all[i].end())
        in.all[i].push_back(op);
    }
    for (std::size_t k = 0; k < s.sensors.size(); ++k) {
      slowest_hz[k] = std::min(slowest_hz[k], ph.sensor_rate[k]);
      fastest_hz[k] = std::max(fastest_hz[k], ph.sensor_rate[k]);
    }
  }
  // The longest a frame stays the newest one (ms), jitter added.
  in.frame_life.resize(s.sensors.size());
  for (std::size_t k = 0; k < s.sensors.size(); ++k)
    in.frame_life[k] = 1000.0 / slowest_hz[k] + to_ms(s.sensors[k].jitter);
  // Shortest release period of each operation over its definitions (ms; +inf if none).
  in.period.assign(ops, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < ops; ++i)
    for (const OperationSpec* op : in.all[i]) {
      const double hz = op->trigger_sensor >= 0
                            ? fastest_hz[static_cast<std::size_t>(op->trigger_sensor)]
                            : op->rate_hz;
      if (hz > 0) in.period[i] = std::min(in.period[i], 1000.0 / hz);
    }
  in.enc_one = to_ms(in.mean.encoder());
  in.enc_prof = p.find("encoder");
  in.enc_top = in.enc_prof == nullptr ? 0 : std::min(in.max_batch, in.enc_prof->max_batch());
  in.lanes = s.device.lanes;
  return in;
}

// The least lane time of a set of an operation's nodes (encoders aside): plain costs, and
// the runs of each head in the cheapest batches (a batch holding other jobs' runs as
// well takes no less).
double BoundInput::lane_time(const OperationSpec& op, const std::vector<char>& in) const {
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
}

// One definition's graph: each node's mean cost, and the longest paths on mean costs into (up)
// and out of (down) each node, itself included.
struct Paths {
  std::vector<double> cost, up, down;
  std::vector<std::vector<std::size_t>> succ, pred;
};

Paths longest_paths(const BoundInput& in, const OperationSpec& op) {
  const std::size_t n = op.nodes.size();
  Paths g{std::vector<double>(n), std::vector<double>(n), std::vector<double>(n),
          std::vector<std::vector<std::size_t>>(n), std::vector<std::vector<std::size_t>>(n)};
  for (std::size_t v = 0; v < n; ++v) {
    const NodeSpec& node = op.nodes[v];
    g.cost[v] = node.is_plain() ? to_ms(node.cost->mean) : to_ms(in.mean.head(node.head));
    g.up[v] = g.cost[v] + (node.is_plain() ? 0.0 : in.enc_one);
    g.down[v] = g.cost[v];
  }
  // In topological order (Kahn's), linear in nodes and edges: a chain of thousands of
  // nodes took a pass over the edges per node, and its ancestor sets a cubic closure.
  std::vector<int> in_degree(n, 0);
  for (const EdgeSpec& e : op.edges) {
    const auto from = static_cast<std::size_t>(e.from), to = static_cast<std::size_t>(e.to);
    g.succ[from].push_back(to);
    g.pred[to].push_back(from);
    ++in_degree[to];
  }
  std::vector<std::size_t> order;
  order.reserve(n);
  for (std::size_t v = 0; v < n; ++v)
    if (in_degree[v] == 0) order.push_back(v);
  for (std::size_t k = 0; k < order.size(); ++k)
    for (std::size_t w : g.succ[order[k]])
      if (--in_degree[w] == 0) order.push_back(w);
  for (std::size_t v : order)
    for (std::size_t w : g.succ[v]) g.up[w] = std::max(g.up[w], g.up[v] + g.cost[w]);
  for (auto it = order.rbegin(); it != order.rend(); ++it)
    for (std::size_t w : g.succ[*it]) g.down[*it] = std::max(g.down[*it], g.cost[*it] + g.down[w]);
  return g;
}

// The nodes reachable from v along `adjacent` (v excluded).
std::vector<char> reach(std::size_t v, const std::vector<std::vector<std::size_t>>& adjacent) {
  std::vector<char> seen(adjacent.size(), 0);
  std::vector<std::size_t> stack{v};
  while (!stack.empty()) {
    const std::size_t u = stack.back();
    stack.pop_back();
    for (std::size_t w : adjacent[u])
      if (!seen[w]) seen[w] = 1, stack.push_back(w);
  }
  return seen;
}

// The work before node v takes at least its lane time over the lanes, as well as its longest
// path.
double time_before(const BoundInput& in, const OperationSpec& op, const Paths& g, std::size_t v) {
  const std::vector<char> anc = reach(v, g.pred);
  std::set<int> encoders;
  if (!op.nodes[v].is_plain()) encoders.insert(op.nodes[v].sensor);
  for (std::size_t x = 0; x < op.nodes.size(); ++x)
    if (anc[x] && !op.nodes[x].is_plain()) encoders.insert(op.nodes[x].sensor);
  const double w = in.lane_time(op, anc) + in.enc_one * static_cast<double>(encoders.size());
  return std::max(g.up[v] - g.cost[v], w / in.lanes);
}

// How many jobs batches of each size serve on time, over the whole workload (the windows).
struct Windows {
  // serve[b][k][n]: the most on-time jobs n frames of sensor k in an encoder batch of b serve.
  std::vector<std::vector<std::vector<int>>> serve;
  // The jobs one run on sensor k serves on time at most (any batch), and the most runs that
  // may batch usefully (one per frame of a sensor for the operations it triggers, as many
  // as their window holds; the windows of the others).
  std::vector<int> share;
  // By batch size b, with the batch's cost in the path: frames_queued[b][k] for the
  // operations sensor k triggers, the most of their windows; useful[b] all of them.
  std::vector<std::map<int, int>> frames_queued;
  std::vector<int> useful;
  // frames_of[def][b]: for a definition triggered by the sensor it reads, the most frames
  // of it within its window with an encoder batch of b in the path.
  std::map<const OperationSpec*, std::vector<int>> frames_of;
  // head_on_time[h][b]: the most on-time runs of head h a batch of b holds.
  std::map<int, std::vector<int>> head_on_time;
};

// The windows of one operation, the most over its definitions.
struct OperationWindows {
  std::map<std::pair<int, int>, std::vector<int>> serve;  // (b, sensor) -> by n, max over defs
  std::map<int, std::vector<int>> heads;                  // head -> by b, max over defs
  std::map<int, int> share;                // sensor -> jobs of this operation one run serves
  std::map<std::pair<int, int>, int> own;  // (b, sensor read, not triggering it) -> runs
};

// Per head of definition `op` of operation i, by batch size b, its on-time runs in a batch
// of b (into `heads`); and per sensor read, the time a job needs after the sensor's encoder
// run (returned).
std::map<int, double> head_windows(const BoundInput& in, const OperationSpec& op, int i,
                                   const Paths& g, std::map<int, std::vector<int>>& heads) {
  const std::size_t n = op.nodes.size();
  std::map<int, std::vector<int>> h;     // head -> by b
  std::map<int, double> after_encoder;   // sensor -> the time a job needs after its run
  std::map<int, std::vector<char>> fed;  // sensor -> the nodes that run after its encoder
  for (std::size_t v = 0; v < n; ++v) {
    const NodeSpec& node = op.nodes[v];
    if (node.is_plain()) continue;
    after_encoder[node.sensor] = std::max(after_encoder[node.sensor], g.down[v]);
    const std::vector<char> desc = reach(v, g.succ);
    auto& f = fed.try_emplace(node.sensor, n, 0).first->second;
    f[v] = 1;
    for (std::size_t x = 0; x < n; ++x) f[x] = f[x] || desc[x];
    const UnitProfile* hp = in.head_profile(node.head);
    if (hp == nullptr) continue;
    const int top = in.top_batch(hp);
    auto& by_b = h[node.head];
    by_b.resize(static_cast<std::size_t>(top) + 1, 0);
    // The work after the node, as before it: its lane time over the lanes or its longest path.
    const double around = time_before(in, op, g, v) +
                          std::max(g.down[v] - g.cost[v], in.lane_time(op, desc) / in.lanes);
    for (int b = 1; b <= top; ++b)
      by_b[static_cast<std::size_t>(b)] += in.window(op, around + mean_ms(hp, b), i);
  }
  for (auto& [k, f] : fed)
    after_encoder[k] = std::max(after_encoder[k], in.lane_time(op, f) / in.lanes);
  for (const auto& [head, by_b] : h) raise_to(heads[head], by_b);
  return after_encoder;
}

// Per sensor that definition `op` of operation i reads, by encoder batch size: its window with
// the batch in the path, and the on-time jobs n frames serve.
void encoder_windows(const BoundInput& in, const OperationSpec& op, int i,
                     std::map<int, double>& after_encoder, OperationWindows& mine, Windows& all) {
  for (int k : sensors_read(op)) {
    const auto ku = static_cast<std::size_t>(k);
    // Jobs of this operation one run serves: one (a frame's), or own-rate merges.
    int per_run = 1;
    if (op.trigger_sensor != k) {
      const double span = std::max(to_ms(in.s.scheduler.gamma), in.frame_life[ku]);
      const double per = std::floor(span / in.period[static_cast<std::size_t>(i)]) + 1;
      per_run = static_cast<int>(std::min<double>(op.max_inflight, per));
    }
    mine.share[k] = std::max(mine.share[k], per_run);
    for (int b = 1; b <= in.enc_top; ++b) {
      const int w = in.window(op, mean_ms(in.enc_prof, b) + after_encoder[k], i);
      if (op.trigger_sensor == k) {
        int& f = all.frames_queued[static_cast<std::size_t>(b)][k];
        f = std::max(f, w);
        auto& frames = all.frames_of[&op];
        frames.resize(static_cast<std::size_t>(in.enc_top) + 1, 0);
        frames[static_cast<std::size_t>(b)] = w;
      } else {
        mine.own[{b, k}] = std::max(mine.own[{b, k}], w);
      }
      std::vector<int> by_n(static_cast<std::size_t>(b) + 1);
      for (int m = 0; m <= b; ++m) by_n[static_cast<std::size_t>(m)] = std::min(m * per_run, w);
      raise_to(mine.serve[{b, k}], by_n);
    }
  }
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
Windows batch_windows(const BoundInput& in) {
  const Scenario& s = in.s;
  const auto enc_sizes = static_cast<std::size_t>(in.enc_top) + 1;
  Windows all{std::vector<std::vector<std::vector<int>>>(
                  enc_sizes,
                  std::vector<std::vector<int>>(s.sensors.size(), std::vector<int>(enc_sizes, 0))),
              std::vector<int>(s.sensors.size(), 0),
              std::vector<std::map<int, int>>(enc_sizes),
              std::vector<int>(enc_sizes, 0),
              {},
              {}};
  for (int i = 0; i < s.operation_count(); ++i) {
    OperationWindows mine;
    for (const OperationSpec* op : in.all[static_cast<std::size_t>(i)]) {
      const Paths g = longest_paths(in, *op);
      std::map<int, double> after_encoder = head_windows(in, *op, i, g, mine.heads);
      encoder_windows(in, *op, i, after_encoder, mine, all);
    }
    for (const auto& [bk, by_n] : mine.serve)
      add_to(all.serve[static_cast<std::size_t>(bk.first)][static_cast<std::size_t>(bk.second)],
             by_n);
    for (auto [k, c] : mine.share) all.share[static_cast<std::size_t>(k)] += c;
    for (auto [bk, w] : mine.own) all.useful[static_cast<std::size_t>(bk.first)] += w;
    for (const auto& [head, by_b] : mine.heads) add_to(all.head_on_time[head], by_b);
  }
  for (std::size_t b = 1; b < all.frames_queued.size(); ++b)
    for (auto [k, f] : all.frames_queued[b]) all.useful[b] += f;
  return all;
}

// The first way of splitting an encoder batch: among its on-time jobs, each at least C(b) / J(b),
// J(b) the most on-time jobs a batch of b serves (the best split of b frames among the sensors,
// a knapsack). The same charge per sensor read, whatever the sensor.
double charge_by_jobs(const BoundInput& in, const Windows& win) {
  double by_jobs = in.enc_one;
  for (int b = 1; b <= in.enc_top; ++b) {
    std::vector<int> most(static_cast<std::size_t>(b) + 1, 0);  // items used -> jobs served
    for (std::size_t k = 0; k < in.s.sensors.size(); ++k) {
      std::vector<int> next = most;
      for (int used = 0; used <= b; ++used)
        for (int m = 1; used + m <= b; ++m)
          next[static_cast<std::size_t>(used + m)] =
              std::max(next[static_cast<std::size_t>(used + m)],
                       most[static_cast<std::size_t>(used)] +
                           win.serve[static_cast<std::size_t>(b)][k][static_cast<std::size_t>(m)]);
      most = std::move(next);
    }
    const int jobs = *std::max_element(most.begin(), most.end());
    if (jobs > 0) by_jobs = std::min(by_jobs, mean_ms(in.enc_prof, b) / jobs);
  }
  return by_jobs;
}

// The least C(b) / b over the useful batch sizes: a batch of b frames of which fewer than b
// serve on-time jobs costs each of those more than the batch of those alone would, so only
// batches whose every frame may be useful count.
double charge_per_run(const BoundInput& in, const Windows& win) {
  double per_run = in.enc_one;
  for (int b = 2; b <= in.enc_top; ++b)
    if (win.useful[static_cast<std::size_t>(b)] >= b)
      per_run = std::min(per_run, mean_ms(in.enc_prof, b) / b);
  return per_run;
}

// A head's charge per run: least over b of C(b) / (on-time runs in a batch of b).
std::map<int, double> head_charges(const BoundInput& in, const Windows& win) {
  std::map<int, double> head_cost;
  for (int head = 0; head < static_cast<int>(in.s.model.heads.size()); ++head) {
    const UnitProfile* hp = in.head_profile(head);
    if (hp == nullptr) {
      head_cost[head] = 0.0;
      continue;
    }
    double best = mean_ms(hp, 1);
    const auto it = win.head_on_time.find(head);
    if (it != win.head_on_time.end())
      for (std::size_t b = 1; b < it->second.size(); ++b) {
        const int on_time = std::min(static_cast<int>(b), it->second[b]);
        if (on_time > 0) best = std::min(best, mean_ms(hp, static_cast<int>(b)) / on_time);
      }
    head_cost[head] = best;
  }
  return head_cost;
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
using OpCosts = std::map<const OperationSpec*, OpCost>;

OpCosts op_costs(const BoundInput& in, const std::map<int, double>& head_cost,
                 const std::array<std::vector<double>, 2>& enc_charge) {
  OpCosts oc;
  for (const auto& defs : in.all)
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
      const double cp = to_ms(least_critical_path(*op, in.mean));
      c.feasible = cp <= to_ms(resolve_deadline(*op, in.resolve));
      oc[op] = c;
    }
  return oc;
}

// The sensors whose every reader is triggered by them and reads no other sensor.
std::vector<char> per_frame_sensors(const BoundInput& in, const OpCosts& oc) {
  std::vector<char> by_frame(in.s.sensors.size(), 1);
  for (const auto& [op, c] : oc)
    for (int k : c.read)
      if (c.read.size() > 1 || op->trigger_sensor != k) by_frame[static_cast<std::size_t>(k)] = 0;
  return by_frame;
}

// Charges way `split` per frame with a run of E: each definition reading a per-frame
// sensor gets its group's charge or its own cost (the others keep the first way's).
void charge_per_frame(const BoundInput& in, const std::vector<char>& by_frame, OpCosts& oc,
                      double e, std::size_t split) {
  for (auto& [op, c] : oc) c.work[split] = c.work[0];
  for (std::size_t k = 0; k < in.s.sensors.size(); ++k) {
    if (!by_frame[k]) continue;
    // In the order of `all` (not of `oc`'s pointers), so that ties sort the same every run.
    std::vector<std::pair<double, OpCost*>> items;
    for (const auto& defs : in.all)
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
}

// Whether way `split` is valid: no batch of b frames (of several sensors, as they carry the
// most: a knapsack) carries more than C(b) above its jobs' own costs.
bool batches_within_cost(const BoundInput& in, const Windows& win, const OpCosts& oc,
                         std::size_t split) {
  bool valid = true;
  for (int b = 1; valid && b <= in.enc_top; ++b) {
    std::vector<double> most(static_cast<std::size_t>(b) + 1, 0.0);  // frames -> excess
    for (std::size_t k = 0; k < in.s.sensors.size(); ++k) {
      // excess[j]: the most a frame of sensor k, j frames before the newest, carries.
      std::vector<double> excess(static_cast<std::size_t>(b), 0.0);
      for (std::size_t j = 0; j < excess.size(); ++j)
        for (const auto& defs : in.all) {
          double top = 0;  // one job of an operation per frame, of one of its definitions
          for (const OperationSpec* op : defs) {
            const OpCost& c = oc.at(op);
            const auto f = win.frames_of.find(op);
            if (!c.feasible || op->trigger_sensor != static_cast<int>(k) ||
                f == win.frames_of.end() ||
                f->second[static_cast<std::size_t>(b)] < static_cast<int>(j) + 1)
              continue;
            top = std::max(top, c.work[split] - c.own);
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
    valid = *std::max_element(most.begin(), most.end()) <= mean_ms(in.enc_prof, b) + 1e-9;
  }
  return valid;
}

// More ways per frame, where every sensor read is read per frame: a larger run E, up to a
// whole run C(1), where a batch's frames cannot all carry on-time jobs of every operation.
// A frame j frames before the newest of a batch of b serves on time only the operations
// whose window holds j + 1 of its frames (frames_of), so the batch's jobs are charged
// above their own costs at most the sum, over its frames, of the excess (charge − own) of
// the operations each may serve; the way is valid where that is at most C(b) for every b
// (batches_within_cost). Returns the ways of splitting there are then.
std::size_t add_larger_runs(const BoundInput& in, const Windows& win,
                            const std::vector<char>& by_frame, double per_run, OpCosts& oc) {
  std::size_t splits = kSplits;
  bool every_by_frame = in.enc_prof != nullptr;
  for (const auto& [op, c] : oc)
    for (int k : c.read) every_by_frame = every_by_frame && by_frame[static_cast<std::size_t>(k)];
  for (int e = 1; every_by_frame && e <= in.enc_top; ++e) {
    const double run = mean_ms(in.enc_prof, e) / e;
    if (run <= per_run) continue;  // no larger than the third way's
    for (auto& [op, c] : oc) c.work.push_back(0);
    charge_per_frame(in, by_frame, oc, run, splits);
    if (batches_within_cost(in, win, oc, splits)) {
      ++splits;
    } else {
      for (auto& [op, c] : oc) c.work.pop_back();
    }
  }
  return splits;
}

// Each definition's least lane time under every way of splitting (OpCost::work), and how many
// ways there are.
struct Charges {
  OpCosts oc;
  std::size_t splits = kSplits;
};

Charges split_charges(const BoundInput& in) {
  const Windows win = batch_windows(in);
  // Ways to split a batch's time, each giving every on-time job at least the charge below;
  // each gives an upper bound, and the bound is the lowest (kSplits; the third, per frame,
  // is further down).
  //  - Among its on-time jobs: a job's share is at least C(b) / J(b) (charge_by_jobs).
  //  - Among its runs, C(b) / b each, and a run's among the at most share_k jobs it serves:
  //    per read of sensor k, the least C(b) / b over the useful batch sizes (b frames or
  //    more within the windows with the batch's cost C(b) in the path), / share_k.
  //    Lower where frames of a sensor feeding few operations batch with those of another.
  const double by_jobs = charge_by_jobs(in, win);
  const double per_run = charge_per_run(in, win);
  std::array<std::vector<double>, 2> enc_charge{std::vector<double>(in.s.sensors.size(), by_jobs),
                                                std::vector<double>(in.s.sensors.size())};
  for (std::size_t k = 0; k < in.s.sensors.size(); ++k)
    enc_charge[1][k] = per_run / std::max(1, win.share[k]);
  Charges ch{op_costs(in, head_charges(in, win), enc_charge)};
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
  const std::vector<char> by_frame = per_frame_sensors(in, ch.oc);
  charge_per_frame(in, by_frame, ch.oc, per_run, 2);
  ch.splits = add_larger_runs(in, win, by_frame, per_run, ch.oc);
  return ch;
}

// A job that counts, by deadline, with its least lane time under each way of splitting.
struct Due {
  TimePoint deadline;
  std::vector<double> work;
};

// The jobs of the run that count, sorted by deadline.
std::vector<Due> due_jobs(const BoundInput& in, const std::vector<JobRow>& jobs,
                          const OpCosts& oc) {
  std::vector<Due> due;
  for (const JobRow& j : jobs) {
    // The definition in force at its release: that of the last phase begun by then.
    auto ph = std::upper_bound(in.phases.begin(), in.phases.end(), j.release,
                               [](TimePoint t, const PhaseWorkload& w) { return t < w.span.from; });
    if (ph != in.phases.begin()) --ph;
    const OperationSpec* op = ph->ops[static_cast<std::size_t>(j.operation)].get();
    if (op == nullptr) continue;
    const OpCost& c = oc.at(op);
    if (c.feasible) due.push_back({j.deadline, c.work});
  }
  std::sort(due.begin(), due.end(),
            [](const Due& a, const Due& b) { return a.deadline < b.deadline; });
  return due;
}

// The least-cost jobs first: how many of those counted in `count` (cost -> jobs) fit
// `capacity` ms.
std::int64_t most_that_fit(const std::map<double, std::int64_t>& count, double capacity) {
  double used = 0;
  std::int64_t n = 0;
  for (const auto& [c, k] : count) {
    // As many as fit (room / c, rounded either way, then checked), at most all k.
    std::int64_t take =
        c > 0 ? std::min<std::int64_t>(k, static_cast<std::int64_t>((capacity - used) / c) + 1) : k;
    while (take > 0 && used + static_cast<double>(take) * c > capacity) --take;
    used += static_cast<double>(take) * c;
    n += take;
    if (take < k) break;
  }
  return n;
}

// The most jobs on time under way `w` of splitting: a demand bound at every deadline and at
// the run's end, where at most `in_flight_at_end` jobs finish later.
std::int64_t jobs_that_fit(const BoundInput& in, const std::vector<Due>& due, std::size_t w,
                           std::int64_t in_flight_at_end) {
  const TimePoint from = in.s.warmup;
  std::int64_t fit = std::numeric_limits<std::int64_t>::max();
  std::map<double, std::int64_t> count;
  // Every job counted in lane time is released after `from`: those due by t did all their
  // work in [from, t], and the jobs due later are counted as on time (a demand bound at
  // every deadline).
  const auto total = static_cast<std::int64_t>(due.size());
  for (std::size_t i = 0; i < due.size();) {
    const TimePoint t = due[i].deadline;
    for (; i < due.size() && due[i].deadline == t; ++i) ++count[due[i].work[w]];
    const std::int64_t n = most_that_fit(count, in.lanes * to_ms(std::max(t - from, Duration{0})));
    fit = std::min(fit, n + (total - static_cast<std::int64_t>(i)));
  }
  // And at the run's end: those that finish by then fit its lane time, at most the jobs in
  // flight then finish later.
  const std::int64_t by_end = most_that_fit(count, in.lanes * to_ms(in.s.duration - from));
  const std::int64_t due_later =
      total - (std::upper_bound(due.begin(), due.end(), in.s.duration,
                                [](TimePoint t, const Due& d) { return t < d.deadline; }) -
               due.begin());
  return std::min(fit, by_end + std::min(in_flight_at_end, due_later));
}

}  // namespace

double work_bound(const Scenario& s, const Profile& p) {
  // The releases are the same for every policy (same frames, same own-rate ticks; a release
  // skipped at max_inflight is counted as released): take them from a FIFO run.
  auto r = simulate_policy(s, p, "fifo", s.seed, {}, false);
  if (!r) throw std::runtime_error(r.error().to_string());
  const BoundInput in = bound_input(s, p);
  const Charges ch = split_charges(in);
  const std::vector<Due> due = due_jobs(in, r->jobs, ch.oc);
  const auto released = static_cast<std::int64_t>(r->jobs.size());
  if (released == 0) return 1.0;
  // Releases stop at the run's end, so the jobs on time that finish after it were in flight
  // then: at most max_inflight of each operation.
  std::int64_t in_flight_at_end = 0;
  for (const auto& defs : in.all) {
    int most = 0;
    for (const OperationSpec* op : defs) most = std::max(most, op->max_inflight);
    in_flight_at_end += most;
  }
  std::int64_t fit = std::numeric_limits<std::int64_t>::max();
  for (std::size_t w = 0; w < ch.splits; ++w)
    fit = std::min(fit, jobs_that_fit(in, due, w, in_flight_at_end));
  // The last deadline's count is at most every job that counts: fit <= due.size() <= released
  // (0 when none counts).
  return static_cast<double>(fit) / static_cast<double>(released);
}

}  // namespace red
