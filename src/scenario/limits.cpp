#include "limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>
#include <vector>

namespace red::limits {

std::optional<Error> check_size(const Scenario& s) {
  if (s.initial.size() > kMaxOperations)
    return Error{s.file, 0,
                 fmt::format("{} operations: at most {} (docs/SCENARIOS.md, \"Limits\")",
                             s.initial.size(), kMaxOperations)};
  std::vector<double> sensor_rate(s.sensors.size(), 0.0);
  for (std::size_t i = 0; i < s.sensors.size(); ++i) sensor_rate[i] = s.sensors[i].rate_hz;
  for (const EventSpec& ev : s.events)
    for (const auto& [sensor, rate] : ev.sensor_rates)
      sensor_rate[static_cast<std::size_t>(sensor)] =
          std::max(sensor_rate[static_cast<std::size_t>(sensor)], rate);
  const double seconds = to_s(s.duration);
  std::size_t nodes = 0;
  std::vector<double> releases(s.initial.size(), 0.0);  // per operation, its largest bound
  const auto count = [&](std::size_t index, const OperationSpec& op) {
    nodes += op.nodes.size();
    double r = op.rate_hz * seconds;
    if (op.release_count)
      r = *op.release_count;
    else if (op.trigger_sensor >= 0)
      r = sensor_rate[static_cast<std::size_t>(op.trigger_sensor)] * seconds;
    releases[index] = std::max(releases[index], r);
  };
  for (std::size_t i = 0; i < s.initial.size(); ++i)
    if (s.initial[i]) count(i, *s.initial[i]);
  for (const EventSpec& ev : s.events)
    for (const auto& [index, op] : ev.changes)
      if (op) count(static_cast<std::size_t>(index), *op);
  if (nodes > kMaxNodes)
    return Error{s.file, 0,
                 fmt::format("{} nodes over every operation's definitions: at most {} "
                             "(docs/SCENARIOS.md, \"Limits\")",
                             nodes, kMaxNodes)};
  const double total = std::accumulate(releases.begin(), releases.end(), 0.0);
  if (!(total <= kMaxReleases))
    return Error{s.file, 0,
                 fmt::format("about {:.3g} jobs in {:g} s: at most {:g} per run (shorten "
                             "duration_s or lower the rates; docs/SCENARIOS.md, \"Limits\")",
                             total, seconds, kMaxReleases)};
  return std::nullopt;
}

}  // namespace red::limits
