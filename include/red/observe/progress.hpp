#pragma once
/// \file
/// Progress of long runs on one updating terminal line: wall time elapsed, simulated (or
/// run) time, jobs, current miss rate. An observer of the scheduler; the wall clock comes
/// through a Clock (only Clock implementations read a clock, STYLE.md).
///
///     SteadyClock clock;
///     ProgressReporter progress(clock, std::cerr, ProgressReporter::stderr_is_terminal());
///     progress.begin_run("red", scenario.duration);
///     simulator.add_observer(&progress);
///     simulator.run();
///     progress.finish();  // clears the line
///
/// Quiet unless enabled (the CLI enables it when stderr is a terminal) and until the
/// command has run for `delay`; then it redraws at most every `interval`.

#include <cstdint>
#include <iosfwd>
#include <string>

#include "red/core/clock.hpp"
#include "red/core/time.hpp"
#include "red/sched/observer.hpp"

namespace red {

/// When and how often the line is drawn.
struct ProgressOptions {
  Duration delay = std::chrono::seconds{2};  ///< quiet for runs shorter than this
  Duration interval = std::chrono::milliseconds{250};
  /// The clock is read once per this many callbacks (callbacks come millions a second in
  /// the simulator; a clock read per callback would show in its speed).
  std::uint32_t check_every = 256;
  /// What the run's own time is called on the line: "sim" (simulator) or "run" (runtime).
  std::string time_label = "sim";
};

/// Draws "\r<label>  elapsed 3.2 s  sim 4.1/20.0 s (21%)  jobs 812  miss 2.3%" on `out`.
/// Not thread-safe; the scheduler calls its observers one at a time.
class ProgressReporter final : public Observer {
 public:
  /// `clock` and `out` must outlive the reporter. Elapsed time counts from construction.
  ProgressReporter(const Clock& clock, std::ostream& out, bool enabled,
                   ProgressOptions options = {});
  ~ProgressReporter() override;
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  /// True when stderr is a terminal (isatty).
  static bool stderr_is_terminal() noexcept;

  /// Starts a run: `label` names it (policy, sweep point), `length` is the scenario's
  /// duration (0 if unknown). Resets the job counts; elapsed time keeps counting.
  void begin_run(std::string label, Duration length);
  /// Erases the line if one was drawn; call before printing anything else.
  void finish();

  void on_job_end(const JobRecord& job) override;
  void on_decision(TimePoint now, int ready, int idle_lanes, int waiting) override;

  /// The line as it would be drawn now (without "\r" and the erase code), for tests.
  [[nodiscard]] std::string line(TimePoint wall) const;
  /// Lines drawn so far.
  [[nodiscard]] std::uint64_t draws() const noexcept { return draws_; }

 private:
  void tick();

  const Clock& clock_;
  std::ostream& out_;
  bool enabled_;
  ProgressOptions options_;
  TimePoint origin_;
  TimePoint next_draw_;
  std::string label_;
  Duration length_{0};
  TimePoint sim_now_{0};
  std::uint64_t jobs_ = 0, decided_ = 0, missed_ = 0;
  std::uint32_t calls_ = 0;
  std::uint64_t draws_ = 0;
  bool drawn_ = false;
};

}  // namespace red
