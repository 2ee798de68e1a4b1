#include "red/metrics/phases.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace red {

namespace {

double round6(double x) {
  return std::round(x * 1e6) / 1e6;
}

bool completed(const JobRow& j) {
  return j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
}

// Accumulates one set of jobs; the same rules as MetricsCollector::summarize (OutcomeTally).
struct Tally {
  OutcomeTally t;
  std::vector<double> latency_ms;
  std::map<std::string, std::int64_t> causes;

  void add(const JobRow& j) {
    t.add(j.outcome, j.qoe);
    if (!j.cause.empty()) ++causes[j.cause];
    if (completed(j)) latency_ms.push_back(to_ms(j.finish - j.release));
  }

  PhaseFigures done() {
    PhaseFigures f;
    f.jobs = t.jobs;
    f.completed = t.completed();
    f.missed = t.missed();  // late or without result
    f.dropped = t.dropped;
    f.unfinished = t.unfinished;
    if (t.decided() > 0) {
      f.miss_rate = round6(t.miss_rate());
      f.drop_rate = round6(t.drop_rate());
      f.qoe = round6(t.qoe());
    }
    std::sort(latency_ms.begin(), latency_ms.end());
    f.latency_p50_ms = round6(percentile_sorted(latency_ms, 0.50));
    f.latency_p99_ms = round6(percentile_sorted(latency_ms, 0.99));
    f.causes = causes;
    return f;
  }
};

}  // namespace

std::vector<PhaseSpan> workload_phases(const Scenario& s, TimePoint end) {
  std::vector<PhaseSpan> out;
  out.push_back({s.warmup, std::max(end, s.warmup), {}});
  for (std::size_t i = 0; i < s.events.size(); ++i) {
    const TimePoint at = s.events[i].at;
    if (at <= s.warmup) {
      // Before the measured window: its effect is in the first phase.
      out.front().events.push_back(static_cast<int>(i));
      continue;
    }
    if (at >= end) continue;
    if (at == out.back().from) {
      out.back().events.push_back(static_cast<int>(i));  // events at the same time: one phase
      continue;
    }
    out.back().to = at;
    out.push_back({at, end, {static_cast<int>(i)}});
  }
  return out;
}

std::vector<PhaseMetrics> phase_metrics(const Scenario& s, const std::vector<JobRow>& jobs,
                                        TimePoint end) {
  const std::vector<PhaseSpan> spans = workload_phases(s, end);
  const auto ops = static_cast<std::size_t>(s.operation_count());
  std::vector<Tally> all(spans.size());
  std::vector<std::vector<Tally>> per_op(spans.size(), std::vector<Tally>(ops));
  for (const JobRow& j : jobs) {
    // The phase of its release; jobs released after the last boundary (the run's tail,
    // when `end` is early) stay in the last phase, so every job is in exactly one.
    std::size_t p = 0;
    while (p + 1 < spans.size() && j.release >= spans[p + 1].from) ++p;
    all[p].add(j);
    if (j.operation >= 0 && static_cast<std::size_t>(j.operation) < ops)
      per_op[p][static_cast<std::size_t>(j.operation)].add(j);
  }
  std::vector<PhaseMetrics> out;
  for (std::size_t p = 0; p < spans.size(); ++p) {
    PhaseMetrics m;
    m.span = spans[p];
    m.all = all[p].done();
    for (std::size_t o = 0; o < ops; ++o)
      if (per_op[p][o].t.jobs > 0)
        m.operations.emplace_back(s.operation_name(static_cast<int>(o)), per_op[p][o].done());
    out.push_back(std::move(m));
  }
  return out;
}

std::string phase_label(const Scenario& s, const PhaseSpan& span) {
  if (span.events.empty()) return s.events.empty() ? "whole run" : "start";
  std::string kinds, indices;
  for (int e : span.events) {
    kinds += (kinds.empty() ? "" : ", ") + s.events[static_cast<std::size_t>(e)].kind;
    indices += (indices.empty() ? "" : ", ") + std::to_string(e);
  }
  return fmt::format("after {} (event{} {})", kinds, span.events.size() > 1 ? "s" : "", indices);
}

std::string phase_table(const Scenario& s, const std::vector<std::string>& policies,
                        const std::vector<std::vector<PhaseMetrics>>& phases) {
  std::string out;
  // No completed job, no latency: "-" rather than a 0 that reads as instant.
  auto latency = [](double ms, const PhaseFigures& f) {
    return f.completed > 0 ? fmt::format("{:.2f}", ms) : std::string("-");
  };
  auto row = [&](const PhaseMetrics& ph, const std::string& op, const PhaseFigures& f) {
    out += fmt::format(
        "{:>7.3f} {:>7.3f}  {:<12} {:>6} {:>7.2f} {:>7.2f} {:>6.3f} {:>8} {:>8}  {}\n",
        to_s(ph.span.from), to_s(ph.span.to), op, f.jobs, 100.0 * f.miss_rate, 100.0 * f.drop_rate,
        f.qoe, latency(f.latency_p50_ms, f), latency(f.latency_p99_ms, f), phase_label(s, ph.span));
  };
  for (std::size_t i = 0; i < policies.size() && i < phases.size(); ++i) {
    out += fmt::format("phases of {} (jobs by release time):\n", policies[i]);
    out += fmt::format("{:>7} {:>7}  {:<12} {:>6} {:>7} {:>7} {:>6} {:>8} {:>8}  {}\n", "from s",
                       "to s", "operation", "jobs", "miss%", "drop%", "QoE", "p50 ms", "p99 ms",
                       "phase");
    for (const PhaseMetrics& ph : phases[i]) {
      for (const auto& [op, f] : ph.operations) row(ph, op, f);
      if (ph.operations.size() != 1) row(ph, "all", ph.all);
    }
  }
  return out;
}

}  // namespace red
