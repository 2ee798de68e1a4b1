#include "red/sim/simulator.hpp"

#include "red/core/stop.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <queue>
#include <vector>

#include "red/core/rng.hpp"
#include "red/sched/round.hpp"

namespace red {

namespace {

// Ahead: a lane's handler decides the unit it queues behind what it holds (docs/DESIGN.md, "Queued
// lanes"; SchedulerConfig::ahead_lead).
enum class EvKind : std::uint8_t { Complete, Frame, Ahead };

struct Ev {
  TimePoint t;
  std::uint64_t seq;
  EvKind kind;
  int index;            // lane or sensor
  std::uint64_t value;  // dispatch id or frame number
  bool operator>(const Ev& o) const noexcept { return t != o.t ? t > o.t : seq > o.seq; }
};

// Interference in the simulator is a slowdown of every unit: 1 + intensity.
double slowdown_of(const Scenario& s) {
  return s.interference ? 1.0 + s.interference->intensity : 1.0;
}

}  // namespace

Simulator::Simulator(const Scenario& scenario, const Profile& profile,
                     std::unique_ptr<Policy> policy, SimOptions options)
    : scenario_(scenario),
      options_(options),
      scheduler_(scenario, profile, std::move(policy),
                 [&] {
                   SchedulerConfig c = SchedulerConfig::from(scenario, profile);
                   if (options.group_from) c.group_from = *options.group_from;
                   // docs/DESIGN.md, "Online costs": the simulator draws its costs from the
                   // profile the scheduler plans with, unless given others (--costs); there the
                   // estimates could only chase the draws' noise, and stay off unless the
                   // scenario asks.
                   if (!scenario.scheduler.online_costs && options.costs == nullptr)
                     c.measure_costs = false;
                   return c;
                 }()),
      sampler_(scenario, options.costs != nullptr ? *options.costs : profile, options.seed,
               slowdown_of(scenario)),
      sync_cost_(scenario.device.sync_cost  ? *scenario.device.sync_cost
                 : options.costs != nullptr ? options.costs->sync_round_trip
                                            : profile.sync_round_trip),
      handoff_(options.costs != nullptr && options.costs->calibration
                   ? options.costs->calibration->handoff
               : profile.calibration ? profile.calibration->handoff
                                     : Duration{0}),
      queued_gap_(options.costs != nullptr && options.costs->calibration
                      ? options.costs->calibration->queued_gap
                  : profile.calibration ? profile.calibration->queued_gap
                                        : Duration{0}),
      encoder_(profile.find("encoder")) {
  for (const std::string& h : scenario.model.heads) heads_.push_back(profile.find("head/" + h));
}

// One run's state: the event queue, what each lane holds, and the round's steps.
struct Simulator::Run {
  // Per lane: the dispatches it holds, oldest first (one, or up to the queue depth), with
  // their starts and profiled p50.
  struct HeldUnit {
    std::uint64_t id;
    TimePoint start;
    Duration p50;
  };

  Simulator& sim;
  Scheduler& sched;
  SimResult r;
  std::priority_queue<Ev, std::vector<Ev>, std::greater<>> q;
  std::uint64_t seq = 0;
  std::vector<TimePoint> base;  // un-jittered time of each sensor's next frame
  TimePoint now{0};
  std::size_t nlanes;
  std::vector<std::deque<HeldUnit>> held;
  std::vector<TimePoint> lane_end;  // when the last unit each lane holds ends
  // docs/DESIGN.md, "Queued lanes": with on-demand synchronization, a lane's handler queues its
  // next unit behind what it holds a lead before that is expected to end (the scheduler's rule,
  // Scheduler::queue_ahead_at; an enqueue costs the simulated host nothing).
  bool ahead;
  std::vector<int> touched;  // lanes whose handler decides its queue this round
  bool releasing = true;

  explicit Run(Simulator& s)
      : sim(s),
        sched(s.scheduler_),
        base(s.scenario_.sensors.size()),
        nlanes(static_cast<std::size_t>(s.scenario_.device.lanes)),
        held(nlanes),
        lane_end(nlanes, TimePoint{0}),
        ahead(s.scheduler_.queues_ahead()) {
    touched.reserve(nlanes);
    for (std::size_t i = 0; i < base.size(); ++i) {
      base[i] = sim.scenario_.sensors[i].phase;
      q.push({base[i] + jitter(i, 0), seq++, EvKind::Frame, static_cast<int>(i), 0});
    }
  }

  Duration jitter(std::size_t s, std::uint64_t k) const {
    const SensorSpec& sp = sim.scenario_.sensors[s];
    if (sp.jitter <= Duration{0}) return Duration{0};
    // Jitter stays below one period so frames of a sensor arrive in order.
    const Duration cap =
        std::min(sp.jitter, period_of(sched.sensor_rate(static_cast<int>(s))) - Duration{1});
    const double u =
        unit_uniform(hash_combine(hash_combine(sim.options_.seed ^ 0x4a4954ULL, s), k));
    return Duration{static_cast<std::int64_t>(u * static_cast<double>(cap.count()))};
  }

  void plan_ahead(int lane) {
    const auto& h = held[static_cast<std::size_t>(lane)];
    if (!ahead || h.empty() || !sched.has_room_ahead(lane)) return;
    Duration p50{0};
    for (const HeldUnit& u : h) p50 += u.p50;
    const TimePoint at = sched.queue_ahead_at(h.front().start, p50);
    q.push({std::max(at, now), seq++, EvKind::Ahead, lane, h.back().id});
  }

  void start_unit(Dispatch& d, TimePoint start) {
    sched.on_start(d.lane, start);
    int busy_others = 0;
    for (std::size_t l = 0; l < nlanes; ++l)
      busy_others += static_cast<int>(!held[l].empty() && static_cast<int>(l) != d.lane);
    const TimePoint end = start + sim.sampler_.sample(d, start, busy_others);
    const auto l = static_cast<std::size_t>(d.lane);
    held[l].push_back(
        {d.id, start,
         ahead ? profiled_cost(d, sim.encoder_, sim.heads_, &LatencyStats::p50) : Duration{0}});
    lane_end[l] = end;
    q.push({end, seq++, EvKind::Complete, d.lane, d.id});
    ++r.unit_events;
  }

  // The round's inputs: every event at `now` (completions, queue-ahead decisions, frames).
  void events_now() {
    while (!q.empty() && q.top().t == now) {
      const Ev e = q.top();
      q.pop();
      ++r.events;
      if (e.kind == EvKind::Complete) {
        auto& h = held[static_cast<std::size_t>(e.index)];
        if (h.empty() || h.front().id != e.value) continue;
        h.pop_front();
        ++r.unit_events;
        sched.on_complete(e.index, now, UnitStatus::Completed);
        plan_ahead(e.index);
      } else if (e.kind == EvKind::Ahead) {
        // Still holding what it held when this was planned, with room: decide now.
        const auto& h = held[static_cast<std::size_t>(e.index)];
        if (!h.empty() && h.back().id == e.value) touched.push_back(e.index);
      } else {
        if (!releasing) continue;  // a frame
        const auto s = static_cast<std::size_t>(e.index);
        sched.on_frame(e.index, e.value, now);
        base[s] += period_of(sched.sensor_rate(e.index));
        q.push({base[s] + jitter(s, e.value + 1), seq++, EvKind::Frame, e.index, e.value + 1});
      }
    }
  }

  // A lane whose lead came fills its queue: a queued unit starts when the one before it
  // ends (plus the device's gap between two queued units), or once its handler has
  // decided and enqueued it, whichever is later. Nothing to queue now: it tries again at
  // its next unit boundary.
  void fill_queues() {
    for (int l : touched) {
      bool queued = false;
      while (sched.has_room_ahead(l)) {
        const auto ds = sched.dispatch_ahead(now, l);
        if (ds.empty()) break;
        start_unit(*ds.front(), std::max(now + sim.handoff_,
                                         lane_end[static_cast<std::size_t>(l)] + sim.queued_gap_));
        queued = true;
      }
      if (queued) plan_ahead(l);
    }
    touched.clear();
  }
};

SimResult Simulator::run() {
  Run run(*this);
  SimResult& r = run.r;
  const TimePoint stop_releases = scenario_.duration;
  const TimePoint hard_stop = scenario_.duration + options_.drain_limit;
  std::uint64_t rounds = 0;
  for (;;) {
    const TimePoint t_ext = run.q.empty() ? kNever : run.q.top().t;
    const TimePoint t_int = scheduler_.next_wakeup();
    TimePoint t = std::min(t_ext, t_int);
    if (run.releasing && t >= stop_releases) {
      // The scenario is over: nothing new is released; in-flight jobs may still finish.
      run.releasing = false;
      scheduler_.apply_events(stop_releases - Duration{1});
      scheduler_.stop_releases();
      continue;
    }
    if (t == kNever || t > hard_stop || (!run.releasing && scheduler_.jobs_in_flight() == 0)) break;
    // A stop signal ends a long simulation within about a millisecond of host time.
    if ((++rounds & 1023U) == 0 && stop_requested()) {
      r.stopped = true;
      break;
    }
    run.now = t;
    // One round (red/sched/round.hpp): events, then what happened at `now`, then releases.
    const auto started = run_round(scheduler_, run.now, [&] { run.events_now(); });
    for (Dispatch* d : started) {
      // A calibrated profile measured the hand-off without a round trip too.
      run.start_unit(*d, run.now + (d->round_trip ? sync_cost_ : handoff_));
      run.plan_ahead(d->lane);
    }
    run.fill_queues();
    ++r.events;
  }
  const TimePoint now = run.now;
  r.end = run.releasing ? std::min(now, stop_releases) : std::max(now, stop_releases);
  scheduler_.finish(r.end);
  r.stats = scheduler_.stats();
  return r;
}

}  // namespace red
