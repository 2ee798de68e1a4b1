#pragma once
/// \file
/// Internal to src/sched: what releases jobs, besides the operations themselves (OpState): the
/// sensors' newest frames, the own-clock ticks (own rate, release: {count}) and the workload
/// events still to come. The scheduler calls it where a frame comes (`sensor`), where an
/// operation's next tick changes (`note_tick`), where releases are due (`next_tick`,
/// `inputs_ready`) and where events are applied (`next_event`, `event_applied`).

#include <algorithm>
#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "red/graph/refine.hpp"
#include "state.hpp"

namespace red {
namespace sched_detail {

class Releases {
 public:
  // ---- sensors --------------------------------------------------------------------------

  /// The scenario's sensors at their rates (the constructor).
  void set_sensors(const std::vector<SensorSpec>& sensors) {
    sensors_.resize(sensors.size());
    for (std::size_t i = 0; i < sensors.size(); ++i) sensors_[i].rate_hz = sensors[i].rate_hz;
  }
  [[nodiscard]] SensorState& sensor(int i) noexcept {
    return sensors_[static_cast<std::size_t>(i)];
  }
  [[nodiscard]] const SensorState& sensor(int i) const noexcept {
    return sensors_[static_cast<std::size_t>(i)];
  }
  [[nodiscard]] const std::vector<SensorState>& sensors() const noexcept { return sensors_; }
  /// True when every sensor graph `g` reads has produced a frame (the trigger frame counts).
  [[nodiscard]] bool inputs_ready(const RefinedGraph& g, int trigger_sensor) const {
    for (int sn : g.sensors)
      if (sn != trigger_sensor && !sensor(sn).has_frame) return false;
    return true;
  }

  // ---- own-clock ticks --------------------------------------------------------------------

  /// Operation i's next_tick changed: its entry is pushed (kNever: none).
  void note_tick(const std::vector<OpState>& ops, int i) {
    const TimePoint t = ops[static_cast<std::size_t>(i)].next_tick;
    if (t == kNever) return;
    ticks_.emplace_back(t, i);
    std::push_heap(ticks_.begin(), ticks_.end(), std::greater<>{});
  }
  /// The earliest current entry (kNever, -1 when none), stale ones above it dropped.
  std::pair<TimePoint, int> next_tick(const std::vector<OpState>& ops) const {
    while (!ticks_.empty()) {
      const auto [t, i] = ticks_.front();
      const OpState& o = ops[static_cast<std::size_t>(i)];
      if (o.g != nullptr && o.remaining != 0 && o.next_tick == t) return {t, i};
      std::pop_heap(ticks_.begin(), ticks_.end(), std::greater<>{});
      ticks_.pop_back();
    }
    return {kNever, -1};
  }

  // ---- workload events --------------------------------------------------------------------

  /// The index of the next workload event to apply (the scenario's count when none is left).
  [[nodiscard]] std::size_t next_event() const noexcept { return next_event_; }
  void event_applied() noexcept { ++next_event_; }
  /// No event is applied any more (stop_releases): `count`, the scenario's events.
  void end_events(std::size_t count) noexcept { next_event_ = count; }

 private:
  std::vector<SensorState> sensors_;
  // Own-clock releases as a min-heap of (tick, operation): the earliest comes first, ties in
  // operation order, without a pass over every operation at each event. An entry is current
  // while its operation still releases (g set, remaining not 0) at that tick; others are stale
  // and dropped when they reach the top. Every change of a next_tick pushes an entry.
  mutable std::vector<std::pair<TimePoint, int>> ticks_;
  std::size_t next_event_ = 0;
};

}  // namespace sched_detail
}  // namespace red
