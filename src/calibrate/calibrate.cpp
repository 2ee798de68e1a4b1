/// \file
/// Calibration: fits the simulator's model of a real run to the units of real runs
/// (docs/FIDELITY.md). A unit's time is modelled as
///   residual(u) × lane_factor[other lanes busy at its start] × factor(block of its start),
/// each part measured: the lane factor from units that started beside k busy lanes, the
/// time factor as the median ratio within each block, the residual as what is left.

#include "red/calibrate/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

#include <fmt/format.h>

namespace red {

namespace {

struct Sample {
  std::string name;
  int batch = 1;
  Duration dur{0};
  int busy_others = 0;
  std::size_t run = 0;
  std::int64_t block = 0;
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 1.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const double hi = *mid;
  const double lo = *std::max_element(v.begin(), mid);
  return 0.5 * (lo + hi);
}

/// The value at quantile q of sorted values, linear between ranks.
double at_quantile(const std::vector<double>& sorted, double q) {
  if (sorted.size() == 1) return sorted.front();
  const double x = q * static_cast<double>(sorted.size() - 1);
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= sorted.size()) return sorted.back();
  const double f = x - static_cast<double>(i);
  return sorted[i] + f * (sorted[i + 1] - sorted[i]);
}

Duration ns(double v) {
  return Duration{static_cast<std::int64_t>(std::llround(v))};
}

LatencyStats stats_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  LatencyStats s;
  s.samples = static_cast<int>(v.size());
  s.min = ns(v.front());
  s.max = ns(v.back());
  s.mean = ns(std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size()));
  s.p50 = ns(at_quantile(v, 0.50));
  s.p95 = ns(at_quantile(v, 0.95));
  s.p99 = ns(at_quantile(v, 0.99));
  s.mean = std::clamp(s.mean, s.min, s.max);
  return s;
}

LatencyStats scaled(const LatencyStats& s, double k) {
  auto sc = [k](Duration d) { return ns(static_cast<double>(d.count()) * k); };
  LatencyStats o = s;
  o.min = sc(s.min);
  o.mean = sc(s.mean);
  o.p50 = sc(s.p50);
  o.p95 = sc(s.p95);
  o.p99 = sc(s.p99);
  o.max = sc(s.max);
  return o;
}

/// Units running on other lanes when each unit started.
std::vector<int> busy_others(const std::vector<UnitRow>& rows) {
  std::map<int, std::vector<std::pair<TimePoint, TimePoint>>> by_lane;
  for (const UnitRow& r : rows) by_lane[r.lane].emplace_back(r.start, r.end);
  for (auto& [lane, v] : by_lane) std::sort(v.begin(), v.end());
  std::vector<int> out;
  out.reserve(rows.size());
  for (const UnitRow& r : rows) {
    int k = 0;
    for (const auto& [lane, v] : by_lane) {
      if (lane == r.lane) continue;
      // The last unit of that lane starting before r: is it still running?
      auto it = std::upper_bound(v.begin(), v.end(), std::make_pair(r.start, TimePoint::max()));
      if (it != v.begin() && std::prev(it)->second > r.start) ++k;
    }
    out.push_back(k);
  }
  return out;
}

/// (unit name, batch size)
using Key = std::pair<std::string, int>;

/// Step 1: every completed unit with its name, time, lanes busy beside it and time block, and
/// the hand-offs the runtime timed.
struct Gathered {
  std::vector<Sample> samples;
  std::vector<double> handoffs, round_trips, queued_gaps;  // ns
};

Gathered gather(const std::vector<CalibrationRun>& runs, const Scenario& s,
                const CalibrationOptions& o) {
  Gathered g;
  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const std::vector<UnitRow>& rows = runs[ri].units;
    const std::vector<int> busy = busy_others(rows);
    for (double h : runs[ri].handoff_us)
      if (h >= 0.0 && h < 5000.0)
        (runs[ri].round_trips ? g.round_trips : g.handoffs).push_back(h * 1e3);
    for (double q : runs[ri].queued_gap_us)
      if (q >= 0.0 && q < 5000.0) g.queued_gaps.push_back(q * 1e3);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const UnitRow& r = rows[i];
      if (r.status != UnitStatus::Completed || r.end <= r.start) continue;
      std::string name = calibration_unit_name(r, s);
      if (name.empty()) continue;
      g.samples.push_back(Sample{std::move(name), std::max(1, r.batch), r.end - r.start, busy[i],
                                 ri, r.start.count() / o.block.count()});
    }
  }
  return g;
}

/// Step 2: a baseline per (unit, batch): the median of units that ran with no other lane
/// busy (of all of them where too few did), and every time of each.
struct Baselines {
  std::map<Key, std::vector<double>> all;
  std::map<Key, double> base;
  [[nodiscard]] double of(const Sample& x) const { return base.at({x.name, x.batch}); }
};

Baselines baselines(const std::vector<Sample>& samples, const CalibrationOptions& o) {
  Baselines b;
  std::map<Key, std::vector<double>> alone;
  for (const Sample& x : samples) {
    const auto d = static_cast<double>(x.dur.count());
    b.all[{x.name, x.batch}].push_back(d);
    if (x.busy_others == 0) alone[{x.name, x.batch}].push_back(d);
  }
  for (const auto& [k, v] : b.all) {
    const auto a = alone.find(k);
    b.base[k] = a != alone.end() && static_cast<int>(a->second.size()) >= o.min_samples
                    ? median_of(a->second)
                    : median_of(v);
  }
  return b;
}

/// Step 3: lane factors, the median ratio to the baseline of units started beside k busy
/// lanes (index 0 is 1; a k seen too rarely keeps k - 1's).
struct LaneFactors {
  std::vector<double> factors{1.0};
  int max_busy = 0;
  [[nodiscard]] double at(int k) const {
    return factors[static_cast<std::size_t>(std::min(k, max_busy))];
  }
};

LaneFactors lane_factors_of(const std::vector<Sample>& samples, const Baselines& b,
                            const CalibrationOptions& o) {
  LaneFactors l;
  for (const Sample& x : samples) l.max_busy = std::max(l.max_busy, x.busy_others);
  for (int k = 1; k <= l.max_busy; ++k) {
    std::vector<double> r;
    for (const Sample& x : samples)
      if (x.busy_others == k) r.push_back(static_cast<double>(x.dur.count()) / b.of(x));
    l.factors.push_back(r.size() >= static_cast<std::size_t>(o.min_samples)
                            ? std::clamp(median_of(r), 0.05, 20.0)
                            : l.factors.back());
  }
  return l;
}

/// Step 4: time factors, per run and block the median ratio of its units to their baseline
/// (the lane factor divided out); `factors` in time order within each run.
struct TimeFactors {
  std::map<std::pair<std::size_t, std::int64_t>, double> by_block;
  std::vector<double> factors;
};

TimeFactors time_factors(const std::vector<Sample>& samples, const Baselines& b,
                         const LaneFactors& lanes) {
  std::map<std::pair<std::size_t, std::int64_t>, std::vector<double>> per_block;
  for (const Sample& x : samples)
    per_block[{x.run, x.block}].push_back(static_cast<double>(x.dur.count()) /
                                          (b.of(x) * lanes.at(x.busy_others)));
  TimeFactors t;
  for (const auto& [k, v] : per_block) {
    const double f = std::clamp(median_of(v), 0.05, 20.0);
    t.by_block[k] = f;
    t.factors.push_back(f);  // map order: run, then block: time order within each run
  }
  return t;
}

/// The residual quantile table of some times: `o.table_points` quantiles, u = 0 .. 1.
std::vector<Duration> table_of(std::vector<double> v, const CalibrationOptions& o) {
  std::sort(v.begin(), v.end());
  std::vector<Duration> t;
  for (int i = 0; i < o.table_points; ++i)
    t.push_back(ns(at_quantile(v, static_cast<double>(i) / (o.table_points - 1))));
  return t;
}

/// Step 5: each (unit, batch) seen often enough gets its in-run statistics in `p` and its
/// residual table (both factors divided out) in `cal`. Returns the in-run / isolated mean
/// ratio per unit and batch size seen.
std::map<std::string, std::map<int, double>> fit_units(const Profile& isolated,
                                                       const std::vector<Sample>& samples,
                                                       const Baselines& b, const LaneFactors& lanes,
                                                       const TimeFactors& time,
                                                       const CalibrationOptions& o, Profile& p,
                                                       Calibration& cal) {
  std::map<Key, std::vector<double>> residual;
  for (const Sample& x : samples)
    residual[{x.name, x.batch}].push_back(
        static_cast<double>(x.dur.count()) /
        (time.by_block.at({x.run, x.block}) * lanes.at(x.busy_others)));
  std::map<std::string, std::map<int, double>> ratio;  // in-run / isolated mean, by batch
  for (const auto& [k, v] : b.all) {
    const auto& [name, batch] = k;
    if (static_cast<int>(v.size()) < o.min_samples) continue;
    UnitProfile& u = p.units[name];
    const LatencyStats in_run = stats_of(v);
    if (const UnitProfile* iso = isolated.find(name); iso != nullptr && batch <= iso->max_batch())
      ratio[name][batch] = static_cast<double>(in_run.mean.count()) /
                           std::max(1.0, static_cast<double>(iso->at(batch).mean.count()));
    // Batch sizes below `batch` that were never seen keep (or get) isolated figures first.
    while (u.max_batch() < batch) u.by_batch.push_back(in_run);
    u.by_batch[static_cast<std::size_t>(batch - 1)] = in_run;
    auto& tables = cal.residual[name];
    if (static_cast<int>(tables.size()) < batch) tables.resize(static_cast<std::size_t>(batch));
    tables[static_cast<std::size_t>(batch - 1)] = table_of(residual[k], o);
  }
  return ratio;
}

/// Step 6: batch sizes of a calibrated unit never seen in the runs, scaled by the nearest
/// measured size's in-run / isolated ratio; their residual is the scaled isolated
/// distribution (the time factor's median is about 1, so the in-run scale stands).
void fill_unseen_batches(const Profile& isolated,
                         const std::map<std::string, std::map<int, double>>& ratio,
                         const CalibrationOptions& o, Profile& p, Calibration& cal) {
  for (const auto& [name, by_batch] : ratio) {
    const UnitProfile* iso = isolated.find(name);
    if (iso == nullptr) continue;
    UnitProfile& u = p.units[name];
    auto& tables = cal.residual[name];
    tables.resize(static_cast<std::size_t>(std::max(iso->max_batch(), u.max_batch())));
    for (int b = 1; b <= iso->max_batch(); ++b) {
      if (by_batch.count(b) != 0) continue;
      auto nearest = by_batch.begin();
      for (auto it = by_batch.begin(); it != by_batch.end(); ++it)
        if (std::abs(it->first - b) < std::abs(nearest->first - b)) nearest = it;
      const LatencyStats est = scaled(iso->at(b), nearest->second);
      if (u.max_batch() < b) u.by_batch.resize(static_cast<std::size_t>(b), est);
      u.by_batch[static_cast<std::size_t>(b - 1)] = est;
      std::vector<Duration> t;
      for (int i = 0; i < o.table_points; ++i)
        t.push_back(est.quantile(static_cast<double>(i) / (o.table_points - 1)));
      tables[static_cast<std::size_t>(b - 1)] = std::move(t);
    }
  }
}

}  // namespace

std::string calibration_unit_name(const UnitRow& row, const Scenario& s) {
  auto head = [&]() -> std::string {
    if (row.head < 0 || row.head >= static_cast<int>(s.model.heads.size())) return "";
    return s.model.heads[static_cast<std::size_t>(row.head)];
  };
  switch (row.kind) {
    case UnitKind::Encoder:
      return "encoder";
    case UnitKind::Head:
      return head().empty() ? "" : "head/" + head();
    case UnitKind::Coarse:
      return head().empty() ? "" : "coarse/" + head();
    case UnitKind::Mono: {
      // jobs: "op#seq:node ..."; the operation of the first member.
      const auto hash = row.jobs.find('#');
      if (hash == std::string::npos || hash == 0) return "";
      return "mono/" + row.jobs.substr(0, hash);
    }
    case UnitKind::Plain:
      return "";
  }
  return "";
}

Expected<Profile> calibrate_profile(const Profile& isolated, const Scenario& s,
                                    const std::vector<CalibrationRun>& runs,
                                    const CalibrationOptions& o) {
  if (o.block <= Duration{0} || o.run_blocks < 1 || o.table_points < 2 || o.min_samples < 1)
    return Error{"", 0, "calibration options: block > 0, run_blocks >= 1, table_points >= 2"};
  Gathered g = gather(runs, s, o);
  if (g.samples.size() < static_cast<std::size_t>(o.min_samples))
    return Error{"", 0,
                 fmt::format("calibration: the real runs completed {} units; too few to fit",
                             g.samples.size())};
  const Baselines b = baselines(g.samples, o);
  const LaneFactors lanes = lane_factors_of(g.samples, b, o);
  TimeFactors time = time_factors(g.samples, b, lanes);
  Profile p = isolated;
  p.source = "calibrated";
  Calibration cal;
  cal.scenario = s.file;
  for (const CalibrationRun& r : runs) cal.policies.push_back(r.policy);
  cal.seconds_per_policy = o.seconds_per_policy;
  cal.interference = s.interference ? s.interference->intensity : 0.0;
  cal.block = o.block;
  cal.run_blocks = o.run_blocks;
  cal.factors = std::move(time.factors);
  cal.lane_factors = lanes.factors;
  if (!g.handoffs.empty()) cal.handoff = ns(median_of(g.handoffs));
  if (!g.queued_gaps.empty()) cal.queued_gap = ns(median_of(g.queued_gaps));
  if (!g.round_trips.empty()) p.sync_round_trip = ns(median_of(g.round_trips));
  const auto ratio = fit_units(isolated, g.samples, b, lanes, time, o, p, cal);
  fill_unseen_batches(isolated, ratio, o, p, cal);
  // A table left empty (a batch size neither measured nor isolated) falls back to the stats.
  p.calibration = std::move(cal);
  return p;
}

std::string calibration_table(const Profile& isolated, const Profile& calibrated) {
  std::string out = fmt::format("{:<16} {:>5} {:>8} {:>13} {:>13} {:>12} {:>7}\n", "unit", "batch",
                                "samples", "isolated ms", "in-run ms", "in-run p99", "ratio");
  for (const auto& [name, u] : calibrated.units) {
    for (int b = 1; b <= u.max_batch(); ++b) {
      const LatencyStats& c = u.at(b);
      if (calibrated.calibration && c.samples == 0) continue;
      const UnitProfile* iso = isolated.find(name);
      const bool measured_in_run = iso == nullptr || b > iso->max_batch() ||
                                   iso->at(b).samples != c.samples || iso->at(b).mean != c.mean;
      if (!measured_in_run) continue;
      const double iso_ms = iso != nullptr && b <= iso->max_batch() ? to_ms(iso->at(b).mean) : 0.0;
      out +=
          fmt::format("{:<16} {:>5} {:>8} {:>13} {:>13.3f} {:>12.3f} {:>7}\n", name, b, c.samples,
                      iso_ms > 0 ? fmt::format("{:.3f}", iso_ms) : "-", to_ms(c.mean), to_ms(c.p99),
                      iso_ms > 0 ? fmt::format("{:.2f}", to_ms(c.mean) / iso_ms) : "-");
    }
  }
  if (calibrated.calibration) {
    const Calibration& k = *calibrated.calibration;
    std::vector<double> f = k.factors;
    std::sort(f.begin(), f.end());
    if (!f.empty())
      out += fmt::format(
          "time factor per {:.0f} ms block ({} blocks): min {:.2f}, p10 {:.2f}, median {:.2f}, "
          "p90 {:.2f}, max {:.2f}\n",
          to_ms(k.block), f.size(), f.front(), at_quantile(f, 0.1), at_quantile(f, 0.5),
          at_quantile(f, 0.9), f.back());
    std::string lf;
    for (std::size_t i = 0; i < k.lane_factors.size(); ++i)
      lf += fmt::format("{}{} busy: {:.2f}", i ? ", " : "", i, k.lane_factors[i]);
    out += fmt::format("lane factor by other lanes busy at start: {}\n", lf);
    out += fmt::format("hand-off without a round trip: {:.1f} us; round trip: {:.1f} us\n",
                       to_us(k.handoff), to_us(calibrated.sync_round_trip));
    if (k.queued_gap > Duration{0})
      out += fmt::format("gap before a unit queued on its lane: {:.1f} us\n", to_us(k.queued_gap));
  }
  return out;
}

}  // namespace red
