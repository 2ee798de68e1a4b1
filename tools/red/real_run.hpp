#pragma once
/// \file
/// Real runs (`red run`, `red compare --backend torch`): the runtime on a real backend.

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "red/calibrate/calibrate.hpp"
#include "red/core/expected.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/backend.hpp"
#include "red/runtime/runtime.hpp"
#include "red/scenario/scenario.hpp"

namespace red::cli {

/// The hand-offs a real run timed (RuntimeReport): completion -> next start on a lane, and
/// on an asynchronous lane the gap before a unit already queued.
struct Handoffs {
  std::vector<double> handoff_us;
  std::vector<double> queued_gap_us;
};

/// Options of a real run.
struct RealRunOptions;

/// Why a real run's profile may not hold this machine's costs (the built-in one, another
/// machine's, another device's), with the command that measures them; nullopt when it was
/// measured here, or on the synthetic backend (it runs the profile). Said before the run.
std::optional<std::string> profile_origin_note(const Scenario& s, const Profile& p,
                                               const RealRunOptions& o);

/// Units whose in-run mean differed from the profile's by more than 30 % (10 runs at least),
/// by how much, and the command that calibrates; nullopt when none. Said after the run.
std::optional<std::string> costs_differed(const PolicyMetrics& m, const std::string& label);

struct RealRunOptions {
  std::string backend = "torch";  ///< torch or synthetic
  std::string device = "cpu";     ///< LibTorch device (cpu, cuda, cuda:N)
  int threads = 0;                ///< LibTorch intra-op threads (0: default)
  /// Asynchronous lanes on the CPU (enqueue, then wait: the stand-in of a GPU lane); a GPU
  /// always runs them so.
  bool asynchronous = false;
  /// LibTorch's CUDA sync debug mode on warn (`--debug-sync`).
  bool debug_sync = false;
  bool realtime = true;
  std::uint64_t seed = 1;
  std::optional<SyncMode> sync;                     ///< overrides the policy's synchronization mode
  double watchdog_x = RuntimeOptions{}.watchdog_x;  ///< unit limit in × its p99 (0: off)
  bool keep_units = true;  ///< make one row per unit execution (units.csv, plots)
  /// Keep the job and unit rows in memory (PolicyRun::jobs, units); false: only the
  /// summary's bounded state (and whatever `rows` keeps).
  bool keep_rows = true;
  RowSink* rows = nullptr;  ///< gets every row as it is made (a streamed jobs.csv, units.csv)
  /// How stderr names the run ("red (3 of 5)" in a compare); empty: the policy's name.
  std::string label;
};

/// Registers --device, --threads, --debug-sync and --async on a command that makes a backend (run,
/// compare, node), with one wording everywhere.
void add_device_options(CLI::App* cmd, RealRunOptions& o);

/// Whether the device `o` asks for is there for its backend in this build: cpu always;
/// cuda and cuda:N only for the torch backend, with a LibTorch that has CUDA and sees that
/// GPU. Checked before anything is measured; Error (exit 2) names the device otherwise.
/// Nothing falls back to the CPU.
std::optional<Error> check_device(const RealRunOptions& o);

/// The device a measured profile was taken on ("cpu", "cuda:0"), read from Profile::device;
/// empty for the built-in default.
std::string profile_device(const Profile& p);

/// The device `p` was measured on when it is another kind than `device` (a CPU profile
/// for a GPU run, or the reverse); nullopt when they match or `p` was not measured.
std::optional<std::string> measured_elsewhere(const Profile& p, const std::string& device);

/// The one place a real backend is made (run, compare, node, profile --calibrate): the
/// device checked first (check_device), the threads shared among the lanes, a warning on
/// stderr when `p` was measured on another kind of device. Error when unknown or when it
/// cannot load.
Expected<std::unique_ptr<Backend>> make_backend(const Scenario& s, const Profile& p,
                                                const RealRunOptions& o);

/// Runs one policy in real time; `extra` observers (trace, progress) see the run too.
Expected<PolicyRun> run_real(const Scenario& s, const Profile& p, const std::string& policy,
                             Backend& backend, const RealRunOptions& o,
                             const std::vector<Observer*>& extra = {},
                             RuntimeReport* report = nullptr);

/// What calibration needs of one real run of `policy` (docs/FIDELITY.md): its units
/// started after the warm-up, the hand-offs the runtime timed, and whether those were
/// round trips through the global synchronizer (the policy's sync mode is per-edge).
CalibrationRun calibration_run(const Scenario& s, const std::string& policy,
                               const std::vector<UnitRow>& units, std::vector<double> handoff_us,
                               std::optional<SyncMode> sync = std::nullopt);

/// rss.csv text: policy, t_s, rss_mb, ready, in_flight: the runtime's samples (once a
/// second) of each real run, in order.
std::string samples_csv(const std::vector<std::string>& policies,
                        const std::vector<RuntimeReport>& reports);

/// Prints what a real run measured besides the job metrics.
void print_runtime_report(const std::string& policy, const RuntimeReport& r);

/// One glibc malloc arena for the whole process (`mallopt(M_ARENA_MAX, 1)`), unless the
/// environment sets the arena count itself (MALLOC_ARENA_MAX, or GLIBC_TUNABLES naming
/// arena_max). Called first thing in main, before any thread allocates. With LibTorch,
/// the handler threads' and intra-op workers' allocations otherwise land in several
/// arenas whose partly used pages malloc_trim cannot give back: a `red compare` then kept
/// 20-40 % more after its later policies than after the first (docs/BENCHMARKS.md,
/// "Memory of a real run"); with one arena each policy's memory goes back to the same level.
void use_one_malloc_arena() noexcept;

}  // namespace red::cli
