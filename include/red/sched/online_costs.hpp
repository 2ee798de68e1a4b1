#pragma once
/// \file
/// Online cost estimates (docs/DESIGN.md, "Online costs"): what the model's units cost *in
/// this run*, learned as they complete, and the profile the scheduler plans with from them.
///
/// A profile is measured once, on some machine, under some load; a run meets other costs (a
/// co-located process, thermal throttling, another machine altogether). For every completed
/// run of the encoder or a head the scheduler records its time over the profile's median at
/// that batch size. Every `interval`, for a unit whose recent runs (the last `window`) fall
/// above (or below) the planned median more often than chance allows (a sign test), it takes
/// per batch size the median of those ratios (the unit's, over all batch sizes, where a size
/// has too few) — the statistic `red profile --calibrate` fits, robust to a stray slow run —
/// and where that has moved more than `threshold` from the factor applied, it applies it: the plan
/// profile is the given one with every figure of that (unit, batch) scaled by its factor. A
/// profile that is right for the run never moves (the dead band), so plans on it are the
/// plans made on the profile alone.
///
/// Deterministic in its inputs: the simulator drives it as the runtime does.

#include <cstdint>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/records.hpp"

namespace red {

/// How the estimates follow the run.
struct OnlineCostOptions {
  /// Plans follow the estimates. false: plans rest on the profile all run long, and the
  /// run's costs are only measured (figures()).
  bool follow = true;
  /// Ratios newer than this count (at least `min_samples` of the newest, whatever their age).
  Duration window{std::chrono::seconds{1}};
  int min_samples = 10;  ///< a unit with fewer does not move; a batch size with fewer
                         ///< takes its unit's factor
  /// The evidence a move needs: |z| of the sign test (runs above the planned median against
  /// half of them) at least this.
  double evidence = 3.0;
  double threshold = 0.1;  ///< and the relative move of the estimate at least this
  Duration interval{std::chrono::milliseconds{100}};  ///< the plan changes at most this often
};

/// One unit at one batch size: the profile's figures against the run's (summary.json's
/// `costs`).
struct UnitCostFigures {
  std::string unit;  ///< "encoder", "head/<name>"
  int batch = 1;
  int runs = 0;              ///< completed runs of it in this run (compound units excluded)
  Duration profile_mean{0};  ///< the profile's mean at this batch size
  Duration profile_p50{0};   ///< and its median
  Duration run_mean{0};      ///< the runs' mean
  Duration run_p50{0};       ///< and their median (of the last runs kept)
  double factor = 1.0;       ///< the factor applied at the end (1: the profile's)
  [[nodiscard]] double ratio() const noexcept {  ///< run mean / profile mean (0: no runs)
    return runs > 0 && profile_mean > Duration{0}
               ? static_cast<double>(run_mean.count()) / static_cast<double>(profile_mean.count())
               : 0.0;
  }
};

class OnlineCosts {
 public:
  /// `base` and `model` must outlive it.
  OnlineCosts(const Profile& base, const ModelSpec& model, OnlineCostOptions opt = {});

  /// A dispatch completed at `now` after running `took`. Encoder and head runs count at their
  /// batch size; a coarse or mono unit (several parts) counts its ratio for each of its model
  /// parts at batch 1 (a coarse one in the figures as `coarse/<head>` too); plain-only units
  /// are not the model's and do not count.
  void observe(const Dispatch& d, Duration took, TimePoint now);
  /// Takes the estimates at `now` (at most once per interval): true when the plan changed.
  bool update(TimePoint now);
  /// The profile to plan with: the given one until an estimate moves.
  [[nodiscard]] const Profile& plan() const noexcept { return changed_ ? plan_ : base_; }
  /// How many times the plan changed.
  [[nodiscard]] int changes() const noexcept { return changes_; }
  /// Every (unit, batch size) that ran, or that the plan scales, in profile order.
  [[nodiscard]] std::vector<UnitCostFigures> figures() const;
  [[nodiscard]] const OnlineCostOptions& options() const noexcept { return opt_; }

 private:
  struct Sample {
    TimePoint at{0};
    float ratio = 1.0F;
    std::uint8_t batch = 1;
  };
  struct Unit {
    std::string name;
    const UnitProfile* prof = nullptr;  // in base_; null: the profile lacks it
    std::vector<Sample> ring;           // the newest kRing ratios
    std::size_t next = 0;
    std::vector<int> runs;                 // per batch size (index b - 1)
    std::vector<Duration> total;           // per batch size: the runs' time
    std::vector<std::vector<float>> kept;  // per batch size: the last kKeep times (ms), a ring
    std::vector<double> applied;           // per batch size: the factor in plan_
    std::vector<double> next_applied;      // update()'s scratch
  };
  static constexpr std::size_t kRing = 64;
  static constexpr std::size_t kKeep = 256;

  void record(int unit, int batch, double ratio, Duration took, bool timed, TimePoint now);
  [[nodiscard]] Duration median_at(int unit, int batch) const;

  const Profile& base_;
  const ModelSpec& model_;
  OnlineCostOptions opt_;
  // 0: the encoder, 1 + h: head h (planned_ of them, what plans read), then coarse/<h>
  // (figures only).
  std::vector<Unit> units_;
  std::size_t planned_ = 0;
  Profile plan_;
  bool changed_ = false;
  bool fresh_ = false;  // samples since the last update
  TimePoint last_update_ = kNever;
  int changes_ = 0;
  std::vector<float> scratch_;
};

}  // namespace red
