/// \file
/// Profiles (docs/DESIGN.md, "Profiles"): the built-in default costs, JSON reading and writing, and
/// the check that a profile covers a scenario. Times are microseconds in the file, nanoseconds
/// inside.

#include "red/profile/profile.hpp"

#include "red/core/file.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "red/core/assert.hpp"
#include "red/core/rng.hpp"
#include "red/scenario/manifest.hpp"

namespace red {

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

// ---- JSON ---------------------------------------------------------------------------------

namespace {

using nlohmann::json;

/// Thrown inside parse_profile only.
struct Bad {
  std::string message;
};

[[noreturn]] void bad(std::string message) {
  throw Bad{std::move(message)};
}

const json& need(const json& obj, const char* key, const std::string& where) {
  const auto it = obj.find(key);
  if (it == obj.end()) bad(fmt::format("{}: missing key '{}'", where, key));
  return *it;
}

void only_keys(const json& obj, std::initializer_list<const char*> allowed,
               const std::string& where) {
  for (const auto& [key, value] : obj.items()) {
    bool known = false;
    for (const char* a : allowed) known = known || key == a;
    if (known) continue;
    std::string list;
    for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    bad(fmt::format("{}: unknown key '{}' (allowed: {})", where, key, list));
  }
}

// A value as an error message shows it: its JSON, cut to a line (a value may be megabytes).
std::string shown(const json& v) {
  std::string text = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

double num(const json& v, const std::string& where) {
  if (!v.is_number()) bad(where + ": must be a number, got " + shown(v));
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < 0.0) bad(where + ": must be a finite number >= 0, got " + shown(v));
  return x;
}

std::int64_t whole(const json& v, const std::string& where) {
  if (!v.is_number_integer()) bad(where + ": must be an integer, got " + shown(v));
  return v.get<std::int64_t>();
}

std::string str(const json& v, const std::string& where) {
  if (!v.is_string()) bad(where + ": must be a string, got " + shown(v));
  return v.get<std::string>();
}

Duration micros(const json& v, const std::string& where) {
  const double us = num(v, where);
  if (us > 1e15) bad(where + ": is too large");
  return from_us(us);
}

Measurement parse_measurement(const json& m) {
  if (!m.is_object()) bad("measurement: must be an object");
  only_keys(
      m,
      {"timing", "warmup_min", "warmup_max", "tolerance", "window", "device_warmup_s", "unstable"},
      "measurement");
  Measurement out;
  const auto count = [&m](const char* key) {
    if (!m.contains(key)) return 0;
    const std::int64_t n = whole(m[key], std::string("measurement.") + key);
    if (n < 0 || n > 1'000'000'000) bad(fmt::format("measurement.{}: must be in [0, 1e9]", key));
    return static_cast<int>(n);
  };
  if (m.contains("timing")) out.timing = str(m["timing"], "measurement.timing");
  out.warmup_min = count("warmup_min");
  out.warmup_max = count("warmup_max");
  out.window = count("window");
  out.unstable = count("unstable");
  if (m.contains("tolerance")) out.tolerance = num(m["tolerance"], "measurement.tolerance");
  if (m.contains("device_warmup_s"))
    out.device_warmup_s = num(m["device_warmup_s"], "measurement.device_warmup_s");
  return out;
}

/// A number that may be negative (a figure of a finding; other_busy_cpus -1: unknown).
double signed_num(const json& v, const std::string& where) {
  if (!v.is_number()) bad(where + ": must be a number, got " + shown(v));
  const double x = v.get<double>();
  if (!std::isfinite(x)) bad(where + ": must be a finite number, got " + shown(v));
  return x;
}

Quality parse_quality(const json& q) {
  if (!q.is_object()) bad("quality: must be an object");
  only_keys(q, {"verdict", "machine", "findings"}, "quality");
  Quality out;
  out.verdict = str(need(q, "verdict", "quality"), "quality.verdict");
  if (out.verdict != "good" && out.verdict != "suspect")
    bad("quality.verdict: must be \"good\" or \"suspect\", got " + shown(q["verdict"]));
  if (q.contains("machine")) {
    const json& m = q["machine"];
    if (!m.is_object()) bad("quality.machine: must be an object");
    only_keys(m,
              {"online_cpus", "threads", "load1_before", "load1_after", "other_busy_cpus",
               "process_cpu_s", "wall_s"},
              "quality.machine");
    out.has_machine = true;
    const auto count = [&m](const char* key) {
      const std::int64_t n =
          whole(need(m, key, "quality.machine"), std::string("quality.machine.") + key);
      if (n < 0 || n > 1'000'000) bad(fmt::format("quality.machine.{}: must be in [0, 1e6]", key));
      return static_cast<int>(n);
    };
    out.machine.online_cpus = count("online_cpus");
    out.machine.threads = count("threads");
    const auto figure = [&m](const char* key, double& into) {
      if (m.contains(key)) into = num(m[key], std::string("quality.machine.") + key);
    };
    figure("load1_before", out.machine.load1_before);
    figure("load1_after", out.machine.load1_after);
    figure("process_cpu_s", out.machine.process_cpu_s);
    figure("wall_s", out.machine.wall_s);
    if (m.contains("other_busy_cpus"))
      out.machine.other_busy_cpus =
          signed_num(m["other_busy_cpus"], "quality.machine.other_busy_cpus");
  }
  if (q.contains("findings")) {
    const json& fs = q["findings"];
    if (!fs.is_array()) bad("quality.findings: must be an array");
    for (std::size_t i = 0; i < fs.size(); ++i) {
      const std::string where = fmt::format("quality.findings[{}]", i);
      const json& f = fs[i];
      if (!f.is_object()) bad(where + ": must be an object");
      only_keys(f, {"unit", "batch", "kind", "figures", "message", "advice"}, where);
      QualityFinding out_f;
      if (f.contains("unit")) out_f.unit = str(f["unit"], where + ".unit");
      if (f.contains("batch")) {
        const std::int64_t b = whole(f["batch"], where + ".batch");
        if (b < 0 || b > 1'000'000) bad(where + ".batch: must be in [0, 1e6]");
        out_f.batch = static_cast<int>(b);
      }
      out_f.kind = str(need(f, "kind", where), where + ".kind");
      if (f.contains("figures")) {
        const json& g = f["figures"];
        if (!g.is_object()) bad(where + ".figures: must be an object");
        for (const auto& [key, v] : g.items())
          out_f.figures.emplace_back(key, signed_num(v, where + ".figures." + key));
      }
      if (f.contains("message")) out_f.message = str(f["message"], where + ".message");
      if (f.contains("advice")) out_f.advice = str(f["advice"], where + ".advice");
      out.findings.push_back(std::move(out_f));
    }
  }
  return out;
}

UnitProfile parse_unit(const json& arr, const std::string& where) {
  if (!arr.is_array() || arr.empty()) bad(where + ": must be a non-empty list of batch sizes");
  UnitProfile u;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const json& e = arr[i];
    const std::string at = fmt::format("{}[{}]", where, i);
    if (!e.is_object()) bad(at + ": must be an object");
    only_keys(e,
              {"batch", "samples", "warmup_runs", "min_us", "mean_us", "p50_us", "p95_us", "p99_us",
               "max_us"},
              at);
    const std::int64_t batch = whole(need(e, "batch", at), at + ".batch");
    if (batch != static_cast<std::int64_t>(i) + 1)
      bad(
          fmt::format("{}: batch sizes must run 1, 2, ... without gaps; entry {} has batch {} "
                      "(expected {})",
                      where, i, batch, i + 1));
    LatencyStats s;
    if (e.contains("samples")) {
      const std::int64_t n = whole(e["samples"], at + ".samples");
      if (n < 0 || n > 1'000'000'000) bad(at + ".samples: must be in [0, 1e9]");
      s.samples = static_cast<int>(n);
    }
    if (e.contains("warmup_runs")) {
      const std::int64_t n = whole(e["warmup_runs"], at + ".warmup_runs");
      if (n < 0 || n > 1'000'000'000) bad(at + ".warmup_runs: must be in [0, 1e9]");
      s.warmup_runs = static_cast<int>(n);
    }
    s.min = micros(need(e, "min_us", at), at + ".min_us");
    s.mean = micros(need(e, "mean_us", at), at + ".mean_us");
    s.p50 = micros(need(e, "p50_us", at), at + ".p50_us");
    s.p95 = micros(need(e, "p95_us", at), at + ".p95_us");
    s.p99 = micros(need(e, "p99_us", at), at + ".p99_us");
    s.max = micros(need(e, "max_us", at), at + ".max_us");
    if (!(s.min <= s.p50 && s.p50 <= s.p95 && s.p95 <= s.p99 && s.p99 <= s.max))
      bad(at + ": statistics must satisfy min <= p50 <= p95 <= p99 <= max");
    if (!(s.min <= s.mean && s.mean <= s.max))
      bad(at + ": statistics must satisfy min <= mean <= max");
    u.by_batch.push_back(s);
  }
  return u;
}

MemoryStats parse_memory(const json& m, const std::string& where) {
  if (!m.is_object()) bad(where + ": must be an object");
  only_keys(m, {"parameter_bytes", "peak_activation_bytes", "resident_bytes"}, where);
  MemoryStats s;
  auto field = [&](const char* key, std::int64_t& out) {
    if (!m.contains(key)) return;
    out = whole(m[key], where + "." + key);
    if (out < 0) bad(where + "." + key + ": must be >= 0");
  };
  field("parameter_bytes", s.parameter_bytes);
  field("peak_activation_bytes", s.peak_activation_bytes);
  field("resident_bytes", s.resident_bytes);
  return s;
}

std::vector<Duration> parse_table(const json& t, const std::string& where) {
  if (!t.is_array() || t.size() < 2 || t.size() > 1001)
    bad(where + ": must be a list of 2 to 1001 quantiles (microseconds)");
  std::vector<Duration> out;
  for (std::size_t i = 0; i < t.size(); ++i) {
    out.push_back(micros(t[i], fmt::format("{}[{}]", where, i)));
    if (i > 0 && out[i] < out[i - 1]) bad(where + ": quantiles must not decrease");
  }
  return out;
}

Calibration parse_calibration(const json& c) {
  const std::string where = "calibration";
  if (!c.is_object()) bad(where + ": must be an object");
  only_keys(c,
            {"scenario", "policies", "seconds_per_policy", "interference", "block_ms", "run_blocks",
             "factors", "lane_factors", "handoff_us", "queued_gap_us", "residual"},
            where);
  Calibration k;
  if (c.contains("scenario")) k.scenario = str(c["scenario"], where + ".scenario");
  if (c.contains("policies")) {
    if (!c["policies"].is_array()) bad(where + ".policies: must be a list of names");
    for (const json& n : c["policies"]) k.policies.push_back(str(n, where + ".policies"));
  }
  if (c.contains("seconds_per_policy"))
    k.seconds_per_policy = num(c["seconds_per_policy"], where + ".seconds_per_policy");
  if (c.contains("interference")) {
    k.interference = num(c["interference"], where + ".interference");
    if (k.interference > 1.0) bad(where + ".interference: must be in [0, 1]");
  }
  if (c.contains("block_ms")) {
    const double ms = num(c["block_ms"], where + ".block_ms");
    if (ms < 1.0 || ms > 60'000.0) bad(where + ".block_ms: must be in [1, 60000]");
    k.block = from_ms(ms);
  }
  if (c.contains("run_blocks")) {
    const std::int64_t r = whole(c["run_blocks"], where + ".run_blocks");
    if (r < 1 || r > 10'000) bad(where + ".run_blocks: must be in [1, 10000]");
    k.run_blocks = static_cast<int>(r);
  }
  auto factor_list = [&](const char* key, std::vector<double>& out) {
    const json& v = c[key];
    const std::string at = where + "." + key;
    if (!v.is_array() || v.size() > 100'000) bad(at + ": must be a list of numbers");
    out.clear();
    for (const json& x : v) {
      const double f = num(x, at);
      if (f < 0.05 || f > 20.0) bad(at + ": factors must lie in [0.05, 20], got " + shown(x));
      out.push_back(f);
    }
  };
  if (c.contains("factors")) factor_list("factors", k.factors);
  if (c.contains("lane_factors")) {
    factor_list("lane_factors", k.lane_factors);
    if (k.lane_factors.empty()) k.lane_factors.push_back(1.0);
  }
  if (c.contains("handoff_us")) k.handoff = micros(c["handoff_us"], where + ".handoff_us");
  if (c.contains("queued_gap_us"))
    k.queued_gap = micros(c["queued_gap_us"], where + ".queued_gap_us");
  if (c.contains("residual")) {
    const json& r = c["residual"];
    if (!r.is_object()) bad(where + ".residual: must be an object of units");
    for (const auto& [name, arr] : r.items()) {
      const std::string at = where + ".residual." + name;
      if (!arr.is_array() || arr.empty() || arr.size() > 64)
        bad(at + ": must be a list of quantile tables, one per batch size");
      auto& tables = k.residual[name];
      for (std::size_t b = 0; b < arr.size(); ++b)
        tables.push_back(parse_table(arr[b], fmt::format("{}[{}]", at, b)));
    }
  }
  return k;
}

// Written with keys in reading order (ordered_json); read back with any order.
using ordered = nlohmann::ordered_json;

ordered stats_json(const LatencyStats& s, int batch) {
  ordered o{{"batch", batch}, {"samples", s.samples}};
  if (s.warmup_runs > 0) o["warmup_runs"] = s.warmup_runs;
  for (const auto& [key, v] :
       {std::pair{"min_us", s.min}, std::pair{"mean_us", s.mean}, std::pair{"p50_us", s.p50},
        std::pair{"p95_us", s.p95}, std::pair{"p99_us", s.p99}, std::pair{"max_us", s.max}})
    o[key] = to_us(v);
  return o;
}

ordered measurement_json(const Measurement& m) {
  return ordered{{"timing", m.timing},         {"warmup_min", m.warmup_min},
                 {"warmup_max", m.warmup_max}, {"tolerance", m.tolerance},
                 {"window", m.window},         {"device_warmup_s", m.device_warmup_s},
                 {"unstable", m.unstable}};
}

ordered quality_json(const Quality& q) {
  ordered o{{"verdict", q.verdict}};
  if (q.has_machine) {
    const MachineState& m = q.machine;
    o["machine"] = ordered{{"online_cpus", m.online_cpus},
                           {"threads", m.threads},
                           {"load1_before", m.load1_before},
                           {"load1_after", m.load1_after},
                           {"other_busy_cpus", m.other_busy_cpus},
                           {"process_cpu_s", m.process_cpu_s},
                           {"wall_s", m.wall_s}};
  }
  ordered fs = ordered::array();
  for (const QualityFinding& f : q.findings) {
    ordered g = ordered::object();
    for (const auto& [key, v] : f.figures) g[key] = std::round(v * 1000) / 1000;
    fs.push_back(ordered{{"unit", f.unit},
                         {"batch", f.batch},
                         {"kind", f.kind},
                         {"figures", std::move(g)},
                         {"message", f.message},
                         {"advice", f.advice}});
  }
  o["findings"] = std::move(fs);
  return o;
}

ordered memory_json(const MemoryStats& m) {
  return ordered{{"parameter_bytes", m.parameter_bytes},
                 {"peak_activation_bytes", m.peak_activation_bytes},
                 {"resident_bytes", m.resident_bytes}};
}

/// 1-based line of a byte offset in `text` (nlohmann reports the offset just past the
/// offending character).
int line_of_byte(const std::string& text, std::size_t byte) {
  const std::size_t end = std::min(byte == 0 ? 0 : byte - 1, text.size());
  return 1 + static_cast<int>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(end), '\n'));
}

/// Where values start in a JSON text that parsed without error: a scanner that follows one
/// path ("units.encoder[1].p99_us") and skips everything else.
class JsonLocator {
 public:
  explicit JsonLocator(const std::string& text) : t_(text) {}

  /// The byte offset of the value at `path` (components: keys, or "[i]" indices), or npos.
  std::size_t find(const std::vector<std::string>& path) {
    i_ = 0;
    space();
    for (const std::string& part : path) {
      if (i_ >= t_.size()) return std::string::npos;
      if (part.front() == '[') {
        if (t_[i_] != '[') return std::string::npos;
        std::size_t want = 0;  // a unit's name may hold '[': not an index then
        const auto [end, ec] = std::from_chars(part.data() + 1, part.data() + part.size(), want);
        if (ec != std::errc{} || end != part.data() + part.size()) return std::string::npos;
        ++i_;
        space();
        for (std::size_t k = 0; k < want; ++k) {
          if (i_ >= t_.size() || t_[i_] == ']') return std::string::npos;
          skip_value();
          space();
          if (i_ < t_.size() && t_[i_] == ',') ++i_;
          space();
        }
        if (i_ >= t_.size() || t_[i_] == ']') return std::string::npos;
        continue;
      }
      if (t_[i_] != '{') return std::string::npos;
      ++i_;
      for (;;) {
        space();
        if (i_ >= t_.size() || t_[i_] != '"') return std::string::npos;
        const std::size_t key_start = i_ + 1;
        skip_string();
        const std::string key = t_.substr(key_start, i_ - 1 - key_start);
        space();
        ++i_;  // ':'
        space();
        if (key == part) break;
        skip_value();
        space();
        if (i_ >= t_.size() || t_[i_] != ',') return std::string::npos;
        ++i_;
      }
    }
    return i_;
  }

 private:
  void space() {
    while (i_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[i_])) != 0) ++i_;
  }
  void skip_string() {  // at '"'; ends past the closing quote
    for (++i_; i_ < t_.size() && t_[i_] != '"'; ++i_)
      if (t_[i_] == '\\') ++i_;
    ++i_;
  }
  void skip_value() {
    if (i_ >= t_.size()) return;
    if (t_[i_] == '"') return skip_string();
    if (t_[i_] == '{' || t_[i_] == '[') {
      int depth = 0;  // the text is valid JSON: brackets balance outside strings
      while (i_ < t_.size()) {
        const char c = t_[i_];
        if (c == '"') {
          skip_string();
          continue;
        }
        if (c == '{' || c == '[') ++depth;
        if (c == '}' || c == ']') --depth;
        ++i_;
        if (depth == 0) return;
      }
      return;
    }
    while (i_ < t_.size() && t_[i_] != ',' && t_[i_] != '}' && t_[i_] != ']' &&
           std::isspace(static_cast<unsigned char>(t_[i_])) == 0)
      ++i_;
  }

  const std::string& t_;
  std::size_t i_ = 0;
};

/// The line of the value a profile error is about: its message starts with the value's path
/// ("units.encoder[1].p99_us: ..."; "profile" is the document), and "unknown key 'k'" or
/// "missing key" name a key of it. The nearest enclosing value that exists; 0 if none.
int line_of_error(const std::string& text, const std::string& message) {
  const std::size_t colon = message.find(": ");
  if (colon == std::string::npos) return 0;
  const std::string where = message.substr(0, colon);
  if (where.find(' ') != std::string::npos) return 0;  // not a path
  std::vector<std::string> path;
  if (where != "profile") {
    std::string part;
    for (const char c : where) {
      if (c == '.' || c == '[') {
        if (!part.empty()) path.push_back(part);
        part = c == '[' ? "[" : "";
      } else if (c != ']') {
        part += c;
      }
    }
    if (!part.empty()) path.push_back(part);
  }
  const std::string unknown = "unknown key '";
  if (message.compare(colon + 2, unknown.size(), unknown) == 0) {
    const std::size_t end = message.find('\'', colon + 2 + unknown.size());
    path.push_back(message.substr(colon + 2 + unknown.size(), end - colon - 2 - unknown.size()));
  }
  JsonLocator locate(text);
  for (;;) {
    const std::size_t at = locate.find(path);
    if (at != std::string::npos) return line_of_byte(text, at + 1);
    if (path.empty()) return 0;
    path.pop_back();
  }
}

}  // namespace

Expected<Profile> parse_profile(const std::string& text, const std::string& file) {
  // Deep nesting would exhaust the parser's stack (it recurses): refused before parsing.
  if (auto e = check_json_depth(text, file)) return *e;
  json doc;
  // A key given twice in one object: JSON parsers keep one of the two silently.
  std::vector<std::set<std::string>> keys;
  std::string duplicate;
  const json::parser_callback_t note_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) {
      keys.emplace_back();
    } else if (event == json::parse_event_t::object_end) {
      if (!keys.empty()) keys.pop_back();
    } else if (event == json::parse_event_t::key && !keys.empty() && duplicate.empty() &&
               !keys.back().insert(parsed.get<std::string>()).second) {
      duplicate = parsed.get<std::string>();
    }
    return true;
  };
  try {
    doc = json::parse(text, note_keys);
    if (!duplicate.empty()) {
      // The line of the key's second appearance in the text.
      const std::string quoted = json(duplicate).dump();
      const std::size_t first = text.find(quoted);
      const std::size_t second =
          first == std::string::npos ? first : text.find(quoted, first + quoted.size());
      const std::size_t at = second == std::string::npos ? 0 : second;
      const int line = 1 + static_cast<int>(std::count(
                               text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
      return Error{file, second == std::string::npos ? 0 : line,
                   "duplicate key " + quoted + " (an object names each key once)"};
    }
  } catch (const json::parse_error& e) {
    // nlohmann's message is "[json.exception.parse_error.101] parse error at line L, column
    // C: what"; the Error carries the line itself, so only "what" is kept.
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    if (what.rfind("parse error", 0) == 0)
      if (const auto p = what.find(": "); p != std::string::npos) what = what.substr(p + 2);
    // The parser quotes what it last read, which may be megabytes of one token.
    if (what.size() > 200) what = what.substr(0, 197) + "...";
    return Error{file, line_of_byte(text, e.byte), "JSON syntax error: " + what};
  } catch (const std::exception& e) {
    std::string what = e.what();  // may quote a whole token (number overflow parsing '…')
    if (what.size() > 200) what = what.substr(0, 197) + "...";
    return Error{file, 0, "cannot parse the profile: " + what};
  }
  try {
    if (!doc.is_object()) bad("a profile must be a JSON object");
    only_keys(doc,
              {"schema", "source", "device", "model", "sync_round_trip_us", "profile_wall_s",
               "measurement", "quality", "units", "memory", "calibration"},
              "profile");
    const json& schema = need(doc, "schema", "profile");
    if (!schema.is_number_integer() || schema.get<std::int64_t>() != Profile::kSchema)
      bad(fmt::format("unsupported profile schema {} (this build reads schema {})", shown(schema),
                      Profile::kSchema));
    Profile p;
    if (doc.contains("source")) p.source = str(doc["source"], "source");
    if (doc.contains("device")) p.device = str(doc["device"], "device");
    if (doc.contains("model")) p.model = str(doc["model"], "model");
    if (doc.contains("sync_round_trip_us"))
      p.sync_round_trip = micros(doc["sync_round_trip_us"], "sync_round_trip_us");
    if (doc.contains("profile_wall_s"))
      p.profile_wall_s = num(doc["profile_wall_s"], "profile_wall_s");
    const json& units = need(doc, "units", "profile");
    if (!units.is_object() || units.empty()) bad("units: must be a non-empty object");
    for (const auto& [name, arr] : units.items()) p.units[name] = parse_unit(arr, "units." + name);
    if (doc.contains("memory")) {
      const json& m = doc["memory"];
      if (!m.is_object()) bad("memory: must be an object");
      only_keys(m, {"shared", "separate"}, "memory");
      if (m.contains("shared")) p.shared_memory = parse_memory(m["shared"], "memory.shared");
      if (m.contains("separate"))
        p.separate_memory = parse_memory(m["separate"], "memory.separate");
    }
    if (doc.contains("calibration")) p.calibration = parse_calibration(doc["calibration"]);
    if (doc.contains("measurement")) p.measurement = parse_measurement(doc["measurement"]);
    if (doc.contains("quality")) p.quality = parse_quality(doc["quality"]);
    return p;
  } catch (const Bad& b) {
    int line = 0;
    try {
      line = line_of_error(text, b.message);
    } catch (const std::exception&) {
      line = 0;  // the message stands without a line
    }
    return Error{file, line, b.message};
  } catch (const std::exception& e) {
    return Error{file, 0, std::string("cannot read the profile: ") + e.what()};
  }
}

Expected<Profile> load_profile(const std::string& path) {
  auto text = read_file(path);
  if (!text) return text.error();
  return parse_profile(text.value(), path);
}

namespace {

/// Units in reading order: encoder, heads, coarse units, separate networks, then others.
int unit_rank(const std::string& name) {
  if (name == "encoder") return 0;
  if (name.rfind("head/", 0) == 0) return 1;
  if (name.rfind("coarse/", 0) == 0) return 2;
  if (name.rfind("separate/", 0) == 0) return 3;
  return 4;
}

}  // namespace

std::string profile_to_json(const Profile& p) {
  ordered doc;
  doc["schema"] = Profile::kSchema;
  doc["source"] = p.source;
  doc["device"] = p.device;
  doc["model"] = p.model;
  doc["sync_round_trip_us"] = to_us(p.sync_round_trip);
  doc["profile_wall_s"] = p.profile_wall_s;
  if (p.measurement) doc["measurement"] = measurement_json(*p.measurement);
  if (p.quality) doc["quality"] = quality_json(*p.quality);
  std::vector<std::pair<int, std::string>> names;
  for (const auto& [name, unit] : p.units) names.emplace_back(unit_rank(name), name);
  std::sort(names.begin(), names.end());
  ordered units = ordered::object();
  for (const auto& [rank, name] : names) {
    const UnitProfile& unit = p.units.at(name);
    ordered arr = ordered::array();
    for (std::size_t i = 0; i < unit.by_batch.size(); ++i)
      arr.push_back(stats_json(unit.by_batch[i], static_cast<int>(i) + 1));
    units[name] = std::move(arr);
  }
  doc["units"] = std::move(units);
  if (p.shared_memory || p.separate_memory) {
    ordered mem = ordered::object();
    if (p.shared_memory) mem["shared"] = memory_json(*p.shared_memory);
    if (p.separate_memory) mem["separate"] = memory_json(*p.separate_memory);
    doc["memory"] = std::move(mem);
  }
  if (p.calibration) {
    const Calibration& k = *p.calibration;
    ordered c = ordered::object();
    c["scenario"] = k.scenario;
    c["policies"] = k.policies;
    c["seconds_per_policy"] = k.seconds_per_policy;
    c["interference"] = k.interference;
    c["block_ms"] = to_ms(k.block);
    c["run_blocks"] = k.run_blocks;
    c["factors"] = k.factors;
    c["lane_factors"] = k.lane_factors;
    c["handoff_us"] = to_us(k.handoff);
    if (k.queued_gap > Duration{0}) c["queued_gap_us"] = to_us(k.queued_gap);
    ordered res = ordered::object();
    for (const auto& [name, tables] : k.residual) {
      ordered arr = ordered::array();
      for (const auto& t : tables) {
        ordered q = ordered::array();
        for (Duration d : t) q.push_back(std::round(to_us(d) * 1000.0) / 1000.0);
        arr.push_back(std::move(q));
      }
      res[name] = std::move(arr);
    }
    c["residual"] = std::move(res);
    doc["calibration"] = std::move(c);
  }
  return doc.dump(2) + "\n";
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
