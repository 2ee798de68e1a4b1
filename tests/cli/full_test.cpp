// The lean `red` and `red-full` (tools/red/full.hpp): which command lines need LibTorch or
// DDS, where red-full is looked for, and what a lean red says when red-full is missing.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "../support/cli.hpp"
#include "full.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using cli::needs_full;

TEST(NeedsFull, CommandsOfTheCoreRunInTheLeanRed) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {},
           {"--version"},
           {"--help"},
           {"validate", "s.yaml"},
           {"simulate", "s.yaml", "--policy", "red"},
           {"sweep", "s.yaml", "--set", "rate_scale=1:2:0.5"},
           {"analyze", "s.yaml"},
           {"compare", "s.yaml"},
           {"compare", "s.yaml", "--backend", "sim"},
           {"compare", "s.yaml", "--backend=synthetic"},
           {"run", "s.yaml", "--backend", "synthetic"},
           {"run", "s.yaml", "--backend=synthetic"},
       })
    EXPECT_EQ(needs_full(args), std::nullopt) << (args.empty() ? "" : args.front());
}

TEST(NeedsFull, LibTorchAndDdsCommandsNameWhatTheyNeed) {
  EXPECT_EQ(needs_full({"run", "s.yaml"}), "LibTorch");  // torch is run's default backend
  EXPECT_EQ(needs_full({"run", "s.yaml", "--backend", "torch"}), "LibTorch");
  EXPECT_EQ(needs_full({"compare", "s.yaml", "--backend", "torch"}), "LibTorch");
  EXPECT_EQ(needs_full({"compare", "s.yaml", "--backend=torch"}), "LibTorch");
  EXPECT_EQ(needs_full({"profile"}), "LibTorch");
  EXPECT_EQ(needs_full({"profile", "--calibrate", "s.yaml"}), "LibTorch");
  EXPECT_EQ(needs_full({"node", "s.yaml"}), "the DDS bridge");
  EXPECT_EQ(needs_full({"camera"}), "the DDS bridge");
  EXPECT_EQ(needs_full({"security", "create-keystore", "k"}), "the DDS bridge");
  // The last --backend counts, as in CLI11; after "--" nothing is an option.
  EXPECT_EQ(needs_full({"run", "--backend", "torch", "--backend", "synthetic"}), std::nullopt);
  EXPECT_EQ(needs_full({"compare", "s.yaml", "--", "--backend", "torch"}), std::nullopt);
}

TEST(FullCandidates, BesideRedThenInLibexec) {
  EXPECT_EQ(cli::full_candidates("/usr/bin/red", "../libexec/red"),
            (std::vector<std::string>{"/usr/bin/red-full", "/usr/libexec/red/red-full"}));
  EXPECT_EQ(cli::full_candidates("/opt/red/bin/red", "../lib/red"),
            (std::vector<std::string>{"/opt/red/bin/red-full", "/opt/red/lib/red/red-full"}));
}

// A red copied alone into a directory has no red-full beside it (nor in ../libexec/red):
// a command that needs LibTorch says so and fails; one that does not runs.
TEST(LeanRed, WithoutRedFullACommandThatNeedsLibTorchSaysWhatIsMissing) {
  const fs::path dir = fs::temp_directory_path() / ("red-lean-" + std::to_string(::getpid()));
  fs::create_directories(dir / "bin");
  const fs::path red = dir / "bin" / "red";
  fs::copy_file(RED_CLI, red, fs::copy_options::overwrite_existing);
  const std::string err = (dir / "err.txt").string();
  const std::string run = test::quote(red.string()) + " run " +
                          test::scenario("minibench-tight.yaml") + " --policy red 2>" +
                          test::quote(err) + " >/dev/null";
  const int status = std::system(run.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  const std::string message = test::read_text(err);
  EXPECT_NE(message.find("LibTorch"), std::string::npos) << message;
#if RED_HAS_FULL
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_NE(message.find("red-full is missing"), std::string::npos) << message;
  EXPECT_NE(message.find((dir / "libexec" / "red" / "red-full").string()), std::string::npos)
      << message;
#endif
  const std::string validate = test::quote(red.string()) + " validate " +
                               test::scenario("minibench-tight.yaml") + " >/dev/null 2>&1";
  EXPECT_EQ(std::system(validate.c_str()), 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace red
