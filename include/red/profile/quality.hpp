#pragma once
/// \file
/// How far a profile's figures can be trusted (docs/CLI.md, "Profile quality"): the state of
/// the machine while `red profile` measured (online CPUs, threads, other processes' load) and
/// findings on the figures themselves (a large spread, a batch that costs less than a smaller
/// one, a machine busier than the threads asked for). Pure judging, no LibTorch: `red profile`
/// writes the result into the profile, `red validate` and `red analyze` warn when it is suspect.

#include <string>
#include <utility>
#include <vector>

namespace red {

struct Profile;

/// The machine while a profile was measured.
struct MachineState {
  int online_cpus = 0;      ///< CPUs online (sysconf _SC_NPROCESSORS_ONLN)
  int threads = 0;          ///< intra-op threads the measuring used
  double load1_before = 0;  ///< /proc/loadavg, 1-minute average, before measuring
  double load1_after = 0;   ///< and after
  /// CPUs' worth of other processes' CPU time while measuring: the CPU time all CPUs spent
  /// busy (/proc/stat) less this process's own (getrusage), over the wall time. A direct
  /// figure for the measuring window, where the 1-minute load lags by a minute. < 0: unknown.
  double other_busy_cpus = -1;
  double process_cpu_s = 0;  ///< this process's CPU time while measuring
  double wall_s = 0;         ///< wall time of the measuring
  /// The machine: "<hostname>, <CPU model>, <online CPUs> CPUs" (this_host()); empty in
  /// profiles written before it was recorded.
  std::string host;
};

/// This machine as MachineState::host names it.
std::string this_host();

/// One thing wrong with a profile's figures or the machine that measured them.
struct QualityFinding {
  std::string unit;  ///< the unit, or empty for the machine
  int batch = 0;     ///< the batch size, or 0 for the machine / the whole unit
  std::string kind;  ///< "spread", "non_monotone" or "oversubscribed"
  std::vector<std::pair<std::string, double>> figures;  ///< the numbers behind it, in order
  std::string message;                                  ///< what is wrong, in a sentence
  std::string advice;                                   ///< what to do
};

/// A profile's quality: the machine state (when recorded), the findings and a verdict.
struct Quality {
  bool has_machine = false;
  MachineState machine;
  std::vector<QualityFinding> findings;
  std::string verdict = "good";  ///< "good" (no finding) or "suspect"
};

/// Where the judging draws its lines (docs/CLI.md, "Profile quality", says why these).
struct QualityThresholds {
  /// Spread: max / p50 above this, and max − p50 at least `spread_floor_ms` (one preemption
  /// of a sub-millisecond unit makes a large ratio that says little).
  double spread_ratio = 5.0;
  double spread_floor_ms = 1.0;
  /// Non-monotone: the mean at batch b + 1 below the mean at b by more than this fraction.
  double batch_tolerance = 0.10;
  /// Oversubscribed: threads + other processes' busy CPUs above online CPUs plus this margin.
  double oversubscribe_margin = 0.5;
};

/// Judges a profile's figures, and the machine state when given: the findings, in order
/// (machine first, then units in name order, batch sizes ascending). A clean profile gives none.
std::vector<QualityFinding> judge_profile(const Profile& p, const MachineState* machine,
                                          const QualityThresholds& t = {});

/// The Quality of a profile: judge_profile and the verdict.
Quality assess_quality(const Profile& p, const MachineState* machine,
                       const QualityThresholds& t = {});

/// One line per finding for a user (message and advice), at most `cap` lines; a last line
/// says how many more there are.
std::vector<std::string> quality_lines(const Quality& q, std::size_t cap);

/// A reading of the CPU counters at one moment (Linux /proc; zeros where not available).
struct CpuSnapshot {
  bool ok = false;           ///< /proc/stat could be read
  double busy_cpu_s = 0;     ///< CPU seconds all CPUs spent busy since boot
  double process_cpu_s = 0;  ///< this process's CPU seconds (user + system)
  double load1 = 0;          ///< /proc/loadavg, 1 minute
  double wall_s = 0;         ///< a monotonic clock, seconds
};

/// Reads the counters now.
CpuSnapshot cpu_snapshot();

/// CPUs online now (at least 1).
int online_cpus();

/// The machine state between two snapshots taken around the measuring.
MachineState machine_between(const CpuSnapshot& before, const CpuSnapshot& after, int threads);

/// CPUs' worth of other processes' work over a short window now (two snapshots `window_s`
/// apart), or the 1-minute load when /proc/stat is not readable.
double other_busy_cpus_now(double window_s);

/// The default intra-op thread count of `red profile`: the CPUs not busy with other
/// processes (online − busy, rounded), at least 1, so that the measuring does not
/// oversubscribe the machine.
int default_profile_threads(int online, double other_busy);

}  // namespace red
