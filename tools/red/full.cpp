/// \file
/// The lean `red` hands the commands that need LibTorch or DDS to `red-full` (full.hpp).

#include "full.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <system_error>

#include <unistd.h>

#include "commands.hpp"

namespace red::cli {

namespace {

// The value of --backend (`--backend X` or `--backend=X`), or `fallback` without one.
std::string backend_of(const std::vector<std::string>& args, const std::string& fallback) {
  std::string backend = fallback;
  for (std::size_t i = 1; i < args.size(); ++i) {
    if (args[i] == "--") break;
    if (args[i] == "--backend" && i + 1 < args.size()) backend = args[i + 1];
    if (args[i].rfind("--backend=", 0) == 0) backend = args[i].substr(10);
  }
  return backend;
}

}  // namespace

std::optional<std::string> needs_full(const std::vector<std::string>& args) {
  if (args.empty()) return std::nullopt;
  const std::string& cmd = args.front();
  if (cmd == "node" || cmd == "camera" || cmd == "security") return "the DDS bridge";
  if (cmd == "profile") return "LibTorch";
  // The defaults of each command's --backend (cmd_compare.cpp, cmd_run.cpp).
  if (cmd == "run" && backend_of(args, "torch") == "torch") return "LibTorch";
  if (cmd == "compare" && backend_of(args, "sim") == "torch") return "LibTorch";
  return std::nullopt;
}

std::vector<std::string> full_candidates(const std::string& self, const std::string& libexec_rel) {
  const std::filesystem::path dir = std::filesystem::path(self).parent_path();
  return {(dir / "red-full").string(),
          (dir / libexec_rel / "red-full").lexically_normal().string()};
}

std::optional<int> run_full_if_needed(int argc, char** argv) {
#if defined(RED_LIBEXEC_REL)
  const std::vector<std::string> args(argv + std::min(argc, 1), argv + argc);
  const auto what = needs_full(args);
  if (!what) return std::nullopt;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const auto where = full_candidates(ec ? std::string(argv[0]) : self.string(), RED_LIBEXEC_REL);
  for (const std::string& path : where) {
    if (::access(path.c_str(), X_OK) != 0) continue;
    ::execv(path.c_str(), argv);  // returns only on failure
    std::cerr << "red: '" << args.front() << "' needs " << *what << ", which " << path
              << " runs, and it could not be started: " << std::strerror(errno) << '\n';
    return kRunFailure;
  }
  std::cerr << "red: '" << args.front() << "' needs " << *what
            << ", which red-full runs, and red-full is missing (looked for " << where[0] << " and "
            << where[1] << "): reinstall red, or rebuild it with the target red-full\n";
  return kRunFailure;
#else
  // A build with neither LibTorch nor DDS: this red is the only one, and says itself what
  // it lacks.
  (void)argc;
  (void)argv;
  return std::nullopt;
#endif
}

}  // namespace red::cli
