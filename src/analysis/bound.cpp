#include "red/analysis/bound.hpp"

#include <algorithm>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/metrics/metrics.hpp"
#include "red/sim/run.hpp"

namespace red {

double work_bound(const Scenario& s, const Profile& p) {
  // The releases are the same for every policy (same frames, same own-rate ticks): take
  // them from a FIFO run, which drops nothing late.
  auto r = simulate_policy(s, p, "fifo", s.seed, {}, false);
  if (!r) throw std::runtime_error(r.error().to_string());
  const CostModel mean{&p, &s.model, EstimateKind::Mean};
  const double enc = to_ms(mean.encoder());
  // Per operation: necessary work (encoders aside), sensors read, coarse critical path.
  struct OpCost {
    double work = 0, cp = 0, deadline = 0;
    int trigger = -1;
  };
  std::vector<OpCost> oc;
  std::map<int, int> ops_per_trigger;
  for (int i = 0; i < s.operation_count(); ++i) {
    const auto& op = s.initial[static_cast<std::size_t>(i)];
    OpCost c;
    if (op) {
      for (const NodeSpec& n : op->nodes)
        c.work += n.is_plain() ? to_ms(n.cost->mean) : to_ms(mean.head(n.head));
      c.cp = to_ms(coarse_critical_path(*op, mean));
      c.deadline = to_ms(resolve_deadline(*op, CostModel{&p, &s.model, s.scheduler.estimate}));
      c.trigger = op->trigger_sensor;
      bool reads = false;
      for (const NodeSpec& n : op->nodes) reads = reads || !n.is_plain();
      if (reads && c.trigger >= 0) ++ops_per_trigger[c.trigger];
      if (reads && c.trigger < 0) c.work += enc;  // own rate: its own encoder run
    }
    oc.push_back(c);
  }
  std::vector<double> costs;
  std::int64_t released = 0;
  for (const JobRow& j : r->jobs) {
    ++released;
    const OpCost& c = oc[static_cast<std::size_t>(j.operation)];
    // A fine-graph critical path is at most the coarse one; exclude only what no policy
    // can meet even alone.
    if (c.cp > c.deadline) continue;
    double w = c.work;
    if (c.trigger >= 0 && ops_per_trigger.count(c.trigger) != 0)
      w += enc / ops_per_trigger[c.trigger];
    costs.push_back(w);
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
