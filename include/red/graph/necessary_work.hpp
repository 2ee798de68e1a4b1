#pragma once
/// \file
/// The necessary work of a workload: the least lane time per second that meeting every deadline
/// takes when the work runs as RED runs it (docs/DESIGN.md, "Overload"; docs/ANALYSIS.md,
/// "Necessary work"). One model, used by everything in RED that reasons about how much work there
/// is: `red-robust`'s admission and overload state, `red analyze`'s verdicts, the sweep's physical
/// limit.
///
/// What it counts:
/// * **Encoder runs per frame, not per job.** A sensor frame is encoded once for every operation
///   it triggers; operations sampling the newest frame at their own rate need at most one run per
///   frame and at least one per release of the fastest of them, or per its releases within γ of
///   each other (DynamicMerge lets them share one), never more than the camera's frames.
/// * **Batches.** Runs of one unit (the encoder, or one head) gather into a batch of b, which costs
///   C(b) of the profile at that batch size. A batch helps on-time jobs only if its first member
///   can still finish it and everything after it by its deadline, so each operation contributes at
///   most ⌊(D − P(u) − C(b)) · rate⌋ + 1 members (P(u) the least time before and after the unit on
///   its job's path) and never more than its `max_inflight`. The cost of one run is then the least,
///   over batch sizes b up to `max_batch` and the profile's largest measured size, of C(b) divided
///   by the runs such a batch can hold on time. A profile whose batch of 2 costs what one run costs
///   halves the work where two runs can gather.
/// * **Plain nodes** at their own cost, every job.
///
/// Each figure is a lower bound of what any schedule spends on the jobs it makes on time, at the
/// profile's mean costs; the synchronization round trips are left out (they can overlap work).

#include <array>
#include <cstddef>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// The workload in effect: each operation's snapshot and release rate, each sensor's rate.
struct WorkInput {
  struct Stream {
    const OperationSpec* op = nullptr;  ///< null: not in the workload
    double rate_hz = 0;                 ///< releases per second
  };
  std::vector<Stream> ops;        ///< by operation index
  std::vector<double> sensor_hz;  ///< by sensor index
};

/// What one unit (the encoder, or one head) costs per run in a workload.
struct UnitWork {
  double runs_hz = 0;  ///< runs needed per second (frames to encode, or head runs)
  int batch = 1;       ///< the batch size whose cost per on-time run is least (at the mean)
  int serves = 1;      ///< the runs such a batch can hold on time (≤ batch)
  /// Lane time per run by EstimateKind: C(batch) / serves, at most C(1).
  std::array<Duration, 4> per_run{};
};

/// The necessary work of one workload state.
struct WorkEstimate {
  std::vector<UnitWork> units;  ///< by slot: WorkModel::kEncoder, WorkModel::head_slot(h)
  std::vector<double> op_load;  ///< by operation: its share of the lanes' time
  /// By operation: the encoder runs one of its jobs accounts for, its cameras' runs shared among
  /// the operations reading them by rate (an operation sampling a camera that triggers another
  /// one adds no run of its own).
  std::vector<double> encoder_runs_per_job;
  double load = 0;  ///< the device's: Σ runs × lane time per run over the lanes
};

/// The model: a profile, the model's heads, and the scheduler's batching limits.
class WorkModel {
 public:
  static constexpr std::size_t kEncoder = 0;
  [[nodiscard]] static std::size_t head_slot(int h) noexcept {
    return 1 + static_cast<std::size_t>(h);
  }

  /// `p` and `m` must outlive the model. `resolve` resolves deadlines given as a multiple of the
  /// critical path; `max_batch` is the scheduler's (1: no batching); `gamma` DynamicMerge's window
  /// (an operation sampling the newest frame shares one run among its releases within it);
  /// `slowdown` multiplies every cost (interference, as the simulator charges it).
  WorkModel(const Profile& p, const ModelSpec& m, EstimateKind resolve, int max_batch, int lanes,
            Duration gamma = Duration{0}, double slowdown = 1.0);

  /// The necessary work of the workload `in`.
  [[nodiscard]] WorkEstimate estimate(const WorkInput& in) const { return estimate(in, false); }

  /// The least load any batching could reach: every run at the least of C(b) / b over batch
  /// sizes, deadlines aside. At most estimate(in).load, and linear in the rates.
  [[nodiscard]] double floor_load(const WorkInput& in) const;

  /// The most runs of one operation a batch of one unit can hold with every one on time (the
  /// rule the model and the work bound share): its releases every `period_ms` within `slack_ms` of
  /// the first, `slack_ms` being its deadline less the time its job needs through the unit with
  /// the batch in it; at most `cap` (its max_inflight); 0 when `slack_ms` < 0.
  [[nodiscard]] static int on_time_runs(double slack_ms, double period_ms, int cap) noexcept;

  /// Whether a load over a span of `span_s` seconds is more than the lanes can do for the jobs
  /// released in it: those jobs may still run until the latest deadline `deadline_s` after it.
  [[nodiscard]] static bool overloaded(double load, double span_s, double deadline_s) noexcept;

 private:
  [[nodiscard]] WorkEstimate estimate(const WorkInput& in, bool unbounded) const;
  // The steps of estimate (necessary_work.cpp): each operation's runs offered to the units'
  // batches, the frames to encode, the batch size of each unit, each operation's share.
  struct Demand;
  void offer_operation(const WorkInput& in, std::size_t i, Demand& d, WorkEstimate& w) const;
  void offer_frames(const WorkInput& in, Demand& d, WorkEstimate& w) const;
  void choose_batches(const Demand& d, bool unbounded, WorkEstimate& w) const;
  void share_loads(const WorkInput& in, Demand& d, WorkEstimate& w) const;
  [[nodiscard]] Duration cost(std::size_t slot, int batch, EstimateKind k) const;
  [[nodiscard]] Duration least(std::size_t slot) const;  // the least mean over batch sizes
  [[nodiscard]] int top_batch(std::size_t slot) const;

  const Profile* profile_;
  const ModelSpec* model_;
  EstimateKind resolve_;
  int max_batch_;
  int lanes_;
  double gamma_s_;
  double slowdown_;
  std::vector<const UnitProfile*> units_;  // by slot, null where the profile has none
};

}  // namespace red
