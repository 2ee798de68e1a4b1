#pragma once
/// \file
/// A sound response-time upper bound where a published analysis applies (`red analyze`,
/// docs/ANALYSIS.md): one lane, a work-conserving non-preemptive policy over the coarse or
/// mono graph (fifo, edf, mono, lst), periodic releases with bounded jitter. Every job then
/// completes within the longest level-0 busy period of the lane, computed as the least
/// fixed point of L = Σ_i ⌈(L + J_i) / T_i⌉ · C_i with every cost at its max (the
/// synchronous busy period of J. P. Lehoczky, "Fixed priority scheduling of periodic task
/// sets with arbitrary deadlines", RTSS 1990, and of L. George, N. Rivierre, M. Spuri,
/// "Preemptive and non-preemptive real-time uniprocessor scheduling", INRIA RR-2966, 1996,
/// section 4: under any work-conserving policy a job released in a busy period finishes by its
/// end, and no busy period is longer than L). Where the setting differs (several lanes,
/// merge waits, batching, depends_on, one-shot releases), the result says why no analysis
/// applies instead of inventing one.

#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/policy.hpp"

namespace red {

/// The bound for one operation.
struct OperationBound {
  std::string name;
  Duration bound{0};     ///< no job of it completes later than this after its release
  Duration deadline{0};  ///< its tightest relative deadline over the run
  Duration job_cost{0};  ///< C_i: a job's lane time at max costs, round trips included
  Duration period{0};    ///< T_i: its shortest release period over the run
  Duration jitter{0};    ///< J_i: its release jitter
  [[nodiscard]] bool guaranteed() const noexcept { return bound <= deadline; }
};

/// The response-time bound of a scenario under one policy, or why none applies.
struct ResponseBound {
  bool applies = false;
  std::string why_not;  ///< when !applies: "no analysis applies: <why>"
  std::string method;   ///< the analysis followed, with its papers
  Duration busy_period{0};
  double utilization = 0;  ///< Σ C_i / T_i at max costs
  std::vector<OperationBound> operations;
};

/// Computes the bound of `s` under a policy with options `o` (policy_options()) and profile
/// `p`. Every operation that ever exists counts as present for the whole run, at its most
/// expensive snapshot and highest rate, so events are covered.
ResponseBound response_bound(const Scenario& s, const Profile& p, const PolicyOptions& o);

}  // namespace red
