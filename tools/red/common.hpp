#pragma once
/// \file
/// What the `red` subcommands share: loading a scenario with overrides and its profile,
/// printing located errors, writing a run's outputs.

#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "red/core/expected.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sim/run.hpp"

namespace red::cli {

/// Options shared by the commands that read a scenario.
struct ScenarioArgs {
  std::string path;
  std::optional<std::string> profile;
  std::vector<std::string> sets;  ///< key=value overrides
};

/// Prints `file:line: message` on stderr.
inline void print_error(const Error& e) {
  std::cerr << "red: " << e.to_string() << '\n';
}

/// Loads the scenario, applies overrides; Error on bad input.
Expected<Scenario> load(const ScenarioArgs& a);

/// Splits "a,b,c".
std::vector<std::string> split_list(const std::string& s);

/// Writes summary.json, jobs.csv and units.csv for a set of runs into `dir`.
std::optional<Error> write_outputs(const std::string& dir, const Scenario& s, const Profile& p,
                                   const std::string& backend, std::uint64_t seed,
                                   const std::vector<PolicyRun>& runs);

}  // namespace red::cli
