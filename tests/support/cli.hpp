#pragma once
// Helpers for tests that run the `red` binary.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace red::test {

/// The whole of a file ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
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

}  // namespace red::test
