#pragma once
/// \file
/// The work bound on the on-time fraction (docs/DESIGN.md, "Overload"): of the jobs a scenario
/// releases after its warm-up, the largest share that fits the lanes' time when the cheapest jobs
/// are admitted first. No policy can do better on average-cost work, so `red analyze` reports it
/// for the whole device and the overload grid (tests/support/load_grid.hpp) judges policies by it.

#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The work bound (docs/DESIGN.md, "Overload"): of the jobs released after warm-up in a run of `s`,
/// the largest share that fits the lanes' time when the cheapest are admitted first, jobs whose
/// least critical path (least_critical_path) exceeds their deadline excluded. A job's cost is the
/// least lane time any policy can spend on it when it is on time, on mean costs: its plain costs;
/// per head, and per sensor it reads an encoder run, the least over batch sizes b of C(b) divided
/// by the most on-time jobs a batch of b can serve. A batch is at most `max_batch`; it serves at
/// most the jobs of each operation released within D − P_b(u) of each other (P_b(u) the
/// time a job needs through the unit with the unit at C(b): before and after it, the longer
/// of the longest path and the lane time over the lanes; none if that exceeds D), at most
/// max_inflight of them; an encoder run on a frame serves one job of each operation the
/// frame triggers, and of an operation sampling the newest frame its releases within γ or
/// while the frame stays the newest (docs/DESIGN.md, "DynamicMerge"); a batch of frames of several
/// sensors is split among them as serves the most jobs. Where a sensor's frames are read
/// only by the operations they trigger, serving m jobs of a frame also costs at least a run
/// (the least share of a batch of frames that may all serve on-time jobs) and the m
/// cheapest jobs' own costs, and the jobs of the cheapest group are charged the run evenly;
/// where every sensor read is read so, also with a larger run (up to C(1)) where the older
/// frames of a batch serve fewer operations on time, if no batch of b frames is then
/// charged more than C(b) above its jobs' own costs (the bound is the least of these ways of
/// splitting). The lane time is counted up to each
/// job deadline t (the jobs due by t fit lanes × (t − warm-up), those due later count as on
/// time), and at the run's end (releases stop then: the jobs that finish later were in flight,
/// at most max_inflight per operation); the least of these counts. In [0, 1]; 1 when nothing is
/// released. Throws std::runtime_error only if the simulation of the releases fails (it
/// cannot for a validated scenario and covering profile).
double work_bound(const Scenario& s, const Profile& p);

}  // namespace red
