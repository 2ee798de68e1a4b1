#pragma once
/// \file
/// Error values for loading, configuration and the CLI: a message that names the file,
/// the line and the problem. Bad input never throws past a loader and never crashes.

#include <optional>
#include <string>
#include <utility>
#include <variant>

namespace red {

/// A located error: `file:line: message` when printed.
struct Error {
  std::string file;     ///< the input file, or empty for command-line problems
  int line = 0;         ///< 1-based line, or 0 when the whole file is meant
  std::string message;  ///< what is wrong, in words a user can act on

  /// `file:line: message`, `file: message` or just `message`.
  [[nodiscard]] std::string to_string() const {
    if (file.empty()) return message;
    if (line <= 0) return file + ": " + message;
    return file + ":" + std::to_string(line) + ": " + message;
  }
};

/// Either a value or an Error. A minimal stand-in for C++23 std::expected.
///
///     Expected<Scenario> s = load_scenario("s.yaml");
///     if (!s) { std::cerr << s.error().to_string() << '\n'; return 2; }
template <typename T>
class Expected {
 public:
  Expected(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Expected(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  [[nodiscard]] bool has_value() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return has_value(); }

  [[nodiscard]] T& value() & { return std::get<0>(v_); }
  [[nodiscard]] const T& value() const& { return std::get<0>(v_); }
  [[nodiscard]] T&& value() && { return std::get<0>(std::move(v_)); }
  [[nodiscard]] const Error& error() const { return std::get<1>(v_); }

  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T&& operator*() && { return std::move(*this).value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }

 private:
  std::variant<T, Error> v_;
};

}  // namespace red
