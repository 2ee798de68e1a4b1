#pragma once
/// \file
/// What `red simulate`, `red compare` and `red run` share (cmd_simulate.cpp, cmd_compare.cpp,
/// cmd_run.cpp): their options and run_policies, which runs one or more policies on one
/// scenario (simulator or real backend) and prints and writes the results (run_policies.cpp).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common.hpp"
#include "real_run.hpp"

namespace red::cli {

struct RunArgs {
  ScenarioArgs scenario;
  std::string policy = "red";
  std::string policies;
  std::string backend = "sim";
  RealRunOptions real;
  bool no_realtime = false;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> out;
  std::size_t trace_events = kDefaultTraceEvents;
  std::string sync;                     ///< empty: the policy's own
  std::optional<std::string> costs;     ///< --costs F.json: the simulator's unit costs
  std::optional<std::string> timeline;  ///< --timeline FROM:TO (seconds)
  bool phases = false;                  ///< --phases: print the figures per workload phase
  /// --write-profile F.json: the run's own costs as a calibrated profile (a real run)
  std::optional<std::string> write_profile;
};

/// The options every one of the three takes: scenario, profile, overrides, seed, --out, ...
void add_common(CLI::App* cmd, RunArgs& a);

/// Options of the real backends (compare --backend torch, run).
void add_real(CLI::App* cmd, RunArgs& a);

// Runs the given policies on one scenario and prints and writes the results. In the
// simulator every policy sees the same releases and the same sampled unit times (common
// random numbers, docs/DESIGN.md, "Metrics"); on a real backend the same releases. Returns the
// exit code.
int run_policies(const RunArgs& a, const std::vector<std::string>& names, bool table,
                 const char* command);

}  // namespace red::cli
