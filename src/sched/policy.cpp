#include "red/sched/policy.hpp"

#include <array>
#include <charconv>
#include <string>
#include <system_error>
#include <utility>

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

const char* to_string(RankMode m) noexcept {
  switch (m) {
    case RankMode::Policy:
      return "policy";
    case RankMode::JobDeadline:
      return "job-deadline";
    case RankMode::Overload:
      return "overload";
  }
  return "?";
}

const char* to_string(Admission m) noexcept {
  return m == Admission::None ? "none" : "shed";
}

namespace {

const char* estimate_name(EstimateKind k) noexcept {
  switch (k) {
    case EstimateKind::Mean:
      return "mean";
    case EstimateKind::P95:
      return "p95";
    case EstimateKind::P99:
      return "p99";
    case EstimateKind::Max:
      return "max";
  }
  return "?";
}

// One option: its key, how it is spelled, how it is read.
template <typename E, std::size_t N>
std::string choose(E& field, std::string_view key, std::string_view value,
                   const std::array<std::pair<const char*, E>, N>& values) {
  std::string allowed;
  for (const auto& [name, v] : values) {
    if (value == name) {
      field = v;
      return {};
    }
    allowed += allowed.empty() ? "" : ", ";
    allowed += name;
  }
  return "option '" + std::string(key) + "': '" + std::string(value) +
         "' is not one of: " + allowed;
}

constexpr std::array<std::pair<const char*, bool>, 6> kBool{
    {{"yes", true}, {"no", false}, {"true", true}, {"false", false}, {"on", true}, {"off", false}}};

}  // namespace

std::string set_option(PolicyOptions& o, std::string_view key, std::string_view value) {
  if (key == "graph")
    return choose(
        o.graph, key, value,
        std::array<std::pair<const char*, GraphMode>, 3>{
            {{"coarse", GraphMode::Coarse}, {"fine", GraphMode::Fine}, {"mono", GraphMode::Mono}}});
  if (key == "deadlines")
    return choose(o.deadlines, key, value,
                  std::array<std::pair<const char*, DeadlineMode>, 4>{
                      {{"none", DeadlineMode::None},
                       {"end-to-end", DeadlineMode::EndToEnd},
                       {"proportional", DeadlineMode::Proportional},
                       {"equal", DeadlineMode::Equal}}});
  if (key == "reassign") return choose(o.reassign, key, value, kBool);
  if (key == "merge") return choose(o.merge, key, value, kBool);
  if (key == "batching") return choose(o.batching, key, value, kBool);
  if (key == "sync")
    return choose(o.sync, key, value,
                  std::array<std::pair<const char*, SyncMode>, 2>{
                      {{"per-edge", SyncMode::PerEdge}, {"on-demand", SyncMode::OnDemand}}});
  if (key == "drop")
    return choose(
        o.drop, key, value,
        std::array<std::pair<const char*, DropMode>, 3>{{{"none", DropMode::None},
                                                         {"strict", DropMode::Strict},
                                                         {"hopeless", DropMode::Hopeless}}});
  if (key == "drop_estimate")
    return choose(
        o.drop_estimate, key, value,
        std::array<std::pair<const char*, EstimateKind>, 4>{{{"mean", EstimateKind::Mean},
                                                             {"p95", EstimateKind::P95},
                                                             {"p99", EstimateKind::P99},
                                                             {"max", EstimateKind::Max}}});
  if (key == "admission")
    return choose(o.admission, key, value,
                  std::array<std::pair<const char*, Admission>, 2>{
                      {{"none", Admission::None}, {"shed", Admission::Shed}}});
  if (key == "admit_margin") {
    int v = -1;
    const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
    if (ec != std::errc{} || end != value.data() + value.size() || v < 0 || v > 100)
      return "option 'admit_margin': '" + std::string(value) +
             "' is not a whole percent from 0 to 100";
    o.admit_margin = v;
    return {};
  }
  if (key == "shed_rate") return choose(o.shed_by_rate, key, value, kBool);
  if (key == "lookahead") return choose(o.lookahead, key, value, kBool);
  if (key == "shed_lone") return choose(o.shed_lone, key, value, kBool);
  if (key == "batch_by_job") return choose(o.batch_by_job, key, value, kBool);
  if (key == "path_rank") return choose(o.path_rank, key, value, kBool);
  if (key == "miss_gate") return choose(o.miss_gate, key, value, kBool);
  if (key == "rank")
    return choose(
        o.rank, key, value,
        std::array<std::pair<const char*, RankMode>, 3>{{{"policy", RankMode::Policy},
                                                         {"job-deadline", RankMode::JobDeadline},
                                                         {"overload", RankMode::Overload}}});
  std::string keys;
  for (const std::string& k : option_keys()) keys += (keys.empty() ? "" : ", ") + k;
  return "unknown policy option '" + std::string(key) + "' (options: " + keys + ")";
}

std::string apply_options(PolicyOptions& o, std::string_view list) {
  PolicyOptions out = o;  // all or nothing: a bad entry changes nothing
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    const std::string_view item = list.substr(0, comma);
    list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
    if (item.empty()) continue;
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == item.size())
      return "'" + std::string(item) + "' is not key=value";
    if (std::string err = set_option(out, item.substr(0, eq), item.substr(eq + 1)); !err.empty())
      return err;
  }
  o = out;
  return {};
}

const std::vector<std::string>& option_keys() {
  static const std::vector<std::string> v{
      "graph",     "deadlines",     "reassign",     "merge",        "batching", "sync",
      "drop",      "drop_estimate", "admission",    "admit_margin", "rank",     "shed_rate",
      "lookahead", "shed_lone",     "batch_by_job", "path_rank",    "miss_gate"};
  return v;
}

std::string describe(const PolicyOptions& o) {
  auto yn = [](bool b) { return b ? "yes" : "no"; };
  return std::string("graph=") + to_string(o.graph) + ",deadlines=" + to_string(o.deadlines) +
         ",reassign=" + yn(o.reassign) + ",merge=" + yn(o.merge) + ",batching=" + yn(o.batching) +
         ",sync=" + to_string(o.sync) + ",drop=" + to_string(o.drop) +
         ",drop_estimate=" + estimate_name(o.drop_estimate) +
         ",admission=" + to_string(o.admission) +
         ",admit_margin=" + std::to_string(o.admit_margin) + ",rank=" + to_string(o.rank) +
         ",shed_rate=" + yn(o.shed_by_rate) + ",lookahead=" + yn(o.lookahead) +
         ",shed_lone=" + yn(o.shed_lone) + ",batch_by_job=" + yn(o.batch_by_job) +
         ",path_rank=" + yn(o.path_rank);
}

std::optional<PolicyOptions> preset_options(std::string_view name) {
  // docs/DESIGN.md, "Policies": every preset is a row of the table; red-robust is docs/DESIGN.md,
  // "Overload".
  PolicyOptions o;
  o.reassign = false;
  o.merge = false;
  o.batching = false;
  o.sync = SyncMode::PerEdge;
  o.drop = DropMode::Strict;
  if (name == "fifo") {
    o.graph = GraphMode::Coarse;
    o.deadlines = DeadlineMode::None;
    o.drop = DropMode::None;
  } else if (name == "edf") {
    o.graph = GraphMode::Coarse;
    o.deadlines = DeadlineMode::EndToEnd;
  } else if (name == "mono") {
    o.graph = GraphMode::Mono;
    o.deadlines = DeadlineMode::EndToEnd;
  } else if (name == "red-fg") {
    o.graph = GraphMode::Fine;
    o.deadlines = DeadlineMode::Proportional;
    o.merge = true;
  } else if (name == "red-ida") {
    o.graph = GraphMode::Fine;
    o.deadlines = DeadlineMode::Proportional;
    o.reassign = o.merge = true;
  } else if (name == "red" || name == "lst" || name == "red-robust") {
    o.graph = GraphMode::Fine;
    o.deadlines = DeadlineMode::Proportional;
    o.reassign = o.merge = o.batching = true;
    o.sync = SyncMode::OnDemand;
    if (name == "red-robust") {
      // docs/DESIGN.md, "Overload": shed early on an optimistic estimate, finish what was started
      // while overloaded.
      o.drop = DropMode::Hopeless;
      o.drop_estimate = EstimateKind::Mean;
      o.admission = Admission::Shed;
      o.admit_margin = 5;  // the least of 0, 5, 10, 20 % with the most points near the bound
      o.rank = RankMode::Overload;
      o.shed_by_rate = true;
      o.lookahead = true;
      o.shed_lone = true;
      o.batch_by_job = true;
      o.path_rank = true;
      o.miss_gate = true;
    }
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
  static const std::vector<std::string> v{"fifo",    "mono", "edf",       "red-fg",
                                          "red-ida", "red",  "red-robust"};
  return v;
}

const std::vector<std::string>& known_policies() {
  static const std::vector<std::string> v{"fifo",    "mono", "edf",        "red-fg",
                                          "red-ida", "red",  "red-robust", "lst"};
  return v;
}

}  // namespace red
