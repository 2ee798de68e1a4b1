// Overload (docs/DESIGN.md, "Overload"): the demand test (the work due by each deadline against
// what the lanes can do by then), the work figures it counts (plan_work, work_left, critical
// paths) and the round's overload state (assess_overload). Part of the scheduler
// (scheduler_impl.hpp): scheduler.cpp calls these in the order of a decision. Shedding (admission,
// shed_lone, shedding by rate, hopeless aborts), which asks the demand test, is shedding.cpp.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "scheduler_impl.hpp"

namespace red {

void Scheduler::Impl::plan_work() {
  const Scenario& sc = s.scenario_;
  const WorkModel model(*profile, sc.model, s.config_.estimate,
                        opt.batching ? s.config_.max_batch : 1, s.config_.lanes,
                        opt.merge ? s.config_.gamma : Duration{0});
  WorkInput in;
  for (const SensorState& sn : sensors) in.sensor_hz.push_back(sn.rate_hz);
  for (const OpState& o : ops) {
    WorkInput::Stream st;
    if (o.g != nullptr && o.remaining != 0 && !o.all_at_once) {
      st.op = o.g->spec.get();
      st.rate_hz = o.own_rate       ? o.rate_hz
                   : o.trigger >= 0 ? sensors[static_cast<std::size_t>(o.trigger)].rate_hz
                                    : 0.0;
    }
    in.ops.push_back(st);
  }
  const WorkEstimate w = model.estimate(in);
  encoder_runs_per_job = w.encoder_runs_per_job;
  // The encoder at the model's cost per run (frames shared and batched as the deadlines let them
  // gather); a head at its cost alone. Counting heads batched too let admission take work that was
  // then dropped: on the overload grid at twice capacity 43 of 216 points wasted over 20 % of the
  // lanes, where at most 1 in 20 may (docs/journal/robot-workloads.md, "One model of necessary
  // work").
  run_cost.assign(w.units.size(), {});
  for (std::size_t k = 0; k < kEstimates; ++k) {
    run_cost[WorkModel::kEncoder][k] = w.units[WorkModel::kEncoder].per_run[k];
    for (std::size_t h = 0; h < sc.model.heads.size(); ++h)
      run_cost[WorkModel::head_slot(static_cast<int>(h))][k] =
          costs.with(static_cast<EstimateKind>(k)).head(static_cast<int>(h));
  }
  // The jobs' cached work figures were counted at the costs before.
  for (Job& j : jobs)
    if (j.live) j.dirty = true;
  shedding.on_costs();
}

bool Scheduler::Impl::earlier(int a, int b) const {
  const Job& x = jobs[static_cast<std::size_t>(a)];
  const Job& y = jobs[static_cast<std::size_t>(b)];
  return x.deadline != y.deadline ? x.deadline < y.deadline : x.id < y.id;
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

int Scheduler::Impl::first_overrun(TimePoint now, std::size_t k, bool schedule, int margin,
                                   std::size_t from, bool skip_doomed, int min_crit) {
  // Admission (skip_doomed) looking ahead counts, by each job's deadline, the work of the
  // jobs still to come that are due by then too.
  const bool ahead = skip_doomed && shedding.looking_ahead(*this, now);
  const auto lane_count = static_cast<std::int64_t>(s.config_.lanes);
  if (lane_count > 1 && schedule)
    return first_overrun_lanes(now, k, margin, from, skip_doomed, min_crit);
  // Admission on one lane counts the unit running there first, whatever its job's deadline
  // (it is not preempted): that blocking made jobs with little slack hopeless at once.
  const bool blocking = skip_doomed && lane_count == 1;
  Duration due{0};
  if (blocking)
    for (const Lane& l : lanes) {
      for (int q = 0; q < l.count; ++q)
        for (const Member& mb : l.at(q).members) {
          const Job& j = job(mb.slot);
          if (!j.live || j.id != mb.job) continue;
          const auto u = static_cast<std::size_t>(mb.unit);
          due += residual(j, u, now, k) / std::max(1, j.u[u].share);
        }
    }
  for (std::size_t i = 0; i < by_deadline.size(); ++i) {
    Job& j = job(by_deadline[i]);
    if (ops[static_cast<std::size_t>(j.op)].criticality < min_crit) continue;
    if (skip_doomed && doomed(j, now, k)) continue;
    const Duration w = work_left(j, now, k);
    due += w;
    if (blocking)
      for (int r : j.running_units) {
        const auto u = static_cast<std::size_t>(r);
        due -= residual(j, u, now, k) / std::max(1, j.u[u].share);
      }
    if (i < from) continue;
    const Duration coming =
        ahead ? shedding.expected_due(*this, now, j.deadline, k, nullptr, 0, min_crit)
              : Duration{0};
    if (lane_count == 1) {
      if (now + padded(due + coming, margin) > j.deadline) return static_cast<int>(i);
      continue;
    }
    if (now + padded(due + coming, margin) / lane_count > j.deadline) return static_cast<int>(i);
    // The job's critical path is at most its own work: only a job whose work alone does not
    // fit needs the longer walk.
    if (now + padded(w, margin) > j.deadline &&
        now + padded(critical_path(j, now, k), margin) > j.deadline)
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

bool Scheduler::Impl::demand_overruns(TimePoint now, std::size_t k) {
  // first_overrun returns the first job i with now + due_i / lanes > d_i (due_i the work
  // left of jobs 0..i), or with its own work and critical path past d_i. Only whether one
  // exists matters here. With due bracketed by prefix sums of work_base (at most the work
  // left) and work_most (at least it), and the critical path at most the job's own work:
  // a lower prefix past some deadline is an overrun; upper prefixes and upper own work
  // within every deadline are none. Otherwise the exact walk decides.
  const auto lane_count = static_cast<std::int64_t>(s.config_.lanes);
  Duration least{0}, most{0};
  bool surely = false, maybe = false;
  for (const int slot : by_deadline) {
    Job& j = job(slot);
    refresh(j);
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
  return first_overrun(now, k, false, 0, 0, false) >= 0;
}

bool Scheduler::Impl::doomed(Job& j, TimePoint now, std::size_t k) {
  return now + critical_path(j, now, k) > j.deadline;
}

int Scheduler::Impl::first_overrun_lanes(TimePoint now, std::size_t k, int margin, std::size_t from,
                                         bool skip_doomed, int min_crit) {
  lane_free.assign(lanes.size(), now);
  gap_begin.assign(lanes.size(), now);
  gap_end.assign(lanes.size(), now);
  for (std::size_t l = 0; l < lanes.size(); ++l) {
    // The running unit, then each queued behind it (a lane runs them one after another).
    for (int q = 0; q < lanes[l].count; ++q) {
      const TimePoint from_t = lane_free[l];
      for (const Member& mb : lanes[l].at(q).members) {
        const Job& j = job(mb.slot);
        if (!j.live || j.id != mb.job) continue;
        lane_free[l] = std::max(
            lane_free[l],
            from_t + padded(residual(j, static_cast<std::size_t>(mb.unit), now, k), margin));
      }
    }
  }
  for (std::size_t i = 0; i < by_deadline.size(); ++i) {
    Job& j = job(by_deadline[i]);
    if (ops[static_cast<std::size_t>(j.op)].criticality < min_crit) continue;
    if (skip_doomed && doomed(j, now, k)) continue;
    const RefinedGraph& g = *j.g;
    unit_end.assign(g.units.size(), now);
    TimePoint end = now;
    for (std::size_t u = 0; u < g.units.size(); ++u) {
      const UnitRt& ur = j.u[u];
      if (ur.state == UState::Done || ur.state == UState::Cancelled) continue;
      if (ur.state == UState::Running) {
        unit_end[u] = now + padded(residual(j, u, now, k), margin);
        end = std::max(end, unit_end[u]);
        continue;
      }
      TimePoint ready_at = now;
      for (int p : g.units[u].preds)
        ready_at = std::max(ready_at, unit_end[static_cast<std::size_t>(p)]);
      Duration c = padded(unit_cost(g.units[u], k), margin);
      if (ur.state == UState::Queued && ur.task >= 0)  // a merged encoder run is shared
        c /= static_cast<std::int64_t>(std::max<std::size_t>(1, task(ur.task).members.size()));
      // An idle gap left on a lane by a unit that waited for its predecessors takes the
      // unit if it fits (backfilling, as a work-conserving dispatcher would run it there).
      bool backfilled = false;
      for (std::size_t l = 0; l < lane_free.size() && !backfilled; ++l) {
        const TimePoint at = std::max(ready_at, gap_begin[l]);
        if (at + c > gap_end[l]) continue;
        unit_end[u] = at + c;
        gap_begin[l] = unit_end[u];
        backfilled = true;
      }
      if (backfilled) {
        end = std::max(end, unit_end[u]);
        continue;
      }
      // The lane free the latest by ready_at (the smallest gap), else the one free first.
      std::size_t best = 0;
      bool fits = false;
      for (std::size_t l = 0; l < lane_free.size(); ++l) {
        const bool f = lane_free[l] <= ready_at;
        if (f ? (!fits || lane_free[l] > lane_free[best])
              : (!fits && lane_free[l] < lane_free[best]))
          best = l;
        fits = fits || f;
      }
      const TimePoint at = std::max(ready_at, lane_free[best]);
      if (at - lane_free[best] > gap_end[best] - gap_begin[best]) {
        gap_begin[best] = lane_free[best];  // keep the larger idle gap of the lane
        gap_end[best] = at;
      }
      unit_end[u] = at + c;
      lane_free[best] = unit_end[u];
      end = std::max(end, unit_end[u]);
    }
    if (i >= from && end > j.deadline) return static_cast<int>(i);
  }
  return -1;
}

bool Scheduler::Impl::saturated() const {
  for (const OpState& o : ops)
    if (o.g != nullptr && o.remaining != 0 && o.inflight >= o.max_inflight) return true;
  return false;
}

void Scheduler::Impl::assess_overload(TimePoint now) {
  // max_inflight (docs/DESIGN.md, "max_inflight"): an operation at its limit skips its next
  // release, so finishing its oldest job first is what keeps its frames (red-robust ranks by job
  // deadline then).
  const bool robust = ranking.overload_aware();
  const bool at_limit = robust && saturated() && evidenced(now);
  // The demand test (a walk over every job in flight) decides nothing that a saturated
  // operation has not decided already, unless criticalities differ or a ready encoder on
  // several lanes is ranked by it (no encoder becomes ready within a round): skipped then.
  const bool test =
      (robust || ranking.mixed_criticality()) &&
      (!at_limit || ranking.mixed_criticality() || (s.config_.lanes > 1 && ready_encoders > 0));
  demand_overrun = test && demand_overruns(now, idx(s.config_.estimate));
  overloaded = demand_overrun || at_limit;
  // docs/DESIGN.md, "Overload" "finish what was started": once overloaded, the jobs in flight then
  // are finished by job deadline; ranking them back by intermediate deadlines between two
  // overloaded rounds would start newer jobs' early levels ahead of them again.
  if (robust) {
    if (overloaded && !by_deadline.empty())
      overload_hold = std::max(overload_hold, job(by_deadline.back()).deadline);
    overloaded = overloaded || now < overload_hold;
  }
}

}  // namespace red
