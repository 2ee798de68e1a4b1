/// \file
/// BM_Decision64: one scheduling decision with 64 jobs in flight (docs/DESIGN.md, "Performance
/// targets": median ≤ 2 μs, p99 ≤ 20 μs).
///
/// A decision is what the global synchronizer does when a unit finishes: on_complete()
/// on the lane, dispatch() picks the next unit (ranking every ready task, with docs/DESIGN.md,
/// "Intermediate deadlines" re-assignment of intermediate deadlines under `red`), on_start() for
/// what it picked. Releases, frames, strict drops and merge-wait wake-ups happen between decisions,
/// as in the simulator, but outside the timed window. Each decision is timed on its own with
/// steady_clock, so the benchmark reports the median and p99 per decision (counters
/// p50_us, p99_us), not only the mean.
///
/// The workload: 32 own-rate operations (240 Hz each, sampling the newest frame of one
/// 30 Hz camera), alternately 3 nodes (lane, seg -> steer) and 2 nodes (det -> steer),
/// 200 ms deadlines, max_inflight 2, gamma 10 ms, on 4 lanes with the built-in default
/// profile. Releases outpace the lanes, so every operation keeps up to 2 jobs in flight:
/// 64 in all, fewer for a moment after jobs finish, until their operations' next ticks
/// (the counter `inflight` shows the mean seen at the decisions).

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "red/core/assert.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/round.hpp"
#include "red/sched/scheduler.hpp"
#include "red/sim/cost_sampler.hpp"

namespace red::bench {

namespace {

constexpr int kOperations = 32;
constexpr int kMaxInflight = 2;  // 32 operations x 2 = 64 jobs in flight
constexpr int kLanes = 4;
constexpr int kWarmupDecisions = 20'000;

/// The scenario text: see the file comment.
std::string decision_scenario_yaml() {
  std::string y = fmt::format(
      "name: decision64\n"
      // Long enough for every decision the benchmarks take (about 1,500 a simulated
      // second), within the scenario limit of 1e7 releases a run (32 x 240 Hz x 1300 s).
      "duration_s: 1300\n"
      "seed: 3\n"
      "device: {{lanes: {}}}\n"
      "model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}\n"
      "scheduler: {{gamma_ms: 10}}\n"
      "sensors:\n"
      "  camera: {{rate_hz: 30}}\n"
      "operations:\n",
      kLanes);
  for (int i = 0; i < kOperations; ++i) {
    y += fmt::format(
        "  - name: op{}\n"
        "    rate_hz: 240\n"
        "    phase_ms: {:.3f}\n"
        "    deadline_ms: 200\n"
        "    max_inflight: {}\n",
        i, 4.0 * i / kOperations, kMaxInflight);
    if (i % 2 == 0)
      y += "    nodes: {L: {head: lane, sensor: camera}, S: {head: seg, sensor: camera}, "
           "C: {head: steer, sensor: camera}}\n"
           "    edges: [[L, C], [S, C]]\n";
    else
      y += "    nodes: {O: {head: det, sensor: camera}, C: {head: steer, sensor: camera}}\n"
           "    edges: [[O, C]]\n";
  }
  return y;
}

Scenario must_parse(const std::string& yaml) {
  auto s = parse_scenario(yaml, "decision64.yaml");
  if (!s) {
    std::fprintf(stderr, "red_bench: %s\n", s.error().to_string().c_str());
    std::abort();
  }
  return std::move(s.value());
}

using Clock = std::chrono::steady_clock;

/// Drives a Scheduler with a virtual clock and sampled unit costs (a minimal simulator),
/// stopping at every unit completion to time the decision made there.
class DecisionDriver {
 public:
  explicit DecisionDriver(const std::string& policy)
      : scenario_(must_parse(decision_scenario_yaml())),
        profile_(default_profile()),
        scheduler_(scenario_, profile_, make_policy(policy), SchedulerConfig::from(scenario_)),
        sampler_(scenario_, profile_, scenario_.seed),
        sync_cost_(profile_.sync_round_trip),
        frame_period_(Duration{static_cast<std::int64_t>(1e9 / scenario_.sensors[0].rate_hz)}),
        lane_end_(static_cast<std::size_t>(kLanes), kNever) {}

  /// Runs to steady state: 64 jobs in flight, lanes busy, scratch vectors grown.
  void warm_up() {
    for (int i = 0; i < kWarmupDecisions; ++i) (void)step();
  }

  /// Advances to the next unit completion and times the decision made there:
  /// on_complete + dispatch + on_start (releases and drops due at that instant are
  /// applied between on_complete and dispatch, untimed).
  Duration step() {
    for (;;) {
      int lane = -1;
      TimePoint end = kNever;
      for (std::size_t i = 0; i < lane_end_.size(); ++i)
        if (lane_end_[i] < end) {
          end = lane_end_[i];
          lane = static_cast<int>(i);
        }
      TimePoint wake = scheduler_.next_wakeup();
      // Everything due by now_ has been handled at now_: a wake-up at or before now_ could
      // only be a stale one, and following it would spin without moving the clock.
      if (wake <= now_) wake = kNever;
      if (next_frame_ <= end && next_frame_ <= wake) {
        now_ = next_frame_;
        untimed_round([&] { scheduler_.on_frame(0, frame_++, now_); });
        next_frame_ += frame_period_;
        continue;
      }
      if (wake < end) {
        now_ = wake;
        untimed_round([] {});
        continue;
      }
      RED_ASSERT(lane >= 0);
      now_ = end;
      lane_end_[static_cast<std::size_t>(lane)] = kNever;
      inflight_ = scheduler_.jobs_in_flight();
      // One round (red/sched/round.hpp); the completion and the decision are timed.
      Clock::time_point t0, t1;
      open_round(scheduler_, now_, [&] {
        t0 = Clock::now();
        scheduler_.on_complete(lane, now_, UnitStatus::Completed);
        t1 = Clock::now();
      });
      ready_ = scheduler_.ready_tasks();
      const auto t2 = Clock::now();
      const std::span<Dispatch* const> started = scheduler_.dispatch(now_);
      for (Dispatch* d : started) scheduler_.on_start(d->lane, start_time(*d));
      const auto t3 = Clock::now();
      picked_ = !started.empty();
      for (Dispatch* d : started) lane_end_[static_cast<std::size_t>(d->lane)] = end_time(*d);
      return std::chrono::duration_cast<Duration>((t1 - t0) + (t3 - t2));
    }
  }

  [[nodiscard]] int inflight() const noexcept { return inflight_; }
  [[nodiscard]] int ready() const noexcept { return ready_; }
  [[nodiscard]] bool picked() const noexcept { return picked_; }

 private:
  TimePoint start_time(const Dispatch& d) const {
    return now_ + (d.round_trip ? sync_cost_ : Duration{0});
  }
  TimePoint end_time(const Dispatch& d) const { return d.start + sampler_.sample(d); }

  // A scheduling point that is not a unit completion (frame, release tick, drop, end of
  // a merge wait): handled like the simulator does, not timed.
  template <typename Inputs>
  void untimed_round(Inputs&& inputs) {
    for (Dispatch* d : run_round(scheduler_, now_, std::forward<Inputs>(inputs))) {
      scheduler_.on_start(d->lane, start_time(*d));
      lane_end_[static_cast<std::size_t>(d->lane)] = end_time(*d);
    }
  }

  Scenario scenario_;
  Profile profile_;
  Scheduler scheduler_;
  CostSampler sampler_;
  Duration sync_cost_;
  Duration frame_period_;
  std::vector<TimePoint> lane_end_;
  TimePoint now_{0};
  TimePoint next_frame_{0};
  std::uint64_t frame_ = 0;
  int inflight_ = 0;
  int ready_ = 0;
  bool picked_ = false;
};

/// Nearest-rank percentile of sorted samples.
double percentile_us(const std::vector<std::int64_t>& sorted, double p) {
  if (sorted.empty()) return 0.0;
  auto rank = static_cast<std::size_t>(p * static_cast<double>(sorted.size()));
  rank = std::min(sorted.size() - 1, rank == 0 ? 0 : rank - 1);
  return static_cast<double>(sorted[rank]) / 1e3;
}

struct DecisionStats {
  std::uint64_t decisions = 0;
  double inflight = 0, ready = 0, picked = 0;
  double mean_us = 0, p50_us = 0, p90_us = 0, p99_us = 0, p999_us = 0, max_us = 0;
};

DecisionStats summarize(std::vector<std::int64_t>& ns, double inflight_sum, double ready_sum,
                        double picked_sum) {
  DecisionStats st;
  st.decisions = ns.size();
  if (ns.empty()) return st;
  const auto n = static_cast<double>(ns.size());
  double sum = 0;
  for (std::int64_t x : ns) sum += static_cast<double>(x);
  std::sort(ns.begin(), ns.end());
  st.inflight = inflight_sum / n;
  st.ready = ready_sum / n;
  st.picked = picked_sum / n;
  st.mean_us = sum / n / 1e3;
  st.p50_us = percentile_us(ns, 0.50);
  st.p90_us = percentile_us(ns, 0.90);
  st.p99_us = percentile_us(ns, 0.99);
  st.p999_us = percentile_us(ns, 0.999);
  st.max_us = static_cast<double>(ns.back()) / 1e3;
  return st;
}

void BM_Decision64(benchmark::State& state, const char* policy) {
  DecisionDriver driver(policy);
  driver.warm_up();
  std::vector<std::int64_t> ns;
  ns.reserve(1 << 20);
  double inflight = 0, ready = 0, picked = 0;
  for (auto _ : state) {
    const Duration t = driver.step();
    state.SetIterationTime(to_s(t));
    ns.push_back(t.count());
    inflight += driver.inflight();
    ready += driver.ready();
    picked += driver.picked() ? 1.0 : 0.0;
  }
  const DecisionStats st = summarize(ns, inflight, ready, picked);
  state.counters["p50_us"] = st.p50_us;
  state.counters["p99_us"] = st.p99_us;
  state.counters["max_us"] = st.max_us;
  state.counters["inflight"] = st.inflight;
  state.counters["ready"] = st.ready;
}

// The model of necessary work (red/graph/necessary_work.hpp) on the same 32 operations: what
// red-robust's demand test pays when the workload changes (Scheduler::Impl::plan_work); a decision
// in between reads its per-run costs from a table.
void BM_NecessaryWork32(benchmark::State& state) {
  const Scenario s = must_parse(decision_scenario_yaml());
  const Profile p = default_profile();
  const WorkModel model(p, s.model, s.scheduler.estimate, s.scheduler.max_batch, s.device.lanes,
                        s.scheduler.gamma);
  WorkInput in;
  for (const SensorSpec& sn : s.sensors) in.sensor_hz.push_back(sn.rate_hz);
  for (const auto& op : s.initial) in.ops.push_back({op.get(), op->rate_hz});
  for (auto _ : state) {
    WorkEstimate w = model.estimate(in);
    benchmark::DoNotOptimize(w);
  }
  state.counters["load"] = model.estimate(in).load;  // over the lanes: releases outpace them
}

}  // namespace

/// `red_bench --decision-stats[=N]`: N timed decisions per policy (default 200000) with
/// their distribution, without Google Benchmark. Returns the exit code.
int decision_stats_main(std::uint64_t decisions) {
  // The cost of the two clock pairs inside every sample.
  std::vector<std::int64_t> clock_ns;
  clock_ns.reserve(100'000);
  for (int i = 0; i < 100'000; ++i) {
    const auto a = Clock::now();
    const auto b = Clock::now();
    const auto c = Clock::now();
    const auto d = Clock::now();
    clock_ns.push_back(std::chrono::duration_cast<Duration>((b - a) + (d - c)).count());
  }
  std::sort(clock_ns.begin(), clock_ns.end());
  fmt::print("decision with {} jobs in flight: {} operations x max_inflight {}, {} lanes\n",
             kOperations * kMaxInflight, kOperations, kMaxInflight, kLanes);
  fmt::print(
      "{} timed decisions per policy after {} warm-up decisions; clock overhead per "
      "sample (median) {:.3f} us, included\n",
      decisions, kWarmupDecisions, percentile_us(clock_ns, 0.5));
  fmt::print("{:<10} {:>9} {:>9} {:>7} {:>7} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9}\n", "policy",
             "decisions", "inflight", "ready", "picked", "mean us", "p50 us", "p90 us", "p99 us",
             "p99.9 us", "max us");
  for (const char* policy : {"red-robust", "red", "red-ida", "red-fg", "edf", "fifo", "mono"}) {
    DecisionDriver driver(policy);
    driver.warm_up();
    std::vector<std::int64_t> ns;
    ns.reserve(decisions);
    double inflight = 0, ready = 0, picked = 0;
    for (std::uint64_t i = 0; i < decisions; ++i) {
      ns.push_back(driver.step().count());
      inflight += driver.inflight();
      ready += driver.ready();
      picked += driver.picked() ? 1.0 : 0.0;
    }
    const DecisionStats st = summarize(ns, inflight, ready, picked);
    fmt::print(
        "{:<10} {:>9} {:>9.1f} {:>7.1f} {:>7.3f} {:>8.3f} {:>8.3f} {:>8.3f} {:>8.3f} {:>9.3f} "
        "{:>9.3f}\n",
        policy, st.decisions, st.inflight, st.ready, st.picked, st.mean_us, st.p50_us, st.p90_us,
        st.p99_us, st.p999_us, st.max_us);
  }
  return 0;
}

BENCHMARK_CAPTURE(BM_Decision64, red, "red")->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Decision64, red_robust, "red-robust")
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_Decision64, edf, "edf")->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_NecessaryWork32)->Unit(benchmark::kMicrosecond);

}  // namespace red::bench
