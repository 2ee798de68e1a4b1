// Jobs and releases: operation versions (install), releasing a job on its operation's tick or
// frame, ending and freeing it, and what observers are told. Part of the scheduler
// (scheduler_impl.hpp).

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::notify_job(const Job& j, JobOutcome o, TimePoint finish, bool release_event) {
  if (observers.empty()) return;
  JobRecord r;
  r.id = j.id;
  r.operation = j.op;
  r.seq = j.seq;
  r.release = j.release;
  r.deadline = j.deadline;
  r.finish = finish;
  r.outcome = o;
  r.counted = j.counted;
  r.frame_age = j.oldest_frame == kNever ? Duration{0} : finish - j.oldest_frame;
  r.reason = reason_text(j);
  r.graph = j.g;
  for (Observer* ob : observers) release_event ? ob->on_job_release(r) : ob->on_job_end(r);
}

void Scheduler::Impl::install(int i, const std::shared_ptr<const OperationSpec>& spec, TimePoint at,
                              bool initial) {
  OpState& o = ops[static_cast<std::size_t>(i)];
  if (!spec) {
    o.g = nullptr;
    o.next_tick = kNever;
    return;
  }
  const bool was_active = o.g != nullptr;
  RefineOptions at_given = ropt;
  at_given.deadline = resolve_deadline(*spec, given);
  graphs.push_back(refine(spec, i, costs, at_given));
  o.g = graphs.back().get();
  const double old_rate = o.rate_hz;
  o.trigger = spec->trigger_sensor;
  o.own_rate = spec->trigger_sensor < 0 && spec->rate_hz > 0.0;
  o.all_at_once = spec->trigger_sensor < 0 && spec->rate_hz <= 0.0;
  o.rate_hz = spec->rate_hz;
  o.max_inflight = spec->max_inflight;
  o.depends_on = spec->depends_on;
  o.criticality = spec->criticality;
  if (!was_active) o.remaining = spec->release_count ? *spec->release_count : -1;
  o.sensors_read = o.g->sensors;
  // A held all-at-once release survives a new version of its operation (docs/DESIGN.md, "Task
  // model" events).
  if (!o.all_at_once) o.awaits_frames = false;
  if (o.own_rate || o.all_at_once) {
    if (!was_active || initial) {
      o.next_tick = at + spec->phase;
      o.awaits_frames = false;
    } else if (o.own_rate && old_rate != o.rate_hz) {
      // A rate change takes effect from the next release: one new period from now.
      o.next_tick = at + period_of(o.rate_hz);
    }
  } else {
    o.next_tick = kNever;
  }
  releases.note_tick(ops, i);
}

void Scheduler::Impl::release(int op_index, TimePoint now, int trigger_sensor,
                              std::uint64_t trigger_frame) {
  OpState& o = ops[static_cast<std::size_t>(op_index)];
  if (o.g == nullptr || o.remaining == 0) return;
  // docs/DESIGN.md, "Refinement": a job computes on frames its sensors produced. Before a sensor's
  // first frame there is nothing to read, so this tick or trigger frame releases no job.
  if (!releases.inputs_ready(*o.g, trigger_sensor)) return;
  if (o.remaining > 0 && --o.remaining == 0) {
    shedding.on_workload();
    plan_work();
  }
  const std::uint64_t seq = o.released++;
  ++s.stats_.releases;
  const RefinedGraph& g = *o.g;
  if (o.inflight >= o.max_inflight) {
    // max_inflight (docs/DESIGN.md, "max_inflight"): the frame is skipped and counted as a drop.
    o.last_skip = now;
    overload.on_skip(now);
    Job tmp;
    tmp.id = jobs.next_id();
    tmp.op = op_index;
    tmp.seq = seq;
    tmp.g = &g;
    tmp.release = now;
    tmp.deadline = now + g.deadline;
    tmp.counted = now >= s.config_.warmup;
    tmp.reason = DropReason::MaxInflight;
    notify_job(tmp, JobOutcome::Skipped, now, true);
    notify_job(tmp, JobOutcome::Skipped, now, false);
    return;
  }
  // Shedding by rate (shedding.hpp) decides before the job is made; it ends once released.
  const bool reject = shedding.rejects_at_release(*this, op_index, now);
  const int slot = jobs.alloc();
  Job& j = job(slot);
  j.id = jobs.next_id();
  j.live = true;
  j.ended = false;
  j.op = op_index;
  j.seq = seq;
  j.g = &g;
  j.release = now;
  j.deadline = now + g.deadline;
  j.plan = j.deadline;
  j.counted = now >= s.config_.warmup;
  j.samples_newest = trigger_sensor < 0;
  j.unfinished = static_cast<int>(g.units.size());
  j.running = 0;
  j.oldest_frame = kNever;
  j.reason = DropReason::None;
  j.failure.clear();
  j.dependents.clear();
  j.dependent_ids.clear();
  j.stamp = 0;
  j.dirty = true;
  j.grouped = 0;
  j.started = false;
  const std::vector<SensorState>& sensors = releases.sensors();
  j.frame.assign(sensors.size(), 0);
  j.frame_time.assign(sensors.size(), now);
  for (int sn : g.sensors) {
    const auto si = static_cast<std::size_t>(sn);
    if (sn == trigger_sensor) {
      j.frame[si] = trigger_frame;
      j.frame_time[si] = sensors[si].time;
    } else if (sensors[si].has_frame) {
      j.frame[si] = sensors[si].frame;
      j.frame_time[si] = sensors[si].time;
    }
  }
  j.u.assign(g.units.size(), UnitRt{});
  for (std::size_t i = 0; i < g.units.size(); ++i)
    j.u[i].pending = static_cast<int>(g.units[i].preds.size());
  // depends_on {use: latest}: the newest job of that operation must end first (docs/SCENARIOS.md).
  if (o.depends_on >= 0) {
    OpState& dep = ops[static_cast<std::size_t>(o.depends_on)];
    if (dep.last_slot >= 0) {
      Job& d = job(dep.last_slot);
      if (d.live && !d.ended && d.id == dep.last_job) {
        d.dependents.push_back(slot);
        d.dependent_ids.push_back(j.id);
        inheritance.released(*this, j, d);  // deadline inheritance (inherit.hpp)
        for (int u : g.head_sources) ++j.u[static_cast<std::size_t>(u)].pending;
      }
    }
  }
  o.last_slot = slot;
  o.last_job = j.id;
  ++o.inflight;
  ++s.in_flight_;
  overload.on_release(jobs, slot);
  if (opt.drop != DropMode::None) {
    deadlines.push_back({j.deadline, {slot, j.id}});
    std::push_heap(deadlines.begin(), deadlines.end(), std::greater<>{});
  }
  notify_job(j, JobOutcome::Unfinished, now, true);
  for (std::size_t i = 0; i < g.units.size(); ++i)
    if (j.u[i].pending == 0) make_ready(slot, static_cast<int>(i));
  // The offered load; admission before the next decision; the rejection by rate.
  shedding.released(*this, slot, reject, now);
}

void Scheduler::Impl::end_job(int slot, JobOutcome outcome, TimePoint now) {
  Job& j = job(slot);
  if (j.ended) return;
  j.ended = true;
  --s.in_flight_;
  --ops[static_cast<std::size_t>(j.op)].inflight;
  shedding.on_end(j.op, outcome, j.reason, now);
  overload.on_end(jobs, slot, outcome, now);
  if (outcome != JobOutcome::Met && outcome != JobOutcome::Missed) {
    // Abort (docs/DESIGN.md, "Drops" strict): queued units leave their tasks; running ones finish
    // and their output is discarded when they return.
    for (std::size_t i = 0; i < j.u.size(); ++i) {
      UnitRt& u = j.u[i];
      if (u.state == UState::Queued) remove_member(u.task, slot, static_cast<int>(i));
      if (u.state == UState::Queued || u.state == UState::Blocked) u.state = UState::Cancelled;
      touch(j);
    }
  }
  notify_job(j, outcome, now, false);
  // Dependents may go on: they use the newest output there is.
  for (std::size_t k = 0; k < j.dependents.size(); ++k) {
    const int ds = j.dependents[k];
    Job& d = job(ds);
    if (!d.live || d.ended || d.id != j.dependent_ids[k]) continue;
    for (int u : d.g->head_sources) {
      UnitRt& ur = d.u[static_cast<std::size_t>(u)];
      if (ur.state == UState::Blocked && --ur.pending == 0) make_ready(ds, u);
    }
  }
  if (j.running == 0) free_job(slot);
}

}  // namespace red
