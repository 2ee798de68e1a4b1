// How red-robust sheds a job (shedding.hpp): shedding by rate at a release, admission
// (shed_lone, then Moore and Hodgson) before a decision, hopeless aborts at a pick, and the
// offered load and jobs to come they read. Part of the scheduler (scheduler_impl.hpp), which
// calls it at the points shedding.hpp names.

#include "shedding.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "scheduler_impl.hpp"

namespace red {
namespace sched_detail {

// ---- shedding by rate ---------------------------------------------------------------------

void ShedByRate::on_end(int op, JobOutcome outcome, DropReason reason, TimePoint now) {
  if (outcome != JobOutcome::Dropped || reason == DropReason::RejectedByRate) return;
  const auto i = static_cast<std::size_t>(op);
  if (i >= last_shed_.size()) last_shed_.resize(i + 1, kNever);
  last_shed_[i] = now;
}

void ShedByRate::plan(const std::vector<OpState>& ops, int lanes, std::size_t k) {
  stale_ = false;
  outranked_.assign(ops.size(), 0);
  order_.clear();
  // Operations that read sensors are left out (neither outranked nor counted): a job's own
  // cost says little where encoder runs are shared and heads batched across jobs; with
  // them in, 17 more grid points fell below 0.9 x the bound, every one a MIMONet set.
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const OpState& o = ops[i];
    if (o.g == nullptr || o.remaining == 0 || !o.own_rate || !o.g->sensors.empty()) continue;
    Duration w{0};
    for (const RefinedUnit& ru : o.g->units) w += ru.costs[k];
    order_.push_back({w, static_cast<int>(i)});
  }
  std::sort(order_.begin(), order_.end());
  double used = 0.0;  // lanes asked for by the operations with cheaper jobs
  for (const auto& [w, i] : order_) {
    const auto ii = static_cast<std::size_t>(i);
    if (used >= static_cast<double>(lanes)) outranked_[ii] = 1;
    used += ops[ii].rate_hz * std::chrono::duration<double>(w).count();
  }
}

bool ShedByRate::ahead_shed(int op, TimePoint now) const {
  const Duration window = from_s(kWindow);
  for (const auto& [w, i] : order_) {
    if (i == op) return false;
    const auto ii = static_cast<std::size_t>(i);
    const TimePoint t = ii < last_shed_.size() ? last_shed_[ii] : kNever;
    if (t != kNever && now - t < window) return true;
  }
  return false;
}

// ---- at a release -------------------------------------------------------------------------

bool Shedding::rejects_at_release(Scheduler::Impl& m, int op, TimePoint now) {
  // docs/DESIGN.md, "Overload": past capacity, the jobs of an operation that cheaper ones
  // outrank are rejected before they cost anything (shedding by rate).
  const PolicyOptions& opt = m.opt;
  return opt.admission == Admission::Shed && opt.shed_by_rate && !m.ranking.mixed_criticality() &&
         by_rate_.rejects(op, now, m.ops, m.s.config().lanes, idx(opt.drop_estimate),
                          [&] { return past_capacity(m) && m.overload.evidenced(m, now); });
}

void Shedding::released(Scheduler::Impl& m, int slot, bool rejected, TimePoint now) {
  released_ = true;
  if (m.opt.admission == Admission::Shed) {
    // The offered load (docs/DESIGN.md, "Overload" detect overload from demand).
    Job& j = m.job(slot);
    const double dt = std::chrono::duration<double>(now - offered_at_).count();
    offered_ = offered_ * std::exp(-dt / kOfferedWindow) +
               std::chrono::duration<double>(m.work_left(j, now, idx(m.opt.drop_estimate))).count();
    offered_at_ = now;
  }
  if (rejected) reject(m, slot, DropReason::RejectedByRate, now);
}

bool Shedding::past_capacity(const Scheduler::Impl& m) const {
  return offered_ > kOfferedWindow * static_cast<double>(m.s.config().lanes);
}

bool Shedding::looking_ahead(const Scheduler::Impl& m, TimePoint now) const {
  return m.opt.lookahead && m.overload.evidenced(m, now) &&
         offered_ > kLookaheadAt * kOfferedWindow * static_cast<double>(m.s.config().lanes);
}

Duration Shedding::expected_due(Scheduler::Impl& m, TimePoint now, TimePoint t, std::size_t k,
                                Duration* largest, int criticality, int min_crit) {
  const std::vector<OpState>& ops = m.ops;
  if (expected_stale_) {
    expected_stale_ = false;
    // A job to come: its heads and plain nodes, and its share of its cameras' encoder runs as
    // the model of necessary work counts them (Overload::plan).
    expected_work_.assign(ops.size(), {});
    for (std::size_t i = 0; i < ops.size(); ++i) {
      const OpState& o = ops[i];
      if (o.g == nullptr) continue;
      bool encoders = false;
      for (const RefinedUnit& ru : o.g->units) {
        encoders = encoders || ru.kind == UnitKind::Encoder;
        if (ru.kind == UnitKind::Encoder) continue;
        for (std::size_t e = 0; e < kEstimates; ++e) expected_work_[i][e] += m.unit_cost(ru, e);
      }
      if (!encoders || i >= m.overload.encoder_runs_per_job().size()) continue;
      for (std::size_t e = 0; e < kEstimates; ++e)
        expected_work_[i][e] +=
            scaled_by(m.overload.encoder_run(e), m.overload.encoder_runs_per_job()[i]);
    }
  }
  Duration due{0};
  for (std::size_t i = 0; i < ops.size(); ++i) {
    const OpState& o = ops[i];
    if (o.g == nullptr || o.remaining == 0 || o.criticality < min_crit) continue;
    // The next release: the own-rate tick, or the triggering sensor's next frame.
    double hz = 0;
    TimePoint next = kNever;
    if (o.own_rate) {
      hz = o.rate_hz;
      next = o.next_tick;
    } else if (o.trigger >= 0) {
      const SensorState& sn = m.releases.sensor(o.trigger);
      hz = sn.rate_hz;
      if (sn.has_frame && hz > 0) next = sn.time + from_s(1.0 / hz);
    }
    if (hz <= 0 || next == kNever) continue;
    if (next <= now)
      next += from_s(std::ceil(std::chrono::duration<double>(now - next).count() * hz + 1e-9) / hz);
    const TimePoint first_deadline = next + o.g->deadline;
    if (first_deadline > t) continue;
    const auto count = 1 + static_cast<std::int64_t>(
                               std::chrono::duration<double>(t - first_deadline).count() * hz);
    const Duration w = expected_work_[i][k];
    due += w * count;
    if (largest != nullptr && o.criticality <= criticality) *largest = std::max(*largest, w);
  }
  return due;
}

// ---- before a decision: admission ---------------------------------------------------------

void Shedding::admit_released(Scheduler::Impl& m, TimePoint now) {
  if (m.opt.admission == Admission::Shed && released_) admit(m, now);
  released_ = false;
}

void Shedding::reject(Scheduler::Impl& m, int slot, DropReason why, TimePoint now) {
  m.job(slot).reason = why;
  ++m.stats().rejected;
  m.end_job(slot, JobOutcome::Dropped, now);
}

void Shedding::admit(Scheduler::Impl& m, TimePoint now) {
  const PolicyOptions& opt = m.opt;
  const std::vector<int>& by_deadline = m.overload.by_deadline();
  const std::size_t k = idx(opt.drop_estimate);
  // Below capacity the list schedule's order (jobs by deadline) is not the policy's, and
  // it would reject jobs that the policy's intermediate deadlines fit in; the lower bound
  // decides there. Past capacity the list schedule keeps what the lanes cannot finish out.
  const bool schedule = past_capacity(m);
  // The margin keeps room for overruns where the lanes are full (below capacity the idle
  // time absorbs them).
  const int margin = schedule ? opt.admit_margin : 0;
  // Moore and Hodgson over the jobs by deadline: at each window that overruns, the victim
  // goes and the test starts again; a window with nothing to shed is passed over. A job that
  // cannot make it even alone (on the estimate, from now) counts for nothing: the hopeless
  // check ends it, and its work would make every later window overrun.
  const bool ahead = looking_ahead(m, now);
  if (opt.shed_lone && schedule && m.overload.evidenced(m, now)) shed_lone_jobs(m, now, k, margin);
  // Criticality (docs/DESIGN.md, "Criticality"): under overload pick() runs the most critical work
  // first, so a job is in the way of a more critical one only through the units the lanes hold. A
  // job is rejected for a window only if the jobs of its criticality or more overrun by themselves;
  // jobs at carried_from or above are known not to (rejections only make room).
  int carried_from = std::numeric_limits<int>::max();
  // The workload's least critical operations: only their jobs are victims. Nothing in here
  // changes which operations are live.
  const int least_op = m.ranking.mixed_criticality() ? least_op_criticality(m) : 0;
  std::size_t from = 0;
  for (;;) {
    const int over = m.overload.first_overrun(m, now, k, schedule, margin, from, true);
    if (over < 0) return;
    from = static_cast<std::size_t>(over) + 1;
    // The first job alone overrunning its deadline on the estimate: rejecting it frees the
    // lanes for nobody now, and the estimate may be pessimistic (a profile taken under
    // load); the hopeless check decides on its progress instead. Not alone when looking
    // ahead: the jobs to come before its deadline are what it would take the lane from.
    if (over == 0 && !ahead) continue;
    int victim = -1;
    Duration victim_work{0};
    int victim_crit = 0;
    for (int i = 0; i <= over; ++i) {
      const int slot = by_deadline[static_cast<std::size_t>(i)];
      Job& j = m.job(slot);
      m.refresh(j);
      if (j.started || m.doomed(j, now, k)) continue;
      const int crit = m.ops[static_cast<std::size_t>(j.op)].criticality;
      if (crit >= carried_from || (m.ranking.mixed_criticality() && crit > least_op)) continue;
      const Duration w = m.work_left(j, now, k);
      const bool better = victim < 0 || crit < victim_crit ||
                          (crit == victim_crit && w > victim_work) ||
                          (crit == victim_crit && w == victim_work);  // later deadline wins
      if (better) {
        victim = slot;
        victim_work = w;
        victim_crit = crit;
      }
    }
    if (victim < 0) continue;  // only started jobs are due by then: hopeless checks decide
    if (m.ranking.mixed_criticality() && victim_crit > least_criticality(m)) {
      // Less critical jobs (started, or past this window) share the overrun: whether the
      // victim's class alone overruns decides. The victim is the least critical candidate.
      const int own = m.overload.first_overrun(m, now, k, schedule, margin, 0, true, victim_crit);
      if (own < 0) carried_from = victim_crit;
      if (own < 0 || own > over) continue;
    }
    if (ahead) {
      // Moore and Hodgson over the jobs to come as well: where one of them, no more critical,
      // has more work due by then than the victim, it is that job that goes, at its release.
      Duration largest{0};
      expected_due(m, now, m.job(by_deadline[static_cast<std::size_t>(over)]).deadline, k, &largest,
                   victim_crit);
      if (largest > victim_work) continue;
    }
    from = 0;
    reject(m, victim, DropReason::Rejected, now);
  }
}

int Shedding::least_op_criticality(const Scheduler::Impl& m) {
  int least = std::numeric_limits<int>::max();
  for (const OpState& o : m.ops)
    if (o.g != nullptr && o.remaining != 0) least = std::min(least, o.criticality);
  return least;
}

int Shedding::least_criticality(Scheduler::Impl& m) {
  int least = std::numeric_limits<int>::max();
  for (const int slot : m.overload.by_deadline())
    least = std::min(least, m.ops[static_cast<std::size_t>(m.job(slot).op)].criticality);
  return least;
}

void Shedding::shed_lone_jobs(Scheduler::Impl& m, TimePoint now, std::size_t est, int margin) {
  const std::vector<OpState>& ops = m.ops;
  // With max_inflight, an operation's throughput is its slots over its jobs' response time.
  // Past capacity every operation of a MIMONet set fills its slots, each skips the frames
  // that come while it is full, and the frames each one takes drift apart: an encoder run
  // then serves one or two jobs, not one per operation. Rejecting a job that would run its
  // frame's encoder alone, when it would leave its operation fewer than half its slots,
  // keeps the slot for a frame the operations share (docs/journal/overload-grid.md, round 7).
  auto reads = [](const OpState& o, int sensor) {
    return std::find(o.sensors_read.begin(), o.sensors_read.end(), sensor) != o.sensors_read.end();
  };
  lone_.clear();
  for (const int slot : m.overload.by_deadline()) {
    const Job& j = m.job(slot);
    const OpState& o = ops[static_cast<std::size_t>(j.op)];
    if (j.release != now || j.started || o.own_rate || o.trigger < 0) continue;
    if (2 * o.inflight <= o.max_inflight) continue;  // half its slots or more still free
    // Its slots must be what limits it: a release of it skipped at max_inflight within the
    // offered-load window, or the demand test overrun. Past capacity by the offered load
    // alone is not enough (issue 37: on a robot workload at 1x with max_inflight 1 this rule
    // lost 41 % of the jobs, all of which red met). Gating on the demand test alone cost the
    // overload grid 31 of 464 points (worst -8.2 points); with the skips, 11 (worst -5.7).
    if ((o.last_skip == kNever || now - o.last_skip > from_s(kOfferedWindow)) &&
        !m.overload.demand_overrun())
      continue;
    const int t = o.trigger;
    const auto tu = static_cast<std::size_t>(t);
    bool others = false;  // another operation reads the sensor: the frame could be shared
    for (const OpState& p : ops)
      others = others || (&p != &o && p.g != nullptr && p.remaining != 0 && reads(p, t));
    if (!others) continue;
    bool shared = false;
    for (const int other : m.overload.by_deadline()) {
      if (other == slot) continue;
      const Job& k = m.job(other);
      if (k.frame[tu] == j.frame[tu] && reads(ops[static_cast<std::size_t>(k.op)], t)) {
        shared = true;
        break;
      }
    }
    if (!shared) lone_.push_back(slot);
  }
  // Criticality (docs/DESIGN.md, "Criticality"): a lone job more critical than some job in flight
  // goes only when the jobs of its criticality or more overrun by themselves (pick() runs them
  // ahead of the others under overload).
  if (m.ranking.mixed_criticality() && !lone_.empty()) {
    const int least = least_criticality(m);
    const int least_op = least_op_criticality(m);
    std::erase_if(lone_, [&](int slot) {
      const int crit = ops[static_cast<std::size_t>(m.job(slot).op)].criticality;
      return crit > least_op || (crit > least && m.overload.first_overrun(m, now, est, true, margin,
                                                                          0, true, crit) < 0);
    });
  }
  for (const int slot : lone_) reject(m, slot, DropReason::Rejected, now);
}

// ---- at a pick: hopeless aborts -----------------------------------------------------------

// docs/DESIGN.md, "Drops" hopeless, on the drop estimate and with the round trip this
// dispatch pays: aborts the first member job of the best that cannot make its deadline. An
// overload-aware policy (rank=overload) aborts only while overloaded: with the lanes to spare,
// a job that may still make it costs no other job anything; nor does a job alone in flight
// (the estimate may be pessimistic, and its deadline still ends it).
bool Shedding::abort_hopeless(Scheduler::Impl& m, int t, Duration rt, TimePoint now) {
  const PolicyOptions& opt = m.opt;
  if (opt.drop != DropMode::Hopeless ||
      (m.ranking.overload_aware() &&
       !(m.overload.overloaded() && m.overload.by_deadline().size() > 1)))
    return false;
  for (const auto& [slot, unit] : m.task(t).members) {
    Job& j = m.job(slot);
    // Below capacity a job is kept while its best case (0.9 × the drop estimate, the
    // default profile's min) still makes it: aborting it frees lanes no one lacks.
    // So is a job of the most critical operations at any load: it runs first under
    // overload (docs/DESIGN.md, "Criticality"), so keeping it costs only less critical work.
    const Duration cp = remaining_for_drop(m, j, now);
    const bool most_critical =
        m.ranking.mixed_criticality() &&
        m.ops[static_cast<std::size_t>(j.op)].criticality >= m.ranking.top_criticality();
    if (now + rt + (past_capacity(m) && !most_critical ? cp : cp * 9 / 10) > j.deadline) {
      j.reason = DropReason::Hopeless;
      ++m.stats().hopeless;
      m.end_job(slot, JobOutcome::Dropped, now);  // may free this task: rank again
      return true;
    }
  }
  return false;
}

Duration Shedding::remaining_for_drop(Scheduler::Impl& m, Job& j, TimePoint now) {
  // The remaining critical path on the drop estimate, no longer than with every unit not started
  // at its least time in any batch (a batch may cost less than a run alone: docs/DESIGN.md,
  // "Overload"; red/graph/necessary_work.hpp).
  const std::size_t k = idx(m.opt.drop_estimate);
  const Duration cp = m.critical_path(j, now, k);
  Duration least = j.cp_least;
  const RefinedGraph& g = *j.g;
  for (int r : j.running_units) {
    const auto ur = static_cast<std::size_t>(r);
    Duration after{0};
    for (int sx : g.units[ur].succs)
      after = std::max(after, g.units[static_cast<std::size_t>(sx)].least_tail);
    least = std::max(least, Scheduler::Impl::residual(j, ur, now, k) + after);
  }
  return std::min(cp, least);
}

}  // namespace sched_detail
}  // namespace red
