// The criticality guard (docs/DESIGN.md, "Criticality"; PolicyOptions::guard): a unit of less
// critical work does not start where it would make a more critical job miss that could make it
// otherwise. Lanes do not preempt a unit once it runs, so the order under overload alone (the most
// critical ready work first) does not protect a job released while a long, less critical unit
// holds its lane. The type CriticalityGuard (guard.hpp); part of the scheduler
// (scheduler_impl.hpp), whose pick() asks it.

#include <algorithm>
#include <cstdint>
#include <span>

#include "guard.hpp"

#include "scheduler_impl.hpp"

namespace red {

namespace {

// A frame later than this after its period is no longer expected at once (camera jitter, a
// transport's delay); past it the sensor's next frame is predicted a period on.
Duration late_allowance(Duration period) {
  return std::min(period / 4, Duration{std::chrono::milliseconds{5}});
}

// Percent added to the dispatch's cost and to the protected job's path when judged on the plan's
// estimate (docs/DESIGN.md, "Criticality").
constexpr int kMargin = 5;

}  // namespace

TimePoint Scheduler::Impl::lane_free_at(const Lane& l, TimePoint now) const {
  if (!l.busy()) return now;
  const Dispatch& running = l.at(0);
  TimePoint t = std::max(now, std::max(running.start, running.decided_at) + running.expected);
  for (int q = 1; q < l.count; ++q) t += l.at(q).expected;
  return t;
}

namespace sched_detail {

// Whether a more critical operation waits on the dispatch's jobs (depends_on, directly or down
// a chain): work it waits on is not held back for it, as holding it would hold that operation.
bool CriticalityGuard::waits_on_run(Scheduler::Impl& m, int op) {
  for (int d = m.ops[static_cast<std::size_t>(op)].depends_on, hops = 0;
       d >= 0 && hops < static_cast<int>(m.ops.size());
       d = m.ops[static_cast<std::size_t>(d)].depends_on, ++hops)
    for (int slot : slots_)
      if (m.job(slot).op == d) return true;
  return false;
}

CriticalityGuard::Verdict CriticalityGuard::check(Scheduler::Impl& m, std::span<const int> run,
                                                  int lane, TimePoint now, TimePoint begin) {
  Verdict v;
  // The dispatch's criticality is its most critical member's: only more critical work is
  // protected from it, and not its own members.
  Run g{run, now, begin, std::numeric_limits<int>::min(), m.sync.round_trip(), kNever};
  slots_.clear();
  units_.clear();
  for (int t : run)
    for (const auto& [slot, unit] : m.task(t).members) {
      g.crit = std::max(g.crit, m.ops[static_cast<std::size_t>(m.job(slot).op)].criticality);
      slots_.push_back(slot);
      units_.push_back(unit);
    }
  if (g.crit >= m.ranking.top_criticality()) return v;
  // Where another lane frees first, more critical work can go there instead.
  for (std::size_t i = 0; i < m.lanes.size(); ++i)
    if (static_cast<int>(i) != lane) g.other = std::min(g.other, m.lane_free_at(m.lanes[i], now));
  // Judged twice. On mean costs, where the blocking is what typically happens, the dispatch is
  // held whatever the hold costs its own jobs. On the plan's estimate (SchedulerConfig::estimate,
  // p99 by default), which foresees more blocking than happens, it is held only where the hold
  // costs none of its jobs a deadline it would meet by running now.
  judge(m, g, EstimateKind::Mean, false, v);
  if (!v.blocks && m.s.config().estimate != EstimateKind::Mean)
    judge(m, g, m.s.config().estimate, true, v);
  return v;
}

// The dispatch's run on estimate `kind`: a unit's cost, or a batch's from the profile.
Duration CriticalityGuard::run_cost(Scheduler::Impl& m, std::span<const int> run,
                                    EstimateKind kind) {
  const auto k = static_cast<std::size_t>(kind);
  const Task& first = m.task(run.front());
  if (run.size() == 1) {
    const auto [slot, unit] = first.members.front();
    return m.job(slot).g->units[static_cast<std::size_t>(unit)].costs[k];
  }
  const UnitProfile* p = m.batching.unit_profile(first);
  return p != nullptr ? p->at(static_cast<int>(run.size())).estimate(kind)
                      : first.cost * static_cast<std::int64_t>(run.size());
}

// One judgement of guard(), on estimate `kind`; with `must_afford`, the hold must cost none of
// the dispatch's jobs a deadline.
void CriticalityGuard::judge(Scheduler::Impl& m, const Run& g, EstimateKind kind, bool must_afford,
                             Verdict& v) {
  const auto k = static_cast<std::size_t>(kind);
  // On the plan's estimate, with a margin: on a busy machine units overran even their p99
  // by a few percent, and a critical job that by estimate kept 1.6 ms of its 50 missed.
  const int margin = must_afford ? kMargin : 0;
  const Duration own = run_cost(m, g.run, kind);  // the held jobs: on the estimate itself
  const TimePoint end = g.begin + Overload::padded(own, margin);
  const TimePoint blocked_until = std::min(end, g.other);

  // More critical jobs in flight with work ready for a lane: each needs its remaining work (its
  // critical path) from when a lane frees. A job whose units all run, or wait on units that run,
  // goes on on their lane (docs/DESIGN.md, "Synchronization": the run continues).
  for (int slot : m.overload.by_deadline()) {
    Job& j = m.job(slot);
    if (!j.live || j.ended || m.ops[static_cast<std::size_t>(j.op)].criticality <= g.crit) continue;
    if (std::find(slots_.begin(), slots_.end(), slot) != slots_.end()) continue;
    if (waits_on_run(m, j.op)) continue;
    bool waiting = false;
    for (std::size_t u = 0; !waiting && u < j.u.size(); ++u)
      waiting = j.u[u].state == UState::Queued;
    if (!waiting) continue;
    const Duration w = Overload::padded(m.critical_path(j, g.now, k), margin);
    if (g.now + g.rt + w <= j.deadline && blocked_until + g.rt + w > j.deadline) {
      v.blocks = true;
      return;  // yield this pick: the job's work is ready, it goes next or on its lane
    }
  }
  releases(m, g, k, margin, own, must_afford, end, blocked_until, v);
}

// Whether the dispatch can wait until more critical work (of path `w`) is done at `done`:
// none of its jobs that would make its deadline by running now misses it by running then.
// Run now, a job of the dispatch still has the more critical work go ahead of its later
// units; held, it runs after that work: the hold costs it the lane's idle time.
bool CriticalityGuard::affords(Scheduler::Impl& m, const Run& g, Duration own, TimePoint done,
                               Duration w) {
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    Job& jm = m.job(slots_[i]);
    const Duration after = m.ranking.path_after(jm, units_[i]);
    if (g.begin + own + w + after <= jm.deadline && done + g.rt + own + after > jm.deadline)
      return false;
  }
  return true;
}

// The next release of each more critical operation before the dispatch would end (`end`): its
// job needs its whole critical path within its deadline.
void CriticalityGuard::releases(Scheduler::Impl& m, const Run& g, std::size_t k, int margin,
                                Duration own, bool must_afford, TimePoint end,
                                TimePoint blocked_until, Verdict& v) {
  const TimePoint now = g.now;
  for (std::size_t i = 0; i < m.ops.size(); ++i) {
    const OpState& o = m.ops[i];
    if (o.g == nullptr || o.remaining == 0 || o.criticality <= g.crit) continue;
    if (waits_on_run(m, static_cast<int>(i))) continue;
    if (o.inflight >= o.max_inflight) continue;  // its next release is skipped
    TimePoint r = kNever;
    Duration period{0};
    Duration allowance{0};
    if (o.own_rate) {
      r = o.next_tick;  // the scheduler's own clock: on time
      period = period_of(o.rate_hz);
    } else if (o.trigger >= 0) {
      const SensorState& sn = m.releases.sensor(o.trigger);
      if (!sn.has_frame || sn.rate_hz <= 0) continue;
      period = period_of(sn.rate_hz);
      allowance = late_allowance(period);
      // A sensor silent for two periods has stopped, or is not periodic: predict nothing.
      if (now - sn.time > 2 * period + allowance) continue;
      r = sn.time + period;
      while (r + allowance < now) r += period;
    }
    if (r == kNever || period <= Duration{0} || r >= end) continue;
    Duration w{0};
    for (int src : o.g->sources) w = std::max(w, o.g->units[static_cast<std::size_t>(src)].tail[k]);
    w = Overload::padded(w, margin);
    if (g.rt + w > o.g->deadline) continue;  // it cannot make it even on a free lane
    const TimePoint start = std::max(r, blocked_until);
    if (start + g.rt + w <= r + o.g->deadline ||
        (must_afford && !affords(m, g, own, std::max(r, now) + g.rt + w, w)))
      continue;
    v.blocks = true;
    v.until = std::min(v.until, r > now ? r : r + allowance);
  }
}

bool CriticalityGuard::join(Scheduler::Impl& m, std::span<const int> members, int joining,
                            TimePoint begin, Duration with, Duration without) {
  int crit = std::numeric_limits<int>::min();
  for (const auto& [slot, unit] : m.task(joining).members)
    crit = std::max(crit, m.ops[static_cast<std::size_t>(m.job(slot).op)].criticality);
  if (crit >= m.ranking.top_criticality()) return true;
  // A batch of frames costs more than one frame, and on a busy machine a larger run overran its
  // estimate more: a less critical frame joins a more critical job's run only where that job
  // still makes its deadline with the margin (else the frame runs after, in a run of its own).
  for (int t : members)
    for (const auto& [slot, unit] : m.task(t).members) {
      const Job& jm = m.job(slot);
      if (m.ops[static_cast<std::size_t>(jm.op)].criticality <= crit) continue;
      const Duration after = m.ranking.path_after(jm, unit);
      if (begin + without + after <= jm.deadline &&
          begin + Overload::padded(with, kMargin) + after > jm.deadline)
        return false;
    }
  return true;
}

}  // namespace sched_detail
}  // namespace red
