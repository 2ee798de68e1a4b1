#pragma once
/// \file
/// Why each job missed (docs/REPORTS.md, "Why jobs missed"): for every job that did not meet
/// its deadline, a cause a person can act on, from the rows a run keeps (jobs.csv, units.csv)
/// and the scenario's criticalities. A job shed by a rule (admission, hopeless, max_inflight,
/// a failure) has that rule for cause. A job that ran late, or was dropped when its deadline
/// passed, is explained by the lane time between its release and its deadline:
///
/// * **own**: its own units ran (a unit it shares with other jobs counts as its own);
/// * **overrun**: of that, the part of a unit that ran past what the scheduler expected it to
///   cost when it decided it (Dispatch::expected);
/// * **held**: it had nothing running and a lane was idle: the scheduler held its work back
///   (a DynamicMerge wait, a batch forming, a synchronizer round trip, the criticality guard);
/// * **higher**, **equal**, **lower**: it had nothing running and a lane ran other operations'
///   jobs of higher, equal or lower criticality than its own (a unit shared by several jobs is
///   split among them);
/// * **same operation**: it had nothing running and a lane ran earlier jobs of its operation.
///
/// The primary cause is the share with the most lane time.
///
///     WhyIndex why(scenario, units);          // once per policy's run
///     for (JobRow& j : jobs) why.annotate(j); // JobRow::cause, JobRow::cause_ms

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The shares of a late job's window, in the order ties are broken.
enum class WhyShare : int { Own, Overrun, Held, Higher, Equal, SameOperation, Lower };
inline constexpr std::size_t kWhyShares = 7;

/// The cause of a share as jobs.csv's `cause` names it ("higher-criticality work ahead").
const char* why_label(WhyShare s) noexcept;
/// The short key of a share in jobs.csv's `cause_ms` ("higher").
const char* why_key(WhyShare s) noexcept;

/// The criticality of operation `op` at time `t`: its definition at `t` after the
/// scenario's events (an event may change it); 0 when it has no definition then.
int criticality_at(const Scenario& s, int op, TimePoint t);

/// One unit of a job, for the story of `red report --why`.
struct WhyUnit {
  const UnitRow* unit = nullptr;
  Duration overrun{0};  ///< end − start − expected, when positive and expected is known
};

/// Lane time of other jobs' work in a late job's window, by operation and criticality.
struct WhyOther {
  int operation = -1;
  int criticality = 0;
  Duration lane{0};
};

/// Why one job did not meet its deadline.
struct JobWhy {
  std::string cause;         ///< the primary cause; empty for a met job
  bool by_rule = false;      ///< shed by a rule (the reason), not explained by lane time
  TimePoint from{0}, to{0};  ///< the window looked at: release to deadline (or its end)
  int criticality = 0;       ///< the job's own, at its release
  std::array<Duration, kWhyShares> shares{};  ///< lane time by share (without by_rule)
  std::vector<WhyUnit> units;                 ///< its own units, by start
  std::vector<WhyOther> others;  ///< other work while it had nothing running, most first

  /// The breakdown as jobs.csv's `cause_ms` writes it: "own 12.300; held 4.000" (shares with
  /// lane time, in WhyShare order); empty when by_rule.
  [[nodiscard]] std::string breakdown() const;
};

/// The unit rows of one policy's run indexed by job and time, to explain its jobs. Holds
/// pointers into `units` and a reference to `s`: both must outlive it.
class WhyIndex {
 public:
  WhyIndex(const Scenario& s, const std::vector<UnitRow>& units);

  /// Why `j` (a row of the same run) did not meet its deadline; a default JobWhy (empty
  /// cause) when it met it.
  [[nodiscard]] JobWhy explain(const JobRow& j) const;
  /// Sets j.cause and j.cause_ms from explain(j).
  void annotate(JobRow& j) const;

 private:
  struct Member {
    int operation = -1;
    std::uint64_t seq = 0;
  };
  const Scenario& s_;
  std::vector<const UnitRow*> units_;                                         // by start
  std::vector<std::vector<Member>> members_;                                  // of units_[i]
  std::map<std::pair<int, std::uint64_t>, std::vector<std::size_t>> of_job_;  // into units_
  Duration longest_{0};  // the longest unit, to bound the search of a window
};

/// Sets the cause of every row of `jobs` (one policy's run) from its `units`.
void annotate_causes(const Scenario& s, std::vector<JobRow>& jobs,
                     const std::vector<UnitRow>& units);

/// Causes of a set of jobs: cause → number of jobs, most first (ties by name).
std::vector<std::pair<std::string, std::int64_t>> top_causes(
    const std::map<std::string, std::int64_t>& counts);

}  // namespace red
