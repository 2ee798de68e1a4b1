// Overload (docs/DESIGN.md, "Overload"; overload.hpp): the live jobs by deadline, the demand test
// over them (the work due by each deadline against what the lanes can do by then), the necessary
// work it counts units at (plan), the evidence of overload and the round's verdict (assess); and
// the job figures it reads, which shedding and the criticality guard read too (Impl::work_left,
// critical_path, doomed, saturated). Part of the scheduler (scheduler_impl.hpp): scheduler.cpp
// calls these in the order of a decision. Shedding (admission, shed_lone, shedding by rate,
// hopeless aborts), which asks the demand test, is shedding.cpp.

#include "overload.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::plan_work() {
  overload.plan(*this);
  // The jobs' cached work figures were counted at the costs before.
  for (Job& j : jobs.all())
    if (j.live) j.dirty = true;
  shedding.on_costs();
}

Duration Scheduler::Impl::critical_path(Job& j, TimePoint now, std::size_t k) {
  refresh(j);
  Duration cp = j.cp_base[k];
  const RefinedGraph& g = *j.g;
  for (int r : j.running_units) {
    const auto ur = static_cast<std::size_t>(r);
    Duration after{0};
    for (int sx : g.units[ur].succs)
      after = std::max(after, g.units[static_cast<std::size_t>(sx)].tail[k]);
    cp = std::max(cp, residual(j, ur, now, k) + after);
  }
  return cp;
}

Duration Scheduler::Impl::work_left(Job& j, TimePoint now, std::size_t k) {
  refresh(j);
  Duration w = j.work_base[k];
  for (int u : j.enc_queued) {
    const UnitRt& ur = j.u[static_cast<std::size_t>(u)];
    const auto members = std::max<std::size_t>(1, task(ur.task).members.size());
    w += unit_cost(j.g->units[static_cast<std::size_t>(u)], k) / static_cast<std::int64_t>(members);
  }
  for (int u : j.running_units) {
    const auto ui = static_cast<std::size_t>(u);
    w += residual(j, ui, now, k) / std::max(1, j.u[ui].share);
  }
  return w;
}

bool Scheduler::Impl::doomed(Job& j, TimePoint now, std::size_t k) {
  return now + critical_path(j, now, k) > j.deadline;
}

bool Scheduler::Impl::saturated() const {
  for (const OpState& o : ops)
    if (o.g != nullptr && o.remaining != 0 && o.inflight >= o.max_inflight) return true;
  return false;
}

namespace sched_detail {

void Overload::plan(const Scheduler::Impl& m) {
  const Scenario& sc = m.s.scenario();
  const SchedulerConfig& cfg = m.s.config();
  const WorkModel model(*m.profile, sc.model, cfg.estimate, m.opt.batching ? cfg.max_batch : 1,
                        cfg.lanes, m.opt.merge ? cfg.gamma : Duration{0});
  WorkInput in;
  for (const SensorState& sn : m.releases.sensors()) in.sensor_hz.push_back(sn.rate_hz);
  for (const OpState& o : m.ops) {
    WorkInput::Stream st;
    if (o.g != nullptr && o.remaining != 0 && !o.all_at_once) {
      st.op = o.g->spec.get();
      st.rate_hz = o.own_rate       ? o.rate_hz
                   : o.trigger >= 0 ? m.releases.sensor(o.trigger).rate_hz
                                    : 0.0;
    }
    in.ops.push_back(st);
  }
  const WorkEstimate w = model.estimate(in);
  encoder_runs_per_job_ = w.encoder_runs_per_job;
  // The encoder at the model's cost per run (frames shared and batched as the deadlines let them
  // gather); a head at its cost alone. Counting heads batched too let admission take work that was
  // then dropped: on the overload grid at twice capacity 43 of 216 points wasted over 20 % of the
  // lanes, where at most 1 in 20 may (docs/journal/robot-workloads.md, "One model of necessary
  // work").
  run_cost_.assign(w.units.size(), {});
  for (std::size_t k = 0; k < kEstimates; ++k) {
    run_cost_[WorkModel::kEncoder][k] = w.units[WorkModel::kEncoder].per_run[k];
    for (std::size_t h = 0; h < sc.model.heads.size(); ++h)
      run_cost_[WorkModel::head_slot(static_cast<int>(h))][k] =
          m.costs.with(static_cast<EstimateKind>(k)).head(static_cast<int>(h));
  }
}

bool Overload::evidenced(const Scheduler::Impl& m, TimePoint now) const {
  return !m.opt.miss_gate || (last_miss_ != kNever && now - last_miss_ <= from_s(kMissWindow));
}

bool Overload::earlier(const JobPool& jobs, int a, int b) {
  const Job& x = jobs[a];
  const Job& y = jobs[b];
  return x.deadline != y.deadline ? x.deadline < y.deadline : x.id < y.id;
}

void Overload::on_release(const JobPool& jobs, int slot) {
  by_deadline_.insert(std::upper_bound(by_deadline_.begin(), by_deadline_.end(), slot,
                                       [&jobs](int a, int b) { return earlier(jobs, a, b); }),
                      slot);
}

void Overload::on_end(const JobPool& jobs, int slot, JobOutcome outcome, TimePoint now) {
  if (outcome == JobOutcome::Missed || outcome == JobOutcome::Dropped) last_miss_ = now;
  const auto at = std::lower_bound(by_deadline_.begin(), by_deadline_.end(), slot,
                                   [&jobs](int a, int b) { return earlier(jobs, a, b); });
  if (at != by_deadline_.end() && *at == slot) by_deadline_.erase(at);
}

int Overload::first_overrun(Scheduler::Impl& m, TimePoint now, std::size_t k, bool schedule,
                            int margin, std::size_t from, bool skip_doomed, int min_crit) {
  // Admission (skip_doomed) looking ahead counts, by each job's deadline, the work of the
  // jobs still to come that are due by then too.
  const bool ahead = skip_doomed && m.shedding.looking_ahead(m, now);
  const auto lane_count = static_cast<std::int64_t>(m.s.config().lanes);
  if (lane_count > 1 && schedule)
    return first_overrun_lanes(m, now, k, margin, from, skip_doomed, min_crit);
  // Admission on one lane counts the unit running there first, whatever its job's deadline
  // (it is not preempted): that blocking made jobs with little slack hopeless at once.
  const bool blocking = skip_doomed && lane_count == 1;
  Duration due{0};
  if (blocking)
    for (const Lane& l : m.lanes) {
      for (int q = 0; q < l.count; ++q)
        for (const Member& mb : l.at(q).members) {
          const Job& j = m.job(mb.slot);
          if (!j.live || j.id != mb.job) continue;
          const auto u = static_cast<std::size_t>(mb.unit);
          due += m.residual(j, u, now, k) / std::max(1, j.u[u].share);
        }
    }
  for (std::size_t i = 0; i < by_deadline_.size(); ++i) {
    Job& j = m.job(by_deadline_[i]);
    if (m.ops[static_cast<std::size_t>(j.op)].criticality < min_crit) continue;
    if (skip_doomed && m.doomed(j, now, k)) continue;
    const Duration w = m.work_left(j, now, k);
    due += w;
    if (blocking)
      for (int r : j.running_units) {
        const auto u = static_cast<std::size_t>(r);
        due -= m.residual(j, u, now, k) / std::max(1, j.u[u].share);
      }
    if (i < from) continue;
    const Duration coming =
        ahead ? m.shedding.expected_due(m, now, j.deadline, k, nullptr, 0, min_crit) : Duration{0};
    if (lane_count == 1) {
      if (now + padded(due + coming, margin) > j.deadline) return static_cast<int>(i);
      continue;
    }
    if (now + padded(due + coming, margin) / lane_count > j.deadline) return static_cast<int>(i);
    // The job's critical path is at most its own work: only a job whose work alone does not
    // fit needs the longer walk.
    if (now + padded(w, margin) > j.deadline &&
        now + padded(m.critical_path(j, now, k), margin) > j.deadline)
      return static_cast<int>(i);
  }
  return -1;
}

namespace {

// now + w / lanes > deadline, without the division (an integer division per job was half of
// the demand test's time): for w >= 0, w / lanes > x exactly when w >= lanes * (x + 1).
bool spread_past(Duration w, std::int64_t lanes, TimePoint now, TimePoint deadline) {
  std::int64_t bound = 0;
  if (w < Duration{0} || __builtin_add_overflow((deadline - now).count(), 1, &bound) ||
      __builtin_mul_overflow(bound, lanes, &bound))
    return now + w / lanes > deadline;
  return w.count() >= bound;
}

}  // namespace

bool Overload::demand_overruns(Scheduler::Impl& m, TimePoint now, std::size_t k) {
  // first_overrun returns the first job i with now + due_i / lanes > d_i (due_i the work
  // left of jobs 0..i), or with its own work and critical path past d_i. Only whether one
  // exists matters here. With due bracketed by prefix sums of work_base (at most the work
  // left) and work_most (at least it), and the critical path at most the job's own work:
  // a lower prefix past some deadline is an overrun; upper prefixes and upper own work
  // within every deadline are none. Otherwise the exact walk decides.
  const auto lane_count = static_cast<std::int64_t>(m.s.config().lanes);
  Duration least{0}, most{0};
  bool surely = false, maybe = false;
  for (const int slot : by_deadline_) {
    Job& j = m.job(slot);
    m.refresh(j);
    least += j.work_base[k];
    most += j.work_most[k];
    if (spread_past(least, lane_count, now, j.deadline)) {
      surely = true;
      break;
    }
    maybe = maybe || spread_past(most, lane_count, now, j.deadline) ||
            (lane_count > 1 && now + j.work_most[k] > j.deadline);
  }
  if (surely) return true;
  if (!maybe) return false;
  return first_overrun(m, now, k, false, 0, 0, false) >= 0;
}

int Overload::first_overrun_lanes(Scheduler::Impl& m, TimePoint now, std::size_t k, int margin,
                                  std::size_t from, bool skip_doomed, int min_crit) {
  lane_free_.assign(m.lanes.size(), now);
  gap_begin_.assign(m.lanes.size(), now);
  gap_end_.assign(m.lanes.size(), now);
  for (std::size_t l = 0; l < m.lanes.size(); ++l) {
    // The running unit, then each queued behind it (a lane runs them one after another).
    for (int q = 0; q < m.lanes[l].count; ++q) {
      const TimePoint from_t = lane_free_[l];
      for (const Member& mb : m.lanes[l].at(q).members) {
        const Job& j = m.job(mb.slot);
        if (!j.live || j.id != mb.job) continue;
        lane_free_[l] = std::max(
            lane_free_[l],
            from_t + padded(m.residual(j, static_cast<std::size_t>(mb.unit), now, k), margin));
      }
    }
  }
  for (std::size_t i = 0; i < by_deadline_.size(); ++i) {
    Job& j = m.job(by_deadline_[i]);
    if (m.ops[static_cast<std::size_t>(j.op)].criticality < min_crit) continue;
    if (skip_doomed && m.doomed(j, now, k)) continue;
    const RefinedGraph& g = *j.g;
    unit_end_.assign(g.units.size(), now);
    TimePoint end = now;
    for (std::size_t u = 0; u < g.units.size(); ++u) {
      const UnitRt& ur = j.u[u];
      if (ur.state == UState::Done || ur.state == UState::Cancelled) continue;
      if (ur.state == UState::Running) {
        unit_end_[u] = now + padded(m.residual(j, u, now, k), margin);
        end = std::max(end, unit_end_[u]);
        continue;
      }
      TimePoint ready_at = now;
      for (int p : g.units[u].preds)
        ready_at = std::max(ready_at, unit_end_[static_cast<std::size_t>(p)]);
      Duration c = padded(unit_cost(g.units[u], k), margin);
      if (ur.state == UState::Queued && ur.task >= 0)  // a merged encoder run is shared
        c /= static_cast<std::int64_t>(std::max<std::size_t>(1, m.task(ur.task).members.size()));
      // An idle gap left on a lane by a unit that waited for its predecessors takes the
      // unit if it fits (backfilling, as a work-conserving dispatcher would run it there).
      bool backfilled = false;
      for (std::size_t l = 0; l < lane_free_.size() && !backfilled; ++l) {
        const TimePoint at = std::max(ready_at, gap_begin_[l]);
        if (at + c > gap_end_[l]) continue;
        unit_end_[u] = at + c;
        gap_begin_[l] = unit_end_[u];
        backfilled = true;
      }
      if (backfilled) {
        end = std::max(end, unit_end_[u]);
        continue;
      }
      // The lane free the latest by ready_at (the smallest gap), else the one free first.
      std::size_t best = 0;
      bool fits = false;
      for (std::size_t l = 0; l < lane_free_.size(); ++l) {
        const bool f = lane_free_[l] <= ready_at;
        if (f ? (!fits || lane_free_[l] > lane_free_[best])
              : (!fits && lane_free_[l] < lane_free_[best]))
          best = l;
        fits = fits || f;
      }
      const TimePoint at = std::max(ready_at, lane_free_[best]);
      if (at - lane_free_[best] > gap_end_[best] - gap_begin_[best]) {
        gap_begin_[best] = lane_free_[best];  // keep the larger idle gap of the lane
        gap_end_[best] = at;
      }
      unit_end_[u] = at + c;
      lane_free_[best] = unit_end_[u];
      end = std::max(end, unit_end_[u]);
    }
    if (i >= from && end > j.deadline) return static_cast<int>(i);
  }
  return -1;
}

void Overload::assess(Scheduler::Impl& m, TimePoint now) {
  // max_inflight (docs/DESIGN.md, "max_inflight"): an operation at its limit skips its next
  // release, so finishing its oldest job first is what keeps its frames (red-robust ranks by job
  // deadline then).
  const bool robust = m.ranking.overload_aware();
  const bool at_limit = robust && m.saturated() && evidenced(m, now);
  // The demand test (a walk over every job in flight) decides nothing that a saturated
  // operation has not decided already, unless criticalities differ or a ready encoder on
  // several lanes is ranked by it (no encoder becomes ready within a round): skipped then.
  const bool test = (robust || m.ranking.mixed_criticality()) &&
                    (!at_limit || m.ranking.mixed_criticality() ||
                     (m.s.config().lanes > 1 && m.ready.encoders() > 0));
  demand_overrun_ = test && demand_overruns(m, now, idx(m.s.config().estimate));
  overloaded_ = demand_overrun_ || at_limit;
  // docs/DESIGN.md, "Overload" "finish what was started": once overloaded, the jobs in flight then
  // are finished by job deadline; ranking them back by intermediate deadlines between two
  // overloaded rounds would start newer jobs' early levels ahead of them again.
  if (robust) {
    if (overloaded_ && !by_deadline_.empty())
      hold_ = std::max(hold_, m.job(by_deadline_.back()).deadline);
    overloaded_ = overloaded_ || now < hold_;
  }
}

}  // namespace sched_detail
}  // namespace red
