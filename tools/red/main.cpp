/// \file
/// `red`: validate, simulate, compare, sweep, profile (§12).

#include <iostream>
#include <string>

#include "commands.hpp"
#include "real_run.hpp"
#include "red/version.hpp"

int main(int argc, char** argv) {
  red::cli::use_one_malloc_arena();
  CLI::App app{"RED: real-time scheduling of multi-task DNN inference for robots"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "red " + std::string(red::kVersion));
  int exit_code = red::cli::kOk;
  red::cli::register_validate(app, exit_code);
  red::cli::register_simulate(app, exit_code);
  red::cli::register_compare(app, exit_code);
  red::cli::register_sweep(app, exit_code);
  red::cli::register_run(app, exit_code);
  red::cli::register_profile(app, exit_code);
  red::cli::register_analyze(app, exit_code);
#ifdef RED_HAVE_DDS
  red::cli::register_node(app, exit_code);
  red::cli::register_camera(app, exit_code);
#endif
#ifndef RED_HAVE_DDS
  // Known commands of this build's absent DDS bridge (as `red profile` without LibTorch).
  if (argc >= 2 && (std::string(argv[1]) == "node" || std::string(argv[1]) == "camera")) {
    std::cerr << "red: '" << argv[1]
              << "' needs the DDS bridge: install cyclonedds-dev and cyclonedds-tools, then "
                 "rebuild (docs/ROS2.md)\n";
    return red::cli::kRunFailure;
  }
#endif
  // Name an unknown command (CLI11 alone says only that a subcommand is required).
  std::string known;
  bool found = argc < 2 || argv[1][0] == '-';
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    known += (known.empty() ? "" : ", ") + sub->get_name();
    found = found || sub->get_name() == argv[1];
  }
  if (!found) {
    std::cerr << "red: unknown subcommand '" << argv[1] << "' (subcommands: " << known << ")\n";
    return red::cli::kBadInput;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // Bad usage: CLI11 explains; RED's exit code for bad input is 2 (§12).
    app.exit(e);
    return red::cli::kBadInput;
  }
  return exit_code;
}
