#pragma once
/// \file
/// Execution-time profiles (docs/DESIGN.md, "Profiles"): per unit and batch size, the measured
/// latency distribution. The simulator samples from it; the scheduler's deadline arithmetic uses
/// one statistic of it (EstimateKind). One JSON file with a schema version carries it.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/core/time.hpp"
#include "red/profile/quality.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// Latency distribution of one unit at one batch size.
struct LatencyStats {
  Duration min{0};
  Duration mean{0};
  Duration p50{0};
  Duration p95{0};
  Duration p99{0};
  Duration max{0};
  int samples = 0;  ///< timed runs behind the figures (0 for the built-in default)
  /// Untimed runs before them (`red profile` warms each unit and batch size until its time
  /// is stable; 0 when not recorded).
  int warmup_runs = 0;

  /// The statistic that stands for the cost.
  [[nodiscard]] Duration estimate(EstimateKind k) const noexcept;
  /// Every figure (min, mean, p50, p95, p99, max) × f; the counts as they are.
  [[nodiscard]] LatencyStats scaled(double f) const noexcept;
  /// Inverse CDF through the knots (0: min, .5: p50, .95: p95, .99: p99, 1: max), linear
  /// between knots; u in [0, 1). Deterministic for a given u.
  [[nodiscard]] Duration quantile(double u) const noexcept;
};

/// All batch sizes of one unit; by_batch[b - 1] is batch size b.
struct UnitProfile {
  std::vector<LatencyStats> by_batch;

  [[nodiscard]] int max_batch() const noexcept { return static_cast<int>(by_batch.size()); }
  /// Stats at batch b, clamped to the largest measured size.
  [[nodiscard]] const LatencyStats& at(int batch) const noexcept;
};

/// What a calibration pass (`red profile --calibrate`, docs/FIDELITY.md) measured inside a real
/// run, beyond the per-unit statistics it writes into Profile::units: the simulator's model of
/// how a real run departs from costs measured one unit at a time. A unit's time in the
/// simulator is residual(u) × lane_factor[busy other lanes] × factor(t) × interference ratio.
struct Calibration {
  std::string scenario;               ///< the scenario the real runs played
  std::vector<std::string> policies;  ///< the policies run, in order
  double seconds_per_policy = 0.0;
  double interference = 0.0;  ///< the scenario's background intensity during calibration
  /// Residual cost distributions (the time factor and the lane factor divided out), per unit
  /// name and batch size (index b - 1): quantiles at u = i / (n - 1).
  std::map<std::string, std::vector<std::vector<Duration>>> residual;
  /// Slow and fast stretches of the machine: the factor of each time block measured, in order.
  Duration block{std::chrono::milliseconds{500}};
  std::vector<double> factors;
  int run_blocks = 8;  ///< the simulator replays the factors in runs of this many blocks
  /// Cost factor by the number of other lanes busy when a unit starts (index 0 is 1).
  std::vector<double> lane_factors{1.0};
  Duration handoff{0};  ///< completion -> next start on a lane without a round trip (median)
  /// Completion -> start of the unit already queued behind it on an asynchronous lane
  /// (median; 0 when the calibration ran none: device.queue_depth 1 or a CPU backend)
  Duration queued_gap{0};

  /// The residual quantile table of (unit, batch), or nullptr.
  [[nodiscard]] const std::vector<Duration>* table(const std::string& unit,
                                                   int batch) const noexcept;
  /// The time factor at t for a seed (block bootstrap: deterministic in seed and t).
  [[nodiscard]] double factor_at(TimePoint t, std::uint64_t seed) const noexcept;
};

/// Inverse CDF of a quantile table (u = i / (n - 1)), linear between points; u in [0, 1).
Duration table_quantile(const std::vector<Duration>& table, double u) noexcept;

/// How `red profile` measured the units (docs/DESIGN.md, "Profiles"): the clock that timed them and
/// the warm-up before each (unit, batch size).
struct Measurement {
  std::string timing;  ///< "host wall clock" (CPU) or "device events" (GPU)
  int warmup_min = 0;  ///< untimed runs at least, per unit and batch size
  int warmup_max = 0;  ///< and at most (then measured even if not stable)
  /// Stable: the first timed runs are no slower than the rest by more than this fraction
  /// (else they count as warm-up and as many more are timed).
  double tolerance = 0;
  int window = 0;              ///< runs compared at a time
  double device_warmup_s = 0;  ///< the device kept busy before the first unit (GPU clocks)
  int unstable = 0;            ///< (unit, batch size) pairs that hit warmup_max unstable
};

/// Memory figures of a model (bytes).
struct MemoryStats {
  std::int64_t parameter_bytes = 0;
  std::int64_t peak_activation_bytes = 0;
  std::int64_t resident_bytes = 0;
};

/// A profile: unit names are `encoder`, `head/<name>` (a head of the shared model),
/// `coarse/<name>` (encoder + head run back to back) and `separate/<name>` (a full
/// separate network, docs/DESIGN.md, "Built-in model" separate mode).
struct Profile {
  static constexpr int kSchema = 1;

  std::string source;  ///< "builtin-default" or "measured"
  std::string device;  ///< e.g. "cpu (2 threads)"
  std::string model;   ///< e.g. "mimonet [3,192,384]"
  std::map<std::string, UnitProfile> units;
  Duration sync_round_trip{std::chrono::microseconds{50}};  ///< one synchronizer round trip
  std::optional<MemoryStats> shared_memory;                 ///< shared MIMONet
  std::optional<MemoryStats> separate_memory;               ///< four separate networks
  double profile_wall_s = 0.0;                              ///< how long `red profile` took
  std::optional<Calibration> calibration;  ///< in-run measurements (`red profile --calibrate`)
  std::optional<Measurement> measurement;  ///< how the units were timed and warmed
  /// The machine while measuring and findings on the figures (`red profile` writes it; an
  /// optional field: profiles without it still load).
  std::optional<Quality> quality;

  /// The unit named `name`, or nullptr.
  [[nodiscard]] const UnitProfile* find(const std::string& name) const noexcept;
};

/// The profile used when a scenario names none and no measurement exists: the one place
/// where the default unit costs live (see docs/SCENARIOS.md, "Default profile").
Profile default_profile();

/// Reads a profile JSON file; errors name the file and the problem.
Expected<Profile> load_profile(const std::string& path);

/// Parses profile JSON text; `file` labels messages.
Expected<Profile> parse_profile(const std::string& text, const std::string& file);

/// Serializes a profile as JSON (the same schema load_profile reads).
std::string profile_to_json(const Profile& p);

/// Checks that a profile covers what a scenario needs (encoder and every head it uses).
std::optional<Error> check_profile_covers(const Profile& p, const Scenario& s);

/// What Profile::model says a profile was measured on, as `red profile` writes it: the
/// model (`mimonet`, or a manifest's file name such as `model.yaml`), its input and whether
/// its heads ran as separate networks: "model.yaml [3,128,256]", "mimonet [3,192,384] separate".
struct ProfileLabel {
  std::string model;
  std::vector<std::int64_t> input;  ///< C, H, W
  bool separate = false;
};

/// Parses Profile::model; nullopt when it is not of that form (empty, or written by hand).
std::optional<ProfileLabel> parse_profile_label(const std::string& label);

/// The model a scenario runs, labelled as a profile of it would be: "mimonet [3,192,384]",
/// or the manifest's file name and the input ("model.yaml [3,128,256]").
std::string scenario_model_label(const Scenario& s);

/// Whether a profile is of the scenario's model (docs/MODELS.md, "What red validate checks").
struct ProfileIdentity {
  /// Of another model or input size: located at the scenario's `profile:` line, or at
  /// "--profile" when the profile came from the command line.
  std::optional<Error> error;
  std::string warning;  ///< could not be checked (a label that does not parse), or empty
  std::string checked;  ///< what was found, for `red validate`'s listing
};

/// Compares Profile::model with the scenario's model: the model's name and the input size
/// must be the scenario's. `cli_path`: the profile was given as --profile (else it is the
/// scenario's `profile:`, or the built-in default when the scenario names none). The
/// built-in default profile for a built-in model of another input size gives a warning, not
/// an error: it is the documented stand-in when nothing was measured. A scenario with no
/// model (plain nodes only) is not checked.
ProfileIdentity check_profile_identity(const Profile& p, const Scenario& s,
                                       const std::optional<std::string>& cli_path);

}  // namespace red
