/// \file
/// Profiles (docs/DESIGN.md, "Profiles"): latency lookup and quantiles, the built-in default costs,
/// the check that a profile covers a scenario and the profile's model label. JSON reading is
/// profile_read.cpp, writing profile_write.cpp. Times are microseconds in the file, nanoseconds
/// inside.

#include "red/profile/profile.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "red/core/assert.hpp"
#include "red/core/rng.hpp"

namespace red {

LatencyStats LatencyStats::scaled(double f) const noexcept {
  LatencyStats o = *this;
  for (Duration LatencyStats::*m : {&LatencyStats::min, &LatencyStats::mean, &LatencyStats::p50,
                                    &LatencyStats::p95, &LatencyStats::p99, &LatencyStats::max})
    o.*m = scaled_by(this->*m, f);
  return o;
}

Duration LatencyStats::estimate(EstimateKind k) const noexcept {
  switch (k) {
    case EstimateKind::Mean:
      return mean;
    case EstimateKind::P95:
      return p95;
    case EstimateKind::P99:
      return p99;
    case EstimateKind::Max:
      return max;
  }
  return p99;
}

Duration LatencyStats::quantile(double u) const noexcept {
  // Piecewise-linear inverse CDF through the measured knots.
  const std::array<std::pair<double, Duration>, 5> knots{
      {{0.0, min}, {0.5, p50}, {0.95, p95}, {0.99, p99}, {1.0, max}}};
  if (!(u > 0.0)) return min;  // also catches NaN
  if (u >= 1.0) return max;
  for (std::size_t i = 1; i < knots.size(); ++i) {
    const auto& [u1, d1] = knots[i];
    if (u > u1) continue;
    const auto& [u0, d0] = knots[i - 1];
    const double f = (u - u0) / (u1 - u0);
    const double ns = static_cast<double>(d0.count()) + f * static_cast<double>((d1 - d0).count());
    return Duration{static_cast<std::int64_t>(std::llround(ns))};
  }
  return max;
}

Duration table_quantile(const std::vector<Duration>& table, double u) noexcept {
  RED_ASSERT(!table.empty());
  if (table.size() == 1 || !(u > 0.0)) return table.front();
  if (u >= 1.0) return table.back();
  const double x = u * static_cast<double>(table.size() - 1);
  const auto i = static_cast<std::size_t>(x);
  if (i + 1 >= table.size()) return table.back();
  const double f = x - static_cast<double>(i);
  const double ns = static_cast<double>(table[i].count()) +
                    f * static_cast<double>((table[i + 1] - table[i]).count());
  return Duration{static_cast<std::int64_t>(std::llround(ns))};
}

const std::vector<Duration>* Calibration::table(const std::string& unit, int batch) const noexcept {
  const auto it = residual.find(unit);
  if (it == residual.end() || batch < 1 || batch > static_cast<int>(it->second.size()))
    return nullptr;
  const std::vector<Duration>& t = it->second[static_cast<std::size_t>(batch - 1)];
  return t.empty() ? nullptr : &t;
}

double Calibration::factor_at(TimePoint t, std::uint64_t seed) const noexcept {
  if (factors.empty() || block <= Duration{0}) return 1.0;
  // A stationary block bootstrap: time is cut into runs of `run_blocks` blocks; each run
  // replays a stretch of the measured factors from a start drawn from (seed, run).
  const std::int64_t b = std::max<std::int64_t>(0, t.count() / block.count());
  const std::int64_t len = std::max(1, run_blocks);
  const auto run = static_cast<std::uint64_t>(b / len);
  const auto n = factors.size();
  const std::uint64_t start = hash_combine(hash_combine(seed, 0x46414354ULL), run) % n;
  return factors[(start + static_cast<std::uint64_t>(b % len)) % n];
}

const LatencyStats& UnitProfile::at(int batch) const noexcept {
  RED_ASSERT(!by_batch.empty());
  const int b = std::clamp(batch, 1, max_batch());
  return by_batch[static_cast<std::size_t>(b - 1)];
}

const UnitProfile* Profile::find(const std::string& name) const noexcept {
  const auto it = units.find(name);
  return it == units.end() ? nullptr : &it->second;
}

// ---- the built-in default -----------------------------------------------------------------

// Default profile: the ONE place where built-in unit costs live.
//
// These are illustrative CPU-scale costs for the built-in MIMONet at input 3x192x384,
// chosen so that the shared encoder dominates every head (as in the paper), so that the
// simulator can run with no measurement. They are not measurements of any machine:
// `red profile` measures real ones and a scenario's `profile:` key selects them.
//
// Per unit, batch size 1 (milliseconds):      mean    p99
//   encoder                                   12.0   14.0
//   head/lane                                  3.0    3.6
//   head/seg                                   4.0    4.8
//   head/steer                                 0.6    0.75
//   head/det                                   4.5    5.4
// The other statistics follow from mean and p99: min = 0.9 mean, p50 = mean,
// p95 = mean + 0.6 (p99 - mean), max = 1.15 p99.
// Batch b in 1..4 costs (1 + 0.55 (b - 1)) times the single run, statistic by statistic.
// coarse/<h> = encoder + head/<h> statistic by statistic; separate/<h> = coarse/<h>.
// One synchronizer round trip: 50 us.
namespace {

constexpr int kDefaultMaxBatch = 4;
constexpr double kBatchGrowth = 0.55;

LatencyStats default_stats(double mean_ms, double p99_ms, int batch) {
  const double k = 1.0 + kBatchGrowth * static_cast<double>(batch - 1);
  LatencyStats s;
  s.min = from_ms(0.9 * mean_ms * k);
  s.mean = from_ms(mean_ms * k);
  s.p50 = from_ms(mean_ms * k);
  s.p95 = from_ms((mean_ms + 0.6 * (p99_ms - mean_ms)) * k);
  s.p99 = from_ms(p99_ms * k);
  s.max = from_ms(p99_ms * 1.15 * k);
  s.samples = 0;
  return s;
}

UnitProfile default_unit(double mean_ms, double p99_ms) {
  UnitProfile u;
  for (int b = 1; b <= kDefaultMaxBatch; ++b)
    u.by_batch.push_back(default_stats(mean_ms, p99_ms, b));
  return u;
}

LatencyStats sum(const LatencyStats& a, const LatencyStats& b) {
  LatencyStats s;
  s.min = a.min + b.min;
  s.mean = a.mean + b.mean;
  s.p50 = a.p50 + b.p50;
  s.p95 = a.p95 + b.p95;
  s.p99 = a.p99 + b.p99;
  s.max = a.max + b.max;
  s.samples = std::min(a.samples, b.samples);
  return s;
}

}  // namespace

Profile default_profile() {
  Profile p;
  p.source = "builtin-default";
  p.device = "reference CPU (illustrative)";
  p.model = "mimonet [3,192,384]";
  p.sync_round_trip = std::chrono::microseconds{50};
  const UnitProfile encoder = default_unit(12.0, 14.0);
  p.units["encoder"] = encoder;
  const std::array<std::tuple<const char*, double, double>, 4> heads{{
      {"lane", 3.0, 3.6},
      {"seg", 4.0, 4.8},
      {"steer", 0.6, 0.75},
      {"det", 4.5, 5.4},
  }};
  for (const auto& [name, mean_ms, p99_ms] : heads) {
    const UnitProfile head = default_unit(mean_ms, p99_ms);
    UnitProfile coarse;
    for (int b = 1; b <= kDefaultMaxBatch; ++b)
      coarse.by_batch.push_back(sum(encoder.at(b), head.at(b)));
    p.units[std::string("head/") + name] = head;
    p.units[std::string("coarse/") + name] = coarse;
    p.units[std::string("separate/") + name] = coarse;
  }
  return p;
}

std::optional<Error> check_profile_covers(const Profile& p, const Scenario& s) {
  // Every inference node of every snapshot, initial or produced by an event.
  std::vector<const OperationSpec*> snapshots;
  for (const auto& op : s.initial)
    if (op) snapshots.push_back(op.get());
  for (const auto& ev : s.events)
    for (const auto& [index, op] : ev.changes)
      if (op) snapshots.push_back(op.get());
  const std::string file = s.profile.empty() ? s.file : s.profile;
  std::set<std::string> checked;
  for (const OperationSpec* op : snapshots) {
    for (const auto& node : op->nodes) {
      if (node.is_plain()) continue;
      const std::string head = s.model.heads.at(static_cast<std::size_t>(node.head));
      for (const std::string& unit : {std::string("encoder"), "head/" + head}) {
        if (!checked.insert(unit).second) continue;
        if (p.find(unit) == nullptr)
          return Error{
              file, 0,
              fmt::format("the profile ({}) has no unit '{}', needed by node '{}' of "
                          "operation '{}'",
                          p.source.empty() ? "unnamed" : p.source, unit, node.name, op->name)};
      }
    }
  }
  return std::nullopt;
}

namespace {

std::string label_text(const ProfileLabel& l) {
  return l.model + " " + shape_label(l.input) + (l.separate ? " separate" : "");
}

}  // namespace

std::optional<ProfileLabel> parse_profile_label(const std::string& label) {
  // "<model> [C,H,W]" with an optional " separate"; the model's name may hold spaces (a
  // manifest's file name), so the shape is found from the end.
  std::string rest = label;
  ProfileLabel out;
  const std::string sep = " separate";
  if (rest.size() > sep.size() && rest.compare(rest.size() - sep.size(), sep.size(), sep) == 0) {
    out.separate = true;
    rest.resize(rest.size() - sep.size());
  }
  if (rest.empty() || rest.back() != ']') return std::nullopt;
  const std::size_t open = rest.rfind(" [");
  if (open == std::string::npos || open == 0) return std::nullopt;
  out.model = rest.substr(0, open);
  const std::string dims = rest.substr(open + 2, rest.size() - open - 3);
  std::size_t at = 0;
  while (at <= dims.size()) {
    const std::size_t comma = std::min(dims.find(',', at), dims.size());
    std::int64_t v = 0;
    const char* first = dims.data() + at;
    const char* last = dims.data() + comma;
    const auto [ptr, ec] = std::from_chars(first, last, v);
    if (first == last || ec != std::errc{} || ptr != last || v <= 0) return std::nullopt;
    out.input.push_back(v);
    at = comma + 1;
  }
  if (out.input.size() != 3) return std::nullopt;
  return out;
}

std::string scenario_model_label(const Scenario& s) {
  const std::string name = s.model.manifest.empty()
                               ? s.model.builtin
                               : std::filesystem::path(s.model.manifest).filename().string();
  return name + " " + shape_label(s.model.input);
}

ProfileIdentity check_profile_identity(const Profile& p, const Scenario& s,
                                       const std::optional<std::string>& cli_path) {
  ProfileIdentity r;
  const bool builtin_default = !cli_path && s.profile.empty();
  const std::string path = cli_path ? *cli_path : s.profile;
  const std::string named = builtin_default ? "the built-in default profile" : "profile " + path;
  if (s.model.heads.empty()) {
    // No model: plain nodes only, whose costs the scenario gives.
    r.checked = "profile identity: not checked (the scenario runs no model)";
    return r;
  }
  const std::string ours = scenario_model_label(s);
  const auto label = parse_profile_label(p.model);
  if (!label) {
    r.warning = fmt::format(
        "{} does not say which model it was measured on (its model is '{}', not "
        "'NAME [C,H,W]' as red profile writes it): not checked against the scenario's "
        "model, {}",
        named, p.model, ours);
    r.checked = fmt::format(
        "profile identity: not checked ('{}' is not a label red profile "
        "writes)",
        p.model);
    return r;
  }
  const std::string model = s.model.manifest.empty()
                                ? s.model.builtin
                                : std::filesystem::path(s.model.manifest).filename().string();
  const bool same_model = label->model == model;
  const bool same_input = label->input == s.model.input;
  const std::string theirs = label_text(*label);
  r.checked =
      fmt::format("profile identity: {} is of {}, the scenario's model is {}", named, theirs, ours);
  if (same_model && same_input) return r;
  const std::string what = same_model ? "another input size" : "another model";
  const std::string measure =
      s.model.manifest.empty()
          ? fmt::format("red profile --input {},{},{} --out P.json", s.model.input.at(0),
                        s.model.input.at(1), s.model.input.at(2))
          : "red profile --model " + s.model.manifest + " --out P.json";
  if (builtin_default && same_model) {
    // The built-in model at another input: the default profile stands in, as documented.
    r.warning = fmt::format(
        "{} is of {}; the scenario's model is {}: its costs are of another input size "
        "(measure one: {}, then profile: P.json)",
        named, theirs, ours, measure);
    return r;
  }
  const std::string message = fmt::format(
      "{} is of {}; the scenario's model is {} ({}: its costs are not this "
      "model's; measure one: {})",
      named, theirs, ours, what, measure);
  if (cli_path)
    r.error = Error{"", 0, "--profile: " + message};
  else
    r.error = Error{s.file, s.profile_line > 0 ? s.profile_line : s.model.line, message};
  return r;
}

}  // namespace red
