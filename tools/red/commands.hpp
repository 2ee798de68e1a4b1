#pragma once
/// \file
/// The `red` subcommands. Each lives in its own file and registers itself on the app;
/// its callback stores the exit code (0 ok, 1 failure while running, 2 bad input) in
/// `exit_code`. Messages for bad input name the file, the line and the problem.

#include <CLI/CLI.hpp>

namespace red::cli {

/// Exit codes of docs/CLI.md.
inline constexpr int kOk = 0;
inline constexpr int kRunFailure = 1;
inline constexpr int kBadInput = 2;

void register_validate(CLI::App& app, int& exit_code);
void register_simulate(CLI::App& app, int& exit_code);
void register_compare(CLI::App& app, int& exit_code);
void register_sweep(CLI::App& app, int& exit_code);
/// `red run` (cmd_run.cpp): the real-time runtime on a real backend.
void register_run(CLI::App& app, int& exit_code);
/// `red profile` (cmd_profile.cpp; needs the LibTorch backend).
void register_profile(CLI::App& app, int& exit_code);
/// `red node` and `red camera` (cmd_node.cpp; only with the DDS bridge, RED_HAVE_DDS).
void register_node(CLI::App& app, int& exit_code);
void register_camera(CLI::App& app, int& exit_code);
/// `red security` (cmd_security.cpp; only with the DDS bridge): SROS2 keystores and enclaves.
void register_security(CLI::App& app, int& exit_code);
/// `red analyze` (cmd_analyze.cpp): verdicts, headroom, response-time bound, nptest export.
void register_analyze(CLI::App& app, int& exit_code);
/// `red report` (cmd_report.cpp): a run's page redrawn from its saved files.
void register_report(CLI::App& app, int& exit_code);

}  // namespace red::cli
