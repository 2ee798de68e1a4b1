// The version comes from one place (project(VERSION) in CMakeLists.txt): the generated
// red/version.hpp and `red --version` agree with it.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "../support/cli.hpp"
#include "red/version.hpp"

namespace red {
namespace {

TEST(Version, HeaderPartsMakeTheVersionString) {
  const std::string parts = std::to_string(RED_VERSION_MAJOR) + "." +
                            std::to_string(RED_VERSION_MINOR) + "." +
                            std::to_string(RED_VERSION_PATCH);
  EXPECT_EQ(std::string(kVersion), parts);
  EXPECT_EQ(std::string(RED_VERSION_STRING), parts);
  EXPECT_EQ(kVersionMajor, RED_VERSION_MAJOR);
  EXPECT_EQ(kVersionMinor, RED_VERSION_MINOR);
  EXPECT_EQ(kVersionPatch, RED_VERSION_PATCH);
}

TEST(Version, CliPrintsTheHeaderVersion) {
  const std::string cmd = test::quote(RED_CLI) + " --version";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = pclose(p);
  EXPECT_EQ(status, 0);
  EXPECT_EQ(out, "red " + std::string(kVersion) + "\n");
}

}  // namespace
}  // namespace red
