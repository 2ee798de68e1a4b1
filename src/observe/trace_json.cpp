// Writing a TraceObserver's records as Chrome Trace Event JSON (the layout is described
// in red/observe/trace.hpp and docs/REPORTS.md).

#include <fmt/format.h>

#include <algorithm>
#include <ostream>
#include <sstream>

#include "red/graph/refine.hpp"
#include "red/observe/trace.hpp"

namespace red {

namespace {

using Meta = std::vector<std::pair<std::string, std::string>>;

// Track ids: unique across the file (Perfetto's JSON importer keys threads by tid), and
// grouped per process: lanes, the scheduler, then per operation its instants and job rows.
constexpr int kPidStride = 100000;
constexpr int kSchedulerTrack = 900;
constexpr int kOperationBase = 1000;
constexpr int kOperationStride = 100;  // 1 instants track + at most 99 job rows
constexpr int kMaxJobRows = kOperationStride - 1;

int lane_tid(int pid, int lane) {
  return pid * kPidStride + 1 + lane;
}
int op_tid(int pid, int op, int row) {
  return pid * kPidStride + kOperationBase + op * kOperationStride + row;
}

void escape(std::string& out, std::string_view s) {
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(c)));
        else
          out += c;
    }
  }
}

std::string json_string(std::string_view s) {
  std::string out = "\"";
  escape(out, s);
  out += '"';
  return out;
}

// Microseconds with exact nanosecond decimals (no floating-point rounding).
std::string us(Duration t) {
  const std::int64_t ns = t.count();
  const char* sign = ns < 0 ? "-" : "";
  const std::int64_t a = ns < 0 ? -ns : ns;
  return fmt::format("{}{}.{:03}", sign, a / 1000, a % 1000);
}

std::string ms(Duration t) {
  return fmt::format("{:.3f}", to_ms(t));
}

// Buffers events and flushes to the stream in large blocks.
class Emitter {
 public:
  explicit Emitter(std::ostream& out) : out_(out) {}
  ~Emitter() { flush(); }
  Emitter(const Emitter&) = delete;
  Emitter& operator=(const Emitter&) = delete;

  // Starts an event object; the caller appends fields and calls end().
  std::string& begin() {
    buf_ += first_ ? "\n" : ",\n";
    first_ = false;
    buf_ += '{';
    return buf_;
  }
  void end() {
    buf_ += '}';
    if (buf_.size() > (1u << 20)) flush();
  }
  void flush() {
    out_ << buf_;
    buf_.clear();
  }
  std::string& raw() { return buf_; }

 private:
  std::ostream& out_;
  std::string buf_;
  bool first_ = true;
};

void metadata_event(Emitter& e, const char* name, int pid, int tid, const std::string& args) {
  std::string& b = e.begin();
  b += fmt::format(R"("name":"{}","ph":"M","pid":{},"tid":{},"args":{})", name, pid, tid, args);
  e.end();
}

void thread_track(Emitter& e, int pid, int tid, std::string_view name, int sort) {
  metadata_event(e, "thread_name", pid, tid, "{\"name\":" + json_string(name) + "}");
  metadata_event(e, "thread_sort_index", pid, tid, fmt::format("{{\"sort_index\":{}}}", sort));
}

const char* job_color(JobOutcome o) {
  switch (o) {
    case JobOutcome::Met:
      return "good";
    case JobOutcome::Missed:
      return "terrible";
    case JobOutcome::Dropped:
    case JobOutcome::Skipped:
    case JobOutcome::Failed:
      return "bad";
    case JobOutcome::Unfinished:
      return "grey";
  }
  return "grey";
}

const char* miss_mark(JobOutcome o) {
  switch (o) {
    case JobOutcome::Missed:
      return "MISSED";
    case JobOutcome::Dropped:
      return "DROPPED";
    case JobOutcome::Skipped:
      return "SKIPPED";
    case JobOutcome::Failed:
      return "FAILED";
    case JobOutcome::Met:
    case JobOutcome::Unfinished:
      break;
  }
  return nullptr;
}

// A stable slice name per kind of work, so Perfetto colors the same work alike; the jobs
// are in the slice's args.
std::string unit_label(const Scenario& s, const TraceObserver& t, const TraceObserver::UnitRec& u) {
  auto head = [&] {
    return u.head >= 0 && static_cast<std::size_t>(u.head) < s.model.heads.size()
               ? s.model.heads[static_cast<std::size_t>(u.head)]
               : std::string("?");
  };
  const TraceObserver::MemberRec* first =
      u.member_count > 0 ? &t.members()[u.member_begin] : nullptr;
  const std::string op =
      first != nullptr && first->operation >= 0 ? s.operation_name(first->operation) : "?";
  switch (u.kind) {
    case UnitKind::Encoder:
      return "encoder " + (u.sensor >= 0 && static_cast<std::size_t>(u.sensor) < s.sensors.size()
                               ? s.sensors[static_cast<std::size_t>(u.sensor)].name
                               : std::string("?"));
    case UnitKind::Head:
      return "head " + head();
    case UnitKind::Coarse:
      return "coarse " + head();
    case UnitKind::Mono:
      return "mono " + op;
    case UnitKind::Plain: {
      std::string name = t.member_name(*first);
      const auto colon = name.find(':');
      return "plain " + op + (colon == std::string::npos ? "" : name.substr(colon));
    }
  }
  return "unit";
}

void write_units(Emitter& e, const Scenario& s, const TraceObserver& t, int pid,
                 TimePoint end_of_run) {
  std::vector<TimePoint> lane_end;
  for (const TraceObserver::UnitRec& u : t.units()) {
    const auto lane = static_cast<std::size_t>(u.lane);
    if (lane >= lane_end.size()) lane_end.resize(lane + 1, TimePoint{0});
    const int tid = lane_tid(pid, u.lane);
    // The synchronizer round trip occupies the lane between decision and start.
    if (u.start > u.decided && u.decided >= lane_end[lane]) {
      std::string& b = e.begin();
      b += fmt::format(R"("name":"sync","cat":"sync","ph":"X","ts":{},"dur":{},"pid":{},"tid":{},)"
                       R"("args":{{"dispatch":{}}})",
                       us(u.decided), us(u.start - u.decided), pid, tid, u.dispatch);
      e.end();
    }
    const TimePoint end = u.open ? std::max(u.start, end_of_run) : u.end;
    lane_end[lane] = end;
    std::string& b = e.begin();
    b += "\"name\":" + json_string(unit_label(s, t, u));
    b += fmt::format(R"(,"cat":"{}","ph":"X","ts":{},"dur":{},"pid":{},"tid":{},"args":{{)",
                     to_string(u.kind), us(u.start), us(end - u.start), pid, tid);
    b += fmt::format(R"("kind":"{}")", to_string(u.kind));
    if (u.member_count > 0) {
      const TraceObserver::MemberRec& m = t.members()[u.member_begin];
      const std::string name = t.member_name(m);
      const auto colon = name.find(':');
      b += ",\"operation\":" + json_string(s.operation_name(m.operation));
      b += ",\"job\":" + json_string(name.substr(0, colon));
      if (colon != std::string::npos) b += ",\"node\":" + json_string(name.substr(colon + 1));
    }
    if (u.head >= 0 && static_cast<std::size_t>(u.head) < s.model.heads.size())
      b += ",\"head\":" + json_string(s.model.heads[static_cast<std::size_t>(u.head)]);
    if (u.sensor >= 0 && static_cast<std::size_t>(u.sensor) < s.sensors.size())
      b += ",\"sensor\":" + json_string(s.sensors[static_cast<std::size_t>(u.sensor)].name);
    b += fmt::format(R"(,"batch":{},"merged":{},"members":[)", u.batch, u.member_count);
    for (std::uint32_t i = 0; i < u.member_count; ++i) {
      if (i > 0) b += ',';
      b += json_string(t.member_name(t.members()[u.member_begin + i]));
    }
    b += fmt::format(
        R"(],"round_trip":{},"status":"{}","dispatch":{},"decided_ms":{},"policy_deadline_ms":{}}})",
        u.round_trip ? "true" : "false", u.open ? "running" : to_string(u.status), u.dispatch,
        ms(u.decided), ms(u.deadline));
    e.end();
  }
}

void instant(Emitter& e, std::string_view name, const char* cat, TimePoint at, int pid, int tid,
             const std::string& args) {
  std::string& b = e.begin();
  b += "\"name\":" + json_string(name);
  b += fmt::format(R"(,"cat":"{}","ph":"i","s":"t","ts":{},"pid":{},"tid":{},"args":{})", cat,
                   us(at), pid, tid, args);
  e.end();
}

// Jobs: instants on the operation's track; job slices spread over rows so that slices
// never overlap on a track (greedy interval partitioning by release time).
void write_jobs(Emitter& e, const Scenario& s, const TraceObserver& t, int pid,
                std::vector<int>& rows_per_op) {
  const auto& jobs = t.jobs();
  std::vector<std::size_t> order(jobs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return jobs[a].release < jobs[b].release; });
  std::vector<std::vector<TimePoint>> row_end(static_cast<std::size_t>(s.operation_count()));
  for (const std::size_t i : order) {
    const TraceObserver::JobRec& j = jobs[i];
    if (j.operation < 0 || j.operation >= s.operation_count()) continue;
    const std::string& op = s.operation_name(j.operation);
    const std::string job = op + "#" + std::to_string(j.seq);
    const int itid = op_tid(pid, j.operation, 0);
    std::string args = "{\"job\":" + json_string(job);
    if (!j.counted) args += ",\"warmup\":true";
    args += '}';
    instant(e, "release", "job", j.release, pid, itid, args);
    instant(e, "deadline", "job", j.deadline, pid, itid, args);
    if (const char* mark = miss_mark(j.outcome)) {
      std::string margs = "{\"job\":" + json_string(job);
      margs += fmt::format(R"(,"outcome":"{}")", to_string(j.outcome));
      if (j.outcome == JobOutcome::Missed)
        margs += fmt::format(R"(,"late_ms":{})", ms(j.finish - j.deadline));
      if (!j.reason.empty()) margs += ",\"reason\":" + json_string(j.reason);
      margs += '}';
      instant(e, mark, "miss", j.finish, pid, itid, margs);
    }
    if (j.finish <= j.release) continue;  // skipped: never ran
    auto& rows = row_end[static_cast<std::size_t>(j.operation)];
    std::size_t row = 0;
    while (row < rows.size() && rows[row] > j.release) ++row;
    if (row == rows.size()) {
      if (rows.size() >= static_cast<std::size_t>(kMaxJobRows)) continue;
      rows.push_back(j.finish);
    }
    rows[row] = j.finish;
    std::string& b = e.begin();
    b += "\"name\":" + json_string(job);
    b += fmt::format(R"(,"cat":"job","ph":"X","ts":{},"dur":{},"pid":{},"tid":{},"cname":"{}",)"
                     R"("args":{{"outcome":"{}","response_ms":{},"deadline_ms":{})",
                     us(j.release), us(j.finish - j.release), pid,
                     op_tid(pid, j.operation, static_cast<int>(row) + 1), job_color(j.outcome),
                     to_string(j.outcome), ms(j.finish - j.release), ms(j.deadline - j.release));
    if (!j.counted) b += ",\"warmup\":true";
    if (!j.reason.empty()) b += ",\"reason\":" + json_string(j.reason);
    b += "}";
    e.end();
  }
  rows_per_op.clear();
  for (const auto& rows : row_end) rows_per_op.push_back(static_cast<int>(rows.size()));
}

void write_counters(Emitter& e, const TraceObserver& t, int pid) {
  // A merge-wait track that stays at zero (no DynamicMerge) is noise.
  bool waits = false;
  for (const TraceObserver::CounterRec& c : t.counters())
    waits = waits || (c.counter == TraceObserver::Counter::Waiting && c.value > 0);
  for (const TraceObserver::CounterRec& c : t.counters()) {
    if (c.counter == TraceObserver::Counter::Waiting && !waits) continue;
    // Perfetto names a counter track "<name> <arg>": "ready queue length", "merge wait
    // tasks" (tasks in a merge wait or held by the criticality guard), "jobs in flight".
    const char* name = c.counter == TraceObserver::Counter::Ready     ? "ready queue"
                       : c.counter == TraceObserver::Counter::Waiting ? "merge wait"
                                                                      : "jobs";
    const char* key = c.counter == TraceObserver::Counter::Ready     ? "length"
                      : c.counter == TraceObserver::Counter::Waiting ? "tasks"
                                                                     : "in flight";
    std::string& b = e.begin();
    b += fmt::format(R"("name":"{}","ph":"C","ts":{},"pid":{},"tid":{},"args":{{"{}":{}}})", name,
                     us(c.at), pid, pid * kPidStride, key, c.value);
    e.end();
  }
}

void write_process(Emitter& e, const Scenario& s, const TraceProcess& p, int pid, bool global) {
  const TraceObserver& t = *p.trace;
  metadata_event(e, "process_name", pid, pid * kPidStride,
                 "{\"name\":" + json_string(p.name) + "}");
  metadata_event(e, "process_sort_index", pid, pid * kPidStride,
                 fmt::format("{{\"sort_index\":{}}}", pid));
  int lanes = s.device.lanes;
  for (const auto& u : t.units()) lanes = std::max(lanes, u.lane + 1);
  for (int l = 0; l < lanes; ++l)
    thread_track(e, pid, lane_tid(pid, l), fmt::format("lane {}", l), l);
  write_units(e, s, t, pid, t.last_time());

  std::vector<int> rows;
  write_jobs(e, s, t, pid, rows);
  for (int op = 0; op < s.operation_count(); ++op) {
    const int base = lanes + 1 + op * kOperationStride;
    const std::string& name = s.operation_name(op);
    thread_track(e, pid, op_tid(pid, op, 0), name + ": release, deadline, misses", base);
    const int n =
        static_cast<std::size_t>(op) < rows.size() ? rows[static_cast<std::size_t>(op)] : 0;
    for (int r = 0; r < n; ++r)
      thread_track(e, pid, op_tid(pid, op, r + 1),
                   r == 0 ? name + ": jobs" : fmt::format("{}: jobs ({})", name, r + 1),
                   base + 1 + r);
  }

  const int stid = pid * kPidStride + kSchedulerTrack;
  if (!t.waits().empty()) {
    thread_track(e, pid, stid, "scheduler: merge waits", lanes);
    for (const TraceObserver::WaitRec& w : t.waits()) {
      const std::string sensor =
          w.sensor >= 0 && static_cast<std::size_t>(w.sensor) < s.sensors.size()
              ? s.sensors[static_cast<std::size_t>(w.sensor)].name
              : std::string("?");
      instant(
          e, "merge wait", "merge", w.at, pid, stid,
          "{\"sensor\":" + json_string(sensor) + fmt::format(R"(,"until_ms":{}}})", ms(w.until)));
    }
  }
  write_counters(e, t, pid);

  // Workload events: global instants (a line across every track), once per file.
  if (global)
    for (const TraceObserver::EventRec& ev : t.workload_events()) {
      const std::string kind = ev.index >= 0 && static_cast<std::size_t>(ev.index) < s.events.size()
                                   ? s.events[static_cast<std::size_t>(ev.index)].kind
                                   : std::string("event");
      std::string& b = e.begin();
      b += "\"name\":" + json_string(fmt::format("event {}: {}", ev.index, kind));
      b += fmt::format(R"(,"cat":"workload","ph":"i","s":"g","ts":{},"pid":{},"tid":{},)",
                       us(ev.at), pid, stid);
      b += fmt::format(R"("args":{{"index":{},"kind":{}}})", ev.index, json_string(kind));
      e.end();
    }
  if (t.truncated()) {
    std::string& b = e.begin();
    b += fmt::format(
        R"("name":"trace truncated","cat":"trace","ph":"i","s":"p","ts":{},"pid":{},"tid":{},)"
        R"("args":{{"events":{}}})",
        us(t.truncated_at()), pid, stid, t.events());
    e.end();
  }
}

}  // namespace

void write_chrome_trace(std::ostream& out, const Scenario& s,
                        const std::vector<TraceProcess>& processes, const Meta& metadata) {
  out << "{\"displayTimeUnit\":\"ms\",\n\"otherData\":{";
  std::string head = "\"generator\":\"red\",\"scenario\":" + json_string(s.name);
  for (const auto& [k, v] : metadata) head += "," + json_string(k) + ":" + json_string(v);
  head += R"(,"layout":"one process per policy; tracks: one per lane (unit slices), )"
          R"(per operation release/deadline/miss instants and job slices, counters")";
  for (const TraceProcess& p : processes)
    if (p.trace != nullptr && p.trace->truncated())
      head += "," + json_string("truncated " + p.name) + ":" +
              json_string(fmt::format("trace stops at {:.3f} s: the limit of {} events was reached",
                                      to_s(p.trace->truncated_at()), p.trace->events()));
  out << head << "},\n\"traceEvents\":[";
  {
    Emitter e(out);
    int pid = 1;
    for (const TraceProcess& p : processes) {
      if (p.trace != nullptr) write_process(e, s, p, pid, pid == 1);
      ++pid;
    }
  }
  out << "\n]}\n";
}

std::string chrome_trace_json(const Scenario& s, const std::vector<TraceProcess>& processes,
                              const Meta& metadata) {
  std::ostringstream out;
  write_chrome_trace(out, s, processes, metadata);
  return out.str();
}

}  // namespace red
