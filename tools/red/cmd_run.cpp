/// \file
/// `red run`: one policy executed in real time (LibTorch inference or synthetic, profiled unit
/// times; run_policies.hpp).

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "run_policies.hpp"

namespace red::cli {

void register_run(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<RunArgs>();
  a->backend = "torch";
  a->policy = "red-robust";  // docs/DESIGN.md, "Overload": the flagship on a real robot
  CLI::App* cmd = app.add_subcommand("run", "Real execution in real time (LibTorch inference)");
  add_common(cmd, *a);
  add_real(cmd, *a);
  cmd->add_option("--policy", a->policy,
                  "Policy preset: fifo, mono, edf, red-fg, red-ida, red, red-robust, lst")
      ->capture_default_str();
  cmd->add_option("--backend", a->backend,
                  "torch (real inference) or synthetic (spends profiled unit times)")
      ->check(CLI::IsMember({"torch", "synthetic"}))
      ->capture_default_str();
  cmd->callback([a, &exit_code] { exit_code = run_policies(*a, {a->policy}, false, "run"); });
}

}  // namespace red::cli
