#pragma once
/// \file
/// The work bound on the on-time fraction (§15): of the jobs a scenario releases after its
/// warm-up, the largest share that fits the lanes' time when the cheapest jobs are admitted
/// first. No policy can do better on average-cost work, so `red analyze` reports it for the
/// whole device and the overload grid (tests/support/load_grid.hpp) judges policies by it.

#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The work bound (§15): of the jobs released after warm-up in a run of `s`, the largest
/// share that fits the lanes' time when the cheapest are admitted first, jobs whose coarse
/// critical path exceeds their deadline excluded. A job's cost is the least lane time any
/// policy can spend on it, on mean costs: its plain costs; its heads at their cheapest
/// batch; and per sensor it reads, an encoder run at its cheapest batch divided among as
/// many jobs as one run may serve (DynamicMerge, §3: one job per operation triggered by
/// the frame; of an operation sampling the newest frame, its releases within γ or while
/// the frame stays the newest, at most max_inflight). A batch is at most `max_batch`, and
/// holds at most the jobs of each operation released within D − P(u) of each other (P(u)
/// the longest path through the unit), at most max_inflight of them. In [0, 1]; 1 when nothing
/// is released. Throws std::runtime_error only if the simulation of the releases fails (it
/// cannot for a validated scenario and covering profile).
double work_bound(const Scenario& s, const Profile& p);

}  // namespace red
