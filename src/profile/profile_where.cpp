/// \file
/// The line of the value a profile error is about: a scanner over a JSON text that parsed
/// without error, following one value's path. Used by profile_read.cpp only.

#include "profile_where.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstddef>
#include <string>
#include <system_error>
#include <vector>

namespace red::profile_detail {

int line_of_byte(const std::string& text, std::size_t byte) {
  const std::size_t end = std::min(byte == 0 ? 0 : byte - 1, text.size());
  return 1 + static_cast<int>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(end), '\n'));
}

namespace {

/// Where values start in a JSON text that parsed without error: a scanner that follows one
/// path ("units.encoder[1].p99_us") and skips everything else.
class JsonLocator {
 public:
  explicit JsonLocator(const std::string& text) : t_(text) {}

  /// The byte offset of the value at `path` (components: keys, or "[i]" indices), or npos.
  std::size_t find(const std::vector<std::string>& path) {
    i_ = 0;
    space();
    for (const std::string& part : path) {
      if (i_ >= t_.size()) return std::string::npos;
      if (part.front() == '[') {
        if (t_[i_] != '[') return std::string::npos;
        std::size_t want = 0;  // a unit's name may hold '[': not an index then
        const auto [end, ec] = std::from_chars(part.data() + 1, part.data() + part.size(), want);
        if (ec != std::errc{} || end != part.data() + part.size()) return std::string::npos;
        ++i_;
        space();
        for (std::size_t k = 0; k < want; ++k) {
          if (i_ >= t_.size() || t_[i_] == ']') return std::string::npos;
          skip_value();
          space();
          if (i_ < t_.size() && t_[i_] == ',') ++i_;
          space();
        }
        if (i_ >= t_.size() || t_[i_] == ']') return std::string::npos;
        continue;
      }
      if (t_[i_] != '{') return std::string::npos;
      ++i_;
      for (;;) {
        space();
        if (i_ >= t_.size() || t_[i_] != '"') return std::string::npos;
        const std::size_t key_start = i_ + 1;
        skip_string();
        const std::string key = t_.substr(key_start, i_ - 1 - key_start);
        space();
        ++i_;  // ':'
        space();
        if (key == part) break;
        skip_value();
        space();
        if (i_ >= t_.size() || t_[i_] != ',') return std::string::npos;
        ++i_;
      }
    }
    return i_;
  }

 private:
  void space() {
    while (i_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[i_])) != 0) ++i_;
  }
  void skip_string() {  // at '"'; ends past the closing quote
    for (++i_; i_ < t_.size() && t_[i_] != '"'; ++i_)
      if (t_[i_] == '\\') ++i_;
    ++i_;
  }
  void skip_value() {
    if (i_ >= t_.size()) return;
    if (t_[i_] == '"') return skip_string();
    if (t_[i_] == '{' || t_[i_] == '[') {
      int depth = 0;  // the text is valid JSON: brackets balance outside strings
      while (i_ < t_.size()) {
        const char c = t_[i_];
        if (c == '"') {
          skip_string();
          continue;
        }
        if (c == '{' || c == '[') ++depth;
        if (c == '}' || c == ']') --depth;
        ++i_;
        if (depth == 0) return;
      }
      return;
    }
    while (i_ < t_.size() && t_[i_] != ',' && t_[i_] != '}' && t_[i_] != ']' &&
           std::isspace(static_cast<unsigned char>(t_[i_])) == 0)
      ++i_;
  }

  const std::string& t_;
  std::size_t i_ = 0;
};

}  // namespace

int line_of_error(const std::string& text, const std::string& message) {
  const std::size_t colon = message.find(": ");
  if (colon == std::string::npos) return 0;
  const std::string where = message.substr(0, colon);
  if (where.find(' ') != std::string::npos) return 0;  // not a path
  std::vector<std::string> path;
  if (where != "profile") {
    std::string part;
    for (const char c : where) {
      if (c == '.' || c == '[') {
        if (!part.empty()) path.push_back(part);
        part = c == '[' ? "[" : "";
      } else if (c != ']') {
        part += c;
      }
    }
    if (!part.empty()) path.push_back(part);
  }
  const std::string unknown = "unknown key '";
  if (message.compare(colon + 2, unknown.size(), unknown) == 0) {
    const std::size_t end = message.find('\'', colon + 2 + unknown.size());
    path.push_back(message.substr(colon + 2 + unknown.size(), end - colon - 2 - unknown.size()));
  }
  JsonLocator locate(text);
  for (;;) {
    const std::size_t at = locate.find(path);
    if (at != std::string::npos) return line_of_byte(text, at + 1);
    if (path.empty()) return 0;
    path.pop_back();
  }
}

}  // namespace red::profile_detail
