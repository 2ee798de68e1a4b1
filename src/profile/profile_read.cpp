/// \file
/// Reading a profile's JSON (docs/DESIGN.md, "Profiles"): every field validated, each error
/// naming the value's path and, through profile_where.hpp, its line. Times are microseconds in
/// the file, nanoseconds inside.

#include <cerrno>
#include <cmath>
#include <cstring>
#include <set>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "profile_where.hpp"
#include "red/core/file.hpp"
#include "red/profile/profile.hpp"

namespace red {

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
               "process_cpu_s", "wall_s", "host"},
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
    if (m.contains("host")) out.machine.host = str(m["host"], "quality.machine.host");
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
    return Error{file, profile_detail::line_of_byte(text, e.byte), "JSON syntax error: " + what};
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
      line = profile_detail::line_of_error(text, b.message);
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

}  // namespace red
