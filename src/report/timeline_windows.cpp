/// \file
/// The windows a timeline is drawn over: `--timeline FROM:TO` read, and the default windows
/// (the first 2 s after the warm-up, and 2 s around the worst miss). The drawing is timeline.cpp.

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "red/report/timeline.hpp"

namespace red {

namespace {

// `text` as a number of seconds (finite, a plain decimal).
std::optional<double> parse_seconds(const std::string& text) {
  if (text.empty()) return std::nullopt;
  double v = 0;
  const char* end = text.data() + text.size();
  const auto [p, ec] = std::from_chars(text.data(), end, v);
  if (ec != std::errc{} || p != end || !std::isfinite(v)) return std::nullopt;
  return v;
}

// QoE of a decided job for ranking misses: a late job's own, 0 without a result.
double miss_score(const JobRow& j) {
  return j.outcome == JobOutcome::Missed ? j.qoe : 0.0;
}

}  // namespace

Expected<std::pair<Duration, Duration>> parse_timeline_window(const std::string& text) {
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos)
    return Error{"", 0, "--timeline: expected FROM:TO in seconds (e.g. 2:4), got '" + text + "'"};
  const auto from = parse_seconds(text.substr(0, colon));
  const auto to = parse_seconds(text.substr(colon + 1));
  if (!from || !to)
    return Error{"", 0, "--timeline: FROM and TO must be numbers of seconds, got '" + text + "'"};
  if (*from < 0) return Error{"", 0, "--timeline: FROM must be 0 or more, got '" + text + "'"};
  if (*to <= *from) return Error{"", 0, "--timeline: TO must be after FROM, got '" + text + "'"};
  if (*to - *from > 60)
    return Error{
        "", 0,
        "--timeline: a window of at most 60 s (the drawing would be unreadable and huge), got '" +
            text + "'"};
  return std::pair<Duration, Duration>{from_s(*from), from_s(*to)};
}

std::vector<TimelineWindow> default_timeline_windows(const Scenario& s,
                                                     const std::vector<TimelineRun>& runs) {
  const Duration span = std::chrono::seconds{2};
  TimePoint end = s.warmup;
  for (const TimelineRun& r : runs) end = std::max(end, r.end);
  if (end <= s.warmup) end = s.warmup + span;
  std::vector<TimelineWindow> out;
  out.push_back({s.warmup, std::min(end, s.warmup + span), "timeline_start",
                 "Timeline: the first 2 s after the warm-up", ""});
  // The worst miss: lowest QoE, earliest release on ties, over every run.
  const JobRow* worst = nullptr;
  std::string worst_policy;
  for (const TimelineRun& r : runs) {
    if (r.jobs == nullptr) continue;
    for (const JobRow& j : *r.jobs) {
      if (j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Unfinished) continue;
      if (worst == nullptr || miss_score(j) < miss_score(*worst) ||
          (miss_score(j) == miss_score(*worst) && j.release < worst->release)) {
        worst = &j;
        worst_policy = r.policy;
      }
    }
  }
  if (worst == nullptr) return out;
  // The moment it missed: its deadline, or its finish when that is earlier (a skipped
  // release). The window starts 0.3 s before it, so that the miss and what led to it are
  // in view when the page opens (the drawing scrolls sideways), and runs 1.7 s after.
  const TimePoint at = std::min(worst->deadline, worst->finish);
  TimePoint from = std::max(s.warmup, at - std::chrono::milliseconds{300});
  const TimePoint to = std::min(end, from + span);
  from = std::max(s.warmup, std::min(from, to - span));
  const std::string what =
      fmt::format("{} {}#{} ({} at {:.3f} s)", worst_policy, s.operation_name(worst->operation),
                  worst->seq, to_string(worst->outcome), to_s(at));
  if (from == out.front().from) {
    // The same start: one drawing shows both.
    out.front().to = std::max(out.front().to, to);
    out.front().title += ", with the worst miss, " + what;
    return out;
  }
  out.push_back({from, to, "timeline_worst_miss",
                 fmt::format("Timeline: 2 s around the worst miss, {}", what), ""});
  return out;
}

}  // namespace red
