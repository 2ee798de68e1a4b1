#pragma once
/// \file
/// Reading an input file whole, with an Error that names it, and the checks every input
/// text gets before it is parsed (docs/SCENARIOS.md, "Limits").

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "red/core/expected.hpp"

namespace red {

/// The largest input file RED reads (scenario, profile, manifest): 64 MiB. A bigger one (or
/// an endless one, /dev/zero) is an error, not an allocation.
inline constexpr std::size_t kMaxInputBytes = std::size_t{64} << 20;

/// The deepest nesting of brackets a JSON input may have.
inline constexpr int kMaxJsonDepth = 64;

/// The bytes of `path`, at most `max_bytes`. Error{path, 0, "cannot open: …"} for a missing
/// or unreadable file or a directory; an Error naming the limit for a larger file.
Expected<std::string> read_file(const std::string& path, std::size_t max_bytes = kMaxInputBytes);

/// nullopt when `text` is valid UTF-8; else an Error naming `path`, the line and column of
/// the first bad byte. YAML and JSON inputs must be UTF-8, and every name read from them
/// reaches UTF-8 outputs (summary.json, trace.json).
std::optional<Error> check_utf8(std::string_view text, const std::string& path);

/// The line where a second YAML document starts in `text` (a `---` line after content or
/// after a first `---`, or content after a `...` line), or 0 when it holds one. Read from the
/// text, not by a parser: yaml-cpp's LoadAll loops forever on some malformed input.
int second_yaml_document_line(std::string_view text);

/// nullopt when no bracket of the JSON `text` nests deeper than `max_depth` (brackets in
/// strings do not count); else an Error naming `path` and the line where it does. Checked
/// before parsing, so that a deeply nested value cannot exhaust the parser's stack.
std::optional<Error> check_json_depth(std::string_view text, const std::string& path,
                                      int max_depth = kMaxJsonDepth);

}  // namespace red
