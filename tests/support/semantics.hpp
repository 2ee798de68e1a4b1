#pragma once
/// \file
/// Test support: checks a recorded run against the semantics of docs/DESIGN.md, "Refinement" and
/// "Dispatch" — every node output of every completed job produced exactly once, from a frame of the
/// right sensor, after all its predecessors; no unit of a job starting after the job ended; lanes
/// that run one unit at a time. Returns human-readable violations (empty: all good).

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "recording_observer.hpp"
#include "red/core/time.hpp"
#include "red/scenario/scenario.hpp"

namespace red::test {

/// What check_semantics looks at.
struct SemanticsOptions {
  /// Check precedence and "no start after the end" for every job (else only completed ones).
  bool all_jobs = true;
  /// At most this many messages are returned.
  std::size_t max_messages = 25;
  /// Times come from a real clock (the runtime), where only their order is checked:
  /// * the runtime stamps a frame when it releases it, after the camera thread woke, so a
  ///   frame may be stamped any time after its arrival window opens (never before; and a
  ///   sensor's frames keep one stamp each, in frame order, checked in both cases);
  /// * on a lane that holds several units (device.queue_depth > 1, an asynchronous lane), a
  ///   unit's end is recorded when the host handles its completion and the next unit's start
  ///   as the device reports it, already running by then: the next one starts no earlier
  ///   than the one before it did, instead of no earlier than its recorded end.
  /// false in the simulator: a frame arrives within [time, time + jitter], and a queued unit
  /// starts at the end of the one before.
  bool wall_clock = false;
};

namespace detail {

/// Where one (job, unit) ran: the recorded dispatch and the member within it.
struct Exec {
  const SeenUnit* unit = nullptr;
  const Member* member = nullptr;
  int task = 0;  ///< index of the member's task within the dispatch
};

inline int task_of(const Dispatch& d, std::size_t member) {
  for (std::size_t t = 0; t + 1 < d.task_begin.size(); ++t)
    if (member >= static_cast<std::size_t>(d.task_begin[t]) &&
        member < static_cast<std::size_t>(d.task_begin[t + 1]))
      return static_cast<int>(t);
  return -1;
}

/// Frame arrival schedule of a sensor (frames k at phase + k·period, late by at most the
/// jitter), when no event changes its rate.
struct FrameSchedule {
  bool known = false;
  Duration phase{0}, period{0}, jitter{0};
};

inline std::vector<FrameSchedule> frame_schedules(const Scenario& s) {
  std::vector<FrameSchedule> out(s.sensors.size());
  for (std::size_t i = 0; i < s.sensors.size(); ++i) {
    const SensorSpec& sp = s.sensors[i];
    FrameSchedule& f = out[i];
    f.known = true;
    f.phase = sp.phase;
    f.period = Duration{static_cast<std::int64_t>(std::llround(1e9 / sp.rate_hz))};
    f.jitter = std::min(sp.jitter, f.period - Duration{1});
  }
  for (const EventSpec& e : s.events)
    for (const auto& [sensor, rate] : e.sensor_rates)
      out[static_cast<std::size_t>(sensor)].known = false;
  return out;
}

}  // namespace detail

/// Checks a recorded run. `s` is the scenario it ran.
inline std::vector<std::string> check_semantics(const Scenario& s, const RecordingObserver& rec,
                                                const SemanticsOptions& opt = {}) {
  std::vector<std::string> out;
  const bool queued = s.device.queue_depth.value_or(1) > 1;  // lanes hold several units
  auto fail = [&](std::string msg) {
    if (out.size() < opt.max_messages) out.push_back(std::move(msg));
  };
  const auto schedules = detail::frame_schedules(s);

  // (job, unit) -> executions.
  std::map<JobId, std::map<int, std::vector<detail::Exec>>> execs;
  for (const SeenUnit& u : rec.units()) {
    for (std::size_t i = 0; i < u.d.members.size(); ++i) {
      const Member& m = u.d.members[i];
      execs[m.job][m.unit].push_back({&u, &m, detail::task_of(u.d, i)});
    }
    if (u.ended && u.end < u.d.start)
      fail(fmt::format("dispatch {} ends at {} before it starts at {}", u.d.id, u.end.count(),
                       u.d.start.count()));
  }

  // Latest non-skipped release of each operation, in callback order, for depends_on.
  std::vector<const SeenJob*> by_release;
  for (const SeenJob& j : rec.jobs()) by_release.push_back(&j);
  std::sort(by_release.begin(), by_release.end(),
            [](const SeenJob* a, const SeenJob* b) { return a->release_event < b->release_event; });
  std::vector<const SeenJob*> latest(static_cast<std::size_t>(s.operation_count()), nullptr);
  std::map<JobId, const SeenJob*> depends_on_job;
  for (const SeenJob* j : by_release) {
    if (j->graph != nullptr && j->graph->spec->depends_on >= 0 && !j->skipped_at_release) {
      const SeenJob* d = latest[static_cast<std::size_t>(j->graph->spec->depends_on)];
      if (d != nullptr && (d->end_event == 0 || d->end_event > j->release_event))
        depends_on_job[j->id] = d;
    }
    if (!j->skipped_at_release) latest[static_cast<std::size_t>(j->operation)] = j;
  }

  for (const SeenJob& j : rec.jobs()) {
    const bool completed = j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
    if (!opt.all_jobs && !completed) continue;
    const std::string who = fmt::format("job {} ({}#{}, {})", j.id, s.operation_name(j.operation),
                                        j.seq, to_string(j.outcome));
    if (j.graph == nullptr || !j.graph->spec) {
      fail(who + ": released without a graph");
      continue;
    }
    const RefinedGraph& g = *j.graph;
    const OperationSpec& spec = *g.spec;
    const auto found = execs.find(j.id);
    static const std::map<int, std::vector<detail::Exec>> kNone;
    const auto& by_unit = found == execs.end() ? kNone : found->second;
    auto exec_of = [&](int unit) -> const detail::Exec* {
      const auto it = by_unit.find(unit);
      return it == by_unit.end() || it->second.empty() ? nullptr : &it->second.front();
    };
    const std::uint64_t end_event = j.end_event == 0 ? UINT64_MAX : j.end_event;

    for (const auto& [unit, list] : by_unit) {
      if (unit < 0 || unit >= static_cast<int>(g.units.size())) {
        fail(fmt::format("{}: ran unit {} that its graph does not have", who, unit));
        continue;
      }
      if (list.size() != 1) fail(fmt::format("{}: unit {} ran {} times", who, unit, list.size()));
      const RefinedUnit& ru = g.units[static_cast<std::size_t>(unit)];
      const detail::Exec& e = list.front();
      const Dispatch& d = e.unit->d;
      const Member& m = *e.member;
      // docs/DESIGN.md, "Drops" strict abort: queued units leave; only units already running may
      // still end.
      if (e.unit->start_event > end_event)
        fail(fmt::format("{}: unit {} ({}) started at {} after the job ended", who, unit,
                         to_string(ru.kind), d.start.count()));
      if (m.graph != &g)
        fail(fmt::format("{}: unit {} dispatched with another graph version", who, unit));
      if (d.kind != ru.kind)
        fail(fmt::format("{}: unit {} is {} but ran in a {} dispatch", who, unit,
                         to_string(ru.kind), to_string(d.kind)));
      if (m.node != ru.node)
        fail(fmt::format("{}: unit {} reported node {} (expected {})", who, unit, m.node, ru.node));
      // Precedence (docs/DESIGN.md, "Refinement"): every predecessor unit ended, completed, before
      // this one started.
      for (int p : ru.preds) {
        const detail::Exec* pe = exec_of(p);
        // A unit queued behind its predecessor on the same lane (device.queue_depth > 1) is
        // dispatched before that one ends, and starts after it in the lane's order.
        const bool in_lane_order = queued && pe != nullptr && pe->unit->d.lane == d.lane;
        if (pe == nullptr || !pe->unit->ended || pe->unit->status != UnitStatus::Completed ||
            (!in_lane_order && pe->unit->end_event > e.unit->start_event) ||
            (in_lane_order && opt.wall_clock ? pe->unit->d.start > d.start
                                             : pe->unit->end > d.start))
          fail(fmt::format("{}: unit {} ({}) started at {} before its predecessor {} ({}) ended",
                           who, unit, to_string(ru.kind), d.start.count(), p,
                           to_string(g.units[static_cast<std::size_t>(p)].kind)));
      }
      // depends_on {use: latest}: the newest job of that operation ended first.
      if (const auto dj = depends_on_job.find(j.id); dj != depends_on_job.end()) {
        const bool head_source =
            std::find(g.head_sources.begin(), g.head_sources.end(), unit) != g.head_sources.end();
        if (head_source &&
            (dj->second->end_event == 0 || dj->second->end_event > e.unit->start_event))
          fail(fmt::format("{}: unit {} started before job {} it depends on ended", who, unit,
                           dj->second->id));
      }
      // The right sensor and a frame that sensor produced (docs/DESIGN.md, "Refinement").
      int sensor = ru.sensor;
      if (ru.kind == UnitKind::Mono) sensor = g.sensors.empty() ? -1 : g.sensors.front();
      if (ru.node >= 0 && ru.kind != UnitKind::Plain) {
        const NodeSpec& n = spec.nodes[static_cast<std::size_t>(ru.node)];
        if (ru.sensor != n.sensor || (ru.kind != UnitKind::Encoder && ru.head != n.head))
          fail(fmt::format("{}: unit {} reads sensor {} head {}, node {} is sensor {} head {}", who,
                           unit, ru.sensor, ru.head, n.name, n.sensor, n.head));
      }
      if (ru.kind == UnitKind::Encoder && d.batch == 1 && d.sensor != ru.sensor)
        fail(fmt::format("{}: encoder unit {} of sensor {} ran in a dispatch of sensor {}", who,
                         unit, ru.sensor, d.sensor));
      if (ru.kind == UnitKind::Head && d.head != ru.head)
        fail(fmt::format("{}: head unit {} (head {}) ran as head {}", who, unit, ru.head, d.head));
      if (ru.kind == UnitKind::Head) {
        // The features it reads come from its own encoder unit's frame.
        for (int p : ru.preds) {
          if (g.units[static_cast<std::size_t>(p)].kind != UnitKind::Encoder) continue;
          const detail::Exec* pe = exec_of(p);
          if (pe == nullptr) continue;  // reported above
          if (g.units[static_cast<std::size_t>(p)].sensor != ru.sensor)
            fail(fmt::format("{}: head unit {} is fed by an encoder of another sensor", who, unit));
          if (pe->member->frame != m.frame || pe->member->frame_time != m.frame_time)
            fail(fmt::format("{}: head unit {} reads frame {} but its encoder ran frame {}", who,
                             unit, m.frame, pe->member->frame));
        }
      }
      if (sensor >= 0 && (ru.kind == UnitKind::Encoder || ru.kind == UnitKind::Coarse ||
                          ru.kind == UnitKind::Mono)) {
        if (m.frame_time > d.start)
          fail(fmt::format("{}: unit {} starts at {} on frame {} of sensor {} from the future ({})",
                           who, unit, d.start.count(), m.frame, sensor, m.frame_time.count()));
        const detail::FrameSchedule& f = schedules[static_cast<std::size_t>(sensor)];
        if (f.known) {
          const TimePoint base = f.phase + f.period * static_cast<std::int64_t>(m.frame);
          const TimePoint last = base + f.jitter;
          if (m.frame_time < base || (!opt.wall_clock && m.frame_time > last))
            fail(fmt::format(
                "{}: unit {} reads frame {} of sensor {} stamped {}, but that frame "
                "arrives in [{}, {}]",
                who, unit, m.frame, sensor, m.frame_time.count(), base.count(), last.count()));
        }
        // A job released by a frame computes on that frame (only sampling jobs take newer).
        if (spec.trigger_sensor == sensor && m.frame_time != j.release)
          fail(fmt::format("{}: unit {} of a job triggered at {} reads a frame stamped {}", who,
                           unit, j.release.count(), m.frame_time.count()));
      }
    }

    if (!completed) continue;
    // Every unit ran exactly once and completed before the job's end; every node's output
    // was produced exactly once (Head/Coarse/Plain: their node; Mono: all).
    std::vector<int> produced(spec.nodes.size(), 0);
    std::vector<const detail::Exec*> producer(spec.nodes.size(), nullptr);
    for (std::size_t u = 0; u < g.units.size(); ++u) {
      const detail::Exec* e = exec_of(static_cast<int>(u));
      if (e == nullptr) {
        fail(fmt::format("{}: unit {} ({}) never ran", who, u, to_string(g.units[u].kind)));
        continue;
      }
      if (!e->unit->ended || e->unit->status != UnitStatus::Completed ||
          e->unit->end_event > end_event || e->unit->end > j.finish)
        fail(fmt::format("{}: unit {} had not completed when the job completed", who, u));
      for (int n : g.units[u].produces) {
        ++produced[static_cast<std::size_t>(n)];
        producer[static_cast<std::size_t>(n)] = e;
      }
    }
    for (std::size_t n = 0; n < spec.nodes.size(); ++n)
      if (produced[n] != 1)
        fail(fmt::format("{}: node {} produced {} times", who, spec.nodes[n].name, produced[n]));
    // Node precedence in the operation's own DAG (whatever the refinement did).
    for (const EdgeSpec& e : spec.edges) {
      const detail::Exec* a = producer[static_cast<std::size_t>(e.from)];
      const detail::Exec* b = producer[static_cast<std::size_t>(e.to)];
      if (a == nullptr || b == nullptr || a->unit == b->unit) continue;
      const bool in_lane_order = queued && a->unit->d.lane == b->unit->d.lane;
      if ((in_lane_order && opt.wall_clock ? a->unit->d.start > b->unit->d.start
                                           : a->unit->end > b->unit->d.start) ||
          (!in_lane_order && a->unit->end_event > b->unit->start_event))
        fail(fmt::format("{}: node {} started at {} before its predecessor {} ended at {}", who,
                         spec.nodes[static_cast<std::size_t>(e.to)].name, b->unit->d.start.count(),
                         spec.nodes[static_cast<std::size_t>(e.from)].name, a->unit->end.count()));
    }
  }

  // One stamp per frame, and a sensor's later frames stamped no earlier (whatever the
  // tolerance above, a unit reads the frame it names).
  std::map<std::pair<int, std::uint64_t>, TimePoint> stamps;
  for (const SeenUnit& u : rec.units())
    for (const Member& m : u.d.members) {
      if (m.graph == nullptr || m.unit < 0 || m.unit >= static_cast<int>(m.graph->units.size()))
        continue;
      const RefinedUnit& ru = m.graph->units[static_cast<std::size_t>(m.unit)];
      if (ru.sensor < 0 || (ru.kind != UnitKind::Encoder && ru.kind != UnitKind::Coarse)) continue;
      const auto [it, fresh] = stamps.try_emplace({ru.sensor, m.frame}, m.frame_time);
      if (!fresh && it->second != m.frame_time)
        fail(fmt::format("frame {} of sensor {} read with stamps {} and {}", m.frame, ru.sensor,
                         it->second.count(), m.frame_time.count()));
    }
  for (auto it = stamps.begin(); it != stamps.end(); ++it) {
    const auto next = std::next(it);
    if (next != stamps.end() && next->first.first == it->first.first && next->second < it->second)
      fail(fmt::format("sensor {}: frame {} stamped {} before frame {} stamped {}", it->first.first,
                       next->first.second, next->second.count(), it->first.second,
                       it->second.count()));
  }

  // Within one dispatch, the members of one merged task share its sensor and frame.
  for (const SeenUnit& u : rec.units()) {
    if (u.d.kind != UnitKind::Encoder) continue;
    for (std::size_t t = 0; t + 1 < u.d.task_begin.size(); ++t) {
      const auto b = static_cast<std::size_t>(u.d.task_begin[t]);
      const auto e = static_cast<std::size_t>(u.d.task_begin[t + 1]);
      for (std::size_t i = b + 1; i < e; ++i) {
        const Member& m0 = u.d.members[b];
        const Member& mi = u.d.members[i];
        const int s0 = m0.graph->units[static_cast<std::size_t>(m0.unit)].sensor;
        const int si = mi.graph->units[static_cast<std::size_t>(mi.unit)].sensor;
        if (s0 != si || m0.frame != mi.frame)
          fail(
              fmt::format("dispatch {}: merged encoder members read sensor {} frame {} and "
                          "sensor {} frame {}",
                          u.d.id, s0, m0.frame, si, mi.frame));
      }
    }
  }
  return out;
}

/// Checks that every lane runs at most one unit at a time: per lane, a dispatch is decided
/// and started only after the previous one on that lane ended.
/// `wall_clock` as in SemanticsOptions.
inline std::vector<std::string> check_lanes(const Scenario& s, const RecordingObserver& rec,
                                            bool wall_clock = false) {
  std::vector<std::string> out;
  std::vector<const SeenUnit*> last(static_cast<std::size_t>(s.device.lanes), nullptr);
  // Lanes that hold several units (device.queue_depth > 1) are given the next while one
  // runs: it must start after that one ends, and no more than the depth are held at once.
  const int depth = s.device.queue_depth.value_or(1);
  for (const SeenUnit& u : rec.units()) {  // in start order
    if (u.d.lane < 0 || u.d.lane >= s.device.lanes) {
      out.push_back(fmt::format("dispatch {} on lane {} of {}", u.d.id, u.d.lane, s.device.lanes));
      continue;
    }
    const SeenUnit*& prev = last[static_cast<std::size_t>(u.d.lane)];
    if (prev != nullptr && depth > 1 &&
        (!prev->ended || (wall_clock ? prev->d.start > u.d.start : prev->end > u.d.start)))
      out.push_back(fmt::format("lane {}: dispatch {} starts at {} before dispatch {} ends at {}",
                                u.d.lane, u.d.id, u.d.start.count(), prev->d.id,
                                prev->ended ? prev->end.count() : -1));
    if (prev != nullptr && depth == 1 &&
        (!prev->ended || prev->end_event > u.start_event || prev->end > u.d.decided_at ||
         prev->end > u.d.start))
      out.push_back(fmt::format("lane {}: dispatch {} starts at {} while dispatch {} runs until {}",
                                u.d.lane, u.d.id, u.d.start.count(), prev->d.id,
                                prev->ended ? prev->end.count() : -1));
    if (u.d.start < u.d.decided_at)
      out.push_back(fmt::format("dispatch {} starts before it was decided", u.d.id));
    prev = &u;
    if (out.size() > 25) break;
  }
  return out;
}

/// Joins messages for a gtest failure.
inline std::string join_lines(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += "  " + x + "\n";
  return s;
}

}  // namespace red::test
