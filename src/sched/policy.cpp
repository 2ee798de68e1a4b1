#include "red/sched/policy.hpp"

namespace red {

const char* to_string(SyncMode m) noexcept {
  return m == SyncMode::PerEdge ? "per-edge" : "on-demand";
}

const char* to_string(DropMode m) noexcept {
  switch (m) {
    case DropMode::None:
      return "none";
    case DropMode::Strict:
      return "strict";
    case DropMode::Hopeless:
      return "hopeless";
  }
  return "?";
}

std::optional<PolicyOptions> preset_options(std::string_view name) {
  // §7: every preset is a row of the table.
  PolicyOptions o;
  if (name == "fifo") {
    o = {GraphMode::Coarse, DeadlineMode::None, false, false, false,
         SyncMode::PerEdge, DropMode::None};
  } else if (name == "edf") {
    o = {GraphMode::Coarse, DeadlineMode::EndToEnd, false, false, false,
         SyncMode::PerEdge, DropMode::Strict};
  } else if (name == "mono") {
    o = {GraphMode::Mono, DeadlineMode::EndToEnd, false,           false,
         false,           SyncMode::PerEdge,      DropMode::Strict};
  } else if (name == "red-fg") {
    o = {GraphMode::Fine, DeadlineMode::Proportional, false,           true,
         false,           SyncMode::PerEdge,          DropMode::Strict};
  } else if (name == "red-ida") {
    o = {GraphMode::Fine, DeadlineMode::Proportional, true, true, false, SyncMode::PerEdge,
         DropMode::Strict};
  } else if (name == "red" || name == "lst") {
    o = {GraphMode::Fine, DeadlineMode::Proportional, true, true, true, SyncMode::OnDemand,
         DropMode::Strict};
  } else {
    return std::nullopt;
  }
  return o;
}

std::unique_ptr<Policy> make_policy(std::string_view name,
                                    const std::optional<PolicyOptions>& overrides) {
  auto o = preset_options(name);
  if (!o) return nullptr;
  if (overrides) o = overrides;
  if (name == "fifo") return std::make_unique<FifoPolicy>(*o);
  if (name == "lst") return std::make_unique<LeastSlackPolicy>(*o);
  return std::make_unique<EdfPolicy>(std::string(name), *o);
}

const std::vector<std::string>& default_presets() {
  static const std::vector<std::string> v{"fifo", "mono", "edf", "red-fg", "red-ida", "red"};
  return v;
}

const std::vector<std::string>& known_policies() {
  static const std::vector<std::string> v{"fifo", "mono", "edf", "red-fg", "red-ida", "red", "lst"};
  return v;
}

}  // namespace red
