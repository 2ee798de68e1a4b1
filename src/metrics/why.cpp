/// \file
/// Why each job missed (docs/REPORTS.md, "Why jobs missed"): the rule that shed it, or the
/// lane time between its release and its deadline by share.

#include "red/metrics/why.hpp"

#include <algorithm>
#include <cctype>
#include <iterator>
#include <string_view>

#include <fmt/format.h>

namespace red {

namespace {

constexpr std::array<const char*, kWhyShares> kLabels = {"its own work",
                                                         "cost overrun",
                                                         "held back by the scheduler",
                                                         "higher-criticality work ahead",
                                                         "equal-criticality work ahead",
                                                         "its operation's earlier jobs",
                                                         "lower-criticality work ahead"};
constexpr std::array<const char*, kWhyShares> kKeys = {"own",   "overrun", "held", "higher",
                                                       "equal", "same-op", "lower"};

// A time interval [from, to).
struct Span {
  TimePoint from{0}, to{0};
};

// [a, b) ∩ [lo, hi) as a length (0 when they do not meet).
Duration overlap(TimePoint a, TimePoint b, TimePoint lo, TimePoint hi) {
  const TimePoint f = std::max(a, lo);
  const TimePoint t = std::min(b, hi);
  return t > f ? t - f : Duration{0};
}

// The length of [a, b) outside every span of `busy` (sorted, disjoint).
Duration outside(TimePoint a, TimePoint b, const std::vector<Span>& busy) {
  if (b <= a) return Duration{0};
  Duration d = b - a;
  for (const Span& s : busy) d -= overlap(a, b, s.from, s.to);
  return std::max(d, Duration{0});
}

// The cause of a job shed by a rule (its reason), or empty when lane time explains it.
std::string rule_cause(const JobRow& j) {
  switch (j.outcome) {
    case JobOutcome::Met:
    case JobOutcome::Missed:
      return {};
    case JobOutcome::Unfinished:
      return "unfinished at the end of the run";
    case JobOutcome::Failed:
      return "failed: " + (j.reason.empty() ? std::string("unknown") : j.reason);
    case JobOutcome::Skipped:
    case JobOutcome::Dropped:
      break;
  }
  if (j.reason == "rejected at release") return "admission: rejected at release";
  if (j.reason == "hopeless") return "hopeless: shed at dispatch";
  if (j.reason == "max_inflight") return "max_inflight: release skipped";
  if (j.reason.empty() || j.reason == "deadline passed") {
    // A skipped job without a reason is still a rule's; a drop at its deadline is explained
    // by what ran before it.
    return j.outcome == JobOutcome::Skipped ? std::string("skipped") : std::string();
  }
  return j.reason;
}

}  // namespace

const char* why_label(WhyShare s) noexcept {
  return kLabels[static_cast<std::size_t>(s)];
}

const char* why_key(WhyShare s) noexcept {
  return kKeys[static_cast<std::size_t>(s)];
}

int criticality_at(const Scenario& s, int op, TimePoint t) {
  if (op < 0 || op >= s.operation_count()) return 0;
  const OperationSpec* spec = s.initial[static_cast<std::size_t>(op)].get();
  // Events are in time order; an event at `t` has taken effect for a job released at `t`.
  for (const EventSpec& e : s.events) {
    if (e.at > t) break;
    for (const auto& [changed, snapshot] : e.changes)
      if (changed == op && snapshot != nullptr) spec = snapshot.get();
  }
  return spec != nullptr ? spec->criticality : 0;
}

std::string JobWhy::breakdown() const {
  std::string out;
  if (by_rule) return out;
  for (std::size_t i = 0; i < kWhyShares; ++i) {
    if (shares[i] <= Duration{0}) continue;
    if (!out.empty()) out += "; ";
    fmt::format_to(std::back_inserter(out), "{} {:.3f}", kKeys[i], to_ms(shares[i]));
  }
  return out;
}

WhyIndex::WhyIndex(const Scenario& s, const std::vector<UnitRow>& units) : s_(s) {
  std::map<std::string, int, std::less<>> op_of;
  for (int i = 0; i < s.operation_count(); ++i) op_of.emplace(s.operation_name(i), i);
  units_.reserve(units.size());
  for (const UnitRow& u : units) units_.push_back(&u);
  std::stable_sort(units_.begin(), units_.end(),
                   [](const UnitRow* a, const UnitRow* b) { return a->start < b->start; });
  members_.resize(units_.size());
  for (std::size_t i = 0; i < units_.size(); ++i) {
    const UnitRow& u = *units_[i];
    longest_ = std::max(longest_, u.end - u.start);
    // "op#seq:node op#seq:node ...": the operation is what comes before the last '#' of a
    // member, the job what follows it up to ':'.
    std::string_view rest = u.jobs;
    while (!rest.empty()) {
      const std::size_t sp = rest.find(' ');
      const std::string_view tok = rest.substr(0, sp);
      rest = sp == std::string_view::npos ? std::string_view() : rest.substr(sp + 1);
      const std::size_t colon =
          tok.find(':', tok.rfind('#') == std::string_view::npos ? 0 : tok.rfind('#'));
      const std::string_view job = tok.substr(0, colon);
      const std::size_t hash = job.rfind('#');
      if (hash == std::string_view::npos || hash + 1 >= job.size()) continue;
      const auto op = op_of.find(job.substr(0, hash));
      if (op == op_of.end()) continue;
      std::uint64_t seq = 0;
      bool digits = true;
      for (char c : job.substr(hash + 1)) {
        if (std::isdigit(static_cast<unsigned char>(c)) == 0) digits = false;
        seq = seq * 10 + static_cast<std::uint64_t>(c - '0');
      }
      if (!digits) continue;
      members_[i].push_back({op->second, seq});
      auto& own = of_job_[{op->second, seq}];
      // A unit lists a job once per node it runs of it: the unit is the job's once.
      if (own.empty() || own.back() != i) own.push_back(i);
    }
  }
}

JobWhy WhyIndex::explain(const JobRow& j) const {
  JobWhy w;
  if (j.outcome == JobOutcome::Met) return w;
  w.criticality = criticality_at(s_, j.operation, j.release);
  w.from = j.release;
  // The window in which its deadline could still be met: from its release to its deadline,
  // or to its end when it ended before (a drop).
  w.to = std::min(j.deadline, j.outcome == JobOutcome::Missed ? j.deadline : j.finish);
  if (w.to <= w.from) w.to = std::max(j.finish, w.from);
  std::vector<Span> busy;
  if (const auto it = of_job_.find({j.operation, j.seq}); it != of_job_.end()) {
    for (std::size_t i : it->second) {
      const UnitRow& u = *units_[i];
      WhyUnit wu{&u, Duration{0}};
      if (u.expected > Duration{0} && u.end - u.start > u.expected)
        wu.overrun = u.end - u.start - u.expected;
      w.units.push_back(wu);
      const Duration in = overlap(u.start, u.end, w.from, w.to);
      if (in <= Duration{0}) continue;
      // The overrun is the end of the run: the part past start + expected.
      const Duration over = wu.overrun > Duration{0}
                                ? overlap(u.start + u.expected, u.end, w.from, w.to)
                                : Duration{0};
      w.shares[static_cast<std::size_t>(WhyShare::Own)] += in - over;
      w.shares[static_cast<std::size_t>(WhyShare::Overrun)] += over;
      busy.push_back({std::max(u.start, w.from), std::min(u.end, w.to)});
    }
  }
  w.cause = rule_cause(j);
  if (!w.cause.empty()) {
    w.by_rule = true;
    w.shares = {};
    return w;
  }
  // Its running time as disjoint spans (its units may run side by side on several lanes).
  std::sort(busy.begin(), busy.end(), [](const Span& a, const Span& b) { return a.from < b.from; });
  std::vector<Span> merged;
  for (const Span& b : busy) {
    if (!merged.empty() && b.from <= merged.back().to)
      merged.back().to = std::max(merged.back().to, b.to);
    else
      merged.push_back(b);
  }
  // While it had nothing running, each lane ran other work or nothing.
  std::map<std::pair<int, int>, Duration> others;  // (operation, criticality) -> lane time
  Duration other_total{0};
  const auto first = std::lower_bound(units_.begin(), units_.end(), w.from - longest_,
                                      [](const UnitRow* u, TimePoint t) { return u->start < t; });
  for (auto it = first; it != units_.end() && (*it)->start < w.to; ++it) {
    const auto i = static_cast<std::size_t>(it - units_.begin());
    const UnitRow& u = **it;
    const std::vector<Member>& ms = members_[i];
    const bool own = std::any_of(ms.begin(), ms.end(), [&](const Member& m) {
      return m.operation == j.operation && m.seq == j.seq;
    });
    if (own || ms.empty()) continue;
    const Duration lane = outside(std::max(u.start, w.from), std::min(u.end, w.to), merged);
    if (lane <= Duration{0}) continue;
    other_total += lane;
    const Duration share = lane / static_cast<std::int64_t>(ms.size());
    for (const Member& m : ms) {
      const int c = criticality_at(s_, m.operation, u.start);
      WhyShare k = WhyShare::Equal;
      if (m.operation == j.operation)
        k = WhyShare::SameOperation;
      else if (c > w.criticality)
        k = WhyShare::Higher;
      else if (c < w.criticality)
        k = WhyShare::Lower;
      w.shares[static_cast<std::size_t>(k)] += share;
      others[{m.operation, c}] += share;
    }
  }
  const auto lanes = static_cast<std::int64_t>(std::max(1, s_.device.lanes));
  const Duration waiting = outside(w.from, w.to, merged);
  w.shares[static_cast<std::size_t>(WhyShare::Held)] =
      std::max(Duration{0}, waiting * lanes - other_total);
  for (const auto& [key, lane] : others) w.others.push_back({key.first, key.second, lane});
  std::stable_sort(w.others.begin(), w.others.end(),
                   [](const WhyOther& a, const WhyOther& b) { return a.lane > b.lane; });
  std::size_t top = kWhyShares;
  for (std::size_t k = 0; k < kWhyShares; ++k)
    if (w.shares[k] > Duration{0} && (top == kWhyShares || w.shares[k] > w.shares[top])) top = k;
  w.cause = top == kWhyShares ? std::string("no lane time recorded") : std::string(kLabels[top]);
  return w;
}

void WhyIndex::annotate(JobRow& j) const {
  const JobWhy w = explain(j);
  j.cause = w.cause;
  j.cause_ms = w.breakdown();
}

void annotate_causes(const Scenario& s, std::vector<JobRow>& jobs,
                     const std::vector<UnitRow>& units) {
  const WhyIndex why(s, units);
  for (JobRow& j : jobs) why.annotate(j);
}

std::vector<std::pair<std::string, std::int64_t>> top_causes(
    const std::map<std::string, std::int64_t>& counts) {
  std::vector<std::pair<std::string, std::int64_t>> out(counts.begin(), counts.end());
  std::stable_sort(out.begin(), out.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return out;
}

}  // namespace red
