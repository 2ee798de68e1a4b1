/// \file
/// One job's story for `red report --why` (docs/REPORTS.md, "Why jobs missed").

#include "red/report/why_text.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>

#include <fmt/format.h>

#include "red/metrics/why.hpp"

namespace red {

Expected<std::pair<int, std::uint64_t>> parse_job_ref(const std::string& text, const Scenario& s) {
  const std::size_t hash = text.rfind('#');
  if (hash == std::string::npos || hash == 0 || hash + 1 >= text.size())
    return Error{"", 0,
                 "--why " + text +
                     ": not a job; give OPERATION#JOB, as units.csv names jobs "
                     "(e.g. " +
                     (s.operation_count() > 0 ? s.operation_name(0) : "navigate") + "#12)"};
  const std::string seq = text.substr(hash + 1);
  if (seq.size() > 18 || !std::all_of(seq.begin(), seq.end(), [](char c) {
        return std::isdigit(static_cast<unsigned char>(c)) != 0;
      }))
    return Error{"", 0, "--why " + text + ": JOB '" + seq + "' is not a whole number"};
  const std::string op = text.substr(0, hash);
  std::string known;
  for (int i = 0; i < s.operation_count(); ++i) {
    if (s.operation_name(i) == op) return std::pair<int, std::uint64_t>{i, std::stoull(seq)};
    known += (known.empty() ? "" : ", ") + s.operation_name(i);
  }
  return Error{
      "", 0,
      "--why " + text + ": no operation '" + op + "' in this run (its operations: " + known + ")"};
}

std::string why_story(const Scenario& s, const std::string& policy, const JobRow& job,
                      const std::vector<UnitRow>& units) {
  const WhyIndex index(s, units);
  const JobWhy w = index.explain(job);
  std::string out;
  auto line = [&out](const std::string& text) { out += text + "\n"; };
  auto ms = [](TimePoint t) { return fmt::format("{:.3f}", to_ms(t)); };
  line(fmt::format("{}#{} under {} (criticality {} at its release)",
                   s.operation_name(job.operation), job.seq, policy,
                   criticality_at(s, job.operation, job.release)));
  line(fmt::format("  released {} ms, deadline {} ms (relative deadline {:.3f} ms)",
                   ms(job.release), ms(job.deadline), to_ms(job.deadline - job.release)));
  switch (job.outcome) {
    case JobOutcome::Met:
    case JobOutcome::Missed:
      line(
          fmt::format("  outcome {}: finished {} ms, response {:.3f} ms, {:.3f} ms {} its deadline",
                      to_string(job.outcome), ms(job.finish), to_ms(job.finish - job.release),
                      std::abs(to_ms(job.finish - job.deadline)),
                      job.finish > job.deadline ? "past" : "before"));
      break;
    default:
      line(fmt::format("  outcome {} at {} ms{}", to_string(job.outcome), ms(job.finish),
                       job.reason.empty() ? std::string() : " (" + job.reason + ")"));
      break;
  }
  if (job.outcome == JobOutcome::Met) {
    line("  it met its deadline: no cause");
  } else {
    // jobs.csv's cause when it has one (the same rules, unrounded times), else this one.
    line("  cause: " + (job.cause.empty() ? w.cause : job.cause));
  }
  if (!w.by_rule && job.outcome != JobOutcome::Met) {
    line(fmt::format("  lane time from {} to {} ms, by share (ms):", ms(w.from), ms(w.to)));
    std::string shares;
    for (std::size_t k = 0; k < kWhyShares; ++k)
      shares += fmt::format("{}{} {:.3f}", shares.empty() ? "    " : ", ",
                            why_key(static_cast<WhyShare>(k)), to_ms(w.shares[k]));
    line(shares);
  }
  if (w.units.empty()) {
    line("  its units: none recorded (none started after the warm-up, or units.csv has none)");
  } else {
    line("  its units:");
    line(fmt::format("    {:>8} {:>4} {:<12} {:>12} {:>12} {:>12} {:>9} {:>9} {:>9}  {}",
                     "dispatch", "lane", "kind", "decided ms", "start ms", "end ms", "ran ms",
                     "expect ms", "over ms", "status"));
    for (const WhyUnit& u : w.units) {
      const UnitRow& r = *u.unit;
      std::string kind = to_string(r.kind);
      if (r.head >= 0 && static_cast<std::size_t>(r.head) < s.model.heads.size())
        kind += " " + s.model.heads[static_cast<std::size_t>(r.head)];
      line(fmt::format("    {:>8} {:>4} {:<12} {:>12} {:>12} {:>12} {:>9.3f} {:>9} {:>9.3f}  {}{}",
                       r.dispatch, r.lane, kind, ms(r.decided), ms(r.start), ms(r.end),
                       to_ms(r.end - r.start),
                       r.expected > Duration{0} ? fmt::format("{:.3f}", to_ms(r.expected)) : "-",
                       to_ms(u.overrun), to_string(r.status),
                       r.members > 1 ? fmt::format(" (with {})", r.jobs) : std::string()));
    }
  }
  if (!w.by_rule && job.outcome != JobOutcome::Met) {
    if (w.others.empty()) {
      line("  other work while it had nothing running: none");
    } else {
      line("  other work while it had nothing running (lane time, most first):");
      line(fmt::format("    {:<24} {:>11} {:>10}", "operation", "criticality", "lane ms"));
      for (const WhyOther& o : w.others)
        line(fmt::format("    {:<24} {:>11} {:>10.3f}", s.operation_name(o.operation),
                         o.criticality, to_ms(o.lane)));
    }
  }
  return out;
}

}  // namespace red
