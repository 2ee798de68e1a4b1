/// \file
/// The field readers of the scenario loader (fields.hpp): mappings, keys and typed scalars,
/// each checked against its bounds (limits.hpp), with the messages the user sees.

#include "fields.hpp"

#include "limits.hpp"

#include "limits.hpp"
#include "red/core/file.hpp"
#include "yaml_tree.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

namespace red::loader_detail {

using namespace limits;  // the bounds of every value read (limits.hpp)

[[noreturn]] void fail(int line, std::string message) {
  throw Failure{line, std::move(message)};
}

/// The 1-based line of a node; 0 unknown.
int mark_line(const yaml::Node& n) {
  return n.line();
}

/// "<what>: " or nothing at the top level.
std::string at(const std::string& what) {
  return what.empty() ? std::string{} : what + ": ";
}

std::string got(const yaml::Node& n) {
  if (n.is_null()) return ", got nothing";
  if (n.is_map()) return ", got a mapping";
  if (n.is_sequence()) return ", got a list";
  if (n.tag() == "!") return ", got the quoted string '" + n.scalar() + "'";
  if (n.tag() == "tag:yaml.org,2002:str") return ", got the string !!str '" + n.scalar() + "'";
  return ", got '" + n.scalar() + "'";
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

/// The entries of a mapping; `kind` names what a duplicate key is ("key", "node", ...).
std::vector<Entry> entries_of(const Val& v, std::string_view kind) {
  if (!v.node.is_map()) fail(v.line, at(v.what) + "must be a mapping" + got(v.node));
  std::vector<Entry> out;
  std::unordered_map<std::string, int> first_line;  // O(1) per key: mappings of 50,000 nodes
  for (const auto& [key, value] : v.node.entries()) {
    const int key_line = mark_line(key);
    if (!key.is_scalar() || key.scalar().empty())
      fail(key_line, at(v.what) + "keys must be non-empty names" + got(key));
    const std::string name = key.scalar();
    if (const auto [seen, fresh] = first_line.emplace(name, key_line); !fresh)
      fail(key_line, fmt::format("{}duplicate {} '{}' (first at line {})", at(v.what), kind, name,
                                 seen->second));
    // A null value's mark points at the next token, possibly lines later: use the key's.
    const int value_line = value.is_null() ? key_line : mark_line(value);
    out.push_back(Entry{name, key_line,
                        Val{value, value_line ? value_line : key_line,
                            v.what.empty() ? name : v.what + "." + name}});
  }
  return out;
}

// ---- scalars -------------------------------------------------------------------------

/// A scalar that may be read as a number: plain (untagged, unquoted) or tagged `!!int` /
/// `!!float`. A quoted "15" or a `!!str 15` is a string, not a number.
bool is_plain_scalar(const yaml::Node& n) {
  if (!n.is_scalar()) return false;
  const std::string& tag = n.tag();
  return tag.empty() || tag == "?" || tag == "tag:yaml.org,2002:int" ||
         tag == "tag:yaml.org,2002:float";
}

double number(const Val& v) {
  if (is_plain_scalar(v.node)) {
    std::string_view s = v.node.scalar();
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double x = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
    if (ec == std::errc{} && end == s.data() + s.size() && std::isfinite(x)) return x;
  }
  fail(v.line, at(v.what) + "must be a number" + got(v.node));
}

double positive(const Val& v) {
  const double x = number(v);
  if (!(x > 0.0)) fail(v.line, at(v.what) + "must be > 0" + got(v.node));
  return x;
}

double rate(const Val& v) {
  const double x = positive(v);
  if (x < kMinRateHz || x > kMaxRateHz)
    fail(v.line, at(v.what) +
                     fmt::format("must be between {:g} Hz (one a day) and {:g} Hz", kMinRateHz,
                                 kMaxRateHz) +
                     got(v.node));
  return x;
}

double non_negative(const Val& v) {
  const double x = number(v);
  if (x < 0.0) fail(v.line, at(v.what) + "must be >= 0" + got(v.node));
  return x;
}

std::int64_t integer(const Val& v, std::int64_t lo, std::int64_t hi) {
  if (is_plain_scalar(v.node)) {
    std::string_view s = v.node.scalar();
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    std::int64_t x = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
    if (ec == std::errc{} && end == s.data() + s.size()) {
      if (x < lo || x > hi)
        fail(v.line,
             fmt::format("{}must be an integer in [{}, {}]{}", at(v.what), lo, hi, got(v.node)));
      return x;
    }
  }
  fail(v.line, at(v.what) + "must be an integer" + got(v.node));
}

bool boolean(const Val& v) {
  if (is_plain_scalar(v.node) || v.node.tag() == "tag:yaml.org,2002:bool") {
    const std::string& s = v.node.scalar();
    if (s == "true") return true;
    if (s == "false") return false;
  }
  fail(v.line, at(v.what) + "must be true or false" + got(v.node));
}

int small_int(const Val& v, int lo) {
  return static_cast<int>(integer(v, lo, std::numeric_limits<int>::max()));
}

std::string text(const Val& v) {
  if (!v.node.is_scalar() || v.node.scalar().empty())
    fail(v.line, at(v.what) + "must be a non-empty string" + got(v.node));
  return v.node.scalar();
}

/// An absolute ROS 2 topic name (`/a/b_1`: letters, digits, `_`, tokens not starting with a
/// digit, no `//`, no trailing `/`), for `red node` (docs/ROS2.md).
std::string ros_topic(const Val& v) {
  const std::string t = text(v);
  bool ok = t.size() >= 2 && t.front() == '/' && t.back() != '/';
  for (std::size_t i = 1; ok && i < t.size(); ++i) {
    const char c = t[i], prev = t[i - 1];
    ok = (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '/') &&
         !(c == '/' && prev == '/') &&
         !(prev == '/' && std::isdigit(static_cast<unsigned char>(c)) != 0);
  }
  if (!ok)
    fail(v.line,
         at(v.what) + "must be an absolute ROS 2 topic name like /camera/image_raw" + got(v.node));
  return t;
}

/// Milliseconds or seconds from a file, bounded so the nanosecond count cannot overflow.
Duration ms_value(const Val& v, double ms) {
  if (ms > 1e12) fail(v.line, at(v.what) + "is too large" + got(v.node));
  return from_ms(ms);
}

}  // namespace red::loader_detail
