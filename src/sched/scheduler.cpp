#include "red/sched/scheduler.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <string>

#include "red/core/assert.hpp"
#include "scheduler_impl.hpp"

namespace red {

const char* to_string(JobOutcome o) noexcept {
  switch (o) {
    case JobOutcome::Met:
      return "met";
    case JobOutcome::Missed:
      return "missed";
    case JobOutcome::Dropped:
      return "dropped";
    case JobOutcome::Skipped:
      return "skipped";
    case JobOutcome::Failed:
      return "failed";
    case JobOutcome::Unfinished:
      return "unfinished";
  }
  return "?";
}

const char* to_string(UnitStatus s) noexcept {
  switch (s) {
    case UnitStatus::Completed:
      return "completed";
    case UnitStatus::Failed:
      return "failed";
    case UnitStatus::OutOfMemory:
      return "out-of-memory";
    case UnitStatus::Cancelled:
      return "cancelled";
    case UnitStatus::Unfinished:
      return "unfinished";
  }
  return "?";
}

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
    : s(owner), profile(p), opt(owner.policy_->options()) {
  const Scenario& sc = s.scenario_;
  costs = CostModel{&profile, &sc.model, s.config_.estimate};
  ropt = RefineOptions{opt.graph, opt.deadlines, s.config_.level_cost};
  enc_prof = profile.find("encoder");
  enc_single = costs.encoder();
  enc_max_batch = enc_prof != nullptr ? enc_prof->max_batch() : 1;
  for (std::size_t h = 0; h < sc.model.heads.size(); ++h) {
    head_single.push_back(costs.head(static_cast<int>(h)));
    head_prof.push_back(profile.find("head/" + sc.model.heads[h]));
  }
  sensors.resize(sc.sensors.size());
  for (std::size_t i = 0; i < sc.sensors.size(); ++i) sensors[i].rate_hz = sc.sensors[i].rate_hz;
  open_enc.resize(sc.sensors.size());
  lanes.resize(static_cast<std::size_t>(s.config_.lanes));
  ops.resize(static_cast<std::size_t>(sc.operation_count()));
  for (int i = 0; i < sc.operation_count(); ++i)
    if (sc.initial[static_cast<std::size_t>(i)])
      install(i, sc.initial[static_cast<std::size_t>(i)], TimePoint{0}, true);
  // Criticality orders work only under overload (docs/DESIGN.md, "Criticality"); the demand test
  // that detects it runs only when criticalities differ somewhere in the scenario, or the policy
  // ranks by it.
  int lo = std::numeric_limits<int>::max(), hi = std::numeric_limits<int>::min();
  auto see = [&](const std::shared_ptr<const OperationSpec>& op) {
    if (!op) return;
    lo = std::min(lo, op->criticality);
    hi = std::max(hi, op->criticality);
  };
  for (const auto& op : sc.initial) see(op);
  for (const EventSpec& e : sc.events)
    for (const auto& [i, op] : e.changes) see(op);
  mixed_criticality = lo < hi;
  uniform_criticality = lo <= hi ? lo : 0;
  edf_rank = s.policy_->ranks_by_deadline_only();
}

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
  r.reason = j.reason;
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
  graphs.push_back(refine(spec, i, costs, ropt));
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
  note_tick(i);
}

int Scheduler::Impl::alloc_job() {
  if (!free_jobs.empty()) {
    const int slot = free_jobs.back();
    free_jobs.pop_back();
    return slot;
  }
  jobs.emplace_back();
  return static_cast<int>(jobs.size() - 1);
}

bool Scheduler::Impl::inputs_ready(const RefinedGraph& g, int trigger_sensor) const {
  for (int sn : g.sensors)
    if (sn != trigger_sensor && !sensors[static_cast<std::size_t>(sn)].has_frame) return false;
  return true;
}

void Scheduler::Impl::release(int op_index, TimePoint now, int trigger_sensor,
                              std::uint64_t trigger_frame) {
  OpState& o = ops[static_cast<std::size_t>(op_index)];
  if (o.g == nullptr || o.remaining == 0) return;
  // docs/DESIGN.md, "Refinement": a job computes on frames its sensors produced. Before a sensor's
  // first frame there is nothing to read, so this tick or trigger frame releases no job.
  if (!inputs_ready(*o.g, trigger_sensor)) return;
  if (o.remaining > 0 && --o.remaining == 0) {
    rates_changed = true;
    expected_stale = true;
  }
  const std::uint64_t seq = o.released++;
  ++s.stats_.releases;
  const RefinedGraph& g = *o.g;
  if (o.inflight >= o.max_inflight) {
    // max_inflight (docs/DESIGN.md, "max_inflight"): the frame is skipped and counted as a drop.
    o.last_skip = now;
    Job tmp;
    tmp.id = next_job_id++;
    tmp.op = op_index;
    tmp.seq = seq;
    tmp.g = &g;
    tmp.release = now;
    tmp.deadline = now + g.deadline;
    tmp.counted = now >= s.config_.warmup;
    tmp.reason = "max_inflight";
    notify_job(tmp, JobOutcome::Skipped, now, true);
    notify_job(tmp, JobOutcome::Skipped, now, false);
    return;
  }
  // docs/DESIGN.md, "Overload": past capacity, the jobs of an operation that cheaper ones outrank
  // are rejected before they cost anything (plan_rates).
  const bool reject =
      opt.admission == Admission::Shed && opt.shed_by_rate && !mixed_criticality && [&] {
        if (rates_changed) plan_rates();
        return outranked[static_cast<std::size_t>(op_index)] != 0 && past_capacity() &&
               ahead_shed(op_index, now);
      }();
  const int slot = alloc_job();
  Job& j = job(slot);
  j.id = next_job_id++;
  j.live = true;
  j.ended = false;
  j.op = op_index;
  j.seq = seq;
  j.g = &g;
  j.release = now;
  j.deadline = now + g.deadline;
  j.counted = now >= s.config_.warmup;
  j.samples_newest = trigger_sensor < 0;
  j.unfinished = static_cast<int>(g.units.size());
  j.running = 0;
  j.oldest_frame = kNever;
  j.reason.clear();
  j.dependents.clear();
  j.dependent_ids.clear();
  j.stamp = 0;
  j.dirty = true;
  j.grouped = 0;
  j.started = false;
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
        for (int u : g.head_sources) ++j.u[static_cast<std::size_t>(u)].pending;
      }
    }
  }
  o.last_slot = slot;
  o.last_job = j.id;
  ++o.inflight;
  ++s.in_flight_;
  by_deadline.insert(std::upper_bound(by_deadline.begin(), by_deadline.end(), slot,
                                      [this](int a, int b) { return earlier(a, b); }),
                     slot);
  released_since_admission = true;
  if (opt.drop != DropMode::None) {
    deadlines.push_back({j.deadline, {slot, j.id}});
    std::push_heap(deadlines.begin(), deadlines.end(), std::greater<>{});
  }
  notify_job(j, JobOutcome::Unfinished, now, true);
  for (std::size_t i = 0; i < g.units.size(); ++i)
    if (j.u[i].pending == 0) make_ready(slot, static_cast<int>(i));
  if (opt.admission == Admission::Shed) note_offered(j, now);
  if (reject) {
    j.reason = "rejected at release";
    ++s.stats_.rejected;
    rejecting_by_rate = true;
    end_job(slot, JobOutcome::Dropped, now);
    rejecting_by_rate = false;
  }
}

void Scheduler::Impl::end_job(int slot, JobOutcome outcome, TimePoint now) {
  Job& j = job(slot);
  if (j.ended) return;
  j.ended = true;
  --s.in_flight_;
  --ops[static_cast<std::size_t>(j.op)].inflight;
  if (outcome == JobOutcome::Dropped && !rejecting_by_rate)
    ops[static_cast<std::size_t>(j.op)].last_shed = now;
  const auto at = std::lower_bound(by_deadline.begin(), by_deadline.end(), slot,
                                   [this](int a, int b) { return earlier(a, b); });
  if (at != by_deadline.end() && *at == slot) by_deadline.erase(at);
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

void Scheduler::Impl::free_job(int slot) {
  Job& j = job(slot);
  j.live = false;
  free_jobs.push_back(slot);
}

void Scheduler::Impl::rebuild(Job& j) {
  j.dirty = false;
  const RefinedGraph& g = *j.g;
  const auto levels = static_cast<std::size_t>(g.levels);
  const bool sum = s.config_.level_cost == LevelCost::Sum;
  j.lvl_base.assign(levels, Duration{0});
  j.has_base.assign(levels, 0);
  j.running_units.clear();
  j.enc_queued.clear();
  j.work_base.fill(Duration{0});
  j.work_most.fill(Duration{0});
  j.cp_base.fill(Duration{0});
  j.started = false;
  for (std::size_t i = 0; i < g.units.size(); ++i) {
    const UnitRt& u = j.u[i];
    const RefinedUnit& ru = g.units[i];
    if (u.state == UState::Done || u.state == UState::Running) j.started = true;
    if (u.state == UState::Done || u.state == UState::Cancelled) continue;
    const auto h = static_cast<std::size_t>(ru.height);
    j.has_base[h] = 1;
    if (u.state == UState::Running) {
      j.running_units.push_back(static_cast<int>(i));
      for (std::size_t k = 0; k < kEstimates; ++k)
        j.work_most[k] += ru.costs[k] / std::max(1, u.share);
      continue;
    }
    const Duration c = ru.estimate;
    j.lvl_base[h] = sum ? j.lvl_base[h] + c : std::max(j.lvl_base[h], c);
    for (std::size_t k = 0; k < kEstimates; ++k) j.cp_base[k] = std::max(j.cp_base[k], ru.tail[k]);
    if (ru.kind == UnitKind::Encoder && u.state == UState::Queued) {
      j.enc_queued.push_back(static_cast<int>(i));
      // Shared by the task's members now; more may join (less each), and a member that
      // leaves marks the others dirty (remove_member).
      const auto members =
          static_cast<std::int64_t>(std::max<std::size_t>(1, task(u.task).members.size()));
      for (std::size_t k = 0; k < kEstimates; ++k) j.work_most[k] += ru.costs[k] / members;
    } else {
      for (std::size_t k = 0; k < kEstimates; ++k) {
        j.work_base[k] += ru.costs[k];
        j.work_most[k] += ru.costs[k];
      }
    }
  }
  j.remaining_base = Duration{0};
  for (Duration l : j.lvl_base) j.remaining_base += l;

  if (opt.reassign && j.running_units.empty()) shares(j, j.lvl_base, j.has_base, j.frac);
}

void Scheduler::Impl::shares(const Job& j, const std::vector<Duration>& lvl,
                             const std::vector<std::uint8_t>& has,
                             std::vector<double>& frac) const {
  const RefinedGraph& g = *j.g;
  const std::size_t levels = lvl.size();
  frac.resize(levels);
  std::int64_t total = 0;
  std::int64_t n = 0;
  for (std::size_t h = 0; h < levels; ++h) {
    if (has[h] == 0) continue;
    ++n;
    total += (g.override_budget[h] > Duration{0} ? g.override_budget[h] : lvl[h]).count();
  }
  const bool equal = opt.deadlines == DeadlineMode::Equal || total <= 0;
  const std::int64_t denom = equal ? n : total;
  std::int64_t cum = 0;
  double last = 0.0;  // before the first height with work: now
  for (std::size_t h = 0; h < levels; ++h) {
    if (has[h] != 0) {
      cum +=
          equal ? 1 : (g.override_budget[h] > Duration{0} ? g.override_budget[h] : lvl[h]).count();
      last = cum == denom ? 1.0 : static_cast<double>(cum) / static_cast<double>(denom);
    }
    frac[h] = last;
  }
}

void Scheduler::Impl::eval_now(Job& j, TimePoint now) {
  j.stamp = stamp;
  const RefinedGraph& g = *j.g;
  const bool sum = s.config_.level_cost == LevelCost::Sum;
  j.lvl = j.lvl_base;
  for (int i : j.running_units) {
    const UnitRt& u = j.u[static_cast<std::size_t>(i)];
    Duration c = g.units[static_cast<std::size_t>(i)].estimate;
    if (now > u.start) c = std::max(Duration{0}, c - (now - u.start));
    const auto h = static_cast<std::size_t>(g.units[static_cast<std::size_t>(i)].height);
    j.lvl[h] = sum ? j.lvl[h] + c : std::max(j.lvl[h], c);
  }
  j.remaining = Duration{0};
  for (Duration l : j.lvl) j.remaining += l;
  if (opt.reassign) shares(j, j.lvl, j.has_base, j.frac_now);
}

TimePoint Scheduler::Impl::height_deadline(Job& j, int h, TimePoint now) {
  const auto hi = static_cast<std::size_t>(h);
  switch (opt.deadlines) {
    case DeadlineMode::None:
      return j.release;
    case DeadlineMode::EndToEnd:
      return j.deadline;
    case DeadlineMode::Proportional:
    case DeadlineMode::Equal:
      break;
  }
  if (!opt.reassign) return j.release + j.g->static_offset[hi];
  refresh(j);
  if (j.running_units.empty()) return from_share(j, j.frac[hi], now);
  eval(j, now);
  return from_share(j, j.frac_now[hi], now);
}

Duration Scheduler::Impl::remaining_work(Job& j, TimePoint now) {
  refresh(j);
  if (j.running_units.empty()) return j.remaining_base;
  eval(j, now);
  return j.remaining;
}

int Scheduler::Impl::alloc_task() {
  int t;
  if (!free_tasks.empty()) {
    t = free_tasks.back();
    free_tasks.pop_back();
  } else {
    tasks.emplace_back();
    task_ranks.emplace_back();
    t = static_cast<int>(tasks.size() - 1);
  }
  Task& k = task(t);
  k.live = true;
  k.members.clear();
  k.member_at.clear();
  k.wait_until = TimePoint{0};
  k.ready_pos = -1;
  k.group = -1;
  k.lane_only = -1;
  return t;
}

void Scheduler::Impl::push_ready(int t) {
  task(t).ready_pos = static_cast<int>(ready.size());
  ready_encoders += task(t).kind == UnitKind::Encoder ? 1 : 0;
  ready.push_back(t);
}

void Scheduler::Impl::pop_ready(int t) {
  Task& k = task(t);
  if (k.group >= 0) {
    leave_group(t, false);
    return;
  }
  if (k.ready_pos < 0) return;
  ready_encoders -= k.kind == UnitKind::Encoder ? 1 : 0;
  const int last = ready.back();
  ready[static_cast<std::size_t>(k.ready_pos)] = last;
  task(last).ready_pos = k.ready_pos;
  ready.pop_back();
  k.ready_pos = -1;
}

void Scheduler::Impl::drop_open(int t) {
  Task& k = task(t);
  if (k.kind != UnitKind::Encoder) return;
  auto& v = open_enc[static_cast<std::size_t>(k.sensor)];
  v.erase(std::remove(v.begin(), v.end(), t), v.end());
}

void Scheduler::Impl::free_task(int t) {
  pop_ready(t);
  drop_open(t);
  task(t).live = false;
  free_tasks.push_back(t);
}

void Scheduler::Impl::remove_member(int t, int slot, int unit) {
  Task& k = task(t);
  if (k.group >= 0) leave_group(t, true);  // its members change
  auto& m = k.members;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (m[i] == std::pair<int, int>{slot, unit}) continue;
    m[kept] = m[i];
    k.member_at[kept] = k.member_at[i];
    ++kept;
  }
  m.resize(kept);
  k.member_at.resize(kept);
  // The others' share of a queued encoder run grew: their bounds on the work left go stale.
  if (k.kind == UnitKind::Encoder)
    for (auto [js, ju] : m) touch(job(js));
  if (m.empty()) {
    free_task(t);
    return;
  }
  k.min_release = kNever;
  TaskRank& r = task_rank(t);
  r.job_deadline = kNever;
  r.tie = tie_key(m.front().first, m.front().second, k.member_at.front().second);
  for (std::size_t i = 0; i < m.size(); ++i) {
    const Job& j = job(m[i].first);
    k.min_release = std::min(k.min_release, j.release);
    r.job_deadline = std::min(r.job_deadline, rank_deadline(j, m[i].second));
    const Key mk = tie_key(m[i].first, m[i].second, k.member_at[i].second);
    if (mk < r.tie) r.tie = mk;
  }
}

void Scheduler::Impl::make_ready(int slot, int unit) {
  Job& j = job(slot);
  const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
  UnitRt& u = j.u[static_cast<std::size_t>(unit)];
  u.state = UState::Queued;
  if (ru.kind == UnitKind::Encoder && opt.merge) {
    const auto si = static_cast<std::size_t>(ru.sensor);
    const std::uint64_t frame = j.frame[si];
    // DynamicMerge (docs/DESIGN.md, "DynamicMerge"): 1. same frame, unconditionally; 2. a γ-cluster
    // of releases that sample the newest frame, while max(release) − min(release) ≤ γ.
    for (int t : open_enc[si]) {
      Task& k = task(t);
      const bool same = k.frame == frame && (!k.gamma || j.samples_newest);
      const bool gamma =
          k.gamma && j.samples_newest && j.release - k.min_release <= s.config_.gamma;
      if (!same && !gamma) continue;
      k.members.emplace_back(slot, unit);
      k.member_at.emplace_back(ru.height, ru.node);
      TaskRank& r = task_rank(t);
      r.job_deadline = std::min(r.job_deadline, rank_deadline(j, unit));
      if (const Key mk = tie_key(slot, unit, ru.node); mk < r.tie) r.tie = mk;
      if (gamma && frame > k.frame) {
        k.frame = frame;
        k.frame_time = j.frame_time[si];
      }
      k.wait_until = TimePoint{0};  // the member it may have waited for has come
      u.task = t;
      return;
    }
  }
  const int t = alloc_task();
  Task& k = task(t);
  k.kind = ru.kind;
  k.head = ru.head;
  k.sensor = ru.sensor;
  k.gamma = ru.kind == UnitKind::Encoder && j.samples_newest;
  k.frame = ru.sensor >= 0 ? j.frame[static_cast<std::size_t>(ru.sensor)] : 0;
  k.frame_time = ru.sensor >= 0 ? j.frame_time[static_cast<std::size_t>(ru.sensor)] : j.release;
  k.members.emplace_back(slot, unit);
  k.member_at.emplace_back(ru.height, ru.node);
  k.min_release = j.release;
  task_rank(t) = TaskRank{tie_key(slot, unit, ru.node), rank_deadline(j, unit)};
  k.cost = ru.estimate;
  u.task = t;
  push_ready(t);
  if (ru.kind == UnitKind::Encoder && opt.merge)
    open_enc[static_cast<std::size_t>(ru.sensor)].push_back(t);
}

Key Scheduler::Impl::key(int t, TimePoint now, TaskView& v) {
  Task& k = task(t);
  v = TaskView{};
  v.deadline = kNever;
  v.release = kNever;
  v.job_deadline = kNever;
  // What ranking by job deadline reads (rank_deadline), when this round ranks k so.
  const bool rank_by_job = by_job_deadline(k);
  TimePoint by_job = kNever;
  v.cost = k.cost;
  Key best{0, kNever, std::numeric_limits<int>::max(), 0, 0, 0};
  // Re-assignment (docs/DESIGN.md, "Re-assignment") (red, red-ida): one look at the job's cache
  // gives both its height's deadline and its remaining work (height_deadline and remaining_work,
  // inlined).
  const bool shared = opt.reassign && (opt.deadlines == DeadlineMode::Proportional ||
                                       opt.deadlines == DeadlineMode::Equal);
  for (std::size_t i = 0; i < k.members.size(); ++i) {
    const auto [slot, unit] = k.members[i];
    const auto [height, node] = k.member_at[i];
    Job& j = job(slot);
    if (shared) {
      refresh(j);
      const auto h = static_cast<std::size_t>(height);
      if (j.running_units.empty()) {
        v.deadline = std::min(v.deadline, from_share(j, j.frac[h], now));
        v.remaining = std::max(v.remaining, j.remaining_base);
      } else {
        eval(j, now);
        v.deadline = std::min(v.deadline, from_share(j, j.frac_now[h], now));
        v.remaining = std::max(v.remaining, j.remaining);
      }
    } else {
      v.deadline = std::min(v.deadline, height_deadline(j, height, now));
      v.remaining = std::max(v.remaining, remaining_work(j, now));
    }
    v.release = std::min(v.release, j.release);
    v.job_deadline = std::min(v.job_deadline, j.deadline);
    if (rank_by_job) by_job = std::min(by_job, rank_deadline(j, unit));
    if (mixed_criticality)
      v.criticality = std::max(v.criticality, ops[static_cast<std::size_t>(j.op)].criticality);
    const Key mk{0, j.release, j.op, j.seq, node, unit};
    if (mk < best) best = mk;
  }
  // Equal criticalities everywhere (every version of every operation): no look at them.
  if (!mixed_criticality && !k.members.empty())
    v.criticality = std::max(v.criticality, uniform_criticality);
  v.overloaded = overloaded;
  // docs/DESIGN.md, "Overload" "finish what was started": while overloaded (or always,
  // rank=job-deadline) the policy ranks by the job's end-to-end deadline; the task's own deadline
  // stays what batching is checked against.
  if (rank_by_job) {
    TaskView view = v;
    view.deadline = by_job;
    best.rank = s.policy_->rank(view, now);
  } else {
    best.rank = s.policy_->rank(v, now);
  }
  return best;
}

TimePoint Scheduler::Impl::task_deadline(const Task& k, TimePoint now) {
  // key()'s deadline, with no other look: the members' caches are as key() left them.
  TimePoint d = kNever;
  const bool shared = opt.reassign && (opt.deadlines == DeadlineMode::Proportional ||
                                       opt.deadlines == DeadlineMode::Equal);
  for (std::size_t i = 0; i < k.members.size(); ++i) {
    Job& j = job(k.members[i].first);
    const int height = k.member_at[i].first;
    if (shared) {
      refresh(j);
      const auto h = static_cast<std::size_t>(height);
      if (j.running_units.empty()) {
        d = std::min(d, from_share(j, j.frac[h], now));
      } else {
        eval(j, now);
        d = std::min(d, from_share(j, j.frac_now[h], now));
      }
    } else {
      d = std::min(d, height_deadline(j, height, now));
    }
  }
  return d;
}

TimePoint Scheduler::Impl::predicted_member(const Task& k, TimePoint now) const {
  TimePoint best = kNever;
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const OpState& o = ops[i];
    // An operation at max_inflight will skip its next release: nothing to wait for.
    if (o.g == nullptr || !o.own_rate || o.remaining == 0 || o.inflight >= o.max_inflight) continue;
    if (o.next_tick <= now || o.next_tick - k.min_release > s.config_.gamma) continue;
    if (std::find(o.sensors_read.begin(), o.sensors_read.end(), k.sensor) == o.sensors_read.end())
      continue;
    bool member = false;
    for (auto [slot, unit] : k.members)
      member = member || jobs[static_cast<std::size_t>(slot)].op == static_cast<int>(i);
    if (!member) best = std::min(best, o.next_tick);
  }
  return best;
}

bool Scheduler::Impl::slack_covers(Task& k, TimePoint now, TimePoint until) {
  for (auto [slot, unit] : k.members) {
    Job& j = job(slot);
    if (j.deadline - now - remaining_work(j, now) - round_trip_cost(true) < until - now)
      return false;
  }
  return true;
}

Duration Scheduler::Impl::round_trip_cost(bool round_trip) const {
  return round_trip ? s.config_.sync_cost : Duration{0};
}

Duration Scheduler::Impl::batch_estimate(const Task& k, int b) const {
  const UnitProfile* p =
      k.kind == UnitKind::Encoder ? enc_prof : head_prof[static_cast<std::size_t>(k.head)];
  return p != nullptr ? p->at(b).estimate(s.config_.estimate) : k.cost * b;
}

int Scheduler::Impl::batch_limit(const Task& k) const {
  const UnitProfile* p =
      k.kind == UnitKind::Encoder ? enc_prof : head_prof[static_cast<std::size_t>(k.head)];
  return std::min(s.config_.max_batch, p != nullptr ? p->max_batch() : 1);
}

void Scheduler::Impl::set_start(Dispatch& d, TimePoint start) {
  d.start = start;
  for (const Member& mb : d.members) {
    Job& j = job(mb.slot);
    if (j.live && j.id == mb.job) j.u[static_cast<std::size_t>(mb.unit)].start = start;
  }
}

bool Scheduler::Impl::on_demand_continuation(const Lane& lane, const Task& k, TimePoint now) const {
  if (opt.sync != SyncMode::OnDemand || lane.completed_at != now || !lane.run_open) return false;
  for (auto [slot, unit] : k.members) {
    const JobId id = jobs[static_cast<std::size_t>(slot)].id;
    for (const auto& [rs, rid] : lane.run_jobs)
      if (rs == slot && rid == id) return true;
  }
  return false;
}

TimePoint Scheduler::Impl::latest_batch_end(const Task& k) const {
  // The scheduler's estimate (p99, by default) of the path after the unit: on the mean,
  // batches formed that their members' later units then missed (docs/BENCHMARKS.md
  // round 7).
  TimePoint d = kNever;
  for (const auto& [slot, unit] : k.members) {
    const Job& j = jobs[static_cast<std::size_t>(slot)];
    d = std::min(d, j.deadline - path_after(j, unit));
  }
  return d;
}

int Scheduler::Impl::choose_lane(const Task& k, TimePoint now) const {
  if (ahead_lane >= 0) return ahead_lane;  // dispatch_ahead: the lane is given
  int fallback = -1;
  bool fallback_open = true;
  for (std::size_t i = 0; i < lanes.size(); ++i) {
    const Lane& l = lanes[i];
    if (l.busy()) continue;
    if (on_demand_continuation(l, k, now)) return static_cast<int>(i);
    const bool open = l.run_open && l.completed_at == now;
    if (fallback < 0 || (fallback_open && !open)) {
      fallback = static_cast<int>(i);
      fallback_open = open;
    }
  }
  return fallback;
}

void Scheduler::Impl::start_dispatch(int lane_index, TimePoint now, TimePoint deadline) {
  Lane& lane = lanes[static_cast<std::size_t>(lane_index)];
  Dispatch& d = lane.next_slot();
  const Task& first = task(batch.front());
  d.id = ++dispatch_seq;
  d.lane = lane_index;
  d.kind = first.kind;
  d.head = first.head;
  d.sensor = first.sensor;
  d.batch = static_cast<int>(batch.size());
  d.members.clear();
  d.task_begin.clear();
  d.deadline = deadline;
  d.decided_at = now;
  d.start = now;
  // Queued behind the lane's running unit by its own handler: no round trip.
  d.round_trip = ahead_lane < 0 && !on_demand_continuation(lane, first, now);
  // A round trip starts a new run: the handler is handed these jobs' work (docs/DESIGN.md,
  // "Synchronization").
  if (d.round_trip) lane.run_jobs.clear();
  lane.run_open = false;
  for (int t : batch) {
    Task& k = task(t);
    d.task_begin.push_back(static_cast<int>(d.members.size()));
    if (opt.merge && k.kind == UnitKind::Encoder && k.gamma) {
      // A γ-merged run uses the newest frame available when it starts (docs/DESIGN.md,
      // "Refinement"). Without DynamicMerge a job keeps the frame it sampled at release: its
      // encoders on one sensor run as separate tasks, and their heads must all read that one frame.
      const SensorState& sn = sensors[static_cast<std::size_t>(k.sensor)];
      if (sn.has_frame && sn.frame > k.frame) {
        k.frame = sn.frame;
        k.frame_time = sn.time;
      }
    }
    for (auto [slot, unit] : k.members) {
      Job& j = job(slot);
      // Where ranking did not look into the jobs, the job's evaluation at `now` is taken
      // before its unit starts, as ranking would have taken it: a later look in this round
      // reads the values from before.
      if (ranks_from_tasks()) {
        refresh(j);
        if (!j.running_units.empty()) eval(j, now);
      }
      UnitRt& u = j.u[static_cast<std::size_t>(unit)];
      u.state = UState::Running;
      touch(j);
      u.task = -1;
      u.start = now;
      u.share = static_cast<int>(k.members.size());
      if (std::find(lane.run_jobs.begin(), lane.run_jobs.end(),
                    std::pair<int, JobId>{slot, j.id}) == lane.run_jobs.end())
        lane.run_jobs.emplace_back(slot, j.id);
      ++j.running;
      const RefinedUnit& ru = j.g->units[static_cast<std::size_t>(unit)];
      Member m;
      m.job = j.id;
      m.slot = slot;
      m.unit = unit;
      m.operation = j.op;
      m.node = ru.node;
      m.job_seq = j.seq;
      m.release = j.release;
      m.graph = j.g;
      if (ru.sensor >= 0) {
        const auto si = static_cast<std::size_t>(ru.sensor);
        if (ru.kind == UnitKind::Encoder) {
          j.frame[si] = k.frame;  // its head reads the features of this frame
          j.frame_time[si] = k.frame_time;
        }
        m.frame = j.frame[si];
        m.frame_time = j.frame_time[si];
        j.oldest_frame = std::min(j.oldest_frame, m.frame_time);
      } else if (ru.kind == UnitKind::Mono && !j.g->sensors.empty()) {
        const auto si = static_cast<std::size_t>(j.g->sensors.front());
        m.frame = j.frame[si];
        m.frame_time = j.frame_time[si];
        for (int sn : j.g->sensors)
          j.oldest_frame = std::min(j.oldest_frame, j.frame_time[static_cast<std::size_t>(sn)]);
      }
      d.members.push_back(m);
    }
    free_task(t);
  }
  d.task_begin.push_back(static_cast<int>(d.members.size()));
  ++lane.count;
  ++s.stats_.dispatches;
  if (d.round_trip) ++s.stats_.round_trips;
  out.push_back(&d);
}

bool Scheduler::Impl::pick(TimePoint now) {
  for (;;) {
    // One scan ranks every ready task (the policy's key, and the deadline batching
    // orders by); a merge wait then only moves to the next best entry of the scan.
    scanned.clear();
    // Criticality (docs/DESIGN.md, "Criticality"): under overload — the demand test finds more work
    // due than the lanes can do, or some ready job cannot, by estimate, finish alone by its
    // deadline — ready work of the most critical operations goes first and lower-criticality work
    // waits, so it is shed first. With equal criticalities (the default) nothing changes.
    // The demand test's verdict alone: not red-robust's wider `overloaded` (an operation at
    // its max_inflight, the hold after an overload), which put every critical unit first
    // while the lanes could carry everything (issue 37: red-robust missed 2-3x red's jobs).
    bool overload = demand_overrun;
    int top = std::numeric_limits<int>::min();
    // With equal criticalities the order is the keys' alone: the least is kept as they come.
    std::size_t least = 0;
    auto rank_task = [&](int t) __attribute__((always_inline)) {
      Task& tk = task(t);
      if (tk.wait_until > now) return;
      if (tk.lane_only >= 0 && tk.lane_only != ahead_lane) return;  // behind a busy lane
      if (ranks_from_tasks() && by_job_deadline(tk)) {
        // EDF by job deadline reads only the earliest job deadline and the least member
        // key, both kept beside the task (TaskRank): no look into the jobs. The task's own
        // deadline is computed where it is read (task_deadline). With equal criticalities
        // neither the remaining work nor the criticality orders anything. The jobs' caches
        // read later give what this scan would have left, or values that decide the same:
        // refresh() rebuilds from the job's state (of the changes made without `dirty`, a
        // dependent's head source becoming ready changes nothing rebuild() computes, and
        // another member joining a queued encoder run only loosens work_most, a bound the
        // demand test backs with its exact walk), and start_dispatch takes a job's
        // evaluation at `now` before it changes the job.
        const TaskRank& r = task_rank(t);
        Key k = r.tie;
        k.rank = r.job_deadline.count();  // rank() of the view by job deadline (the trait)
        // key()'s criticality with equal ones: the view's 0 or more.
        const int crit = std::max(0, uniform_criticality);
        scanned.push_back({k, TimePoint{0}, t, crit, tk.kind, false, tk.head});
        top = std::max(top, crit);
      } else {
        TaskView v;
        const Key k = key(t, now, v);
        scanned.push_back({k, v.deadline, t, v.criticality, tk.kind, true, tk.head});
        overload = overload || now + v.remaining > v.job_deadline;
        top = std::max(top, v.criticality);
      }
      if (scanned.back().key < scanned[least].key) least = scanned.size() - 1;
    };
    // Every task scanned one by one, and the least of each group of tasks that rank alike
    // (ready_set.cpp): the others of a group rank as it does and come after it in the
    // tie-break, so neither the best, nor under criticality the order, nor batching
    // (groups hold plain units only) reads them.
    // Groups form only in a ready set this large (SchedulerConfig::group_from): below it a
    // scan of every task is as cheap.
    const bool grouping = ready_count() >= s.config_.group_from;
    to_group.clear();
    for (int t : ready) {
      rank_task(t);
      if (grouping) to_group.push_back(t);
    }
    for (int g : live_groups) rank_task(groups[static_cast<std::size_t>(g)].tasks.begin()->second);
    // Those that rank alike from now on join their group, with nothing changed since the scan.
    for (int t : to_group) {
      GroupKey gk;
      if (group_key(t, now, gk)) join_group(t, gk);
    }
    const int shed_below = overload ? top : std::numeric_limits<int>::min();
    auto before = [shed_below](const Scan& a, const Scan& b) {
      const bool shed_a = a.criticality < shed_below, shed_b = b.criticality < shed_below;
      return shed_a != shed_b ? shed_b : a.key < b.key;
    };
    int best = -1;
    int lane_index = -1;
    Duration rt{0};  // the round trip the dispatch to lane_index pays
    const Scan* best_scan = nullptr;
    TimePoint best_deadline{};
    bool rescan = false;
    // Every scanned task was past its merge wait; only a wait begun below changes that.
    bool began_wait = false;
    for (;;) {
      best = -1;
      best_scan = nullptr;
      if (!began_wait && !mixed_criticality) {
        if (!scanned.empty()) {
          best_scan = &scanned[least];
          best = best_scan->task;
        }
      } else {
        for (const Scan& e : scanned) {
          if (began_wait && task(e.task).wait_until > now) continue;  // began a wait this round
          if (best_scan == nullptr || before(e, *best_scan)) {
            best_scan = &e;
            best = e.task;
          }
        }
      }
      if (best < 0) return false;
      Task& k = task(best);
      lane_index = choose_lane(k, now);
      if (lane_index < 0) return false;
      rt = round_trip_cost(
          ahead_lane < 0 &&
          !on_demand_continuation(lanes[static_cast<std::size_t>(lane_index)], k, now));
      // docs/DESIGN.md, "Drops" hopeless, on the drop estimate and with the round trip this
      // dispatch pays. An overload-aware policy (rank=overload) aborts only while overloaded: with
      // the lanes to spare, a job that may still make it costs no other job anything; nor does a
      // job alone in flight (the estimate may be pessimistic, and its deadline still ends it).
      if (opt.drop == DropMode::Hopeless &&
          (opt.rank != RankMode::Overload || (overloaded && by_deadline.size() > 1))) {
        for (const auto& [slot, unit] : k.members) {
          Job& j = job(slot);
          // Below capacity a job is kept while its best case (0.9 × the drop estimate, the
          // default profile's min) still makes it: aborting it frees lanes no one lacks.
          const Duration cp = remaining_for_drop(j, now);
          if (now + rt + (past_capacity() ? cp : cp * 9 / 10) > j.deadline) {
            j.reason = "hopeless";
            ++s.stats_.hopeless;
            end_job(slot, JobOutcome::Dropped, now);  // may free this task: rank again
            rescan = true;
            break;
          }
        }
        if (rescan) break;
      }
      if (opt.merge && k.kind == UnitKind::Encoder && k.gamma) {
        const TimePoint until = predicted_member(k, now);
        if (until != kNever && slack_covers(k, now, until)) {
          k.wait_until = until;
          began_wait = true;
          if (!k.in_waits) {
            k.in_waits = true;
            waits.push_back(best);
          }
          min_wait = std::min(min_wait, until);
          ++s.stats_.merge_waits;
          for (Observer* ob : observers) ob->on_merge_wait(k.sensor, now, until);
          continue;
        }
      }
      break;
    }
    if (rescan) continue;
    Task& k = task(best);
    best_deadline = best_scan->deadline_known ? best_scan->deadline : task_deadline(k, now);
    batch.clear();
    batch.push_back(best);
    TimePoint deadline = best_deadline;
    if (opt.batching && (k.kind == UnitKind::Encoder || k.kind == UnitKind::Head)) {
      // docs/DESIGN.md, "Overload" batch_by_job: while ranked by job deadline, a head batch is
      // checked against what each member's job still needs after the head, not the task's
      // intermediate deadline (past due under overload, it let no batch form).
      const bool by_job = opt.batch_by_job && k.kind == UnitKind::Head && by_job_deadline(k);
      if (by_job) deadline = std::max(deadline, latest_batch_end(k));
      const int limit = batch_limit(k);
      const Duration single =
          k.kind == UnitKind::Encoder ? enc_single : head_single[static_cast<std::size_t>(k.head)];
      // The first to join makes a batch of two, checked below against the best's deadline or
      // an earlier one: where two are dearer than two runs or miss that deadline, none joins,
      // and the candidates are not ranked.
      const bool joinable = limit >= 2 && [&] {
        const Duration cb = batch_estimate(k, 2);
        return cb < single * 2 && now + rt + cb <= deadline;
      }();
      cand.clear();
      for (const Scan& e : scanned) {
        if (!joinable) break;
        if (e.task == best || e.kind != k.kind || e.head != k.head ||
            (began_wait && task(e.task).wait_until > now))
          continue;
        Key byd = e.key;
        // A batch takes its members by deadline.
        byd.rank = (e.deadline_known ? e.deadline : task_deadline(task(e.task), now)).count();
        if (by_job) byd.rank = std::max(byd.rank, latest_batch_end(task(e.task)).count());
        cand.emplace_back(byd, e.task);
      }
      // Only the max_batch − 1 earliest can join: order just those.
      const auto take = std::min(cand.size(), static_cast<std::size_t>(std::max(0, limit - 1)));
      std::partial_sort(cand.begin(), cand.begin() + static_cast<std::ptrdiff_t>(take), cand.end(),
                        [](const auto& a, const auto& b) { return a.first < b.first; });
      cand.resize(take);
      for (const auto& [kk, t] : cand) {
        const int b = static_cast<int>(batch.size()) + 1;
        if (b > limit) break;
        // Batch only when it is cheaper than running one by one and, by estimate, still
        // meets the earliest member deadline once the round trip it pays is over (docs/DESIGN.md,
        // "Refinement" inter-DAG batching).
        const Duration cb = batch_estimate(k, b);
        const TimePoint dl = std::min(deadline, TimePoint{kk.rank});
        if (cb >= single * b || now + rt + cb > dl) break;
        batch.push_back(t);
        deadline = dl;
      }
    }
    start_dispatch(lane_index, now, deadline);
    return true;
  }
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
  while (m.next_event < scenario_.events.size() && scenario_.events[m.next_event].at <= now) {
    const EventSpec& e = scenario_.events[m.next_event];
    // A new version may change an operation's criticality, which ranking reads: the ready
    // set's groups (ready_set.cpp) form again from the next scan.
    m.ungroup_all();
    for (const auto& [op, spec] : e.changes) m.install(op, spec, e.at, false);
    for (const auto& [sensor, rate] : e.sensor_rates)
      m.sensors[static_cast<std::size_t>(sensor)].rate_hz = rate;
    m.rates_changed = true;
    m.expected_stale = true;
    for (Observer* ob : m.observers) ob->on_workload_event(static_cast<int>(m.next_event), e.at);
    ++m.next_event;
  }
}

void Scheduler::on_frame(int sensor, std::uint64_t frame, TimePoint now) {
  Impl& m = *impl_;
  SensorState& sn = m.sensors[static_cast<std::size_t>(sensor)];
  sn.has_frame = true;
  sn.frame = frame;
  sn.time = now;
  for (std::size_t i = 0; i < m.ops.size(); ++i) {
    OpState& o = m.ops[i];
    if (o.awaits_frames && o.g != nullptr && m.inputs_ready(*o.g, -1)) {
      o.awaits_frames = false;
      o.next_tick = now;  // advance(now) releases them
      m.note_tick(static_cast<int>(i));
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
  impl_->next_event = scenario_.events.size();
}

void Scheduler::on_complete(int lane_index, TimePoint now, UnitStatus status,
                            std::string_view reason, TimePoint started) {
  Impl& m = *impl_;
  Lane& lane = m.lanes[static_cast<std::size_t>(lane_index)];
  RED_ASSERT(lane.busy());
  Dispatch& d = lane.oldest();
  lane.pop();  // the slot stays as it is until a later dispatch reuses it
  lane.completed_at = now;
  // docs/DESIGN.md, "Synchronization": a transition other than Completed ends the run; the next
  // dispatch pays a round trip.
  lane.run_open = status == UnitStatus::Completed;
  if (started != kNever) m.set_start(d, std::min(started, now));
  // A unit queued behind this one starts now, in the lane's order.
  if (lane.busy() && lane.oldest().start < now) m.set_start(lane.oldest(), now);
  for (Observer* ob : m.observers) ob->on_unit_end(d, now, status);
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
      j.reason = reason.empty() ? std::string(to_string(status)) : std::string(reason);
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
        j.reason = "deadline passed";
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
    const auto [tick, due] = m.next_tick();
    if (due < 0 || tick > now) break;
    OpState& o = m.ops[static_cast<std::size_t>(due)];
    const TimePoint t = o.next_tick;
    if (o.all_at_once) {
      o.next_tick = kNever;
      if (!m.inputs_ready(*o.g, -1)) {
        o.awaits_frames = true;  // on_frame releases them once every sensor has a frame
        continue;
      }
      while (o.remaining != 0) m.release(due, t, -1, 0);
    } else {
      o.next_tick = t + period_of(o.rate_hz);
      m.note_tick(due);
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
      j.reason = "deadline passed";
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
  m.admit_released(now);
  int idle = 0;
  for (const Lane& l : m.lanes) idle += l.busy() ? 0 : 1;
  if (idle > 0 && m.ready_count() > 0) {
    ++stats_.decisions;
    m.assess_overload(now);
    while (idle > 0 && m.pick(now)) --idle;
  }
  // The earliest end of a merge wait still running is a wake-up (next_wakeup). Recomputed
  // after every round from the waits that end after now, so a wait that is over (its member
  // came, or every lane is busy) never becomes a wake-up in the past.
  // Only tasks that began a wait can be waiting: m.waits lists them (a wait ends for good
  // once it is over or the task left the ready set).
  int waiting = 0;
  m.min_wait = kNever;
  for (std::size_t i = 0; i < m.waits.size();) {
    Task& k = m.task(m.waits[i]);
    if (!k.live || k.ready_pos < 0 || k.wait_until <= now) {
      k.in_waits = false;
      m.waits[i] = m.waits.back();
      m.waits.pop_back();
      continue;
    }
    ++waiting;
    m.min_wait = std::min(m.min_wait, k.wait_until);
    ++i;
  }
  if (!m.observers.empty()) {
    // Ready for any lane: a task ready only behind a busy lane's unit (queue_depth > 1)
    // cannot take an idle lane.
    int ready = m.ready_count();  // grouped tasks are for any lane
    if (config_.queue_depth > 1)
      for (int t : m.ready) ready -= m.task(t).lane_only >= 0 ? 1 : 0;
    for (Observer* ob : m.observers) ob->on_decision(now, ready, idle, waiting);
  }
  return {m.out.data(), m.out.size()};
}

TimePoint Scheduler::next_wakeup() const {
  const Impl& m = *impl_;
  TimePoint t = kNever;
  if (m.next_event < scenario_.events.size()) t = std::min(t, scenario_.events[m.next_event].at);
  t = std::min(t, m.next_tick().first);
  if (!m.deadlines.empty()) t = std::min(t, m.deadlines.front().first);
  if (m.ready_count() > 0) t = std::min(t, m.min_wait);
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
  for (std::size_t i = 0; i < m.jobs.size(); ++i) {
    Job& j = m.jobs[i];
    if (!j.live || j.ended) continue;
    j.ended = true;
    --in_flight_;
    m.notify_job(j, JobOutcome::Unfinished, end, false);
  }
}

int Scheduler::ready_tasks() const noexcept {
  return impl_->ready_count();
}

bool Scheduler::drained() const {
  const Impl& m = *impl_;
  if (in_flight_ > 0 || m.next_event < scenario_.events.size()) return false;
  for (const OpState& o : m.ops) {
    if (o.g == nullptr || o.remaining == 0) continue;
    return false;  // it can still release (periodically, on frames or at its phase)
  }
  return true;
}

double Scheduler::sensor_rate(int sensor) const {
  return impl_->sensors[static_cast<std::size_t>(sensor)].rate_hz;
}

const RefinedGraph* Scheduler::graph(int operation) const {
  return impl_->ops[static_cast<std::size_t>(operation)].g;
}

const Dispatch* Scheduler::running(int lane) const {
  const auto& l = impl_->lanes[static_cast<std::size_t>(lane)];
  return l.busy() ? &l.at(0) : nullptr;
}

TimePoint Scheduler::unit_deadline(int slot, int unit, TimePoint now) {
  Impl& m = *impl_;
  ++m.stamp;
  Job& j = m.job(slot);
  return m.height_deadline(j, j.g->units[static_cast<std::size_t>(unit)].height, now);
}

}  // namespace red
