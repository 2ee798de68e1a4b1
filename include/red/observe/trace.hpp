#pragma once
/// \file
/// A timeline of a run in Chrome Trace Event format (opens in ui.perfetto.dev and
/// chrome://tracing), built as an observer of the scheduler, as taskflow's Chrome observer
/// sits outside its executor. It keeps the times the scheduler passes in (simulated or
/// real) and reads no clock, so the simulator and the real runtime give the same trace.
///
///     TraceObserver trace(scenario);
///     simulator.add_observer(&trace);          // or runtime.add_observer(&trace)
///     simulator.run();
///     std::ofstream f("trace.json");
///     write_chrome_trace(f, scenario, {{"red", &trace}}, {{"backend", "sim"}});
///
/// Layout of the file (docs/REPORTS.md, "Timeline"): one process per policy; in it one
/// track per lane with every unit execution as a slice, per operation a track of release,
/// deadline and miss instants and one or more tracks of job slices (release to finish),
/// a "scheduler" track of merge waits, and counters of the ready queue, the tasks in a
/// merge wait and the jobs in flight. Workload events are global instants.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <iosfwd>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "red/core/time.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"

namespace red {

/// What a TraceObserver keeps.
struct TraceOptions {
  /// Most trace events kept (slices, instants, counter samples), 0 for no limit. Once it
  /// is reached nothing more is recorded and the file's metadata says where the trace
  /// stops, so memory stays bounded on long runs.
  std::size_t max_events = 1'000'000;
  /// Show the round trip to the global synchronizer (dispatch decided → unit started) as a
  /// "sync" slice before the unit on its lane.
  bool sync_slices = true;
};

/// Records a run's units, jobs, merge waits, workload events and queue lengths.
/// Not thread-safe; the scheduler calls its observers one at a time.
class TraceObserver final : public Observer {
 public:
  /// `s` must outlive the observer and every write of its trace.
  explicit TraceObserver(const Scenario& s, TraceOptions options = {});
  ~TraceObserver() override;
  TraceObserver(const TraceObserver&) = delete;
  TraceObserver& operator=(const TraceObserver&) = delete;

  void on_job_release(const JobRecord& job) override;
  void on_job_end(const JobRecord& job) override;
  void on_unit_start(const Dispatch& d) override;
  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) override;
  void on_merge_wait(int sensor, TimePoint now, TimePoint until) override;
  void on_workload_event(int index, TimePoint at) override;
  void on_decision(TimePoint now, int ready, int idle_lanes, int waiting) override;

  /// Trace events recorded so far (an estimate of the events the file will hold).
  [[nodiscard]] std::size_t events() const noexcept { return events_; }
  /// True when max_events was reached and later records were dropped.
  [[nodiscard]] bool truncated() const noexcept { return truncated_; }
  /// Time of the first record that was dropped (meaningful when truncated()).
  [[nodiscard]] TimePoint truncated_at() const noexcept { return truncated_at_; }
  /// Latest time any callback reported.
  [[nodiscard]] TimePoint last_time() const noexcept { return last_; }
  [[nodiscard]] const Scenario& scenario() const noexcept { return scenario_; }

  // Records, for the writer and for tests.
  struct MemberRec {
    std::uint64_t seq = 0;
    int operation = -1;
    int node = -1;
    std::uint32_t spec = 0;  ///< index into specs_ (node names survive the scheduler)
  };
  struct UnitRec {
    std::uint64_t dispatch = 0;
    TimePoint decided{0}, start{0}, end{0}, deadline{0};
    int lane = 0;
    UnitKind kind = UnitKind::Plain;
    int head = -1;
    int sensor = -1;
    int batch = 1;
    bool round_trip = false;
    bool open = true;  ///< started, not ended (still running when the run stopped)
    UnitStatus status = UnitStatus::Completed;
    std::uint32_t member_begin = 0, member_count = 0;
  };
  struct JobRec {
    JobId id = 0;
    int operation = -1;
    std::uint64_t seq = 0;
    TimePoint release{0}, deadline{0}, finish{0};
    JobOutcome outcome = JobOutcome::Unfinished;
    bool counted = true;
    std::string reason;
  };
  /// Which counter a CounterRec samples.
  enum class Counter : std::uint8_t { Ready, Waiting, InFlight };
  struct CounterRec {
    TimePoint at{0};
    int value = 0;
    Counter counter = Counter::Ready;
  };
  struct WaitRec {
    TimePoint at{0}, until{0};
    int sensor = -1;
  };
  struct EventRec {
    int index = 0;
    TimePoint at{0};
  };

  [[nodiscard]] const std::vector<UnitRec>& units() const noexcept { return units_; }
  [[nodiscard]] const std::vector<MemberRec>& members() const noexcept { return members_; }
  [[nodiscard]] const std::vector<JobRec>& jobs() const noexcept { return jobs_; }
  [[nodiscard]] const std::vector<CounterRec>& counters() const noexcept { return counters_; }
  [[nodiscard]] const std::vector<WaitRec>& waits() const noexcept { return waits_; }
  [[nodiscard]] const std::vector<EventRec>& workload_events() const noexcept { return workload_; }
  /// "op#seq:node" of a member.
  [[nodiscard]] std::string member_name(const MemberRec& m) const;

 private:
  bool room(std::size_t n, TimePoint at);
  void see(TimePoint t) noexcept {
    if (t > last_) last_ = t;
  }
  void count(Counter c, int value, TimePoint at);
  std::uint32_t spec_index(const RefinedGraph* g);

  const Scenario& scenario_;
  TraceOptions options_;
  std::size_t events_ = 0;
  bool truncated_ = false;
  TimePoint truncated_at_{0};
  TimePoint last_{0};
  std::vector<UnitRec> units_;
  std::vector<MemberRec> members_;
  std::vector<JobRec> jobs_;
  std::vector<CounterRec> counters_;
  std::vector<WaitRec> waits_;
  std::vector<EventRec> workload_;
  // Per lane, oldest first: index into units_ of each unit the lane holds (the running one
  // and those queued behind it), or -1 for one not recorded.
  std::vector<std::deque<std::int64_t>> open_;
  std::unordered_map<JobId, std::size_t> live_;  // released job -> index into jobs_
  int last_value_[3] = {-1, -1, -1};
  int in_flight_ = 0;
  // Operation snapshots the members' node indices refer to, kept alive past the run.
  std::vector<std::shared_ptr<const OperationSpec>> specs_;
  const RefinedGraph* last_graph_ = nullptr;
  std::uint32_t last_spec_ = 0;
};

/// One process of a trace file: one policy's run.
struct TraceProcess {
  std::string name;                      ///< shown as the process name ("policy red")
  const TraceObserver* trace = nullptr;  ///< not owned
};

/// Writes the trace of one or more runs of the same scenario, one process per run, as a
/// Chrome Trace Event JSON object. `metadata` goes to "otherData" (scenario, backend, seed,
/// ...), with a note for every truncated process. Streams: memory beyond the records is
/// small.
void write_chrome_trace(std::ostream& out, const Scenario& s,
                        const std::vector<TraceProcess>& processes,
                        const std::vector<std::pair<std::string, std::string>>& metadata = {});

/// The same as a string (tests, small runs).
std::string chrome_trace_json(
    const Scenario& s, const std::vector<TraceProcess>& processes,
    const std::vector<std::pair<std::string, std::string>>& metadata = {});

}  // namespace red
