#pragma once
/// \file
/// SIGINT and SIGTERM for the `red` commands: the handler only records the signal (an
/// atomic and one byte down a self-pipe); a watcher thread turns it into a call that stops
/// the work in progress. `red run`, `compare` and `sweep` then write what they have and
/// exit 128 + the signal (130, 143); `red node` and `red camera` end as at --duration.
/// A second signal of the same kind kills the process at once (SA_RESETHAND).
///
///     install_stop_signals();
///     StopWatch watch([&runtime] { runtime.stop_now(); });
///     runtime.run();
///     if (stop_signal() != 0) return stop_exit_code();

#include <functional>
#include <thread>

namespace red::cli {

/// Installs the SIGINT and SIGTERM handlers (sigaction, SA_RESTART | SA_RESETHAND). Once
/// per process; later calls do nothing. Not thread-safe: call it before starting threads.
void install_stop_signals();

/// The first stop signal received (SIGINT or SIGTERM), or 0. Async-signal-safe.
[[nodiscard]] int stop_signal() noexcept;

/// "SIGINT" or "SIGTERM" for the signal received, or "" when none.
[[nodiscard]] const char* stop_signal_name() noexcept;

/// The exit code after a stop signal: 128 + the signal (130 SIGINT, 143 SIGTERM).
[[nodiscard]] int stop_exit_code() noexcept;

/// While alive, calls `on_stop` once, on its own thread, when a stop signal arrives (at
/// once if one arrived before). Needs install_stop_signals(). One at a time per process.
class StopWatch {
 public:
  explicit StopWatch(std::function<void()> on_stop);
  ~StopWatch();
  StopWatch(const StopWatch&) = delete;
  StopWatch& operator=(const StopWatch&) = delete;

 private:
  std::function<void()> on_stop_;
  std::thread thread_;
};

}  // namespace red::cli
