#include "red/sched/policy.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <string>
#include <system_error>
#include <utility>

#include "red/core/assert.hpp"
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
constexpr auto kOptions = std::to_array<OptionSpec>({
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
});

// The class make_policy builds for a preset.
enum class PolicyClass : std::uint8_t { Edf, Fifo, LeastSlack };

// One preset: its name, the policy class, whether `red compare` runs it by default, the preset
// it builds on (none: PolicyOptions{}, fine-grained graph, proportional deadlines, per-edge
// synchronization, strict drops and no other mechanism) and the mechanisms it sets on top of
// that, as --with spells them.
struct Preset {
  std::string_view name;
  PolicyClass policy;
  bool by_default;
  std::string_view base;
  std::string_view with;
};

// Every preset, in table order (docs/DESIGN.md, "Policies"; red-robust: "Overload"); a base
// comes before the presets built on it. Adding a preset is adding a row.
constexpr auto kPresets = std::to_array<Preset>({
    {"fifo", PolicyClass::Fifo, true, "", "graph=coarse,deadlines=none,drop=none"},
    {"mono", PolicyClass::Edf, true, "", "graph=mono,deadlines=end-to-end"},
    {"edf", PolicyClass::Edf, true, "", "graph=coarse,deadlines=end-to-end"},
    {"red-fg", PolicyClass::Edf, true, "", "graph=fine,deadlines=proportional,merge=yes"},
    {"red-ida", PolicyClass::Edf, true, "red-fg", "reassign=yes"},
    {"red", PolicyClass::Edf, true, "red-ida", "batching=yes,sync=on-demand"},
    // docs/DESIGN.md, "Overload": shed early on an optimistic estimate, finish what was started
    // while overloaded. admit_margin: the least of 0, 5, 10, 20 % with the most points near the
    // bound.
    {"red-robust", PolicyClass::Edf, true, "red",
     "drop=hopeless,drop_estimate=mean,admission=shed,admit_margin=5,rank=overload,"
     "shed_rate=yes,lookahead=yes,shed_lone=yes,batch_by_job=yes,path_rank=yes,miss_gate=yes,"
     "inherit=yes,guard=yes"},
    {"lst", PolicyClass::LeastSlack, false, "red", ""},
});

// The options of kPresets[i], built once.
const PolicyOptions& options_of(std::size_t i) {
  static const std::array<PolicyOptions, kPresets.size()> options = [] {
    std::array<PolicyOptions, kPresets.size()> out{};
    for (std::size_t p = 0; p < kPresets.size(); ++p) {
      if (!kPresets[p].base.empty()) {
        std::size_t b = 0;
        while (b < p && kPresets[b].name != kPresets[p].base) ++b;
        RED_ASSERT(b < p);  // a base is a preset of an earlier row
        out[p] = out[b];
      }
      const std::string err = apply_options(out[p], kPresets[p].with);
      RED_ASSERT(err.empty());  // every row spells its mechanisms as --with does
    }
    return out;
  }();
  return options[i];
}

// The index of a preset in kPresets, or kPresets.size().
std::size_t find_preset(std::string_view name) {
  std::size_t i = 0;
  while (i < kPresets.size() && kPresets[i].name != name) ++i;
  return i;
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
  const std::size_t i = find_preset(name);
  if (i == kPresets.size()) return std::nullopt;
  return options_of(i);
}

std::unique_ptr<Policy> make_policy(std::string_view name,
                                    const std::optional<PolicyOptions>& overrides) {
  const std::size_t i = find_preset(name);
  if (i == kPresets.size()) return nullptr;
  const PolicyOptions o = overrides ? *overrides : options_of(i);
  switch (kPresets[i].policy) {
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
