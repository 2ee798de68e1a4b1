#pragma once
// A fake scheduling context for Scheduler tests (as band tests its policies on a mock
// engine): the test is the clock and the executor; nothing reads a clock or sleeps.

#include <algorithm>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
#include "red/sched/scheduler.hpp"

namespace red::test {

/// Parses a scenario written in the test; throws if it does not parse.
inline Scenario parse(const std::string& text) {
  Expected<Scenario> s = parse_scenario(text, "test.yaml");
  if (!s) throw std::runtime_error("scenario does not parse: " + s.error().to_string());
  return std::move(s).value();
}

/// docs/DESIGN.md, "Intermediate deadlines" worked example: D = 120 ms; A and B at height 0 cost 20
/// ms; C at height 1 costs 40 ms.
inline constexpr const char* kWorked = R"(name: worked
duration_s: 10
sensors:
  cam: {rate_hz: 10}
operations:
  - name: job
    trigger: cam
    deadline_ms: 120
    max_inflight: 4
    nodes:
      A: {cost_ms: 20}
      B: {cost_ms: 20}
      C: {cost_ms: 40}
    edges: [[A, C], [B, C]]
)";

/// Drives a Scheduler by hand; `Recorder` is the test's observer.
template <typename Recorder>
class Harness {
 public:
  Harness(const std::string& yaml, std::string_view policy,
          const std::optional<PolicyOptions>& options = std::nullopt, int lanes = 0,
          Profile profile = default_profile())
      : scenario_(parse(yaml)), profile_(std::move(profile)) {
    SchedulerConfig cfg = SchedulerConfig::from(scenario_);
    if (lanes > 0) cfg.lanes = lanes;
    auto p = make_policy(policy, options);
    if (!p) throw std::runtime_error("unknown policy");
    sched_ = std::make_unique<Scheduler>(scenario_, profile_, std::move(p), cfg);
    sched_->add_observer(&rec_);
    lanes_ = cfg.lanes;
  }

  Scheduler& s() { return *sched_; }
  Recorder& rec() { return rec_; }

  void frame(int sensor, std::uint64_t id, TimePoint t) {
    sched_->apply_events(t);
    sched_->on_frame(sensor, id, t);
  }
  /// Releases due by t, without a dispatch round.
  void release_only(TimePoint t) {
    sched_->apply_events(t);
    sched_->advance(t);
  }
  void complete(int lane, TimePoint t, UnitStatus st = UnitStatus::Completed,
                std::string_view reason = {}) {
    sched_->apply_events(t);
    sched_->on_complete(lane, t, st, reason);
  }
  /// advance + dispatch at t; every dispatch starts at t (no round-trip cost).
  std::vector<Dispatch> step(TimePoint t) {
    sched_->apply_events(t);
    sched_->advance(t);
    std::vector<Dispatch> out;
    for (const Dispatch* d : sched_->dispatch(t)) out.push_back(*d);
    for (const Dispatch& d : out) sched_->on_start(d.lane, t);
    return out;
  }
  /// Runs until every lane is idle; a dispatch takes the largest estimate of its members.
  TimePoint run_out(TimePoint t) {
    std::vector<TimePoint> end(static_cast<std::size_t>(lanes_), kNever);
    for (int l = 0; l < lanes_; ++l)
      if (const Dispatch* d = sched_->running(l))
        end[static_cast<std::size_t>(l)] = std::max(t, d->start + cost(*d));
    for (const Dispatch& d : step(t)) end[static_cast<std::size_t>(d.lane)] = t + cost(d);
    for (;;) {
      const auto it = std::min_element(end.begin(), end.end());
      if (*it == kNever) return t;
      t = *it;
      *it = kNever;
      complete(static_cast<int>(it - end.begin()), t);
      for (const Dispatch& d : step(t)) end[static_cast<std::size_t>(d.lane)] = t + cost(d);
    }
  }
  static Duration cost(const Dispatch& d) {
    Duration c{0};
    for (const Member& m : d.members)
      c = std::max(c, m.graph->units[static_cast<std::size_t>(m.unit)].estimate);
    return c;
  }

 private:
  Scenario scenario_;
  Profile profile_;
  Recorder rec_;
  std::unique_ptr<Scheduler> sched_;
  int lanes_ = 1;
};

}  // namespace red::test
