#pragma once
/// \file
/// What the scheduler reports, as plain data: how jobs and unit executions end, a job's
/// record, a dispatch and its members. Observers (red/sched/observer.hpp) receive them;
/// executors (red/runtime/backend.hpp) run dispatches; nothing here calls anything.

#include <cstdint>
#include <string_view>
#include <vector>

#include "red/core/time.hpp"
#include "red/graph/refine.hpp"

namespace red {

using JobId = std::uint64_t;

/// How a job ended (docs/DESIGN.md, "Dispatch" and "Metrics").
enum class JobOutcome : std::uint8_t {
  Met,         ///< completed by its deadline
  Missed,      ///< completed after its deadline
  Dropped,     ///< aborted: deadline passed (strict) or hopeless
  Skipped,     ///< never started: max_inflight reached at release (counted as dropped)
  Failed,      ///< a unit failed (exception, out of memory); counted as dropped
  Unfinished,  ///< still in flight when the run ended
};

const char* to_string(JobOutcome o) noexcept;

/// How a unit execution ended (the handler's terminal states, docs/DESIGN.md, "Synchronization").
enum class UnitStatus : std::uint8_t {
  Completed,
  Failed,
  OutOfMemory,
  Cancelled,
  Unfinished,  ///< still running when the run ended (its row ends at the run's end)
};

const char* to_string(UnitStatus s) noexcept;

/// One job, as reported to observers.
struct JobRecord {
  JobId id = 0;
  int operation = -1;
  std::uint64_t seq = 0;  ///< release index within its operation
  TimePoint release{0};
  TimePoint deadline{0};  ///< absolute end-to-end deadline
  TimePoint finish{0};    ///< completion or abort time (Unfinished: end of run)
  JobOutcome outcome = JobOutcome::Unfinished;
  bool counted = true;    ///< released after the warm-up window
  Duration frame_age{0};  ///< finish − timestamp of the oldest frame its outputs used
  /// Why it ended without completing: the failure (Failed), "max_inflight" (Skipped),
  /// "deadline passed", "hopeless" or "rejected at release" (Dropped).
  std::string_view reason;
  const RefinedGraph* graph = nullptr;
};

/// One (job, unit) covered by a dispatch.
struct Member {
  JobId job = 0;
  int slot = -1;
  int unit = -1;  ///< index into the job's RefinedGraph::units
  int operation = -1;
  int node = -1;
  std::uint64_t job_seq = 0;
  std::uint64_t frame = 0;  ///< frame id the unit reads (Encoder/Head/Coarse)
  TimePoint frame_time{0};
  TimePoint release{0};
  const RefinedGraph* graph = nullptr;
};

/// A unit execution (possibly merged or batched) assigned to one lane.
struct Dispatch {
  std::uint64_t id = 0;
  int lane = 0;
  UnitKind kind = UnitKind::Plain;
  int head = -1;
  int sensor = -1;
  int batch = 1;  ///< number of tasks run as one batch (distinct frames or jobs)
  /// Members, task by task; task_begin[i]..task_begin[i+1] are task i's members.
  std::vector<Member> members;
  std::vector<int> task_begin;
  TimePoint deadline{0};  ///< min deadline of the members (merged/batch deadline)
  TimePoint decided_at{0};
  bool round_trip = true;  ///< needed a round trip to the global synchronizer
  TimePoint start{0};      ///< set by the executor (after the round trip)
  /// What the scheduler expected the run to cost when it decided it: the plan's estimate
  /// (SchedulerConfig::estimate) of a batch of `batch`, at the costs it plans with then.
  Duration expected{0};
};

}  // namespace red
