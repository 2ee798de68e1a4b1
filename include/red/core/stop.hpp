#pragma once
/// \file
/// A process-wide request to stop long computations, set by a stop signal (the CLI's
/// SIGINT and SIGTERM handler) and polled by the work that has nothing partial worth
/// keeping: the simulator's event loop (every 1024 events; a stopped run reports
/// SimResult::stopped and simulate_policy() an error) and the analysis between its steps.
/// A real run stops through its own stop_now() instead.
///
///     request_stop();            // from a signal handler: async-signal-safe
///     if (stop_requested()) ...  // from any thread

namespace red {

/// Asks every polling computation to end early. Async-signal-safe (a lock-free atomic).
void request_stop() noexcept;

/// Whether request_stop() was called (and not cleared since).
[[nodiscard]] bool stop_requested() noexcept;

/// Forgets a request (tests).
void clear_stop_request() noexcept;

/// The error a computation ended by a stop request returns.
inline constexpr const char* kStoppedMessage = "stopped by a stop request (SIGINT or SIGTERM)";

}  // namespace red
