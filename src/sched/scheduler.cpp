// The scheduler's facade: its inputs (frames, unit starts and ends, events, the clock), the
// order of one decision (dispatch(), dispatch_ahead() in queue.cpp) and its queries. The
// mechanisms are one file each behind the one state in scheduler_impl.hpp: jobs.cpp (jobs
// and releases), deadlines.cpp (deadline assignment), tasks.cpp (tasks, DynamicMerge joins),
// ready_set.cpp (the ready set, ReadySet), ranking.cpp (ranking, Ranking), dispatch.cpp
// (pick), merge.cpp (merge waits), batching.cpp, sync.cpp (runs, on-demand synchronization,
// placement; the type OnDemandSync), lanes.cpp (starting a dispatch), overload.cpp (the demand
// test and its work figures; the type Overload), shedding.cpp (how a job is shed: admission,
// shed_lone, shedding by rate, hopeless aborts; the type Shedding), queue.cpp (queued lanes);
// online_costs.cpp (what units cost in this run, and the profile plans are made on:
// use_costs()).

#include "red/sched/scheduler.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <string>

#include "red/core/assert.hpp"
#include "scheduler_impl.hpp"

namespace red {

SchedulerConfig SchedulerConfig::from(const Scenario& s) {
  SchedulerConfig c;
  c.lanes = s.device.lanes;
  c.gamma = s.scheduler.gamma;
  c.max_batch = s.scheduler.max_batch;
  c.estimate = s.scheduler.estimate;
  c.level_cost = s.scheduler.level_cost;
  c.warmup = s.warmup;
  if (s.device.sync_cost) c.sync_cost = *s.device.sync_cost;
  if (s.device.queue_depth) c.queue_depth = *s.device.queue_depth;
  c.online_costs.follow = s.scheduler.online_costs.value_or(true);
  return c;
}

SchedulerConfig SchedulerConfig::from(const Scenario& s, const Profile& p) {
  SchedulerConfig c = from(s);
  c.sync_cost = s.device.sync_cost ? *s.device.sync_cost : p.sync_round_trip;
  // A GPU runs its lanes asynchronously: one unit queued behind the running one keeps the
  // device from waiting for the host between units (docs/DESIGN.md, "Synchronization").
  if (!s.device.queue_depth && p.source == "measured" && !p.device.empty() &&
      p.device.rfind("cpu", 0) != 0)
    c.queue_depth = 2;
  return c;
}

Scheduler::Impl::Impl(Scheduler& owner, const Profile& p)
    : s(owner), profile(&p), opt(owner.policy_->options()) {
  const Scenario& sc = s.scenario_;
  ropt = RefineOptions{opt.graph, opt.deadlines, s.config_.level_cost};
  given = CostModel{&p, &sc.model, s.config_.estimate};
  price(p);
  if (s.config_.measure_costs) online.emplace(p, sc.model, s.config_.online_costs);
  releases.set_sensors(sc.sensors);
  merge.set_sensors(sc.sensors.size());
  lanes.resize(static_cast<std::size_t>(s.config_.lanes));
  sync.set_up(opt.sync, s.config_.sync_cost, s.config_.lanes);
  inheritance.set_up(opt.inherit, s.config_.estimate);
  reassign.set_up(opt.reassign, opt.deadlines);
  ops.resize(static_cast<std::size_t>(sc.operation_count()));
  for (int i = 0; i < sc.operation_count(); ++i)
    if (sc.initial[static_cast<std::size_t>(i)])
      install(i, sc.initial[static_cast<std::size_t>(i)], TimePoint{0}, true);
  ranking.set_up(*s.policy_, sc, s.config_);
  plan_work();
}

void Scheduler::Impl::price(const Profile& p) {
  const Scenario& sc = s.scenario_;
  profile = &p;
  costs = CostModel{profile, &sc.model, s.config_.estimate};
  batching.price(*profile, costs, sc.model);
}

void Scheduler::Impl::use_costs(const Profile& p) {
  price(p);
  // Ranking reads the tasks' costs through the ready set's groups: they form again.
  ready.ungroup_all(*this);
  for (std::size_t i = 0; i < ops.size(); ++i) {
    OpState& o = ops[i];
    if (o.g == nullptr) continue;
    RefineOptions keep = ropt;
    keep.deadline = o.g->deadline;
    graphs.push_back(refine(o.g->spec, static_cast<int>(i), costs, keep));
    o.g = graphs.back().get();
  }
  plan_work();
}

Scheduler::Scheduler(const Scenario& scenario, const Profile& profile,
                     std::unique_ptr<Policy> policy, SchedulerConfig config)
    : scenario_(scenario), policy_(std::move(policy)), config_(config) {
  RED_ASSERT(policy_ != nullptr);
  RED_ASSERT(config_.lanes >= 1);
  impl_ = std::make_unique<Impl>(*this, profile);
}

Scheduler::~Scheduler() = default;

void Scheduler::add_observer(Observer* o) {
  impl_->observers.push_back(o);
}

void Scheduler::apply_events(TimePoint now) {
  Impl& m = *impl_;
  while (m.releases.next_event() < scenario_.events.size() &&
         scenario_.events[m.releases.next_event()].at <= now) {
    const EventSpec& e = scenario_.events[m.releases.next_event()];
    // A new version may change an operation's criticality, which ranking reads: the ready
    // set's groups (ready_set.cpp) form again from the next scan.
    m.ready.ungroup_all(m);
    for (const auto& [op, spec] : e.changes) m.install(op, spec, e.at, false);
    for (const auto& [sensor, rate] : e.sensor_rates) m.releases.sensor(sensor).rate_hz = rate;
    m.shedding.on_workload();
    m.plan_work();
    for (Observer* ob : m.observers)
      ob->on_workload_event(static_cast<int>(m.releases.next_event()), e.at);
    m.releases.event_applied();
  }
}

void Scheduler::on_frame(int sensor, std::uint64_t frame, TimePoint now) {
  Impl& m = *impl_;
  SensorState& sn = m.releases.sensor(sensor);
  sn.has_frame = true;
  sn.frame = frame;
  sn.time = now;
  for (std::size_t i = 0; i < m.ops.size(); ++i) {
    OpState& o = m.ops[i];
    if (o.awaits_frames && o.g != nullptr && m.releases.inputs_ready(*o.g, -1)) {
      o.awaits_frames = false;
      o.next_tick = now;  // advance(now) releases them
      m.releases.note_tick(m.ops, static_cast<int>(i));
    }
  }
  for (std::size_t i = 0; i < m.ops.size(); ++i)
    if (m.ops[i].g != nullptr && m.ops[i].trigger == sensor)
      m.release(static_cast<int>(i), now, sensor, frame);
}

void Scheduler::on_start(int lane, TimePoint start) {
  Impl& m = *impl_;
  Dispatch& d = m.lanes[static_cast<std::size_t>(lane)].newest();
  m.set_start(d, start);
  for (Observer* ob : m.observers) ob->on_unit_start(d);
}

void Scheduler::stop_releases() {
  for (OpState& o : impl_->ops) {
    o.remaining = 0;
    o.next_tick = kNever;
  }
  impl_->releases.end_events(scenario_.events.size());
}

void Scheduler::on_complete(int lane_index, TimePoint now, UnitStatus status,
                            std::string_view reason, TimePoint started) {
  Impl& m = *impl_;
  Lane& lane = m.lanes[static_cast<std::size_t>(lane_index)];
  RED_ASSERT(lane.busy());
  Dispatch& d = lane.oldest();
  lane.pop();  // the slot stays as it is until a later dispatch reuses it
  // docs/DESIGN.md, "Synchronization": a transition other than Completed ends the run; the next
  // dispatch pays a round trip (sync.hpp).
  m.sync.completed(lane_index, now, status);
  if (started != kNever) m.set_start(d, std::min(started, now));
  // A unit queued behind this one starts now, in the lane's order.
  if (lane.busy() && lane.oldest().start < now) m.set_start(lane.oldest(), now);
  for (Observer* ob : m.observers) ob->on_unit_end(d, now, status);
  // docs/DESIGN.md, "Online costs": what the run took teaches the plan.
  if (m.online && status == UnitStatus::Completed) {
    m.online->observe(d, now - d.start, now);
    if (m.online->update(now)) m.use_costs(m.online->plan());
  }
  for (const Member& mb : d.members) {
    Job& j = m.job(mb.slot);
    if (!j.live || j.id != mb.job) continue;
    UnitRt& u = j.u[static_cast<std::size_t>(mb.unit)];
    --j.running;
    if (j.ended) {
      u.state = UState::Cancelled;  // output discarded: the job was aborted meanwhile
      m.touch(j);
      if (j.running == 0) m.free_job(mb.slot);
      continue;
    }
    if (status != UnitStatus::Completed) {
      u.state = UState::Cancelled;
      m.touch(j);
      j.reason = DropReason::Failed;
      j.failure = reason.empty() ? std::string(to_string(status)) : std::string(reason);
      m.end_job(mb.slot, JobOutcome::Failed, now);
      continue;
    }
    u.state = UState::Done;
    m.touch(j);
    --j.unfinished;
    for (int sx : j.g->units[static_cast<std::size_t>(mb.unit)].succs) {
      UnitRt& su = j.u[static_cast<std::size_t>(sx)];
      if (su.early) {
        // Ready already, for this lane: now for any.
        su.early = false;
        if (su.state == UState::Queued && su.task >= 0) m.task(su.task).lane_only = -1;
        continue;
      }
      if (--su.pending == 0 && su.state == UState::Blocked) m.make_ready(mb.slot, sx);
    }
    if (j.unfinished == 0) {
      // docs/DESIGN.md, "Drops" strict: a job whose deadline passed while its last unit ran is
      // aborted and the unit's output discarded, even where the completion reached the scheduler
      // before the deadline's own event (the runtime's timer; the simulator orders them by time).
      if (now > j.deadline && m.opt.drop != DropMode::None) {
        j.reason = DropReason::DeadlinePassed;
        m.end_job(mb.slot, JobOutcome::Dropped, now);
      } else {
        m.end_job(mb.slot, now <= j.deadline ? JobOutcome::Met : JobOutcome::Missed, now);
      }
    }
  }
}

void Scheduler::advance(TimePoint now) {
  Impl& m = *impl_;
  // Own-rate and count releases due by now, in time order (ties: operation order).
  for (;;) {
    const auto [tick, due] = m.releases.next_tick(m.ops);
    if (due < 0 || tick > now) break;
    OpState& o = m.ops[static_cast<std::size_t>(due)];
    const TimePoint t = o.next_tick;
    if (o.all_at_once) {
      o.next_tick = kNever;
      if (!m.releases.inputs_ready(*o.g, -1)) {
        o.awaits_frames = true;  // on_frame releases them once every sensor has a frame
        continue;
      }
      while (o.remaining != 0) m.release(due, t, -1, 0);
    } else {
      o.next_tick = t + period_of(o.rate_hz);
      m.releases.note_tick(m.ops, due);
      m.release(due, t, -1, 0);
    }
  }
  // Strict drops (docs/DESIGN.md, "Drops"): a job whose end-to-end deadline has come is aborted.
  auto& h = m.deadlines;
  while (!h.empty() && h.front().first <= now) {
    const auto [slot, id] = h.front().second;
    std::pop_heap(h.begin(), h.end(), std::greater<>{});
    h.pop_back();
    Job& j = m.job(slot);
    if (j.live && !j.ended && j.id == id) {
      j.reason = DropReason::DeadlinePassed;
      m.end_job(slot, JobOutcome::Dropped, now);
    }
  }
}

std::span<Dispatch* const> Scheduler::dispatch(TimePoint now) {
  Impl& m = *impl_;
  m.out.clear();
  ++m.stamp;  // one scheduling point: deadlines are re-assigned from now
  // docs/DESIGN.md, "Overload": admission right after releases; the demand test that tells
  // overload, when the policy or the scenario's criticalities use it.
  m.shedding.admit_released(m, now);
  int idle = 0;
  for (const Lane& l : m.lanes) idle += l.busy() ? 0 : 1;
  if (idle > 0 && m.ready.count() > 0) {
    ++stats_.decisions;
    m.overload.assess(m, now);
    while (idle > 0 && m.pick(now, -1)) --idle;
  }
  // The waits still running; the earliest end of one is a wake-up (next_wakeup).
  const int waiting = m.merge.sweep(m, now);
  if (!m.observers.empty()) {
    // Ready for any lane: a task ready only behind a busy lane's unit (queue_depth > 1)
    // cannot take an idle lane.
    int ready = m.ready.count();  // grouped tasks are for any lane
    if (config_.queue_depth > 1)
      for (int t : m.ready.listed()) ready -= m.task(t).lane_only >= 0 ? 1 : 0;
    for (Observer* ob : m.observers) ob->on_decision(now, ready, idle, waiting);
  }
  return {m.out.data(), m.out.size()};
}

TimePoint Scheduler::next_wakeup() const {
  const Impl& m = *impl_;
  TimePoint t = kNever;
  if (const std::size_t e = m.releases.next_event(); e < scenario_.events.size())
    t = std::min(t, scenario_.events[e].at);
  t = std::min(t, m.releases.next_tick(m.ops).first);
  if (!m.deadlines.empty()) t = std::min(t, m.deadlines.front().first);
  if (m.ready.count() > 0) t = std::min(t, m.merge.earliest_wait());
  return t;
}

void Scheduler::finish(TimePoint end) {
  Impl& m = *impl_;
  // Units still running when the run ends get their row, cut at the end (REPORTS.md: one
  // row per unit that started).
  for (Lane& l : m.lanes) {
    for (; l.busy(); l.pop())
      for (Observer* ob : m.observers)
        ob->on_unit_end(l.oldest(), std::max(end, l.oldest().start), UnitStatus::Unfinished);
  }
  for (Job& j : m.jobs.all()) {
    if (!j.live || j.ended) continue;
    j.ended = true;
    --in_flight_;
    m.notify_job(j, JobOutcome::Unfinished, end, false);
  }
}

int Scheduler::ready_tasks() const noexcept {
  return impl_->ready.count();
}

bool Scheduler::drained() const {
  const Impl& m = *impl_;
  if (in_flight_ > 0 || m.releases.next_event() < scenario_.events.size()) return false;
  for (const OpState& o : m.ops) {
    if (o.g == nullptr || o.remaining == 0) continue;
    return false;  // it can still release (periodically, on frames or at its phase)
  }
  return true;
}

double Scheduler::sensor_rate(int sensor) const {
  return impl_->releases.sensor(sensor).rate_hz;
}

const RefinedGraph* Scheduler::graph(int operation) const {
  return impl_->ops[static_cast<std::size_t>(operation)].g;
}

const OnlineCosts* Scheduler::online_costs() const noexcept {
  return impl_->online ? &*impl_->online : nullptr;
}

const Profile& Scheduler::plan_profile() const noexcept {
  return *impl_->profile;
}

const Dispatch* Scheduler::running(int lane) const {
  const auto& l = impl_->lanes[static_cast<std::size_t>(lane)];
  return l.busy() ? &l.at(0) : nullptr;
}

TimePoint Scheduler::unit_deadline(int slot, int unit, TimePoint now) {
  Impl& m = *impl_;
  ++m.stamp;
  Job& j = m.job(slot);
  return m.unit_deadline(j, j.g->units[static_cast<std::size_t>(unit)].height, now);
}

}  // namespace red
