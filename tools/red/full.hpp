#pragma once
/// \file
/// The lean `red` and `red-full`. Where RED is built with LibTorch or the DDS bridge, `red`
/// links neither (loading LibTorch's shared libraries costs about 0.6 s at every start, even
/// for `red --version`): the commands that need them run in `red-full`, the same CLI linked
/// with both, which `red` executes in its place with the same arguments.

#include <optional>
#include <string>
#include <vector>

namespace red::cli {

/// What a command line needs that the lean `red` does not link: "LibTorch" (`profile`;
/// `run` and `compare` on the torch backend), "the DDS bridge" (`node`, `camera`, `security`), or
/// nothing. `args` are the arguments after the program name.
std::optional<std::string> needs_full(const std::vector<std::string>& args);

/// Where `red-full` is looked for, beside a `red` at `self`: in its directory (a build
/// tree), then in `libexec_rel` relative to it (an installed tree: ../libexec/red).
std::vector<std::string> full_candidates(const std::string& self, const std::string& libexec_rel);

/// When the command line needs `red-full`, executes it in this process's place and returns
/// only if that fails: the exit code after a message naming what is missing and where it
/// was looked for. std::nullopt when this `red` runs the command itself.
std::optional<int> run_full_if_needed(int argc, char** argv);

}  // namespace red::cli
