#pragma once
/// \file
/// Where a profile error points in its JSON text. Internal to profile_read.cpp.

#include <cstddef>
#include <string>

namespace red::profile_detail {

/// 1-based line of a byte offset in `text` (nlohmann reports the offset just past the
/// offending character).
int line_of_byte(const std::string& text, std::size_t byte);

/// The line of the value a profile error is about: its message starts with the value's path
/// ("units.encoder[1].p99_us: ..."; "profile" is the document), and "unknown key 'k'" or
/// "missing key" name a key of it. The nearest enclosing value that exists; 0 if none.
int line_of_error(const std::string& text, const std::string& message);

}  // namespace red::profile_detail
