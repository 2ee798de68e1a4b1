#include "red/analysis/response_bound.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "red/analysis/workload.hpp"

namespace red {

namespace {

ResponseBound none(std::string why) {
  ResponseBound r;
  r.why_not = "no analysis applies: " + std::move(why);
  return r;
}

// Every snapshot of every operation, and the fastest rate of every sensor.
struct Snapshots {
  std::vector<std::vector<std::shared_ptr<const OperationSpec>>> of;  // by operation
  std::vector<double> max_rate;                                       // by sensor
};

// The snapshots the events leave, or why the analysis does not apply (nullopt: it may).
std::optional<ResponseBound> gather_snapshots(const Scenario& s, Snapshots& snaps) {
  const auto n = static_cast<std::size_t>(s.operation_count());
  snaps.of.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    if (s.initial[i]) snaps.of[i].push_back(s.initial[i]);
  for (const SensorSpec& sn : s.sensors) snaps.max_rate.push_back(sn.rate_hz);
  for (const EventSpec& e : s.events) {
    for (const auto& [op, snap] : e.changes) {
      const auto i = static_cast<std::size_t>(op);
      if (snap) {
        snaps.of[i].push_back(snap);
      } else if (s.initial[i] && s.initial[i]->trigger_sensor < 0) {
        // An own-rate operation that leaves may come back with a new phase: its releases
        // are then not periodic.
        return none("operation '" + s.operation_name(op) +
                    "' runs at its own rate and leaves the workload (its releases are not "
                    "periodic across a re-add)");
      }
    }
    for (const auto& [sensor, rate] : e.sensor_rates)
      snaps.max_rate[static_cast<std::size_t>(sensor)] =
          std::max(snaps.max_rate[static_cast<std::size_t>(sensor)], rate);
  }
  return std::nullopt;
}

// What every operation's bound reads: the costs at their max and as the deadlines resolve them,
// and a synchronization round trip.
struct Costs {
  UnitCosts worst;
  CostModel est;
  Duration sync;
};

// Operation i's job cost, deadline, period and jitter over its snapshots (into `b`), or why the
// analysis does not apply (nullopt: it may).
std::optional<ResponseBound> bound_operation(const Scenario& s, const PolicyOptions& o,
                                             const Snapshots& snaps, const Costs& costs,
                                             std::size_t i, OperationBound& b) {
  b.name = s.operation_name(static_cast<int>(i));
  b.deadline = kNever;
  for (const auto& op : snaps.of[i]) {
    if (op->depends_on >= 0)
      return none("operation '" + b.name +
                  "' depends on another operation's newest job (its head waits)");
    if (op->trigger_sensor < 0 && op->rate_hz <= 0)
      return none("operation '" + b.name + "' is released a fixed number of times at once");
    Duration c{0};
    if (o.graph == GraphMode::Mono) {
      c = work_fine(*op, costs.worst) + costs.sync;  // one unit, one round trip
    } else {
      c = work_coarse(*op, costs.worst) + costs.sync * static_cast<std::int64_t>(op->nodes.size());
    }
    // Under interference the simulator rounds every scaled draw: a nanosecond per unit
    // covers it.
    if (s.interference && s.interference->intensity != 0.0)
      c += Duration{static_cast<std::int64_t>(op->nodes.size())};
    b.job_cost = std::max(b.job_cost, c);
    b.deadline = std::min(b.deadline, resolve_deadline(*op, costs.est));
    Duration period{0}, jitter{0};
    if (op->trigger_sensor >= 0) {
      const auto sn = static_cast<std::size_t>(op->trigger_sensor);
      period = period_of(snaps.max_rate[sn]);
      // The simulator caps a frame's lateness below one period.
      jitter = std::min(s.sensors[sn].jitter, period - Duration{1});
    } else {
      period = period_of(op->rate_hz);
      for (const EventSpec& e : s.events)
        for (const auto& [idx, snap] : e.changes)
          if (static_cast<std::size_t>(idx) == i && snap && snap->rate_hz > 0)
            period = std::min(period, period_of(snap->rate_hz));
      // A rate change takes effect one new period after the event: two releases may then
      // be closer than a period; count it as jitter of one period.
      if (snaps.of[i].size() > 1) jitter = period;
    }
    // Periods of different snapshots: the shortest; jitter: the largest.
    b.period = b.period == Duration{0} ? period : std::min(b.period, period);
    b.jitter = std::max(b.jitter, jitter);
  }
  return std::nullopt;
}

// The level-0 busy period of the operations' bounds in `r`, each operation's bound: the least
// fixed point of W(L) = Σ ⌈(L + J_i) / T_i⌉ C_i, from Σ C_i (George et al., section 4).
ResponseBound busy_period_bound(ResponseBound r) {
  if (r.operations.empty()) return none("no operation releases jobs");
  for (const OperationBound& b : r.operations)
    r.utilization +=
        static_cast<double>(b.job_cost.count()) / static_cast<double>(b.period.count());
  if (r.utilization >= 1.0) {
    ResponseBound over = none(fmt::format(
        "utilization at max costs is {:.3f} >= 1: the busy period is unbounded", r.utilization));
    over.utilization = r.utilization;
    return over;
  }
  Duration l{0};
  for (const OperationBound& b : r.operations) l += b.job_cost;
  for (int it = 0; it < 100000; ++it) {
    Duration w{0};
    for (const OperationBound& b : r.operations) {
      const std::int64_t k = (l + b.jitter + b.period - Duration{1}) / b.period;
      w += b.job_cost * k;
    }
    if (w == l) break;
    l = w;
    if (l > std::chrono::hours{1}) return none("the busy period exceeds an hour");
  }
  r.busy_period = l;
  for (OperationBound& b : r.operations) b.bound = l;
  r.applies = true;
  return r;
}

}  // namespace

ResponseBound response_bound(const Scenario& s, const Profile& p, const PolicyOptions& o) {
  if (s.device.lanes != 1)
    return none(std::to_string(s.device.lanes) +
                " lanes (the busy-period bound is for one lane; a multi-lane DAG analysis is "
                "future work — try --export-nptest with nptest -m)");
  if (o.graph == GraphMode::Fine)
    return none(
        "the fine graph merges encoder runs and may hold an encoder for a predicted member "
        "(DynamicMerge waits idle the lane: not work-conserving)");
  if (o.batching) return none("batching changes a unit's cost with the batch it joins");
  // Drops, shedding and overload ranking only remove or reorder work: the lane stays
  // work-conserving, so they need no condition here.
  Snapshots snaps;
  if (auto not_periodic = gather_snapshots(s, snaps)) return *not_periodic;
  const Costs costs{UnitCosts(s, p, CostPoint::Max), CostModel{&p, &s.model, s.scheduler.estimate},
                    s.device.sync_cost ? *s.device.sync_cost : p.sync_round_trip};
  ResponseBound r;
  r.method =
      "level-0 busy period, one lane, work-conserving non-preemptive scheduling, costs at their "
      "max (Lehoczky, RTSS 1990; George, Rivierre, Spuri, INRIA RR-2966, 1996)";
  for (std::size_t i = 0; i < snaps.of.size(); ++i) {
    if (snaps.of[i].empty()) continue;
    OperationBound b;
    if (auto not_bounded = bound_operation(s, o, snaps, costs, i, b)) return *not_bounded;
    r.operations.push_back(b);
  }
  return busy_period_bound(std::move(r));
}

}  // namespace red
