/// \file
/// `red compare`: every policy (or those listed) on the identical workload, side by side, in
/// the simulator or on a real backend (run_policies.hpp).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.hpp"
#include "common.hpp"
#include "run_policies.hpp"

namespace red::cli {

namespace {

// The presets to compare: --policies (`given`: the option was on the command line), checked, or
// every preset; nullopt once an error is printed.
std::optional<std::vector<std::string>> compare_policies(const std::string& list, bool given) {
  std::vector<std::string> names = !given ? default_presets() : split_list(list);
  if (names.empty() || (given && list.empty())) {
    print_error(Error{"", 0, "--policies: empty list (leave the option out for every preset)"});
    return std::nullopt;
  }
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (names[i] == names[j]) {
        print_error(Error{"", 0, "--policies: '" + names[i] + "' is listed twice"});
        return std::nullopt;
      }
  return names;
}

}  // namespace

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
    const auto names = compare_policies(a->policies, policies->count() > 0);
    exit_code = names ? run_policies(*a, *names, true, "compare") : kBadInput;
  });
}

}  // namespace red::cli
