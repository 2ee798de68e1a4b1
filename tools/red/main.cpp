/// \file
/// `red`: validate, simulate, compare, sweep, profile (docs/CLI.md).

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <system_error>
#include <vector>

#include <unistd.h>

#include "commands.hpp"
#include "full.hpp"
#include "real_run.hpp"
#include "red/version.hpp"

namespace {

/// Edit distance (insertions, deletions, substitutions) of two short words.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

/// "(did you mean --policies?)" for each `--option` on the command line that `sub` does not
/// know and that is a few letters from one it does; empty if none is.
std::string suggestions(const CLI::App& sub, int argc, char** argv) {
  std::string out;
  for (int i = 2; i < argc; ++i) {
    std::string given = argv[i];
    if (given.rfind("--", 0) != 0 || given.size() < 3) continue;
    given = given.substr(2, given.find('=') - 2);
    std::string best;
    std::size_t best_distance = std::max<std::size_t>(2, given.size() / 3) + 1;
    for (const CLI::Option* o : sub.get_options()) {
      for (const std::string& name : o->get_lnames()) {
        if (name == given) {
          best.clear();
          best_distance = 0;
          break;
        }
        const std::size_t d = edit_distance(given, name);
        if (d < best_distance) best = name, best_distance = d;
      }
      if (best_distance == 0) break;
    }
    if (!best.empty())
      out += "red " + sub.get_name() + ": unknown option '--" + given + "' (did you mean --" +
             best + "?)\n";
  }
  return out;
}

// What stdout still buffers goes now, so that a table (or --help, --version) that could not
// be written is an error (exit 1) naming the reason, not an exit 0 with the output gone.
int flush_stdout(int exit_code) {
  errno = 0;
  const bool flushed = std::fflush(stdout) == 0;  // std::cout writes through stdout
  const int reason = errno;
  if (!flushed || std::ferror(stdout) || !std::cout.flush()) {
    errno = reason;
    std::cerr << "red: standard output: " << (errno != 0 ? std::strerror(errno) : "write failed")
              << " (the output is lost)\n";
    return exit_code == red::cli::kOk ? red::cli::kRunFailure : exit_code;
  }
  return exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  // The commands that need LibTorch or DDS run in red-full (full.hpp).
  if (const auto rc = red::cli::run_full_if_needed(argc, argv)) return *rc;
  red::cli::use_one_malloc_arena();
  // Off a terminal, standard output keeps up to 1 MiB before writing: a write that fails
  // then fails at the final flush (or in fmt::print, which throws), with errno still saying
  // why, rather than in a background flush whose reason is gone by the end.
  static char out_buffer[1 << 20];
  if (isatty(STDOUT_FILENO) == 0) std::setvbuf(stdout, out_buffer, _IOFBF, sizeof out_buffer);
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
  red::cli::register_report(app, exit_code);
#ifdef RED_HAVE_DDS
  red::cli::register_node(app, exit_code);
  red::cli::register_camera(app, exit_code);
  red::cli::register_security(app, exit_code);
#elif defined(RED_FULL_HAS_DDS)
  // This red hands node and camera to red-full before parsing (full.hpp): listed for --help.
  app.add_subcommand("node",
                     "RED as a ROS 2-compatible node on DDS: camera topics in, head outputs out");
  app.add_subcommand("camera", "Publish synthetic camera frames (sensor_msgs/Image) on DDS");
  app.add_subcommand("security",
                     "DDS Security keystores and enclaves, as `ros2 security` makes them (SROS2)");
#endif
#if !defined(RED_HAVE_DDS) && !defined(RED_FULL_HAS_DDS)
  // Known commands of this build's absent DDS bridge (as `red profile` without LibTorch).
  if (argc >= 2 && (std::string(argv[1]) == "node" || std::string(argv[1]) == "camera" ||
                    std::string(argv[1]) == "security")) {
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
  } catch (const std::system_error& e) {
    // fmt::print throws when standard output cannot take what it writes (a full disk,
    // /dev/full, a closed pipe): the result is lost, which is a failure, not a crash.
    std::cerr << "red: standard output: " << e.code().message() << " (the output is lost)\n";
    return red::cli::kRunFailure;
  } catch (const CLI::CallForHelp& e) {
    return flush_stdout(app.exit(e));
  } catch (const CLI::CallForAllHelp& e) {
    return flush_stdout(app.exit(e));
  } catch (const CLI::Success& e) {
    return flush_stdout(app.exit(e));  // --version
  } catch (const CLI::ParseError& e) {
    // Bad usage: CLI11 explains, and a misspelt option gets the closest one the command has;
    // RED's exit code for bad input is 2 (docs/CLI.md).
    app.exit(e);
    for (const CLI::App* sub : app.get_subcommands()) std::cerr << suggestions(*sub, argc, argv);
    return red::cli::kBadInput;
  }
  return flush_stdout(exit_code);
}
