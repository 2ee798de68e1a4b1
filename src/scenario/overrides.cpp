/// \file
/// Overrides of a loaded scenario (`--set key=value`, `red sweep`): apply_override checks the
/// new value and every value it scales against the loader's limits (limits.hpp).

#include "red/scenario/loader.hpp"

#include "limits.hpp"
#include "red/core/file.hpp"
#include "yaml_tree.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>

namespace red {
namespace {

using namespace limits;  // the bounds of every value read (limits.hpp)

std::optional<Duration> scaled(Duration d, double factor) {
  const double x = static_cast<double>(d.count()) * factor;
  if (!(x <= 1e18)) return std::nullopt;
  return Duration{static_cast<std::int64_t>(std::llround(x))};
}

/// Rewrites every operation snapshot (initial and in events) with `edit`, which returns
/// false when a value would overflow. Snapshots shared between places stay shared.
template <typename Edit>
bool rewrite_operations(Scenario& s, Edit edit) {
  std::map<const OperationSpec*, std::shared_ptr<const OperationSpec>> done;
  auto redo = [&](std::shared_ptr<const OperationSpec>& p) {
    if (!p) return true;
    auto [it, fresh] = done.try_emplace(p.get());
    if (fresh) {
      auto copy = std::make_shared<OperationSpec>(*p);
      if (!edit(*copy)) return false;
      it->second = std::move(copy);
    }
    p = it->second;
    return true;
  };
  for (auto& p : s.initial)
    if (!redo(p)) return false;
  for (auto& ev : s.events)
    for (auto& [index, p] : ev.changes)
      if (!redo(p)) return false;
  return true;
}

}  // namespace

std::optional<Error> apply_override(Scenario& s, const std::string& key, double value,
                                    std::vector<std::string>* warnings) {
  auto bad = [&](const std::string& why) {
    return Error{"", 0, fmt::format("override {}={}: {}", key, value, why)};
  };
  if (!std::isfinite(value)) return bad("the value must be a finite number");
  Scenario out = s;
  if (key == "deadline_scale") {
    if (!(value > 0.0)) return bad("must be > 0");
    const bool ok = rewrite_operations(out, [&](OperationSpec& op) {
      if (op.deadline.critical_path_x) {
        *op.deadline.critical_path_x *= value;
        if (!(*op.deadline.critical_path_x >= kMinCriticalPathX &&
              *op.deadline.critical_path_x <= kMaxCriticalPathX))
          return false;
      }
      const auto fixed = scaled(op.deadline.fixed, value);
      if (!fixed || (op.deadline.fixed > Duration{0} && *fixed < kMinDeadline)) return false;
      op.deadline.fixed = *fixed;
      for (auto& n : op.nodes) {
        if (!n.deadline) continue;
        const auto d = scaled(*n.deadline, value);
        if (!d || *d < kMinDeadline) return false;
        n.deadline = *d;
      }
      return true;
    });
    if (!ok)
      return bad(
          fmt::format("a deadline would leave its range (at least 0.001 ms, at most 1e12 ms; "
                      "critical_path_x within [{:g}, {:g}])",
                      kMinCriticalPathX, kMaxCriticalPathX));
  } else if (key == "rate_scale") {
    if (!(value > 0.0)) return bad("must be > 0");
    for (auto& sensor : out.sensors) sensor.rate_hz *= value;
    for (auto& ev : out.events)
      for (auto& [index, rate] : ev.sensor_rates) rate *= value;
    bool ok = rewrite_operations(out, [&](OperationSpec& op) {
      op.rate_hz *= value;  // 0 (no own rate) stays 0
      return op.rate_hz == 0.0 || (op.rate_hz >= kMinRateHz && op.rate_hz <= kMaxRateHz);
    });
    auto in_range = [](double r) { return r >= kMinRateHz && r <= kMaxRateHz; };
    for (const auto& sensor : out.sensors) ok = ok && in_range(sensor.rate_hz);
    for (const auto& ev : out.events)
      for (const auto& [index, r] : ev.sensor_rates) ok = ok && in_range(r);
    if (!ok) return bad(fmt::format("a rate would leave [{:g}, {:g}] Hz", kMinRateHz, kMaxRateHz));
  } else if (key == "qoe_lambda") {
    if (!(value > 0.0)) return bad("must be > 0");
    out.scheduler.qoe_lambda = value;
  } else if (key == "online_costs") {
    if (value != 0.0 && value != 1.0) return bad("must be 0 or 1");
    out.scheduler.online_costs = value == 1.0;
  } else if (key == "gamma_ms") {
    if (value < 0.0 || value > 1e12) return bad("must be in [0, 1e12]");
    out.scheduler.gamma = from_ms(value);
  } else if (key == "lanes") {
    if (value < 1.0 || value > static_cast<double>(kMaxLanes) || value != std::floor(value))
      return bad(fmt::format("must be an integer in [1, {}]", kMaxLanes));
    out.device.lanes = static_cast<int>(value);
  } else if (key == "queue_depth") {
    if (value < 1.0 || value > static_cast<double>(kMaxQueueDepth) || value != std::floor(value))
      return bad(fmt::format("must be an integer in [1, {}]", kMaxQueueDepth));
    out.device.queue_depth = static_cast<int>(value);
  } else if (key == "duration_s") {
    if (!(value > 0.0)) return bad("must be > 0");
    if (value > 1e9) return bad("is too large (at most 1e9 s)");
    out.duration = from_s(value);
    if (out.warmup >= out.duration)
      return bad(fmt::format("must be more than warmup_s ({})", to_s(out.warmup)));
    // A shorter run leaves out the events it ends before (they are in time order, and no
    // earlier event depends on a later one), saying so.
    const auto first_late =
        std::find_if(out.events.begin(), out.events.end(),
                     [&](const EventSpec& ev) { return ev.at >= out.duration; });
    if (first_late != out.events.end() && warnings != nullptr) {
      std::string lines;
      for (auto it = first_late; it != out.events.end(); ++it)
        lines += (lines.empty() ? "" : ", ") + std::to_string(it->line);
      warnings->push_back(
          fmt::format("duration_s={:g} leaves out {} event(s) at or after {:g} s (line(s) {})",
                      value, out.events.end() - first_late, value, lines));
    }
    out.events.erase(first_late, out.events.end());
  } else if (key == "seed") {
    if (value < 0.0 || value >= 9.2e18 || value != std::floor(value))
      return bad("must be an integer >= 0");
    out.seed = static_cast<std::uint64_t>(value);
  } else {
    return Error{"", 0,
                 fmt::format("override {}={}: unknown key '{}' (allowed: deadline_scale, "
                             "qoe_lambda, gamma_ms, lanes, queue_depth, rate_scale, duration_s, "
                             "seed, online_costs)",
                             key, value, key)};
  }
  if (auto e = check_size(out)) return bad(e->message);
  s = std::move(out);
  return std::nullopt;
}

}  // namespace red
