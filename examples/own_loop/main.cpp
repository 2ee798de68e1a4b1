/// \file
/// Example: RED's scheduler alone, inside your own event loop, with your own policy.
///
/// No red::Runtime here: the program owns the loop, the clock and the executor, and
/// drives red::Scheduler by the recipe at the top of red/sched/scheduler.hpp. The
/// "accelerator" is a set of lanes that finish a unit after its profiled mean time (timers
/// in the loop); frames come from a 30 Hz camera timer. The policy, CriticalSlackPolicy,
/// is defined here: it ranks by criticality first, then by least slack.
///
///     own_loop [seconds]      # default 1 s of releases (real time), then draining
///
/// Built against the installed package: see CMakeLists.txt next to this file.

#include <red/metrics/metrics.hpp>
#include <red/profile/profile.hpp>
#include <red/scenario/builder.hpp>
#include <red/sched/policy.hpp>
#include <red/sched/round.hpp>
#include <red/sched/scheduler.hpp>
#include <red/version.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using std::chrono::milliseconds;

/// A user-defined policy: the most critical operation's work first; among equals, the
/// task whose job has the least slack (deadline − now − remaining critical path). It
/// keeps the mechanisms (graph, deadlines, merging, ...) of the `red` preset.
class CriticalSlackPolicy final : public red::Policy {
 public:
  CriticalSlackPolicy() : options_(red::preset_options("red").value_or(red::PolicyOptions{})) {}

  [[nodiscard]] std::string_view name() const noexcept override { return "crit-slack"; }
  [[nodiscard]] const red::PolicyOptions& options() const noexcept override { return options_; }
  /// Smallest first. Slack is clamped to +-1.2 h, so one criticality level outweighs any
  /// slack (criticalities up to +-2^19 cannot overflow).
  [[nodiscard]] std::int64_t rank(const red::TaskView& t,
                                  red::TimePoint now) const noexcept override {
    const std::int64_t slack = (t.job_deadline - now - t.remaining).count();
    constexpr std::int64_t kLevel = std::int64_t{1} << 43;  // 2.4 h in ns
    return std::clamp(slack, -kLevel / 2, kLevel / 2 - 1) - std::int64_t{t.criticality} * kLevel;
  }

 private:
  red::PolicyOptions options_;  // rank() is const and allocation-free, as Policy requires
};

/// How long a unit runs on the "accelerator": the profile's mean for its kind.
red::Duration unit_cost(const red::Scenario& s, const red::Profile& p, const red::Dispatch& d) {
  std::string unit;
  if (d.kind == red::UnitKind::Encoder) unit = "encoder";
  if (d.kind == red::UnitKind::Head)
    unit = "head/" + s.model.heads[static_cast<std::size_t>(d.head)];
  if (d.kind == red::UnitKind::Coarse)
    unit = "coarse/" + s.model.heads[static_cast<std::size_t>(d.head)];
  if (const red::UnitProfile* u = p.find(unit)) return u->at(d.batch).mean;
  return milliseconds{1};  // plain and mono units: not used by this workload's policy
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 1.0;
  if (argc > 1) {
    char* end = nullptr;
    seconds = std::strtod(argv[1], &end);
    if (end == argv[1] || *end != '\0' || !(seconds > 0.0 && seconds <= 3600.0)) {
      std::cerr << "own_loop: seconds must be a number in (0, 3600], not '" << argv[1] << "'\n";
      return 2;
    }
  }

  // Two operations on one camera: "drive" (lane -> steer, critical) on every frame, and
  // "detect" (det) at its own 10 Hz.
  red::ScenarioBuilder b("own-loop");
  b.duration(std::chrono::duration_cast<red::Duration>(std::chrono::duration<double>(seconds)))
      .lanes(1)
      .sensor("camera", 30.0);
  b.operation("drive")
      .trigger("camera")
      .criticality(1)
      .deadline(milliseconds{40})
      .inference("L", "lane", "camera")
      .inference("C", "steer", "camera")
      .edge("L", "C");
  b.operation("detect").rate(10.0).deadline(milliseconds{80}).inference("D", "det", "camera");
  red::Expected<red::Scenario> built = b.build();
  if (!built) {
    std::cerr << built.error().to_string() << '\n';
    return 2;
  }
  const red::Scenario& scenario = *built;
  const red::Profile profile = red::default_profile();

  red::Scheduler s(scenario, profile, std::make_unique<CriticalSlackPolicy>(),
                   red::SchedulerConfig::from(scenario));
  red::MetricsCollector metrics(scenario, scenario.scheduler.qoe_lambda, false);
  s.add_observer(&metrics);

  // The loop's own state: the camera timer and, per lane, when its unit finishes.
  const auto t0 = std::chrono::steady_clock::now();
  auto clock_now = [&] {
    return std::chrono::duration_cast<red::Duration>(std::chrono::steady_clock::now() - t0);
  };
  const red::Duration period = red::period_of(scenario.sensors[0].rate_hz);
  red::TimePoint next_frame = scenario.sensors[0].phase;
  std::uint64_t frame = 0;
  std::vector<red::TimePoint> lane_done(static_cast<std::size_t>(scenario.device.lanes),
                                        red::kNever);
  const red::TimePoint end_of_releases = scenario.duration;
  const red::TimePoint hard_stop = scenario.duration + std::chrono::seconds{2};
  bool releasing = true;
  red::TimePoint now{0};

  for (;;) {
    // Wake up at the earliest of: a frame, a unit completion, the scheduler's own wakeup.
    red::TimePoint t = std::min(releasing ? next_frame : red::kNever, s.next_wakeup());
    for (red::TimePoint d : lane_done) t = std::min(t, d);
    if (releasing && t >= end_of_releases) {
      releasing = false;  // the scenario is over; in-flight jobs may still finish
      s.stop_releases();
      continue;
    }
    if (t == red::kNever || t > hard_stop || (!releasing && s.jobs_in_flight() == 0)) break;
    std::this_thread::sleep_for(t - clock_now());
    now = std::max({now, t, clock_now()});  // scheduling points never go back in time

    // One round, in the order red/sched/round.hpp keeps: events, inputs, releases, decision.
    const auto started = red::run_round(s, now, [&] {
      for (std::size_t lane = 0; lane < lane_done.size(); ++lane)
        if (lane_done[lane] <= now) {
          lane_done[lane] = red::kNever;
          s.on_complete(static_cast<int>(lane), now, red::UnitStatus::Completed);
        }
      if (releasing && next_frame <= now) {
        s.on_frame(0, frame++, now);
        next_frame += period;
      }
    });
    for (const red::Dispatch* d : started) {
      s.on_start(d->lane, now);  // this executor starts at once (no round trip to pay)
      lane_done[static_cast<std::size_t>(d->lane)] = now + unit_cost(scenario, profile, *d);
    }
  }
  s.finish(now);

  const red::PolicyMetrics m = metrics.summarize(std::string(s.policy().name()), now);
  std::cout << "RED " << red::kVersion << ", policy '" << s.policy().name() << "', "
            << s.stats().decisions << " decisions, " << s.stats().dispatches << " dispatches\n"
            << "jobs " << m.jobs << ", completed " << m.completed << ", met " << m.met
            << ", missed " << m.missed << ", dropped " << m.dropped << "\n"
            << "miss rate " << m.miss_rate << ", QoE " << m.qoe << ", latency mean "
            << m.latency.mean << " ms, p99 " << m.latency.p99 << " ms\n";
  return m.completed > 0 ? 0 : 1;
}
