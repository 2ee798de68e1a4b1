#pragma once
/// \file
/// One job's story for `red report DIR --why OPERATION#JOB` (docs/REPORTS.md, "Why jobs
/// missed"): its release, deadline and outcome, its units, what ran on the lanes while it
/// had nothing running, by operation and criticality, and its cause (metrics/why.hpp).
///
///     auto ref = parse_job_ref("pedestrian#272", scenario);   // Error: what is wrong
///     std::string text = why_story(scenario, "red", job_row, unit_rows);

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"
#include "red/metrics/metrics.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

/// A job named as `OPERATION#JOB` (units.csv's and the timeline's way): (operation index,
/// release index). Error: no '#', a JOB that is not a whole number, an unknown operation
/// (the message lists the scenario's).
Expected<std::pair<int, std::uint64_t>> parse_job_ref(const std::string& text, const Scenario& s);

/// The story of `job`, a row of `policy`'s run with its unit rows `units`, as text lines.
std::string why_story(const Scenario& s, const std::string& policy, const JobRow& job,
                      const std::vector<UnitRow>& units);

}  // namespace red
