// libFuzzer target: `--set key=value` overrides (apply_override), one per input line,
// parsed as the CLI parses them, applied to a scenario that uses every kind of deadline
// and rate an override reaches. A rejected override must leave the scenario unchanged
// (never half-applies); a scenario that takes the overrides is then simulated briefly.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "fuzz_support.hpp"
#include "red/scenario/loader.hpp"

namespace {

constexpr const char* kBase = R"(name: fuzz-override
duration_s: 4
warmup_s: 1
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  camera: {rate_hz: 20}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 150
    nodes:
      L: {head: lane, sensor: camera, deadline_ms: 40}
      S: {head: seg, sensor: camera}
      C: {head: steer, sensor: camera}
    edges: [[L, S], [S, C]]
  - name: tick
    rate_hz: 10
    deadline_ms: {critical_path_x: 1.5}
    nodes: {X: {cost_ms: 1}, Y: {cost: {mean_ms: 2, p99_ms: 3}}}
    edges: [[X, Y]]
events:
  - {at_s: 1.5, add_nodes: {operation: drive, nodes: {O: {head: det, sensor: camera}}, edges: [[L, O], [O, C]]}}
  - {at_s: 2, set_deadline: {operation: drive, deadline_ms: 200}}
  - {at_s: 2.5, set_deadline: {operation: tick, deadline_ms: {critical_path_x: 2}}}
  - {at_s: 3, set_rate: {sensor: camera, rate_hz: 30}}
  - {at_s: 3.5, set_rate: {operation: tick, rate_hz: 15}}
)";

// Everything an override may change, printed (to check that a rejection changes nothing).
std::string fingerprint(const red::Scenario& s) {
  std::ostringstream o;
  o.precision(17);
  o << s.duration.count() << ' ' << s.warmup.count() << ' ' << s.seed << ' ' << s.device.lanes
    << ' ' << s.scheduler.gamma.count() << ' ' << s.scheduler.qoe_lambda << '|';
  for (const red::SensorSpec& x : s.sensors) o << x.rate_hz << ' ';
  auto op = [&o](const red::OperationSpec* spec) {
    if (spec == nullptr) return;
    o << spec->rate_hz << ' ' << spec->deadline.fixed.count() << ' '
      << spec->deadline.critical_path_x.value_or(-1) << ' ';
    for (const red::NodeSpec& n : spec->nodes) o << (n.deadline ? n.deadline->count() : -1) << ' ';
  };
  for (const auto& spec : s.initial) op(spec.get());
  for (const red::EventSpec& e : s.events) {
    o << '|' << e.at.count() << ' ';
    for (const auto& [sensor, rate] : e.sensor_rates) o << sensor << ':' << rate << ' ';
    for (const auto& [index, spec] : e.changes) op(spec.get());
  }
  return o.str();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const red::Scenario base = [] {
    auto s = red::parse_scenario(kBase, "base.yaml");
    if (!s) red::fuzz::fail("the base scenario does not load");
    return std::move(s).value();
  }();
  red::Scenario s = base;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::string line;
  int applied = 0;
  while (std::getline(in, line) && applied < 8) {
    // As the CLI reads `--set key=value` (tools/red/common.cpp).
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = line.substr(0, eq);
    const std::string val = line.substr(eq + 1);
    char* end = nullptr;
    const double v = std::strtod(val.c_str(), &end);
    if (val.empty() || end == nullptr || *end != '\0') continue;
    const std::string before = fingerprint(s);
    if (auto err = red::apply_override(s, key, v)) {
      if (err->message.empty()) red::fuzz::fail("override error without a message");
      if (fingerprint(s) != before) red::fuzz::fail("a rejected override changed the scenario");
      continue;
    }
    ++applied;
  }
  red::fuzz::simulate_if_small(s);
  return 0;
}
