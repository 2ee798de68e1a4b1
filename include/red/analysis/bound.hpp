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
/// share that fits the lanes' time when the cheapest are admitted first (necessary work on
/// mean costs: plain costs, heads, and one encoder run per camera frame, shared among the
/// jobs that frame triggers), jobs whose coarse critical path exceeds their deadline
/// excluded. In [0, 1]; 1 when nothing is released. Throws std::runtime_error only if the
/// simulation of the releases fails (it cannot for a validated scenario and covering profile).
double work_bound(const Scenario& s, const Profile& p);

}  // namespace red
