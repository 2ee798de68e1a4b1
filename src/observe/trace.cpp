#include "red/observe/trace.hpp"

#include <algorithm>

#include "red/graph/refine.hpp"

namespace red {

TraceObserver::TraceObserver(const Scenario& s, TraceOptions options)
    : scenario_(s), options_(options) {
  open_.assign(static_cast<std::size_t>(std::max(1, s.device.lanes)), {});
}

TraceObserver::~TraceObserver() = default;

bool TraceObserver::room(std::size_t n, TimePoint at) {
  if (truncated_) return false;
  if (options_.max_events != 0 && events_ + n > options_.max_events) {
    // Stop at one point in time, so everything before it is complete.
    truncated_ = true;
    truncated_at_ = at;
    return false;
  }
  events_ += n;
  return true;
}

void TraceObserver::count(Counter c, int value, TimePoint at) {
  int& last = last_value_[static_cast<int>(c)];
  if (value == last) return;  // a counter track needs a sample only when it changes
  if (!room(1, at)) return;
  last = value;
  counters_.push_back({at, value, c});
}

std::uint32_t TraceObserver::spec_index(const RefinedGraph* g) {
  if (g == last_graph_) return last_spec_;
  // Few snapshots exist (one per operation and event), so a linear search is enough.
  std::uint32_t i = 0;
  while (i < specs_.size() && specs_[i] != g->spec) ++i;
  if (i == specs_.size()) specs_.push_back(g->spec);
  last_graph_ = g;
  last_spec_ = i;
  return i;
}

void TraceObserver::on_job_release(const JobRecord& job) {
  see(job.release);
  ++in_flight_;
  // Budget for everything the job may show: release, deadline, job slice, outcome mark.
  if (room(4, job.release)) {
    JobRec r;
    r.id = job.id;
    r.operation = job.operation;
    r.seq = job.seq;
    r.release = job.release;
    r.deadline = job.deadline;
    r.finish = job.release;
    r.counted = job.counted;
    live_[job.id] = jobs_.size();
    jobs_.push_back(std::move(r));
  }
  count(Counter::InFlight, in_flight_, job.release);
}

void TraceObserver::on_job_end(const JobRecord& job) {
  see(job.finish);
  --in_flight_;
  const auto it = live_.find(job.id);
  if (it != live_.end()) {  // already budgeted at release
    JobRec& r = jobs_[it->second];
    r.finish = job.finish;
    r.outcome = job.outcome;
    r.reason = std::string(job.reason);
    live_.erase(it);
  }
  count(Counter::InFlight, in_flight_, job.finish);
}

void TraceObserver::on_unit_start(const Dispatch& d) {
  see(d.start);
  const auto lane = static_cast<std::size_t>(d.lane);
  if (lane >= open_.size()) open_.resize(lane + 1);
  const bool sync = options_.sync_slices && d.start > d.decided_at;
  if (!room(sync ? 2 : 1, d.decided_at)) {
    open_[lane].push_back(-1);
    return;
  }
  UnitRec u;
  u.dispatch = d.id;
  u.decided = d.decided_at;
  u.start = d.start;
  u.end = d.start;
  u.deadline = d.deadline;
  u.lane = d.lane;
  u.kind = d.kind;
  u.head = d.head;
  u.sensor = d.sensor;
  u.batch = d.batch;
  u.round_trip = d.round_trip;
  u.member_begin = static_cast<std::uint32_t>(members_.size());
  u.member_count = static_cast<std::uint32_t>(d.members.size());
  for (const Member& m : d.members)
    members_.push_back(
        {m.job_seq, m.operation, m.node, m.graph != nullptr ? spec_index(m.graph) : 0});
  open_[lane].push_back(static_cast<std::int64_t>(units_.size()));
  units_.push_back(u);
}

void TraceObserver::on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) {
  see(end);
  const auto lane = static_cast<std::size_t>(d.lane);
  if (lane >= open_.size() || open_[lane].empty()) return;
  const std::int64_t i = open_[lane].front();
  open_[lane].pop_front();  // a lane ends its units in the order it was given them
  if (i < 0) return;
  UnitRec& u = units_[static_cast<std::size_t>(i)];
  u.start = std::min(d.start, end);  // a queued unit's start moved when the one before ended
  u.end = end;
  u.status = s;
  u.open = false;
}

void TraceObserver::on_merge_wait(int sensor, TimePoint now, TimePoint until) {
  see(now);
  if (room(1, now)) waits_.push_back({now, until, sensor});
}

void TraceObserver::on_workload_event(int index, TimePoint at) {
  see(at);
  if (room(1, at)) workload_.push_back({index, at});
}

void TraceObserver::on_decision(TimePoint now, int ready, int /*idle_lanes*/, int waiting) {
  see(now);
  count(Counter::Ready, ready, now);
  count(Counter::Waiting, waiting, now);
}

std::string TraceObserver::member_name(const MemberRec& m) const {
  std::string out = m.operation >= 0 ? scenario_.operation_name(m.operation) : "?";
  out += '#';
  out += std::to_string(m.seq);
  if (m.node >= 0 && m.spec < specs_.size()) {
    const auto& nodes = specs_[m.spec]->nodes;
    if (static_cast<std::size_t>(m.node) < nodes.size()) {
      out += ':';
      out += nodes[static_cast<std::size_t>(m.node)].name;
    }
  }
  return out;
}

}  // namespace red
