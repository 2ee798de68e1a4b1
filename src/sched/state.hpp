#pragma once
/// \file
/// Internal to src/sched: the records the scheduler keeps (jobs and their units, ready tasks and
/// their keys, the ready set's groups, operations, sensors and lanes), read by every mechanism
/// through Scheduler::Impl (scheduler_impl.hpp).

#include <array>
#include <compare>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "red/sched/scheduler.hpp"

namespace red {
namespace sched_detail {

enum class UState : std::uint8_t { Blocked, Queued, Running, Done, Cancelled };

struct UnitRt {
  UState state = UState::Blocked;
  int pending = 0;
  int task = -1;
  int share = 1;  // members of the dispatch running it (its cost is shared among them)
  TimePoint start{0};
  // Made ready before its one predecessor ended, for the lane that holds that predecessor
  // (dispatch_ahead: the lane runs its units in order); its completion then counts nothing.
  bool early = false;
};

// Why a job ended without completing its units (docs/DESIGN.md, "Drops"): JobRecord::reason
// is its text (reason_text), written at the output edge only.
enum class DropReason : std::uint8_t {
  None,
  MaxInflight,     // "max_inflight": the release was skipped (Skipped)
  DeadlinePassed,  // "deadline passed" (Dropped, strict drops)
  Hopeless,        // "hopeless": aborted at dispatch (Dropped)
  Rejected,        // "rejected at release": admission or shed_lone (Dropped)
  RejectedByRate,  // "rejected at release": shedding by rate, not for lane time (Dropped)
  Failed,          // the executor's reason (Job::failure) (Failed)
};

inline constexpr std::size_t kEstimates = 4;  // EstimateKind values

inline std::size_t idx(EstimateKind k) {
  return static_cast<std::size_t>(k);
}

struct Job {
  // What ranking and the demand test read at every decision comes first (one cache line).
  JobId id = 0;
  bool live = false;   // slot in use (until its running units have returned)
  bool ended = false;  // outcome decided
  bool counted = true;
  bool samples_newest = false;
  // Re-assignment (docs/DESIGN.md, "Re-assignment") cache. The base (costs of units not started,
  // per height) changes only when a unit starts or ends (dirty); running units are adjusted at each
  // decision.
  bool dirty = true;
  bool started = false;  // a unit of it has started
  int op = -1;
  std::uint64_t seq = 0;
  const RefinedGraph* g = nullptr;
  TimePoint release{0};
  TimePoint deadline{0};
  // What its deadlines are planned to: its deadline, or earlier by deadline inheritance
  // (PolicyOptions::inherit, Inheritance in inherit.hpp). Its outcome is decided by `deadline`.
  TimePoint plan{0};
  std::uint64_t stamp = 0;     // decision stamp the values below are valid for
  Duration remaining_base{0};  // Σ lvl_base
  Duration remaining{0};       // Σ remaining level costs (critical-path estimate)
  std::vector<int> running_units;
  std::vector<double> frac;  // budget shares per height, valid while no unit runs
  std::vector<double> frac_now;
  std::vector<Duration> lvl_base;
  std::vector<std::uint8_t> has_base;
  std::vector<Duration> lvl;  // level costs with the running units' remaining costs
  // docs/DESIGN.md, "Overload" demand: work of units not started, by estimate kind, encoders aside
  // (a queued encoder's cost is shared by the members of its task, read when asked); and the level
  // costs under the drop estimate, for hopeless checks.
  std::array<Duration, kEstimates> work_base{};
  // At most work_left at any time while not dirty (every unit not done at its full cost, a
  // running one's shared among its dispatch); work_base is at least it.
  std::array<Duration, kEstimates> work_most{};
  std::vector<int> enc_queued;
  std::array<Duration, kEstimates> cp_base{};  // longest tail among units not started
  Duration cp_least{0};                        // longest least_tail among units not started
  std::vector<UnitRt> u;
  int unfinished = 0;
  int running = 0;
  std::vector<std::uint64_t> frame;   // by sensor index: the frame its units read
  std::vector<TimePoint> frame_time;  // by sensor index
  TimePoint oldest_frame = kNever;    // oldest frame any of its outputs used
  std::vector<int> dependents;        // slots of jobs waiting for this one (depends_on)
  std::vector<JobId> dependent_ids;
  DropReason reason = DropReason::None;
  std::string failure;  // with DropReason::Failed: the executor's reason
  int grouped = 0;      // its ready tasks kept in a ReadyGroup (ready_set.cpp)
};

// The text of a job's drop reason, as JobRecord::reason carries it ("" for none).
inline std::string_view reason_text(const Job& j) {
  switch (j.reason) {
    case DropReason::None:
      return {};
    case DropReason::MaxInflight:
      return "max_inflight";
    case DropReason::DeadlinePassed:
      return "deadline passed";
    case DropReason::Hopeless:
      return "hopeless";
    case DropReason::Rejected:
    case DropReason::RejectedByRate:
      return "rejected at release";
    case DropReason::Failed:
      return j.failure;
  }
  return {};
}

struct Key {
  std::int64_t rank;
  TimePoint release;
  int op;
  std::uint64_t seq;
  // Scenario node order (ties, docs/DESIGN.md, "Dispatch"); a unit of no node (mono) sorts first.
  int node;
  int unit;
  bool operator<(const Key& o) const noexcept {
    if (rank != o.rank) return rank < o.rank;
    if (release != o.release) return release < o.release;
    if (op != o.op) return op < o.op;
    if (seq != o.seq) return seq < o.seq;
    if (node != o.node) return node < o.node;
    return unit < o.unit;
  }
};

struct Task {
  bool live = false;
  UnitKind kind = UnitKind::Plain;
  int head = -1;
  int sensor = -1;
  bool gamma = false;  // members sample the newest frame: γ-mergeable, newest frame at start
  std::uint64_t frame = 0;
  TimePoint frame_time{0};
  std::vector<std::pair<int, int>> members;  // (job slot, unit)
  // Per member, beside `members`: its unit's (height, node), read by ranking at every
  // decision without a look into the job's graph.
  std::vector<std::pair<int, int>> member_at;
  TimePoint min_release{0};
  TimePoint wait_until{0};
  bool in_waits = false;  // listed in DynamicMerge's waits (it began a wait: merge.hpp)
  int ready_pos = -1;     // in ReadySet::listed(); -1: not there (in a group, or not ready)
  int group = -1;         // its ReadyGroup (ready_set.cpp), -1: none
  Duration cost{0};
  // Ready only for this lane (-1: any): its member waits on a unit that lane holds, and runs
  // after it there in the lane's order (UnitRt::early).
  int lane_only = -1;
};

// Over a task's members, kept as they join and leave (their jobs' fields do not change):
// the least tie-break key (rank 0) and the earliest end-to-end deadline (less the path after
// the unit, with path_rank: Ranking::rank_deadline), what ranking by
// job deadline reads without a look into the jobs. Beside the tasks (TaskPool::rank), so
// that a task stays as small as the ranking of the other presets reads it.
struct TaskRank {
  Key tie{};
  TimePoint job_deadline{0};
};

// The ready set's groups (ready_set.cpp). Ready tasks that rank alike at every `now` — one
// unit each that neither merges nor batches, of jobs with no unit running and nothing
// changed since their caches were built, with the same view (TaskView: deadline, release,
// remaining work, cost, criticality, job deadline) at every `now` — differ only in their
// tie-break keys, so a scan needs only the least of each group.
struct GroupKey {
  TimePoint deadline;  // the job's (with re-assignment) or the height's (static modes)
  double share;        // the height's budget share under re-assignment; 0 otherwise
  TimePoint release;
  Duration cost;
  Duration remaining;      // the job's remaining work
  TimePoint job_deadline;  // the job's end-to-end deadline
  TimePoint by_job;        // what ranking by job deadline reads (Ranking::rank_deadline)
  int criticality;
  auto operator<=>(const GroupKey&) const = default;
};

struct ReadyGroup {
  GroupKey key{};
  std::set<std::pair<Key, int>> tasks;  // (tie-break key, task), the least first
  int live_pos = -1;                    // in ReadySet's live groups
};

struct OpState {
  const RefinedGraph* g = nullptr;  // current version; null while not in the workload
  bool own_rate = false;
  bool all_at_once = false;    // release: {count} without trigger or rate
  bool awaits_frames = false;  // all_at_once release held until its sensors have frames
  double rate_hz = 0.0;
  int trigger = -1;
  TimePoint next_tick = kNever;
  std::uint64_t released = 0;
  std::int64_t remaining = -1;  // -1: unlimited
  int inflight = 0;
  int max_inflight = 2;
  int depends_on = -1;
  int criticality = 0;
  int last_slot = -1;
  JobId last_job = 0;
  std::vector<int> sensors_read;  // sensors of its inference nodes
  // Its last release skipped at max_inflight (docs/DESIGN.md, "max_inflight"), kNever: none.
  TimePoint last_skip = kNever;
};

struct SensorState {
  double rate_hz = 0.0;
  bool has_frame = false;
  std::uint64_t frame = 0;
  TimePoint time{0};
};

// A lane holds up to queue_depth dispatches in the order they were given: the oldest runs,
// the others are queued behind it on the device (docs/DESIGN.md, "Queued lanes": what is enqueued
// counts as dispatched). A slot's Dispatch stays where it is until its unit completes, so the
// pointers dispatch() returns stay valid.
struct Lane {
  static constexpr int kMaxDepth = SchedulerConfig::kMaxQueueDepth;
  std::array<Dispatch, kMaxDepth> slots;
  int head = 0;   // the oldest dispatch's slot
  int count = 0;  // dispatches held (0: idle)
  [[nodiscard]] bool busy() const noexcept { return count > 0; }
  [[nodiscard]] Dispatch& at(int i) noexcept {
    return slots[static_cast<std::size_t>((head + i) % kMaxDepth)];
  }
  [[nodiscard]] const Dispatch& at(int i) const noexcept {
    return slots[static_cast<std::size_t>((head + i) % kMaxDepth)];
  }
  [[nodiscard]] Dispatch& oldest() noexcept { return at(0); }
  [[nodiscard]] Dispatch& newest() noexcept { return at(count - 1); }
  // The slot the next dispatch goes to (count < kMaxDepth).
  [[nodiscard]] Dispatch& next_slot() noexcept { return at(count); }
  void pop() noexcept {
    head = (head + 1) % kMaxDepth;
    --count;
  }
};

}  // namespace sched_detail

}  // namespace red
