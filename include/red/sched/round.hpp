#pragma once
/// \file
/// The order of one scheduling round, the same for every driver of a Scheduler: the
/// simulator, the runtime's global synchronizer and its handlers' local decisions, the
/// decision benchmark and examples/own_loop all open their rounds here.

#include <span>
#include <utility>

#include "red/core/time.hpp"
#include "red/sched/scheduler.hpp"

namespace red {

/// Opens a scheduling round at `now` (non-decreasing): first the workload events due by
/// `now` (docs/DESIGN.md, "Task model"), so that nothing after them in the round runs on a
/// workload version that has been replaced; then `inputs()`, in which the driver hands in
/// what it saw by `now` in the order it arrived — units that ended (on_complete) and frames
/// (on_frame); then the releases due by `now` and strict drops (advance). The decision
/// follows: dispatch(now) for the idle lanes, dispatch_ahead(now, lane) for a lane's queue.
template <typename Inputs>
void open_round(Scheduler& s, TimePoint now, Inputs&& inputs) {
  s.apply_events(now);
  std::forward<Inputs>(inputs)();
  s.advance(now);
}

/// A whole round for lanes that hold one unit at a time: open_round(), then the decision
/// for every idle lane. The executor starts each dispatch (Scheduler::on_start).
template <typename Inputs>
std::span<Dispatch* const> run_round(Scheduler& s, TimePoint now, Inputs&& inputs) {
  open_round(s, now, std::forward<Inputs>(inputs));
  return s.dispatch(now);
}

}  // namespace red
