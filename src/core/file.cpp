#include "red/core/file.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace red {

Expected<std::string> read_file(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return Error{path, 0, "cannot open: it is a directory"};
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path, 0, std::string("cannot open: ") + std::strerror(errno)};
  // Read in pieces up to the limit: a device or a pipe has no size to ask for first.
  std::string text;
  char buffer[1 << 16];
  while (in) {
    in.read(buffer, sizeof buffer);
    text.append(buffer, static_cast<std::size_t>(in.gcount()));
    if (text.size() > max_bytes)
      return Error{path, 0,
                   fmt::format("larger than the {} MiB an input file may be", max_bytes >> 20)};
  }
  if (in.bad()) return Error{path, 0, "cannot read the file"};
  return text;
}

namespace {

// Line (1-based) and column (1-based, in bytes) of byte `at` of `text`.
std::pair<int, std::size_t> line_column(std::string_view text, std::size_t at) {
  int line = 1;
  std::size_t start = 0;
  for (std::size_t i = 0; i < at; ++i)
    if (text[i] == '\n') {
      ++line;
      start = i + 1;
    }
  return {line, at - start + 1};
}

// Length of the UTF-8 sequence at text[i], or 0 when it is not well formed (RFC 3629: no
// overlong forms, no surrogates, nothing past U+10FFFF).
std::size_t utf8_length(std::string_view text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  if (c < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80;
  unsigned char hi = 0xBF;
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  return n;
}

}  // namespace

std::optional<Error> check_utf8(std::string_view text, const std::string& path) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = utf8_length(text, i);
    if (n == 0) {
      const auto [line, column] = line_column(text, i);
      return Error{path, line,
                   fmt::format("column {}: byte 0x{:02x} is not valid UTF-8 (the file must be "
                               "UTF-8 text)",
                               column, static_cast<unsigned>(static_cast<unsigned char>(text[i])))};
    }
    i += n;
  }
  return std::nullopt;
}

int second_yaml_document_line(std::string_view text) {
  const auto marker = [](std::string_view line, std::string_view m) {
    return line.substr(0, 3) == m &&
           (line.size() == 3 || line[3] == ' ' || line[3] == '\t' || line[3] == '\r');
  };
  bool content = false;  // the first document has begun (content or its `---`)
  bool ended = false;    // a `...` closed it
  int number = 0;
  for (std::size_t start = 0; start <= text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    ++number;
    start = end + 1;
    if (marker(line, "---")) {
      if (content) return number;
      content = true;
      continue;
    }
    if (marker(line, "...")) {
      ended = content;
      continue;
    }
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string_view::npos || line[first] == '#') continue;
    if (!content && line[first] == '%') continue;  // a directive before the document
    if (ended) return number;
    content = true;
  }
  return 0;
}

std::optional<Error> check_json_depth(std::string_view text, const std::string& path,
                                      int max_depth) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;  // the escaped character, whatever it is
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth)
        return Error{path, line_column(text, i).first,
                     fmt::format("nested deeper than {} levels", max_depth)};
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return std::nullopt;
}

}  // namespace red
