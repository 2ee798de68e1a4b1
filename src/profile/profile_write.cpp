/// \file
/// Writing a profile's JSON (docs/DESIGN.md, "Profiles"): keys in reading order, units
/// encoder first. Times are microseconds in the file, nanoseconds inside.

#include <cmath>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "red/profile/profile.hpp"

namespace red {

namespace {

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
    if (!m.host.empty()) o["machine"]["host"] = m.host;
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

}  // namespace red
