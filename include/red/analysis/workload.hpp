#pragma once
/// \file
/// Static figures of a workload for `red analyze` (docs/ANALYSIS.md): unit costs at one point
/// of their distributions, the workload in effect in each phase that events create, critical
/// paths and work per job on the coarse, fine and merged graphs (docs/DESIGN.md, "Refinement"),
/// release rates, and the worst-case variant of a scenario and profile (every cost at its max) that
/// the verdicts and the headroom search simulate.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/graph/necessary_work.hpp"
#include "red/graph/refine.hpp"
#include "red/metrics/phases.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The point of a unit's latency distribution a figure is computed on.
enum class CostPoint : std::uint8_t {
  Min,       ///< best case: the fastest a unit ever ran
  Mean,      ///< typical
  Estimate,  ///< the scheduler's estimate (the scenario's `estimate`, default p99)
  Max,       ///< worst case measured
};

/// Costs of a scenario's units at one CostPoint, interference slowdown (1 + intensity)
/// included, as the simulator charges them. Synchronization round trips are not included.
class UnitCosts {
 public:
  /// `s` and `p` must outlive the object; `p` must cover `s` (check_profile_covers).
  UnitCosts(const Scenario& s, const Profile& p, CostPoint point);

  /// One encoder run.
  [[nodiscard]] Duration encoder() const noexcept { return encoder_; }
  /// Head `h` of the model.
  [[nodiscard]] Duration head(int h) const noexcept { return heads_[static_cast<std::size_t>(h)]; }
  /// A plain node's cost (its distribution as the simulator assumes it: plain_stats).
  [[nodiscard]] Duration plain(const PlainCost& c) const;
  /// A node as one coarse unit: encoder + head, or its plain cost.
  [[nodiscard]] Duration coarse_node(const NodeSpec& n) const;
  /// A node's own part on the fine graph: its head, or its plain cost.
  [[nodiscard]] Duration fine_node(const NodeSpec& n) const;

 private:
  [[nodiscard]] Duration pick(const LatencyStats& l) const;

  CostPoint point_;
  EstimateKind estimate_;
  double slowdown_;
  Duration encoder_{0};
  std::vector<Duration> heads_;
};

/// The workload in effect during one phase of a run (a span of metrics/phases.hpp).
struct PhaseWorkload {
  PhaseSpan span;
  std::string label;  ///< phase_label(): "start", "whole run", "after add_nodes (event 0)"
  /// By operation index: its snapshot in this phase, or null when it is not in the workload.
  std::vector<std::shared_ptr<const OperationSpec>> ops;
  std::vector<double> sensor_rate;  ///< by sensor index, Hz
};

/// The phases of a run that ends at `end` (workload_phases()), each with the operation
/// snapshots and sensor rates that the events up to its start leave in effect.
std::vector<PhaseWorkload> phase_workloads(const Scenario& s, TimePoint end);

/// Longest path through one job of `op` on the graph `mode` builds (docs/DESIGN.md, "Refinement"):
/// coarse nodes cost encoder + head; on the fine graph every encoder is a source, so a node
/// finishes at max(encoder, its predecessors) + its head; mono is the whole job in one unit (one
/// encoder run per sensor, then every node).
Duration critical_path(const OperationSpec& op, GraphMode mode, const UnitCosts& c);

/// Work of one job on the coarse graph: an encoder run for every inference node.
Duration work_coarse(const OperationSpec& op, const UnitCosts& c);

/// Work of one job on the fine graph with the encoder runs of a job shared: one encoder run
/// per sensor it reads (also the work of a mono job).
Duration work_fine(const OperationSpec& op, const UnitCosts& c);

/// Release rate (Hz) of `op` in phase `ph`: its trigger sensor's rate, its own rate, or,
/// for a fixed number of releases, that number over the scenario's duration.
double release_rate(const OperationSpec& op, const PhaseWorkload& ph, const Scenario& s);

/// Encoder runs per job of every operation of phase `ph` (by index; 0 when absent or it
/// reads no sensor) with DynamicMerge across operations (docs/DESIGN.md, "DynamicMerge"):
/// operations triggered by the same camera share one run per frame; operations sampling the newest
/// frame of a camera at their own rates are estimated to share one run per release of the fastest
/// of them when γ covers half of the slowest one's period, else to run one each, never more runs
/// than the camera has frames. An estimate; the simulator counts the real runs.
std::vector<double> merged_encoder_runs(const Scenario& s, const PhaseWorkload& ph);

/// Work of one job with its encoder runs shared across operations: every node's own part on
/// the fine graph plus `encoder_runs` (merged_encoder_runs) encoder runs.
Duration work_merged(const OperationSpec& op, const UnitCosts& c, double encoder_runs);

/// The model of necessary work (red/graph/necessary_work.hpp) for scenario `s` on profile `p`: its
/// batching limit, lanes and interference slowdown. `s` and `p` must outlive it.
WorkModel work_model(const Scenario& s, const Profile& p);

/// The workload of phase `ph` as the model reads it, every rate that rate_scale scales (sensor
/// rates, own rates) times `scale`; operations with a fixed release count keep their rate.
WorkInput work_input(const Scenario& s, const PhaseWorkload& ph, double scale = 1.0);

/// The necessary work (red/graph/necessary_work.hpp) of each phase of the measured window (warm-up
/// to the end), and the physical limit of the breakdown rate.
struct NecessaryLoad {
  struct Phase {
    PhaseSpan span;         ///< clipped to the measured window
    double load = 0;        ///< the share of the lanes' time its jobs need at the scenario's rates
    double deadline_s = 0;  ///< the latest deadline of its operations: how long its jobs may run on
  };
  std::vector<Phase> phases;
  double mean = 0;  ///< the phases' loads weighted by their length
  /// The largest rate_scale at which no phase is overloaded (WorkModel::overloaded): above it no
  /// policy can meet every deadline. +inf when nothing scales with the rates, 0 when the work
  /// that does not scale alone overloads a phase.
  double limit = 0;
  /// The share at the scenario's own rates (mean over the measured window).
  [[nodiscard]] double total() const noexcept { return mean; }
  /// The physical limit of the breakdown rate.
  [[nodiscard]] double limit_scale() const noexcept { return limit; }
};
NecessaryLoad necessary_load(const Scenario& s, const Profile& p);

/// The profile whose every quantile of every unit and batch size is its max: worst-case
/// costs for the simulator.
Profile worst_case_profile(const Profile& p);

/// `s` for a worst-case run: every deadline given as a multiple of the critical path is
/// resolved on `p` (so the worst-case profile does not move it) and every plain node costs
/// its max (plain_stats) deterministically.
Scenario worst_case_scenario(const Scenario& s, const Profile& p);

}  // namespace red
