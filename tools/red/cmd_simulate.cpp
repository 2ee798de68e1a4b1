/// \file
/// `red simulate`: one policy on one scenario in the simulator (run_policies.hpp).

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "run_policies.hpp"

namespace red::cli {

void register_simulate(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("simulate", "Discrete-event simulation of one policy");
  add_common(cmd, *a);
  cmd->add_option("--policy", a->policy,
                  "Policy preset: fifo, mono, edf, red-fg, red-ida, red, red-robust, lst")
      ->capture_default_str();
  cmd->callback([a, &exit_code] { exit_code = run_policies(*a, {a->policy}, false, "simulate"); });
}

}  // namespace red::cli
