#pragma once
/// \file
/// What the parts of the scenario loader share (loader.cpp, events.cpp): the private Failure
/// it throws, the YAML value with its line and path, mappings with a fixed set of keys, and the
/// typed readers that check each value against its bounds (limits.hpp). Internal to the loader.

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "red/core/time.hpp"
#include "yaml_tree.hpp"

namespace red::loader_detail {

/// The only exception the loader raises; never leaves the loader (parse_scenario).
struct Failure {
  int line = 0;
  std::string message;
};

[[noreturn]] void fail(int line, std::string message);

/// The 1-based line of a node; 0 unknown.
int mark_line(const yaml::Node& n);

/// A YAML value, the line to report it by and its path in the file (for messages).
struct Val {
  yaml::Node node;
  int line = 0;
  std::string what;  ///< e.g. "operations.drive.deadline_ms"; empty for the top level
};

/// "<what>: " or nothing at the top level.
std::string at(const std::string& what);

std::string got(const yaml::Node& n);

std::string join(const std::vector<std::string>& items);

/// One `key: value` of a mapping, in file order.
struct Entry {
  std::string key;
  int key_line = 0;
  Val value;
};

/// The entries of a mapping; `kind` names what a duplicate key is ("key", "node", ...).
std::vector<Entry> entries_of(const Val& v, std::string_view kind = "key");

/// A mapping with a fixed set of allowed keys.
class Fields {
 public:
  Fields(const Val& v, std::initializer_list<const char*> allowed)
      : Fields(v, std::vector<std::string>(allowed.begin(), allowed.end())) {}
  Fields(const Val& v, const std::vector<std::string>& allowed)
      : line_(v.line), what_(v.what), entries_(entries_of(v)) {
    for (const auto& e : entries_)
      if (std::find(allowed.begin(), allowed.end(), e.key) == allowed.end())
        fail(e.key_line,
             fmt::format("{}unknown key '{}' (allowed: {})", at(what_), e.key, join(allowed)));
  }

  [[nodiscard]] const Val* get(std::string_view key) const {
    for (const auto& e : entries_)
      if (e.key == key) return &e.value;
    return nullptr;
  }

  [[nodiscard]] const Val& need(std::string_view key) const {
    if (const Val* v = get(key)) return *v;
    fail(line_, fmt::format("{}missing required key '{}'", at(what_), key));
  }

  [[nodiscard]] const std::vector<Entry>& entries() const { return entries_; }
  [[nodiscard]] int line() const { return line_; }

 private:
  int line_;
  std::string what_;
  std::vector<Entry> entries_;
};

// ---- scalars -------------------------------------------------------------------------

/// A scalar that may be read as a number: plain (untagged, unquoted) or tagged `!!int` /
/// `!!float`. A quoted "15" or a `!!str 15` is a string, not a number.
bool is_plain_scalar(const yaml::Node& n);

double number(const Val& v);

double positive(const Val& v);

double rate(const Val& v);

double non_negative(const Val& v);

std::int64_t integer(const Val& v, std::int64_t lo, std::int64_t hi);

int small_int(const Val& v, int lo);
/// true or false (YAML's plain `true` / `false`).
bool boolean(const Val& v);

std::string text(const Val& v);

/// An absolute ROS 2 topic name (`/a/b_1`: letters, digits, `_`, tokens not starting with a
/// digit, no `//`, no trailing `/`), for `red node` (docs/ROS2.md).
std::string ros_topic(const Val& v);

/// Milliseconds or seconds from a file, bounded so the nanosecond count cannot overflow.
Duration ms_value(const Val& v, double ms);

}  // namespace red::loader_detail
