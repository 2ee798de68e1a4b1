#pragma once
/// \file
/// Scheduling policies (docs/DESIGN.md, "Policies"). A policy is small: it names the combination of
/// mechanisms it uses (PolicyOptions) and ranks ready tasks; the Scheduler does the bookkeeping.
/// The same policy object drives the simulator and the real runtime, and never reads a clock.
///
///     auto p = make_policy("red");          // a preset
///     Scheduler s(scenario, profile, std::move(p), {});

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/graph/refine.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// How handlers synchronize with the global synchronizer (docs/DESIGN.md, "Synchronization").
enum class SyncMode : std::uint8_t {
  PerEdge,   ///< one round trip after every completed unit
  OnDemand,  ///< back-to-back runs; a round trip only when the run breaks
};

/// What happens to late jobs (docs/DESIGN.md, "Drops").
enum class DropMode : std::uint8_t {
  None,      ///< late jobs run to completion (soft real time)
  Strict,    ///< abort a job once its end-to-end deadline has passed
  Hopeless,  ///< also abort at dispatch when now + remaining critical path > deadline
};

/// What the policy ranks ready work by while the scheduler judges the lanes overloaded
/// (docs/DESIGN.md, "Overload").
enum class RankMode : std::uint8_t {
  Policy,       ///< always the policy's own deadlines (the paper's presets)
  JobDeadline,  ///< always the job's end-to-end deadline: finish what was started
  Overload,     ///< the policy's deadlines, the job's deadline while overloaded (red-robust)
};

/// Admission control at release (docs/DESIGN.md, "Overload").
enum class Admission : std::uint8_t {
  None,  ///< every release is admitted (max_inflight aside)
  Shed,  ///< when the work due by some deadline exceeds the lanes' capacity by then, reject
         ///< unstarted jobs (least critical, then most work first) until it fits
};

const char* to_string(SyncMode m) noexcept;
const char* to_string(DropMode m) noexcept;
const char* to_string(RankMode m) noexcept;
const char* to_string(Admission m) noexcept;

/// The mechanisms a policy combines; every column of the table in docs/DESIGN.md, "Policies", is
/// one field.
struct PolicyOptions {
  GraphMode graph = GraphMode::Fine;
  DeadlineMode deadlines = DeadlineMode::Proportional;
  /// Re-assignment at every scheduling point (docs/DESIGN.md, "Re-assignment").
  bool reassign = false;
  bool merge = false;     ///< DynamicMerge(γ) of encoder runs (docs/DESIGN.md, "DynamicMerge")
  bool batching = false;  ///< inter-DAG batching (docs/DESIGN.md, "Batching")
  SyncMode sync = SyncMode::PerEdge;
  DropMode drop = DropMode::Strict;
  /// The cost estimate hopeless aborts and admission judge by: an optimistic one (mean)
  /// keeps the jobs that can still make it (docs/DESIGN.md, "Overload").
  EstimateKind drop_estimate = EstimateKind::Mean;
  Admission admission = Admission::None;
  /// Admission's margin (docs/DESIGN.md, "Overload"), in percent of the estimates it plans with:
  /// admitting work up to exactly the lanes' capacity on mean costs lets every overrun cost a job.
  int admit_margin = 0;
  RankMode rank = RankMode::Policy;
  /// With admission=shed, past capacity (docs/DESIGN.md, "Overload"): reject at release the jobs of
  /// an operation that operations with cheaper jobs (at equal criticality) fill the lanes without,
  /// while one of those sheds jobs itself — the work bound's rule, cheapest jobs first.
  bool shed_by_rate = false;
  /// With admission=shed, once the offered load passes 1.1 × the lanes (docs/DESIGN.md,
  /// "Overload"): admission also counts the work of the jobs periodic operations will release with
  /// deadlines by each pending one, at their current rates, and rejects a pending job only when
  /// none of those jobs to come, no more critical than it, needs more work. On several lanes past
  /// capacity admission runs a list schedule, which does not place the jobs to come; there
  /// only the last part applies.
  bool lookahead = false;
  /// With admission=shed, past capacity (docs/DESIGN.md, "Overload"): reject at release a job that
  /// is alone on its trigger frame (no other job in flight reads that frame, though other
  /// operations read the sensor) and leaves its operation fewer than half its max_inflight slots:
  /// it would pay a whole encoder run for one job and hold a slot that a frame shared with the
  /// other operations could use.
  bool shed_lone = false;
  /// While ranked by job deadline (docs/DESIGN.md, "Overload"): a head batch is checked against
  /// each member's job deadline less the path after the head, not the task's intermediate deadline,
  /// which is past due under overload and let no batch form.
  bool batch_by_job = false;
  /// While ranked by job deadline (docs/DESIGN.md, "Overload"): a unit ranks by its job's deadline
  /// less the longest path after it on the scheduler's estimate (the latest it may end for the job
  /// to make it: EDF on deadlines modified for precedence), not by the job's deadline
  /// alone, which ran a job's off-path units ahead of another job's critical path on
  /// several lanes.
  bool path_rank = false;
  /// With rank=overload (docs/DESIGN.md, "Overload"): the mechanisms that act on signs of
  /// overload other than the demand test — ranking by job deadline because an operation is at
  /// its max_inflight, lookahead, shed_by_rate and shed_lone — act only within 1 s of a job that
  /// did not meet its deadline (missed, dropped or skipped at max_inflight). Admission by the
  /// demand test, hopeless aborts and the criticality order are not gated.
  bool miss_gate = false;
  /// Deadline inheritance across operations (docs/DESIGN.md, "Overload"): a job that a job of
  /// another operation waits on (`depends_on`, use: latest) is planned to end by that job's
  /// deadline less the longest path from its units that wait: its intermediate deadlines and its
  /// rank are taken from the earlier of the two. Its own deadline still decides its outcome.
  bool inherit = false;
  /// With operations of different criticalities (docs/DESIGN.md, "Criticality"): a unit of less
  /// critical work does not start where, by estimate, it would make a more critical job miss that
  /// could make it otherwise — a job in flight, or the next release of a more critical operation
  /// before the unit would end. It runs after (or another lane takes it); the lane may idle until
  /// that release. Nothing changes with equal criticalities.
  bool guard = false;

  bool operator==(const PolicyOptions&) const = default;
};

/// Sets one option from its CLI/scenario spelling (`graph=fine`, `drop=hopeless`, …).
/// Returns an error message naming the key and the allowed values, or empty on success.
std::string set_option(PolicyOptions& o, std::string_view key, std::string_view value);

/// Applies "key=value,key=value" (the CLI's --with); error message or empty.
std::string apply_options(PolicyOptions& o, std::string_view list);

/// Checks the policy options of a scenario's `scheduler:` section (SchedulerSpec::policy_options,
/// as the file writes them; SchedulerSpec::policy_with is their text), as the loader once did:
/// first a key that is neither one of the section's own (scheduler_keys()) nor an option, at its
/// line, naming every key the section takes; then, in option_keys() order, a value that is not
/// text or that set_option refuses, at the value's line. Every command that loads a scenario
/// file calls it right after loading (the CLI's scenario load). An Error{scenario file, line,
/// message}, or nullopt when every option is good.
std::optional<Error> check_policy_options(const Scenario& s);

/// The option keys set_option accepts, in documentation order.
const std::vector<std::string>& option_keys();

/// "graph=fine,deadlines=proportional,…": every option, in option_keys() order.
std::string describe(const PolicyOptions& o);

/// What a policy sees of a ready task when ranking it.
struct TaskView {
  TimePoint deadline{0};      ///< min intermediate deadline of its members (per options)
  TimePoint release{0};       ///< earliest release among member jobs
  TimePoint job_deadline{0};  ///< earliest end-to-end deadline among member jobs
  Duration remaining{0};      ///< largest remaining critical-path estimate of member jobs
  Duration cost{0};           ///< estimated cost of the task itself
  int criticality = 0;        ///< highest criticality among member operations
  /// The scheduler judges the lanes overloaded now (docs/DESIGN.md, "Overload").
  bool overloaded = false;
};

/// A scheduling policy. Implementations must be deterministic and allocation-free in rank().
class Policy {
 public:
  Policy() = default;
  Policy(const Policy&) = delete;
  Policy& operator=(const Policy&) = delete;
  virtual ~Policy() = default;

  /// Short name, e.g. "red".
  [[nodiscard]] virtual std::string_view name() const noexcept = 0;
  /// The mechanisms the scheduler applies for this policy.
  [[nodiscard]] virtual const PolicyOptions& options() const noexcept = 0;
  /// Rank of a ready task: the smallest runs first. Ties: earlier release, then operation
  /// order, then node order (the scheduler breaks them). A function of the view and `now`
  /// alone: the scheduler ranks tasks whose views are equal at every `now` by one call
  /// (SchedulerConfig::group_from).
  [[nodiscard]] virtual std::int64_t rank(const TaskView& t, TimePoint now) const noexcept = 0;
  /// A promise about rank(): true when it returns `t.deadline.count()` and reads nothing
  /// else of the view (earliest deadline first). The scheduler then ranks a task that is
  /// ranked by its jobs' end-to-end deadline (rank=job-deadline, or rank=overload while
  /// overloaded) from what it keeps beside the task, without looking into the jobs or
  /// calling rank(): the same order, much cheaper with many ready tasks. False (the default)
  /// always ranks through rank(). A policy that says true and ranks otherwise gets
  /// decisions its rank() did not make.
  [[nodiscard]] virtual bool ranks_by_deadline_only() const noexcept { return false; }
};

/// Earliest deadline first over whatever deadlines the options assign.
class EdfPolicy final : public Policy {
 public:
  EdfPolicy(std::string name, PolicyOptions o) : name_(std::move(name)), options_(o) {}
  [[nodiscard]] std::string_view name() const noexcept override { return name_; }
  [[nodiscard]] const PolicyOptions& options() const noexcept override { return options_; }
  [[nodiscard]] std::int64_t rank(const TaskView& t, TimePoint) const noexcept override {
    return t.deadline.count();
  }
  [[nodiscard]] bool ranks_by_deadline_only() const noexcept override { return true; }

 private:
  std::string name_;
  PolicyOptions options_;
};

/// Release order, like ROS 2's default executor.
class FifoPolicy final : public Policy {
 public:
  explicit FifoPolicy(PolicyOptions o) : options_(o) {}
  [[nodiscard]] std::string_view name() const noexcept override { return "fifo"; }
  [[nodiscard]] const PolicyOptions& options() const noexcept override { return options_; }
  [[nodiscard]] std::int64_t rank(const TaskView& t, TimePoint) const noexcept override {
    return t.release.count();
  }

 private:
  PolicyOptions options_;
};

/// Least slack first (as in Band): slack = job deadline − now − remaining critical path.
class LeastSlackPolicy final : public Policy {
 public:
  explicit LeastSlackPolicy(PolicyOptions o) : options_(o) {}
  [[nodiscard]] std::string_view name() const noexcept override { return "lst"; }
  [[nodiscard]] const PolicyOptions& options() const noexcept override { return options_; }
  [[nodiscard]] std::int64_t rank(const TaskView& t, TimePoint now) const noexcept override {
    return (t.job_deadline - now - t.remaining).count();
  }

 private:
  PolicyOptions options_;
};

/// The options of a preset (docs/DESIGN.md, "Policies" table), or nullopt for an unknown name.
std::optional<PolicyOptions> preset_options(std::string_view name);

/// A preset policy by name: fifo, mono, edf, red-fg, red-ida, red, red-robust, lst; nullptr
/// if unknown.
/// `overrides` (if given) replaces the preset's options (ablations).
std::unique_ptr<Policy> make_policy(std::string_view name,
                                    const std::optional<PolicyOptions>& overrides = std::nullopt);

/// The presets `red compare` runs by default, in table order.
const std::vector<std::string>& default_presets();

/// Every name make_policy accepts.
const std::vector<std::string>& known_policies();

/// The one message for a name make_policy does not accept: "unknown policy 'NAME' (known: fifo,
/// mono, ...)", every known name in table order. Each command that reads a policy's name says it.
std::string unknown_policy_message(std::string_view name);

}  // namespace red
