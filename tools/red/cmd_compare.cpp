/// \file
/// `red compare`: every policy (or those listed) on the identical workload, side by side, in
/// the simulator or on a real backend (run_policies.hpp).

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "run_policies.hpp"

namespace red::cli {

void register_compare(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<RunArgs>();
  CLI::App* cmd =
      app.add_subcommand("compare", "Every policy on the identical workload, side by side");
  add_common(cmd, *a);
  add_real(cmd, *a);
  CLI::Option* policies = cmd->add_option(
      "--policies", a->policies,
      "Comma-separated presets (default: fifo,mono,edf,red-fg,red-ida,red,red-robust)");
  cmd->add_option("--backend", a->backend,
                  "sim (simulator), torch (real LibTorch inference) or synthetic (real time, "
                  "profiled unit times)")
      ->check(CLI::IsMember({"sim", "torch", "synthetic"}));
  cmd->callback([a, policies, &exit_code] {
    const auto names = policies->count() == 0 ? default_presets() : split_list(a->policies);
    if (names.empty() || (policies->count() > 0 && a->policies.empty())) {
      print_error(Error{"", 0, "--policies: empty list (leave the option out for every preset)"});
      exit_code = kBadInput;
      return;
    }
    for (std::size_t i = 0; i < names.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (names[i] == names[j]) {
          print_error(Error{"", 0, "--policies: '" + names[i] + "' is listed twice"});
          exit_code = kBadInput;
          return;
        }
    exit_code = run_policies(*a, names, true, "compare");
  });
}

}  // namespace red::cli
