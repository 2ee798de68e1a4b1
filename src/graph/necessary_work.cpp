// The necessary work of a workload (red/graph/necessary_work.hpp; docs/DESIGN.md, "Overload").

#include "red/graph/necessary_work.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "red/graph/refine.hpp"

namespace red {

WorkModel::WorkModel(const Profile& p, const ModelSpec& m, EstimateKind resolve, int max_batch,
                     int lanes, Duration gamma, double slowdown)
    : profile_(&p),
      model_(&m),
      resolve_(resolve),
      max_batch_(std::max(1, max_batch)),
      lanes_(std::max(1, lanes)),
      gamma_s_(std::max(0.0, to_s(gamma))),
      slowdown_(slowdown) {
  units_.push_back(p.find("encoder"));
  for (const std::string& h : m.heads) units_.push_back(p.find("head/" + h));
}

Duration WorkModel::cost(std::size_t slot, int batch, EstimateKind k) const {
  const UnitProfile* u = units_[slot];
  if (u == nullptr || u->by_batch.empty()) return Duration{0};
  const Duration d = u->at(batch).estimate(k);
  return slowdown_ == 1.0 ? d : scaled_by(d, slowdown_);
}

int WorkModel::top_batch(std::size_t slot) const {
  const UnitProfile* u = units_[slot];
  return u == nullptr ? 1 : std::clamp(u->max_batch(), 1, max_batch_);
}

Duration WorkModel::least(std::size_t slot) const {
  Duration d = cost(slot, 1, EstimateKind::Mean);
  for (int b = 2; b <= top_batch(slot); ++b) d = std::min(d, cost(slot, b, EstimateKind::Mean));
  return d;
}

int WorkModel::on_time_runs(double slack_ms, double period_ms, int cap) noexcept {
  if (slack_ms < 0) return 0;
  return static_cast<int>(std::min<double>(cap, std::floor(slack_ms / period_ms) + 1));
}

bool WorkModel::overloaded(double load, double span_s, double deadline_s) noexcept {
  return span_s > 0 && load > 1.0 + std::max(0.0, deadline_s) / span_s;
}

namespace {

// Runs of one unit that one operation (or, for the encoder, one sensor) offers to a batch: `hz`
// per second, each with `window_s` between its release and its deadline less the rest of its
// path, at most `cap` at once.
struct Offer {
  double hz = 0;
  double window_s = 0;
  int cap = 1;
};

// The most runs of these offers a batch whose run takes `run_s` can hold with every one on time.
int on_time_members(const std::vector<Offer>& offers, double run_s) {
  int n = 0;
  for (const Offer& o : offers)
    if (o.hz > 0) n += WorkModel::on_time_runs(1e3 * (o.window_s - run_s), 1e3 / o.hz, o.cap);
  return n;
}

// Per sensor: who reads its frames. A frame that triggers operations must be encoded in time for
// every one of them, and each keeps a job in flight per frame: the window and the cap of its runs
// are the least over those operations. Where only operations sampling the newest frame read it,
// a run helps one of them in time: the largest (their deadlines run from their own releases,
// after the frame's).
struct Readers {
  bool triggered = false;  // an operation released on its frames reads them
  double sampled_hz = 0;   // the fastest operation sampling its newest frame, at most its rate
  double trigger_window_s = std::numeric_limits<double>::infinity();
  int trigger_cap = std::numeric_limits<int>::max();
  double sample_window_s = -std::numeric_limits<double>::infinity();
  int sample_cap = 0;
  double rate_sum = 0;  // of the operations reading it (the encoder's work is shared by rate)
};

// The least time before (`start`) and after (`post`) each node of one job given each node's own
// time, relaxed along the edges until nothing changes (at most a round per node).
void relax_paths(const OperationSpec& op, const std::vector<double>& own,
                 std::vector<double>& start, std::vector<double>& post) {
  const std::size_t n = op.nodes.size();
  for (std::size_t round = 0; round < n; ++round) {
    bool changed = false;
    for (const EdgeSpec& e : op.edges) {
      const auto f = static_cast<std::size_t>(e.from), t = static_cast<std::size_t>(e.to);
      if (start[f] + own[f] > start[t] + 1e-15) {
        start[t] = start[f] + own[f];
        changed = true;
      }
      if (own[t] + post[t] > post[f] + 1e-15) {
        post[f] = own[t] + post[t];
        changed = true;
      }
    }
    if (!changed) break;
  }
}

}  // namespace

// What estimate gathers from a workload before it picks the batches.
struct WorkModel::Demand {
  std::vector<std::vector<Offer>> offers;  // by slot: the runs offered to its batches
  std::map<int, Readers> readers;          // by sensor
  std::vector<double> plain;               // by operation: its plain nodes' lane time per second
  std::map<int, double> frames_hz;         // by sensor: frames to encode per second
};

double WorkModel::floor_load(const WorkInput& in) const {
  return estimate(in, true).load;
}

// Operation i's runs of each head, offered to the head's batches, its plain nodes' time and,
// per sensor it reads, what it asks of the sensor's encoder runs.
void WorkModel::offer_operation(const WorkInput& in, std::size_t i, Demand& d,
                                WorkEstimate& w) const {
  const OperationSpec* op = in.ops[i].op;
  const double hz = in.ops[i].rate_hz;
  if (op == nullptr || hz <= 0) return;
  const CostModel resolve{profile_, model_, resolve_};
  const double enc_least = to_s(least(kEncoder));
  const double deadline = to_s(resolve_deadline(*op, resolve));
  // The least time before and after each node on the fine graph: an inference node starts
  // after its frame's encoder run and its predecessors; every unit at its cheapest batch.
  const std::size_t n = op->nodes.size();
  std::vector<double> own(n), start(n), post(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    const NodeSpec& nd = op->nodes[k];
    own[k] = nd.is_plain() ? to_s(CostModel::plain(*nd.cost, EstimateKind::Mean)) * slowdown_
                           : to_s(least(head_slot(nd.head)));
    start[k] = nd.is_plain() ? 0.0 : enc_least;
  }
  relax_paths(*op, own, start, post);
  std::map<int, double> tail;  // per sensor read: the least time after its encoder run
  for (std::size_t k = 0; k < n; ++k) {
    const NodeSpec& nd = op->nodes[k];
    if (nd.is_plain()) {
      d.plain[i] += hz * own[k];
      continue;
    }
    const std::size_t slot = head_slot(nd.head);
    d.offers[slot].push_back({hz, deadline - start[k] - post[k], op->max_inflight});
    w.units[slot].runs_hz += hz;
    double& t = tail[nd.sensor];
    t = std::max(t, own[k] + post[k]);
  }
  for (const auto& [sensor, after] : tail) {
    Readers& r = d.readers[sensor];
    const double frames = in.sensor_hz[static_cast<std::size_t>(sensor)];
    if (op->trigger_sensor == sensor) {
      r.triggered = true;
      r.trigger_window_s = std::min(r.trigger_window_s, deadline - after);
      r.trigger_cap = std::min(r.trigger_cap, std::max(1, op->max_inflight));
    } else {
      // Its releases within γ of each other may share one run (at most max_inflight jobs).
      const double sharing =
          std::min<double>(std::max(1, op->max_inflight), std::floor(gamma_s_ * hz + 1e-9) + 1);
      r.sampled_hz = std::max(r.sampled_hz, std::min(hz / sharing, frames));
      r.sample_window_s = std::max(r.sample_window_s, deadline - after);
      r.sample_cap += op->max_inflight;
    }
    r.rate_sum += hz;
  }
}

// Frames to encode: every frame of a sensor that triggers an operation reading it, else one
// per release of the fastest operation sampling it.
void WorkModel::offer_frames(const WorkInput& in, Demand& d, WorkEstimate& w) const {
  for (const auto& [sensor, r] : d.readers) {
    const double f = r.triggered ? in.sensor_hz[static_cast<std::size_t>(sensor)] : r.sampled_hz;
    d.frames_hz[sensor] = f;
    if (r.triggered)
      d.offers[kEncoder].push_back({f, r.trigger_window_s, r.trigger_cap});
    else
      d.offers[kEncoder].push_back({f, r.sample_window_s, r.sample_cap});
    w.units[kEncoder].runs_hz += f;
  }
}

// Per unit, the batch size whose cost per on-time run is least, and the lane time per run.
void WorkModel::choose_batches(const Demand& d, bool unbounded, WorkEstimate& w) const {
  for (std::size_t slot = 0; slot < units_.size(); ++slot) {
    UnitWork& u = w.units[slot];
    double best = to_s(cost(slot, 1, EstimateKind::Mean));
    for (int b = 1; b <= top_batch(slot); ++b) {
      const double c = to_s(cost(slot, b, EstimateKind::Mean));
      const int held = unbounded ? b : std::min(b, on_time_members(d.offers[slot], c));
      if (held < 1) continue;
      if (c / held < best - 1e-12) {
        best = c / held;
        u.batch = b;
        u.serves = held;
      }
    }
    for (std::size_t k = 0; k < u.per_run.size(); ++k) {
      const auto kind = static_cast<EstimateKind>(k);
      u.per_run[k] = std::min(cost(slot, u.batch, kind) / u.serves, cost(slot, 1, kind));
    }
  }
}

// Each operation's share of the lanes' time: its plain nodes, its head runs and its share by
// rate of the encoder runs of each sensor it reads; and the device's load.
void WorkModel::share_loads(const WorkInput& in, Demand& d, WorkEstimate& w) const {
  const double lanes = lanes_;
  for (std::size_t i = 0; i < in.ops.size(); ++i) {
    const OperationSpec* op = in.ops[i].op;
    const double hz = in.ops[i].rate_hz;
    if (op == nullptr || hz <= 0) continue;
    double s = d.plain[i];
    std::map<int, bool> sensors;
    for (const NodeSpec& nd : op->nodes) {
      if (nd.is_plain()) continue;
      s += hz * to_s(w.units[head_slot(nd.head)].per_run[0]);
      sensors[nd.sensor] = true;
    }
    const double enc = to_s(w.units[kEncoder].per_run[0]);
    for (const auto& [sensor, _] : sensors) {
      const Readers& r = d.readers[sensor];
      if (r.rate_sum <= 0) continue;
      s += d.frames_hz[sensor] * enc * hz / r.rate_sum;
      w.encoder_runs_per_job[i] += d.frames_hz[sensor] / r.rate_sum;
    }
    w.op_load[i] = s / lanes;
    w.load += w.op_load[i];
  }
}

WorkEstimate WorkModel::estimate(const WorkInput& in, bool unbounded) const {
  WorkEstimate w;
  w.units.resize(units_.size());
  w.op_load.assign(in.ops.size(), 0.0);
  w.encoder_runs_per_job.assign(in.ops.size(), 0.0);
  Demand d{std::vector<std::vector<Offer>>(units_.size()),
           {},
           std::vector<double>(in.ops.size(), 0.0),
           {}};
  for (std::size_t i = 0; i < in.ops.size(); ++i) offer_operation(in, i, d, w);
  offer_frames(in, d, w);
  choose_batches(d, unbounded, w);
  share_loads(in, d, w);
  return w;
}

}  // namespace red
