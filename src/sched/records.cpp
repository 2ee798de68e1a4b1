// The names of the record enums (red/sched/records.hpp), as reports and traces write them.

#include "red/sched/records.hpp"

namespace red {

const char* to_string(JobOutcome o) noexcept {
  switch (o) {
    case JobOutcome::Met:
      return "met";
    case JobOutcome::Missed:
      return "missed";
    case JobOutcome::Dropped:
      return "dropped";
    case JobOutcome::Skipped:
      return "skipped";
    case JobOutcome::Failed:
      return "failed";
    case JobOutcome::Unfinished:
      return "unfinished";
  }
  return "?";
}

const char* to_string(UnitStatus s) noexcept {
  switch (s) {
    case UnitStatus::Completed:
      return "completed";
    case UnitStatus::Failed:
      return "failed";
    case UnitStatus::OutOfMemory:
      return "out-of-memory";
    case UnitStatus::Cancelled:
      return "cancelled";
    case UnitStatus::Unfinished:
      return "unfinished";
  }
  return "?";
}

}  // namespace red
