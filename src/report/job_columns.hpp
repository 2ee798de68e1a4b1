#pragma once
/// \file
/// jobs.csv's columns, listed once: each column's name, how a row writes it and how a row read
/// back sets it. The header, the writer (report.cpp) and the reader (stream.cpp) all walk this
/// list, so a new column is one entry. Internal to report/.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red::report_detail {

/// A CSV field (RFC 4180): quoted when it holds a comma, a quote or a line break.
std::string csv(std::string_view v);

/// One column of jobs.csv.
struct JobColumn {
  /// The column's name in the header.
  const char* name;
  /// Appends the column's field of `j`, a row of `policy`'s run, to `out` (no separator).
  void (*write)(std::string& out, const Scenario& s, const std::string& policy, const JobRow& j);
  /// Sets the column's field in `r` from its text; the problem when the text is not one.
  /// nullptr when reading back ignores the column (the policy groups the rows; the response
  /// follows from release and finish). A malformed number throws (the reader reports it).
  std::optional<std::string> (*read)(const Scenario& s, const std::string& text, JobRow& r);
};

/// jobs.csv's columns in order.
extern const std::array<JobColumn, 14> kJobColumns;

/// The columns every jobs.csv has: a file written before `cause` and `cause_ms` were added
/// stops after them, and is read with those two empty.
inline constexpr std::size_t kJobColumnsRequired = 12;

}  // namespace red::report_detail
