#include "red/metrics/metrics.hpp"

#include <algorithm>
#include <cmath>

namespace red {

double percentile_sorted(const std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, rank == 0 ? 0 : rank - 1)];
}

double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  return percentile_sorted(values, p);
}

double qoe_score(Duration response, Duration deadline, double lambda) {
  const double late = std::max(0.0, to_s(response) - to_s(deadline));
  return 1.0 / (1.0 + std::exp(lambda) * late);
}

MetricsCollector::MetricsCollector(const Scenario& s, double qoe_lambda, bool keep_units)
    : scenario_(s), lambda_(qoe_lambda), keep_units_(keep_units) {
  busy_.assign(static_cast<std::size_t>(s.device.lanes), Duration{0});
  head_outputs_.assign(s.model.heads.size(), 0);
}

void MetricsCollector::on_job_end(const JobRecord& j) {
  if (const auto it = spent_.find(j.id); it != spent_.end()) {
    Spent& sp = it->second;
    sp.ended = true;
    sp.wasted = j.counted && (j.outcome == JobOutcome::Dropped ||
                              j.outcome == JobOutcome::Skipped || j.outcome == JobOutcome::Failed);
    if (sp.wasted) wasted_ += sp.time;
    if (sp.running <= 0) spent_.erase(it);
  }
  if (!j.counted) return;
  JobRow r;
  r.operation = j.operation;
  r.seq = j.seq;
  r.id = j.id;
  r.release = j.release;
  r.finish = j.finish;
  r.deadline = j.deadline;
  r.outcome = j.outcome;
  r.frame_age = j.frame_age;
  r.reason = std::string(j.reason);
  if (j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed)
    r.qoe = qoe_score(j.finish - j.release, j.deadline - j.release, lambda_);
  count(r);
  if (sink_ != nullptr) sink_->on_job_row(r);
  if (keep_rows_) jobs_.push_back(std::move(r));
}

void MetricsCollector::count(const JobRow& j) {
  PolicyMetrics& m = counts_;
  tally_.add(j.outcome, j.qoe);
  if (j.outcome == JobOutcome::Dropped || j.outcome == JobOutcome::Skipped ||
      j.outcome == JobOutcome::Failed)
    ++m.drop_reasons[j.reason.empty() ? std::string(to_string(j.outcome)) : j.reason];
  if (j.outcome == JobOutcome::Failed) ++m.failure_reasons[j.reason];
  if (j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed) {
    latency_.add(to_ms(j.finish - j.release));
    frame_age_.add(to_ms(j.frame_age));
  }
}

void MetricsCollector::set_keep_rows(bool keep) {
  keep_rows_ = keep;
  const std::size_t cap = keep ? BoundedDistribution::kUnbounded : BoundedDistribution::kDefaultCap;
  latency_ = BoundedDistribution(cap);
  frame_age_ = BoundedDistribution(cap);
}

std::size_t MetricsCollector::kept() const noexcept {
  return jobs_.size() + units_.size() + latency_.kept() + frame_age_.kept() + spent_.size() +
         counts_.drop_reasons.size() + counts_.failure_reasons.size() + batches_.size();
}

void MetricsCollector::on_merge_wait(int /*sensor*/, TimePoint now, TimePoint /*until*/) {
  if (now >= scenario_.warmup) ++merge_waits_;
}

void MetricsCollector::on_unit_start(const Dispatch& d) {
  for (const Member& m : d.members) ++spent_[m.job].running;
}

void MetricsCollector::on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) {
  // The start it ran from (a unit queued behind another starts when that one ends: the
  // scheduler moves its start then).
  const TimePoint start = d.start;
  const TimePoint from = std::max(start, scenario_.warmup);
  const Duration share =
      end > from ? (end - from) / static_cast<std::int64_t>(d.members.size()) : Duration{0};
  if (end > from) busy_[static_cast<std::size_t>(d.lane)] += end - from;
  for (const Member& m : d.members) {
    const auto it = spent_.find(m.job);
    if (it == spent_.end()) continue;  // not seen starting (observer attached late)
    Spent& sp = it->second;
    sp.time += share;
    // A unit that ran on past its job's end (the job was dropped meanwhile) still counts.
    if (sp.wasted) wasted_ += share;
    if (--sp.running <= 0 && sp.ended) spent_.erase(it);
  }
  if (start < scenario_.warmup) return;
  ++dispatches_;
  if (d.round_trip) ++round_trips_;
  ++batches_[d.batch];
  const std::int64_t members = static_cast<std::int64_t>(d.members.size());
  const RefinedGraph& g = *d.members.front().graph;
  switch (d.kind) {
    case UnitKind::Encoder:
      encoder_runs_ += d.batch;
      encoder_saved_ += members - d.batch;
      break;
    case UnitKind::Coarse:
      encoder_runs_ += 1;
      break;
    case UnitKind::Mono: {
      std::int64_t inference = 0;
      for (const NodeSpec& n : g.spec->nodes) inference += n.is_plain() ? 0 : 1;
      encoder_runs_ += static_cast<std::int64_t>(g.sensors.size());
      encoder_saved_ += inference - static_cast<std::int64_t>(g.sensors.size());
      break;
    }
    case UnitKind::Head:
    case UnitKind::Plain:
      break;
  }
  if (s == UnitStatus::Completed) {
    for (const Member& m : d.members) {
      const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
      for (int n : ru.produces) {
        const int h = m.graph->spec->nodes[static_cast<std::size_t>(n)].head;
        if (h >= 0 && ru.kind != UnitKind::Encoder) ++head_outputs_[static_cast<std::size_t>(h)];
      }
    }
  }
  if (!keep_units_ || (!keep_rows_ && sink_ == nullptr)) return;
  UnitRow r;
  r.dispatch = d.id;
  r.lane = d.lane;
  r.decided = d.decided_at;
  r.start = start;
  r.end = end;
  r.kind = d.kind;
  r.head = d.head;
  r.batch = d.batch;
  r.members = static_cast<int>(members);
  r.round_trip = d.round_trip;
  r.status = s;
  r.expected = d.expected;
  for (const Member& m : d.members) {
    if (!r.jobs.empty()) r.jobs += ' ';
    r.jobs += scenario_.operation_name(m.operation);
    r.jobs += '#';
    r.jobs += std::to_string(m.job_seq);
    if (m.node >= 0) {
      r.jobs += ':';
      r.jobs += m.graph->spec->nodes[static_cast<std::size_t>(m.node)].name;
    }
  }
  if (sink_ != nullptr) sink_->on_unit_row(r);
  if (keep_rows_) units_.push_back(std::move(r));
}

namespace {

double round6(double x) {
  return std::round(x * 1e6) / 1e6;
}

}  // namespace

PolicyMetrics MetricsCollector::summarize(const std::string& name, TimePoint end) const {
  PolicyMetrics m = counts_;
  m.name = name;
  const OutcomeTally& t = tally_;
  const Duration wasted = wasted_;
  m.jobs = t.jobs;
  m.completed = t.completed();
  m.met = t.met;
  m.missed = t.missed();  // late or without result (docs/DESIGN.md, "Metrics")
  m.dropped = t.dropped;
  m.skipped = t.skipped;
  m.failed = t.failed;
  m.unfinished = t.unfinished;
  if (m.jobs > 0) m.on_time = round6(static_cast<double>(m.met) / static_cast<double>(m.jobs));
  if (t.decided() > 0) {
    m.miss_rate = round6(t.miss_rate());
    m.drop_rate = round6(t.drop_rate());
    m.qoe = round6(t.qoe());
  }
  if (latency_.count() > 0) {
    const auto n = static_cast<double>(latency_.count());
    m.latency.mean = round6(latency_.sum() / n);
    const std::vector<double> lat = latency_.percentiles({0.50, 0.90, 0.99});
    m.latency.p50 = round6(lat[0]);
    m.latency.p90 = round6(lat[1]);
    m.latency.p99 = round6(lat[2]);
    m.latency.max = round6(latency_.max());
    m.frame_age_mean_ms = round6(frame_age_.sum() / n);
    m.frame_age_p99_ms = round6(frame_age_.percentile(0.99));
    if (!latency_.exact() || !frame_age_.exact()) {
      m.percentile_error = latency_.relative_error();
      m.percentile_exact_up_to = static_cast<std::int64_t>(latency_.cap());
    }
  }
  m.encoder_runs = encoder_runs_;
  m.encoder_runs_saved = encoder_saved_;
  m.sync_round_trips = round_trips_;
  m.dispatches = dispatches_;
  m.merge_waits = merge_waits_;  // after warm-up, like every other figure
  m.batch_sizes = batches_;
  const double window = std::max(1e-9, to_s(end - scenario_.warmup));
  m.measured_s = round6(window);
  Duration busy{0};
  for (Duration b : busy_) {
    m.lane_utilization.push_back(round6(std::min(1.0, to_s(b) / window)));
    busy += b;
  }
  if (busy > Duration{0}) m.wasted_lane_fraction = round6(to_s(wasted) / to_s(busy));
  for (std::size_t h = 0; h < head_outputs_.size(); ++h)
    m.throughput_hz[scenario_.model.heads[h]] =
        round6(static_cast<double>(head_outputs_[h]) / window);
  return m;
}

void apply_ratios(std::vector<PolicyMetrics>& all, const std::string& baseline) {
  const PolicyMetrics* base = nullptr;
  for (const PolicyMetrics& m : all)
    if (m.name == baseline) base = &m;
  if (base == nullptr) return;
  auto ratio = [](double a, double b) -> std::optional<double> {
    if (b == 0.0) return a == 0.0 ? std::optional<double>(1.0) : std::nullopt;
    return std::round(a / b * 1e4) / 1e4;
  };
  const PolicyMetrics b = *base;
  for (PolicyMetrics& m : all) {
    m.ratio_miss = ratio(m.miss_rate, b.miss_rate);
    m.ratio_latency = ratio(m.latency.mean, b.latency.mean);
    m.ratio_qoe = ratio(m.qoe, b.qoe);
  }
}

}  // namespace red
