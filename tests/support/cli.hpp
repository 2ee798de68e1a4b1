#pragma once
// Helpers for tests that run the `red` binary.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace red::test {

/// The whole of a file ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The index of column `name` among a CSV header's fields; `header.size()` when it has none.
inline std::size_t column_index(const std::vector<std::string>& header, std::string_view name) {
  return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
}

/// `s` quoted for /bin/sh.
inline std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// The quoted path of a bundled scenario.
inline std::string scenario(const std::string& name) {
  return quote(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
}

/// What a run of `red` gave.
struct RunResult {
  bool exited = false;  ///< ended by exit(), not a signal
  int code = -1;        ///< its exit code; -1 when it did not exit
  std::string out, err;
};

#ifdef RED_CLI  // the test target's path of the red binary
/// Runs `PREFIX red ARGS` through /bin/sh with stdin from /dev/null, stdout and stderr
/// through files in `scratch` (which must exist). PREFIX: environment settings; by default
/// no gnuplot (the plots' data and scripts only).
inline RunResult run_red(const std::string& args, const std::filesystem::path& scratch,
                         const std::string& prefix = "RED_GNUPLOT=none") {
  const std::filesystem::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string cmd = prefix + " " + quote(RED_CLI) + " " + args + " >" + quote(out.string()) +
                          " 2>" + quote(err.string()) + " </dev/null";
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.exited = status != -1 && WIFEXITED(status);
  r.code = r.exited ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}
#endif

/// A test with its own empty directory, dir_, removed after it.
class ScratchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("red_" + std::string(info->test_suite_name()) + "_" + std::to_string(::getpid()) + "_" +
            info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  std::filesystem::path dir_;
};

}  // namespace red::test
