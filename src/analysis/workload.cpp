#include "red/analysis/workload.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "red/sim/cost_sampler.hpp"

namespace red {

UnitCosts::UnitCosts(const Scenario& s, const Profile& p, CostPoint point)
    : point_(point),
      estimate_(s.scheduler.estimate),
      slowdown_(s.interference ? 1.0 + s.interference->intensity : 1.0) {
  if (const UnitProfile* e = p.find("encoder")) encoder_ = pick(e->at(1));
  for (const std::string& h : s.model.heads) {
    const UnitProfile* u = p.find("head/" + h);
    heads_.push_back(u != nullptr ? pick(u->at(1)) : Duration{0});
  }
}

Duration UnitCosts::pick(const LatencyStats& l) const {
  Duration d{0};
  switch (point_) {
    case CostPoint::Min:
      d = l.min;
      break;
    case CostPoint::Mean:
      d = l.mean;
      break;
    case CostPoint::Estimate:
      d = l.estimate(estimate_);
      break;
    case CostPoint::Max:
      d = l.max;
      break;
  }
  // The simulator rounds each scaled draw to the nanosecond; so does this.
  return slowdown_ == 1.0 ? d : scaled_by(d, slowdown_);
}

Duration UnitCosts::plain(const PlainCost& c) const {
  return pick(plain_stats(c));
}

Duration UnitCosts::coarse_node(const NodeSpec& n) const {
  return n.is_plain() ? plain(*n.cost) : encoder_ + head(n.head);
}

Duration UnitCosts::fine_node(const NodeSpec& n) const {
  return n.is_plain() ? plain(*n.cost) : head(n.head);
}

std::vector<PhaseWorkload> phase_workloads(const Scenario& s, TimePoint end) {
  std::vector<PhaseWorkload> out;
  for (const PhaseSpan& span : workload_phases(s, end)) {
    PhaseWorkload ph;
    ph.span = span;
    ph.label = phase_label(s, span);
    ph.ops = s.initial;
    for (const SensorSpec& sn : s.sensors) ph.sensor_rate.push_back(sn.rate_hz);
    // The events due by the phase's start are in effect (they are in time order).
    for (const EventSpec& e : s.events) {
      if (e.at > span.from) break;
      for (const auto& [op, snap] : e.changes) ph.ops[static_cast<std::size_t>(op)] = snap;
      for (const auto& [sensor, rate] : e.sensor_rates)
        ph.sensor_rate[static_cast<std::size_t>(sensor)] = rate;
    }
    out.push_back(std::move(ph));
  }
  return out;
}

Duration critical_path(const OperationSpec& op, GraphMode mode, const UnitCosts& c) {
  if (mode == GraphMode::Mono) return work_fine(op, c);
  // Nodes in topological order: the loader guarantees a DAG; relax edges until stable
  // (|nodes| rounds at most, each a pass over the edges).
  std::vector<Duration> finish(op.nodes.size(), Duration{0});
  for (std::size_t i = 0; i < op.nodes.size(); ++i) {
    const NodeSpec& n = op.nodes[i];
    finish[i] = mode == GraphMode::Coarse
                    ? c.coarse_node(n)
                    : (n.is_plain() ? Duration{0} : c.encoder()) + c.fine_node(n);
  }
  for (std::size_t round = 0; round < op.nodes.size(); ++round) {
    bool changed = false;
    for (const EdgeSpec& e : op.edges) {
      const NodeSpec& to = op.nodes[static_cast<std::size_t>(e.to)];
      Duration start = finish[static_cast<std::size_t>(e.from)];
      // Fine graph: the encoder of `to` runs from the release, beside its predecessors.
      if (mode == GraphMode::Fine && !to.is_plain()) start = std::max(start, c.encoder());
      const Duration f = start + c.fine_node(to) +
                         (mode == GraphMode::Coarse && !to.is_plain() ? c.encoder() : Duration{0});
      if (f > finish[static_cast<std::size_t>(e.to)]) {
        finish[static_cast<std::size_t>(e.to)] = f;
        changed = true;
      }
    }
    if (!changed) break;
  }
  Duration cp{0};
  for (Duration f : finish) cp = std::max(cp, f);
  return cp;
}

Duration work_coarse(const OperationSpec& op, const UnitCosts& c) {
  Duration w{0};
  for (const NodeSpec& n : op.nodes) w += c.coarse_node(n);
  return w;
}

namespace {

std::vector<int> sensors_read(const OperationSpec& op) {
  std::vector<int> v;
  for (const NodeSpec& n : op.nodes)
    if (!n.is_plain() && std::find(v.begin(), v.end(), n.sensor) == v.end()) v.push_back(n.sensor);
  return v;
}

}  // namespace

Duration work_fine(const OperationSpec& op, const UnitCosts& c) {
  Duration w = c.encoder() * static_cast<std::int64_t>(sensors_read(op).size());
  for (const NodeSpec& n : op.nodes) w += c.fine_node(n);
  return w;
}

double release_rate(const OperationSpec& op, const PhaseWorkload& ph, const Scenario& s) {
  if (op.trigger_sensor >= 0) return ph.sensor_rate[static_cast<std::size_t>(op.trigger_sensor)];
  if (op.rate_hz > 0) return op.rate_hz;
  const double d = to_s(s.duration);
  return op.release_count && d > 0 ? *op.release_count / d : 0.0;
}

std::vector<double> merged_encoder_runs(const Scenario& s, const PhaseWorkload& ph) {
  const std::size_t n = ph.ops.size();
  std::vector<double> runs(n, 0.0);
  // Per sensor: operations triggered by it that read it, and the others that read it.
  std::map<int, std::vector<std::size_t>> triggered, sampling;
  for (std::size_t i = 0; i < n; ++i) {
    if (!ph.ops[i]) continue;
    for (int sn : sensors_read(*ph.ops[i]))
      (ph.ops[i]->trigger_sensor == sn ? triggered : sampling)[sn].push_back(i);
  }
  for (const auto& [sn, ops] : triggered)
    for (std::size_t i : ops) runs[i] += 1.0 / static_cast<double>(ops.size());
  const double gamma_s = to_s(s.scheduler.gamma);
  for (const auto& [sn, ops] : sampling) {
    double sum = 0, fastest = 0, slowest = 0;
    for (std::size_t i : ops) {
      const double r = release_rate(*ph.ops[i], ph, s);
      sum += r;
      fastest = std::max(fastest, r);
      slowest = slowest == 0 ? r : std::min(slowest, r);
    }
    if (sum <= 0) continue;
    double per_s = ops.size() > 1 && slowest > 0 && 2 * gamma_s >= 1.0 / slowest ? fastest : sum;
    per_s = std::min(per_s, ph.sensor_rate[static_cast<std::size_t>(sn)]);
    for (std::size_t i : ops) runs[i] += per_s / sum;
  }
  return runs;
}

Duration work_merged(const OperationSpec& op, const UnitCosts& c, double encoder_runs) {
  Duration heads{0};
  for (const NodeSpec& n : op.nodes) heads += c.fine_node(n);
  return heads + Duration{static_cast<std::int64_t>(encoder_runs *
                                                    static_cast<double>(c.encoder().count()))};
}

WorkModel work_model(const Scenario& s, const Profile& p) {
  return WorkModel(p, s.model, s.scheduler.estimate, s.scheduler.max_batch, s.device.lanes,
                   s.scheduler.gamma, s.interference ? 1.0 + s.interference->intensity : 1.0);
}

WorkInput work_input(const Scenario& s, const PhaseWorkload& ph, double scale) {
  WorkInput in;
  for (double r : ph.sensor_rate) in.sensor_hz.push_back(r * scale);
  for (const auto& op : ph.ops) {
    WorkInput::Stream st;
    if (op) {
      st.op = op.get();
      const bool scaled = op->trigger_sensor >= 0 || op->rate_hz > 0;
      st.rate_hz = release_rate(*op, ph, s) * (scaled ? scale : 1.0);
    }
    in.ops.push_back(st);
  }
  return in;
}

namespace {

// The phases of the measured window with their spans clipped to it.
std::vector<PhaseWorkload> measured_phases(const Scenario& s) {
  const TimePoint from{s.warmup}, to{s.duration};
  std::vector<PhaseWorkload> out;
  for (PhaseWorkload& ph : phase_workloads(s, to)) {
    ph.span.from = std::max(ph.span.from, from);
    ph.span.to = std::min(ph.span.to, to);
    if (ph.span.to > ph.span.from) out.push_back(std::move(ph));
  }
  return out;
}

}  // namespace

NecessaryLoad necessary_load(const Scenario& s, const Profile& p) {
  const WorkModel model = work_model(s, p);
  const CostModel resolve{&p, &s.model, s.scheduler.estimate};
  const std::vector<PhaseWorkload> phases = measured_phases(s);
  NecessaryLoad out;
  double weight = 0;
  std::vector<double> deadline(phases.size(), 0.0);
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const PhaseWorkload& ph = phases[k];
    for (const auto& op : ph.ops)
      if (op) deadline[k] = std::max(deadline[k], to_s(resolve_deadline(*op, resolve)));
    const double len = to_s(ph.span.to - ph.span.from);
    const double load = model.estimate(work_input(s, ph)).load;
    out.phases.push_back({ph.span, load, deadline[k]});
    out.mean += load * len;
    weight += len;
  }
  if (weight > 0) out.mean /= weight;

  // The limit: the largest rate_scale at which no phase is overloaded. A run costs at least the
  // least of C(b) / b over batch sizes, so a phase's load is at least linear in the scale, and
  // past the scale where that line overloads it every scale does: search down from there.
  auto feasible = [&](double x) {
    for (std::size_t k = 0; k < phases.size(); ++k) {
      const double len = to_s(phases[k].span.to - phases[k].span.from);
      if (WorkModel::overloaded(model.estimate(work_input(s, phases[k], x)).load, len, deadline[k]))
        return false;
    }
    return true;
  };
  double top = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < phases.size(); ++k) {
    const double len = to_s(phases[k].span.to - phases[k].span.from);
    const double at0 = model.floor_load(work_input(s, phases[k], 0.0));
    const double at1 = model.floor_load(work_input(s, phases[k], 1.0));
    if (at1 - at0 <= 1e-12) continue;
    top = std::min(top, std::max(0.0, (1.0 + deadline[k] / len - at0) / (at1 - at0)));
  }
  if (!std::isfinite(top)) {
    out.limit = feasible(1.0) ? std::numeric_limits<double>::infinity() : 0.0;
    return out;
  }
  // Past `top` the least load overloads a phase; just above it the model does too (or the search
  // widens until it does, where a rate does not scale linearly).
  double hi = top * 1.0001 + 1e-9;
  for (int i = 0; i < 60 && feasible(hi); ++i) hi *= 2;
  double lo = hi;
  while (lo > 1e-6 && !feasible(lo)) lo *= 0.995;
  if (lo <= 1e-6) {
    out.limit = 0.0;
    return out;
  }
  hi = std::min(hi, lo / 0.995);
  for (int i = 0; i < 40 && hi - lo > 1e-6 * hi; ++i) {
    const double mid = (lo + hi) / 2;
    (feasible(mid) ? lo : hi) = mid;
  }
  out.limit = lo;
  return out;
}

Profile worst_case_profile(const Profile& p) {
  Profile w = p;
  for (auto& [name, unit] : w.units)
    for (LatencyStats& l : unit.by_batch) l.min = l.mean = l.p50 = l.p95 = l.p99 = l.max;
  // A calibrated profile: the simulator draws residual × time factor × lane factor
  // (docs/FIDELITY.md); the worst case pins each part at its largest measured value.
  if (w.calibration) {
    Calibration& c = *w.calibration;
    for (auto& [name, tables] : c.residual)
      for (std::vector<Duration>& t : tables)
        if (!t.empty()) t.assign(t.size(), t.back());
    if (!c.factors.empty())
      c.factors.assign(1, *std::max_element(c.factors.begin(), c.factors.end()));
    const double lane = *std::max_element(c.lane_factors.begin(), c.lane_factors.end());
    c.lane_factors.assign(c.lane_factors.size(), lane);
  }
  return w;
}

Scenario worst_case_scenario(const Scenario& s, const Profile& p) {
  Scenario w = s;
  const CostModel costs{&p, &s.model, s.scheduler.estimate};
  auto freeze = [&](const std::shared_ptr<const OperationSpec>& op) {
    if (!op) return op;
    auto c = std::make_shared<OperationSpec>(*op);
    c->deadline.fixed = resolve_deadline(*op, costs);
    c->deadline.critical_path_x.reset();
    for (NodeSpec& n : c->nodes)
      if (n.cost) {
        const Duration m = plain_stats(*n.cost).max;
        n.cost = PlainCost{m, m};
      }
    return std::shared_ptr<const OperationSpec>(std::move(c));
  };
  for (auto& op : w.initial) op = freeze(op);
  for (EventSpec& e : w.events)
    for (auto& change : e.changes) change.second = freeze(change.second);
  return w;
}

}  // namespace red
