/// \file
/// jobs.csv's columns (docs/REPORTS.md): name, writer and reader of each, in order.

#include "job_columns.hpp"

#include <iterator>

#include <fmt/format.h>

#include "red/core/time.hpp"

namespace red::report_detail {

std::string csv(std::string_view v) {
  if (v.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(v);
  std::string q = "\"";
  for (char c : v) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + '"';
}

namespace {

using Out = std::string;
using Text = std::string;

// A job that completed, met or missed: its finish, response, QoE and frame age are written.
bool done(const JobRow& j) {
  return j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
}

void ms(Out& out, Duration d) {
  fmt::format_to(std::back_inserter(out), "{:.6f}", to_ms(d));
}

TimePoint at_ms(const Text& v) {
  return TimePoint{from_ms(std::stod(v))};
}

}  // namespace

const std::array<JobColumn, 14> kJobColumns{{
    {"policy",
     [](Out& out, const Scenario&, const std::string& policy, const JobRow&) {
       out += csv(policy);
     },
     nullptr},
    {"operation",
     [](Out& out, const Scenario& s, const std::string&, const JobRow& j) {
       out += csv(s.operation_name(j.operation));
     },
     [](const Scenario& s, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.operation = -1;
       for (int i = 0; i < s.operation_count(); ++i)
         if (s.operation_name(i) == v) r.operation = i;
       if (r.operation < 0) return "unknown operation '" + v + "'";
       return std::nullopt;
     }},
    {"job",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       fmt::format_to(std::back_inserter(out), "{}", j.seq);
     },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.seq = std::stoull(v);
       return std::nullopt;
     }},
    {"release_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { ms(out, j.release); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.release = at_ms(v);
       return std::nullopt;
     }},
    {"finish_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       if (done(j)) ms(out, j.finish);
     },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       if (!v.empty()) r.finish = at_ms(v);
       return std::nullopt;
     }},
    {"deadline_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { ms(out, j.deadline); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.deadline = at_ms(v);
       return std::nullopt;
     }},
    {"outcome",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       out += to_string(j.outcome);
     },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       bool known = false;
       for (JobOutcome o : {JobOutcome::Met, JobOutcome::Missed, JobOutcome::Dropped,
                            JobOutcome::Skipped, JobOutcome::Failed, JobOutcome::Unfinished})
         if (v == to_string(o)) {
           r.outcome = o;
           known = true;
         }
       if (!known) return "unknown outcome '" + v + "'";
       return std::nullopt;
     }},
    {"response_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       if (done(j)) ms(out, j.finish - j.release);
     },
     nullptr},
    {"qoe",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       if (done(j))
         fmt::format_to(std::back_inserter(out), "{:.6f}", j.qoe);
       else
         out += '0';
     },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.qoe = std::stod(v);
       return std::nullopt;
     }},
    {"frame_age_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) {
       if (done(j)) ms(out, j.frame_age);
     },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       if (!v.empty()) r.frame_age = from_ms(std::stod(v));
       return std::nullopt;
     }},
    {"reason",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { out += csv(j.reason); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.reason = v;
       return std::nullopt;
     }},
    // When the job ended: its finish, or when it was dropped, skipped or failed.
    {"ended_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { ms(out, j.finish); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       if (!v.empty()) r.finish = at_ms(v);
       return std::nullopt;
     }},
    // Why it did not meet its deadline (metrics/why.hpp); empty when it met it.
    {"cause",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { out += csv(j.cause); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.cause = v;
       return std::nullopt;
     }},
    {"cause_ms",
     [](Out& out, const Scenario&, const std::string&, const JobRow& j) { out += csv(j.cause_ms); },
     [](const Scenario&, const Text& v, JobRow& r) -> std::optional<std::string> {
       r.cause_ms = v;
       return std::nullopt;
     }},
}};

}  // namespace red::report_detail
