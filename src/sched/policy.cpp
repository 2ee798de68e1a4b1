#include "red/sched/policy.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <string>
#include <system_error>
#include <utility>

#include "red/scenario/estimate.hpp"
#include "red/scenario/loader.hpp"

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

// One option value: `value` is one of `values` (their spellings), else an error naming them.
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

const char* yes_no(bool b) noexcept {
  return b ? "yes" : "no";
}

// One policy option: its key (the only place it is spelled), how its value is read
// (set_option, --with, the scenario's `with`) and how it is shown (describe).
struct OptionSpec {
  const char* key;
  std::string (*set)(PolicyOptions& o, std::string_view key, std::string_view value);
  std::string (*show)(const PolicyOptions& o);
};

// Every option, in documentation order (option_keys(), describe(), the CLI's --with help).
const std::array<OptionSpec, 19> kOptions{{
    {"graph",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(
           o.graph, k, v,
           std::array<std::pair<const char*, GraphMode>, 3>{{{"coarse", GraphMode::Coarse},
                                                             {"fine", GraphMode::Fine},
                                                             {"mono", GraphMode::Mono}}});
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.graph); }},
    {"deadlines",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.deadlines, k, v,
                     std::array<std::pair<const char*, DeadlineMode>, 4>{
                         {{"none", DeadlineMode::None},
                          {"end-to-end", DeadlineMode::EndToEnd},
                          {"proportional", DeadlineMode::Proportional},
                          {"equal", DeadlineMode::Equal}}});
     },
     // The value --with accepts (to_string's "e2e" is the short name reports print).
     [](const PolicyOptions& o) -> std::string {
       return o.deadlines == DeadlineMode::EndToEnd ? "end-to-end" : to_string(o.deadlines);
     }},
    {"reassign",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.reassign, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.reassign); }},
    {"merge",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.merge, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.merge); }},
    {"batching",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.batching, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.batching); }},
    {"sync",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.sync, k, v,
                     std::array<std::pair<const char*, SyncMode>, 2>{
                         {{"per-edge", SyncMode::PerEdge}, {"on-demand", SyncMode::OnDemand}}});
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.sync); }},
    {"drop",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(
           o.drop, k, v,
           std::array<std::pair<const char*, DropMode>, 3>{{{"none", DropMode::None},
                                                            {"strict", DropMode::Strict},
                                                            {"hopeless", DropMode::Hopeless}}});
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.drop); }},
    {"drop_estimate",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.drop_estimate, k, v, kEstimateKinds);
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.drop_estimate); }},
    {"admission",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.admission, k, v,
                     std::array<std::pair<const char*, Admission>, 2>{
                         {{"none", Admission::None}, {"shed", Admission::Shed}}});
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.admission); }},
    {"admit_margin",
     [](PolicyOptions& o, std::string_view k, std::string_view v) -> std::string {
       int n = -1;
       const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
       if (ec != std::errc{} || end != v.data() + v.size() || n < 0 || n > 100)
         return "option '" + std::string(k) + "': '" + std::string(v) +
                "' is not a whole percent from 0 to 100";
       o.admit_margin = n;
       return {};
     },
     [](const PolicyOptions& o) { return std::to_string(o.admit_margin); }},
    {"rank",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(
           o.rank, k, v,
           std::array<std::pair<const char*, RankMode>, 3>{{{"policy", RankMode::Policy},
                                                            {"job-deadline", RankMode::JobDeadline},
                                                            {"overload", RankMode::Overload}}});
     },
     [](const PolicyOptions& o) -> std::string { return to_string(o.rank); }},
    {"shed_rate",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.shed_by_rate, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.shed_by_rate); }},
    {"lookahead",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.lookahead, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.lookahead); }},
    {"shed_lone",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.shed_lone, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.shed_lone); }},
    {"batch_by_job",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.batch_by_job, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.batch_by_job); }},
    {"path_rank",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.path_rank, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.path_rank); }},
    {"miss_gate",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.miss_gate, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.miss_gate); }},
    {"inherit",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.inherit, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.inherit); }},
    {"guard",
     [](PolicyOptions& o, std::string_view k, std::string_view v) {
       return choose(o.guard, k, v, kBool);
     },
     [](const PolicyOptions& o) -> std::string { return yes_no(o.guard); }},
}};

// What every preset starts from (docs/DESIGN.md, "Policies").
PolicyOptions preset_base() {
  PolicyOptions o;
  o.reassign = false;
  o.merge = false;
  o.batching = false;
  o.sync = SyncMode::PerEdge;
  o.drop = DropMode::Strict;
  return o;
}

// red, lst and red-robust: the whole of RED.
PolicyOptions red_options() {
  PolicyOptions o = preset_base();
  o.graph = GraphMode::Fine;
  o.deadlines = DeadlineMode::Proportional;
  o.reassign = o.merge = o.batching = true;
  o.sync = SyncMode::OnDemand;
  return o;
}

// The class make_policy builds for a preset.
enum class PolicyClass : std::uint8_t { Edf, Fifo, LeastSlack };

// One preset: its name, the policy class, whether `red compare` runs it by default, and its
// options.
struct Preset {
  std::string_view name;
  PolicyClass policy;
  bool by_default;
  PolicyOptions (*options)();
};

// Every preset, in table order (docs/DESIGN.md, "Policies"; red-robust: "Overload").
const std::array<Preset, 8> kPresets{{
    {"fifo", PolicyClass::Fifo, true,
     [] {
       PolicyOptions o = preset_base();
       o.graph = GraphMode::Coarse;
       o.deadlines = DeadlineMode::None;
       o.drop = DropMode::None;
       return o;
     }},
    {"mono", PolicyClass::Edf, true,
     [] {
       PolicyOptions o = preset_base();
       o.graph = GraphMode::Mono;
       o.deadlines = DeadlineMode::EndToEnd;
       return o;
     }},
    {"edf", PolicyClass::Edf, true,
     [] {
       PolicyOptions o = preset_base();
       o.graph = GraphMode::Coarse;
       o.deadlines = DeadlineMode::EndToEnd;
       return o;
     }},
    {"red-fg", PolicyClass::Edf, true,
     [] {
       PolicyOptions o = preset_base();
       o.graph = GraphMode::Fine;
       o.deadlines = DeadlineMode::Proportional;
       o.merge = true;
       return o;
     }},
    {"red-ida", PolicyClass::Edf, true,
     [] {
       PolicyOptions o = preset_base();
       o.graph = GraphMode::Fine;
       o.deadlines = DeadlineMode::Proportional;
       o.reassign = o.merge = true;
       return o;
     }},
    {"red", PolicyClass::Edf, true, red_options},
    {"red-robust", PolicyClass::Edf, true,
     [] {
       // docs/DESIGN.md, "Overload": shed early on an optimistic estimate, finish what was
       // started while overloaded.
       PolicyOptions o = red_options();
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
       o.inherit = true;
       o.guard = true;
       return o;
     }},
    {"lst", PolicyClass::LeastSlack, false, red_options},
}};

const Preset* find_preset(std::string_view name) {
  for (const Preset& p : kPresets)
    if (p.name == name) return &p;
  return nullptr;
}

}  // namespace

std::string set_option(PolicyOptions& o, std::string_view key, std::string_view value) {
  for (const OptionSpec& spec : kOptions)
    if (key == spec.key) return spec.set(o, key, value);
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

std::optional<Error> check_policy_options(const Scenario& s) {
  const std::vector<OptionText>& options = s.scheduler.policy_options;
  const std::vector<std::string>& keys = option_keys();
  for (const OptionText& o : options)
    if (std::find(keys.begin(), keys.end(), o.key) == keys.end()) {
      std::vector<std::string> allowed = scheduler_keys();
      allowed.insert(allowed.end(), keys.begin(), keys.end());
      std::string list;
      for (const std::string& k : allowed) list += (list.empty() ? "" : ", ") + k;
      return Error{s.file, o.key_line,
                   "scheduler: unknown key '" + o.key + "' (allowed: " + list + ")"};
    }
  PolicyOptions check;
  for (const std::string& key : keys)
    for (const OptionText& o : options) {
      if (o.key != key) continue;
      if (!o.problem.empty()) return Error{s.file, o.line, o.problem};
      if (std::string err = set_option(check, key, o.value); !err.empty())
        return Error{s.file, o.line, o.what + ": " + err};
    }
  return std::nullopt;
}

const std::vector<std::string>& option_keys() {
  static const std::vector<std::string> v = [] {
    std::vector<std::string> keys;
    for (const OptionSpec& spec : kOptions) keys.emplace_back(spec.key);
    return keys;
  }();
  return v;
}

std::string describe(const PolicyOptions& o) {
  std::string out;
  for (const OptionSpec& spec : kOptions)
    out += (out.empty() ? "" : ",") + std::string(spec.key) + "=" + spec.show(o);
  return out;
}

std::optional<PolicyOptions> preset_options(std::string_view name) {
  const Preset* p = find_preset(name);
  if (p == nullptr) return std::nullopt;
  return p->options();
}

std::unique_ptr<Policy> make_policy(std::string_view name,
                                    const std::optional<PolicyOptions>& overrides) {
  const Preset* p = find_preset(name);
  if (p == nullptr) return nullptr;
  const PolicyOptions o = overrides ? *overrides : p->options();
  switch (p->policy) {
    case PolicyClass::Fifo:
      return std::make_unique<FifoPolicy>(o);
    case PolicyClass::LeastSlack:
      return std::make_unique<LeastSlackPolicy>(o);
    case PolicyClass::Edf:
      break;
  }
  return std::make_unique<EdfPolicy>(std::string(name), o);
}

const std::vector<std::string>& default_presets() {
  static const std::vector<std::string> v = [] {
    std::vector<std::string> names;
    for (const Preset& p : kPresets)
      if (p.by_default) names.emplace_back(p.name);
    return names;
  }();
  return v;
}

const std::vector<std::string>& known_policies() {
  static const std::vector<std::string> v = [] {
    std::vector<std::string> names;
    for (const Preset& p : kPresets) names.emplace_back(p.name);
    return names;
  }();
  return v;
}

std::string unknown_policy_message(std::string_view name) {
  std::string known;
  for (const std::string& k : known_policies()) known += (known.empty() ? "" : ", ") + k;
  return "unknown policy '" + std::string(name) + "' (known: " + known + ")";
}

}  // namespace red
