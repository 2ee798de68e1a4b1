#pragma once
// What the DDS tests share: a DDS domain of their own, running node and the red CLI.

#include <unistd.h>

#include <gtest/gtest.h>
#include <cstdio>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace red::dds {

/// A DDS domain id for this test process (so that concurrent runs never talk), 100..199.
inline int test_domain() {
  return 100 + static_cast<int>(getpid() % 100);
}

/// Runs `node script` with `request` on stdin and returns its stdout as JSON (null on error).
inline nlohmann::json run_node_json(const std::string& script, const std::string& node_path,
                                    const nlohmann::json& request) {
  const std::string in = ::testing::TempDir() + "oracle_in_" + std::to_string(getpid()) + ".json";
  const std::string out = ::testing::TempDir() + "oracle_out_" + std::to_string(getpid()) + ".json";
  std::ofstream(in) << request.dump();
  const std::string cmd =
      "NODE_PATH='" + node_path + "' node '" + script + "' < '" + in + "' > '" + out + "'";
  if (std::system(cmd.c_str()) != 0) return nullptr;
  std::ifstream f(out);
  std::stringstream ss;
  ss << f.rdbuf();
  return nlohmann::json::parse(ss.str(), nullptr, false);
}

}  // namespace red::dds
