#include "red/analysis/nptest.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <set>
#include <tuple>
#include <vector>

#include "red/analysis/workload.hpp"
#include "red/graph/refine.hpp"

namespace red {

namespace {

// Microseconds, rounded toward the safe side of each column.
std::int64_t us_floor(Duration d) {
  const std::int64_t n = d.count();
  return n >= 0 ? n / 1000 : -((-n + 999) / 1000);
}
std::int64_t us_ceil(Duration d) {
  return -us_floor(-d);
}

// The snapshot of operation `i` and the rate of sensor `sn` in effect at time t.
struct Timeline {
  const Scenario& s;
  std::shared_ptr<const OperationSpec> op_at(std::size_t i, TimePoint t) const {
    auto cur = s.initial[i];
    for (const EventSpec& e : s.events) {
      if (e.at > t) break;
      for (const auto& [op, snap] : e.changes)
        if (static_cast<std::size_t>(op) == i) cur = snap;
    }
    return cur;
  }
  double rate_at(std::size_t sn, TimePoint t) const {
    double r = s.sensors[sn].rate_hz;
    for (const EventSpec& e : s.events) {
      if (e.at > t) break;
      for (const auto& [sensor, rate] : e.sensor_rates)
        if (static_cast<std::size_t>(sensor) == sn) r = rate;
    }
    return r;
  }
};

// One release: operation, nominal time, latest arrival, and the frame that triggered it.
struct Release {
  std::size_t op = 0;
  TimePoint at{0};
  TimePoint latest{0};
  std::int64_t frame = -1;  // trigger frame index, -1 for own-rate and one-shot releases
  std::shared_ptr<const OperationSpec> spec;
};

Duration hyperperiod(const Scenario& s, bool& bounded) {
  std::int64_t h = 1;
  bounded = true;
  auto add = [&](Duration period) {
    const std::int64_t g = std::gcd(h, period.count());
    const std::int64_t q = period.count() / g;
    if (h > std::numeric_limits<std::int64_t>::max() / q) {
      bounded = false;
      return;
    }
    h *= q;
  };
  for (const auto& op : s.initial) {
    if (!op) continue;
    if (op->trigger_sensor >= 0)
      add(period_of(s.sensors[static_cast<std::size_t>(op->trigger_sensor)].rate_hz));
    else if (op->rate_hz > 0)
      add(period_of(op->rate_hz));
  }
  return Duration{h};
}

/// One part of a unit at one cost point.
Duration part_cost(const UnitCosts& c, const UnitPart& part) {
  switch (part.kind) {
    case UnitPart::Kind::Encoder:
      return c.encoder();
    case UnitPart::Kind::Head:
      return c.head(part.head);
    case UnitPart::Kind::Plain:
      return c.plain(*part.cost);
  }
  return Duration{0};
}

// export_nptest's steps.

// The window the export covers (x.window, x.hyperperiod, x.note): `window` when given, else one
// hyperperiod after the latest phase where the workload is periodic, else the scenario's.
std::optional<Error> choose_window(const Scenario& s, std::optional<Duration> window,
                                   NptestExport& x) {
  if (window) {
    if (*window <= Duration{0}) return Error{"", 0, "--nptest-window-ms: must be > 0"};
    x.window = *window;
    x.note = "the window given";
  } else {
    bool bounded = false;
    const Duration h = hyperperiod(s, bounded);
    // Releases start at the phases: one hyperperiod after the latest phase.
    Duration phase{0};
    for (const SensorSpec& sn : s.sensors) phase = std::max(phase, sn.phase);
    for (const auto& op : s.initial)
      if (op) phase = std::max(phase, op->phase);
    if (s.events.empty() && bounded && phase + h <= s.duration) {
      x.window = phase + h;
      x.hyperperiod = true;
      x.note = fmt::format("one hyperperiod ({:g} ms) after the latest phase", to_ms(h));
    } else {
      x.window = s.duration;
      x.note = s.events.empty()
                   ? "the scenario's duration (the hyperperiod is longer)"
                   : "the scenario's duration (its events make the workload aperiodic)";
    }
  }
  return std::nullopt;
}

// Every release in the window, by time (ties: operation order): camera frames at their nominal
// times, each late by at most its jitter (below one period), own-rate ticks, one-shot releases.
std::vector<Release> list_releases(const Scenario& s, TimePoint window) {
  const Timeline tl{s};
  std::vector<Release> rel;
  // Camera frames: nominal times, each late by at most its jitter (below one period).
  for (std::size_t sn = 0; sn < s.sensors.size(); ++sn) {
    TimePoint t = s.sensors[sn].phase;
    for (std::int64_t k = 0; t < window; ++k) {
      const Duration period = period_of(tl.rate_at(sn, t));
      const Duration jit = std::min(s.sensors[sn].jitter, period - Duration{1});
      for (std::size_t i = 0; i < s.initial.size(); ++i) {
        auto spec = tl.op_at(i, t);
        if (spec && spec->trigger_sensor == static_cast<int>(sn))
          rel.push_back({i, t, t + std::max(jit, Duration{0}), k, spec});
      }
      t += period;
      if (rel.size() > kNptestMaxJobs) break;
    }
  }
  // Own-rate ticks and one-shot releases.
  for (std::size_t i = 0; i < s.initial.size(); ++i) {
    auto first = tl.op_at(i, Duration{0});
    if (first && first->trigger_sensor < 0 && first->rate_hz <= 0 && first->release_count) {
      for (int k = 0; k < *first->release_count && first->phase < window; ++k)
        rel.push_back({i, first->phase, first->phase, -1, first});
      continue;
    }
    TimePoint t = first ? first->phase : Duration{0};
    std::int64_t count = 0;
    while (t < window && rel.size() <= kNptestMaxJobs) {
      auto spec = tl.op_at(i, t);
      if (!spec || spec->trigger_sensor >= 0 || spec->rate_hz <= 0) {
        t += std::chrono::milliseconds{1};  // absent or not own-rate now: look again later
        continue;
      }
      if (spec->release_count && count >= *spec->release_count) break;
      rel.push_back({i, t, t, -1, spec});
      ++count;
      t += period_of(spec->rate_hz);
    }
  }
  std::stable_sort(rel.begin(), rel.end(), [](const Release& a, const Release& b) {
    return std::tie(a.at, a.op) < std::tie(b.at, b.op);
  });
  return rel;
}

}  // namespace

Expected<NptestExport> export_nptest(const Scenario& s, const Profile& p, const PolicyOptions& o,
                                     std::optional<Duration> window) {
  NptestExport x;
  if (auto e = choose_window(s, window, x)) return *e;
  const std::vector<Release> rel = list_releases(s, x.window);
  const UnitCosts lo(s, p, CostPoint::Min), hi(s, p, CostPoint::Max);
  const CostModel est{&p, &s.model, s.scheduler.estimate};
  const RefineOptions ropt{o.graph, o.deadlines, s.scheduler.level_cost};
  const Duration sync = s.device.sync_cost ? *s.device.sync_cost : p.sync_round_trip;
  const Duration sync_lo = o.sync == SyncMode::PerEdge ? sync : Duration{0};
  std::map<const OperationSpec*, std::shared_ptr<const RefinedGraph>> graphs;
  std::map<std::string, int> task_ids;
  std::string tasks = "Task ID, Kind, Operation, Node\n";
  auto task_id = [&](const std::string& key, const char* kind, const std::string& op,
                     const std::string& node) {
    auto [it, fresh] = task_ids.emplace(key, static_cast<int>(task_ids.size()) + 1);
    if (fresh) tasks += fmt::format("{}, {}, {}, {}\n", it->second, kind, op, node);
    return it->second;
  };
  struct Row {
    int task = 0;
    std::int64_t job = 0;
    TimePoint at{0}, latest{0};
    Duration cmin{0}, cmax{0};
    TimePoint deadline{0}, priority{0};
  };
  std::vector<Row> rows;
  std::map<std::tuple<int, std::int64_t, std::int64_t>, std::size_t> shared;  // sensor, frame/job
  std::set<std::tuple<int, std::int64_t, int, std::int64_t>> edges;
  std::int64_t next_job = 1;
  for (std::size_t r = 0; r < rel.size(); ++r) {
    const Release& re = rel[r];
    const int opi = static_cast<int>(re.op);
    auto& g = graphs[re.spec.get()];
    if (!g) g = refine(re.spec, opi, est, ropt);
    const std::string& op_name = s.operation_name(opi);
    const TimePoint deadline = re.at + g->deadline;
    std::vector<std::size_t> row_of(g->units.size());
    for (std::size_t u = 0; u < g->units.size(); ++u) {
      const RefinedUnit& ru = g->units[u];
      const TimePoint prio = height_deadline(o.deadlines, re.at, deadline, [&] {
        return re.at + g->static_offset[static_cast<std::size_t>(ru.height)];
      });
      Duration cmin{0}, cmax{0};
      std::string key, node;
      const char* kind = to_string(ru.kind);
      const NodeSpec* ns =
          ru.node >= 0 ? &re.spec->nodes[static_cast<std::size_t>(ru.node)] : nullptr;
      for_each_part(*g, ru, [&](const UnitPart& part) {
        cmin += part_cost(lo, part);
        cmax += part_cost(hi, part);
      });
      cmin += sync_lo;
      cmax += sync;
      if (ru.kind == UnitKind::Encoder) {
        // DynamicMerge rule 1 (docs/DESIGN.md, "DynamicMerge"): encoder runs on one frame are one
        // run. Within a job always (same frame); across operations triggered by the same frame
        // under merge.
        const bool by_frame = o.merge && re.frame >= 0 && re.spec->trigger_sensor == ru.sensor;
        const auto skey = by_frame
                              ? std::tuple<int, std::int64_t, std::int64_t>{ru.sensor, re.frame, -1}
                              : std::tuple<int, std::int64_t, std::int64_t>{
                                    ru.sensor, -1, static_cast<std::int64_t>(r)};
        if (o.merge) {
          auto it = shared.find(skey);
          if (it != shared.end()) {
            Row& row = rows[it->second];
            row.deadline = std::min(row.deadline, deadline);
            row.priority = std::min(row.priority, prio);
            row_of[u] = it->second;
            continue;
          }
          shared.emplace(skey, rows.size());
        }
        key = by_frame
                  ? fmt::format("encoder:{}", s.sensors[static_cast<std::size_t>(ru.sensor)].name)
                  : fmt::format("op:{}:{}:encoder", op_name, ns != nullptr ? ns->name : "");
        node = by_frame ? s.sensors[static_cast<std::size_t>(ru.sensor)].name
                        : (ns != nullptr ? ns->name : "") + "/encoder";
      } else if (ns != nullptr) {
        key = fmt::format("op:{}:{}", op_name, ns->name);
        node = ns->name;
      } else {
        key = "op:" + op_name;
        node = "*";
      }
      row_of[u] = rows.size();
      rows.push_back({task_id(key, kind, op_name, node), next_job++, re.at, re.latest, cmin, cmax,
                      deadline, prio});
      if (rows.size() > kNptestMaxJobs)
        return Error{"", 0,
                     fmt::format("more than {} jobs in the {:g} ms window: pass a shorter "
                                 "--nptest-window-ms",
                                 kNptestMaxJobs, to_ms(x.window))};
    }
    for (std::size_t u = 0; u < g->units.size(); ++u)
      for (int pr : g->units[u].preds) {
        const Row& a = rows[row_of[static_cast<std::size_t>(pr)]];
        const Row& b = rows[row_of[u]];
        if (&a != &b) edges.emplace(a.task, a.job, b.task, b.job);
      }
  }
  x.jobs_csv =
      "Task ID, Job ID, Arrival min, Arrival max, Cost min, Cost max, Deadline, Priority\n";
  for (const Row& row : rows)
    x.jobs_csv += fmt::format("{}, {}, {}, {}, {}, {}, {}, {}\n", row.task, row.job,
                              us_floor(row.at), us_ceil(row.latest), us_floor(row.cmin),
                              us_ceil(row.cmax), us_floor(row.deadline), us_floor(row.priority));
  x.prec_csv = "Predecessor TID, Predecessor JID, Successor TID, Successor JID\n";
  for (const auto& [pt, pj, st, sj] : edges)
    x.prec_csv += fmt::format("{}, {}, {}, {}\n", pt, pj, st, sj);
  x.tasks_csv = std::move(tasks);
  x.jobs = rows.size();
  x.edges = edges.size();
  return x;
}

}  // namespace red
