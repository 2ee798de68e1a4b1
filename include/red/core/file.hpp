#pragma once
/// \file
/// Reading an input file whole, with an Error that names it.

#include <string>

#include "red/core/expected.hpp"

namespace red {

/// The bytes of `path`. Error{path, 0, "cannot open: …"} for a missing or unreadable file
/// or a directory.
Expected<std::string> read_file(const std::string& path);

}  // namespace red
