#pragma once
/// \file
/// Internal to src/sched: the criticality guard (docs/DESIGN.md, "Criticality";
/// PolicyOptions::guard), one mechanism in one place: its state, its constants (guard.cpp) and
/// its rule. The scheduler calls it at named points of a pick: `check` on the task chosen
/// (dispatch.cpp's guard_holds) and on a batch being formed, `join` for each task that would
/// join a batch (Batching::form).

#include <limits>
#include <span>
#include <vector>

#include "red/sched/scheduler.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class CriticalityGuard {
 public:
  /// Whether running the dispatch of the tasks `run` on lane `lane` from `begin` (at mean
  /// costs) would make a more critical job miss that could make it otherwise. `until`: when
  /// the reason is a predicted release, the time to look again (the task waits until then);
  /// kNever when it is a job in flight (the task only yields this pick).
  struct Verdict {
    bool blocks = false;
    TimePoint until = kNever;
  };
  Verdict check(Scheduler::Impl& m, std::span<const int> run, int lane, TimePoint now,
                TimePoint begin);
  /// Whether task `joining` may join the tasks `members` of the batch being formed, its run
  /// then costing `with` instead of `without` from `begin`: a member more critical than it that
  /// makes its deadline without the join must still make it, by the plan's estimate with the
  /// guard's margin, after the larger batch.
  static bool join(Scheduler::Impl& m, std::span<const int> members, int joining, TimePoint begin,
                   Duration with, Duration without);

 private:
  // check()'s parts: the dispatch judged, its run's cost, one judgement on an estimate kind
  // (the jobs in flight, then the releases to come), whether a hold is affordable.
  struct Run {
    std::span<const int> run;
    TimePoint now, begin;
    int crit;         // the dispatch's criticality: its most critical member's
    Duration rt;      // a round trip
    TimePoint other;  // when another lane frees first
  };
  bool waits_on_run(Scheduler::Impl& m, int op);
  static Duration run_cost(Scheduler::Impl& m, std::span<const int> run, EstimateKind kind);
  void judge(Scheduler::Impl& m, const Run& g, EstimateKind kind, bool must_afford, Verdict& v);
  bool affords(Scheduler::Impl& m, const Run& g, Duration own, TimePoint done, Duration w);
  void releases(Scheduler::Impl& m, const Run& g, std::size_t k, int margin, Duration own,
                bool must_afford, TimePoint end, TimePoint blocked_until, Verdict& v);

  std::vector<int> slots_;  // scratch of check(): the jobs of the dispatch
  std::vector<int> units_;  // beside slots_: each one's unit in the dispatch
};

}  // namespace sched_detail
}  // namespace red
