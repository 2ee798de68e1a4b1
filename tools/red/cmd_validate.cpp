/// \file
/// `red validate S.yaml`: checks a scenario and prints the resolved workload.

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "red/graph/refine.hpp"
#include "red/scenario/estimate.hpp"
#include "red/scenario/manifest.hpp"

namespace red::cli {

namespace {

std::string describe_node(const Scenario& s, const NodeSpec& n) {
  if (n.is_plain())
    return n.cost->p99 == n.cost->mean ? fmt::format("plain {:.3f} ms", to_ms(n.cost->mean))
                                       : fmt::format("plain mean {:.3f} / p99 {:.3f} ms",
                                                     to_ms(n.cost->mean), to_ms(n.cost->p99));
  return fmt::format("{} on {}", s.model.heads[static_cast<std::size_t>(n.head)],
                     s.sensors[static_cast<std::size_t>(n.sensor)].name);
}

/// A warning (file:line: ...) when no job of `op` can meet its deadline even alone: the deadline
/// is shorter than its least critical path (least_critical_path, at mean costs), the test the
/// analysis bound uses to leave such jobs out. `when`: "" at t = 0, else " from T s (event E)".
std::optional<std::string> deadline_warning(const Scenario& s, const OperationSpec& op,
                                            Duration deadline, const CostModel& mean,
                                            const std::string& when) {
  const Duration least = least_critical_path(op, mean);
  if (deadline >= least) return std::nullopt;
  return Error{s.file, op.deadline.line > 0 ? op.deadline.line : op.line,
               fmt::format("operation '{}'{}: deadline {:.3f} ms is shorter than its least "
                           "critical path {:.3f} ms (every node at its least mean cost), so no "
                           "job can meet it",
                           op.name, when, to_ms(deadline), to_ms(least))}
      .to_string();
}

/// Prints one operation snapshot and its node table; appends the deadline warning, if any, to
/// `warnings` (and prints it on stderr).
void print_operation(const Scenario& s, const OperationSpec& op, int index, const CostModel& costs,
                     const CostModel& mean, const std::string& when,
                     std::vector<std::string>& warnings) {
  const auto coarse =
      refine(std::make_shared<OperationSpec>(op), index, costs,
             {GraphMode::Coarse, DeadlineMode::Proportional, s.scheduler.level_cost});
  const auto fine = refine(std::make_shared<OperationSpec>(op), index, costs,
                           {GraphMode::Fine, DeadlineMode::Proportional, s.scheduler.level_cost});
  std::string trigger;
  if (op.trigger_sensor >= 0)
    trigger = "every frame of " + s.sensors[static_cast<std::size_t>(op.trigger_sensor)].name;
  else if (op.rate_hz > 0)
    trigger = fmt::format("{:g} Hz, newest frames", op.rate_hz);
  else
    trigger = "at start";
  if (op.release_count) trigger += fmt::format(", {} release(s)", *op.release_count);
  fmt::print(
      "  operation {}: {}; deadline {:.3f} ms; coarse critical path {:.3f} ms; criticality {}; "
      "max_inflight {}\n",
      op.name, trigger, to_ms(coarse->deadline), to_ms(coarse->critical_path), op.criticality,
      op.max_inflight);
  if (auto w = deadline_warning(s, op, coarse->deadline, mean, when)) {
    std::cerr << "red: warning: " << *w << '\n';
    warnings.push_back(std::move(*w));
  }
  if (op.depends_on >= 0)
    fmt::print("    depends on the newest job of {}\n", s.operation_name(op.depends_on));
  // Each node's height in the coarse graph and of its head (not encoder) in the fine one,
  // in one pass over the units (the last unit of a node wins, as the listing always did).
  std::vector<int> coarse_height(op.nodes.size(), 0);
  std::vector<int> fine_height(op.nodes.size(), 0);
  for (const RefinedUnit& u : coarse->units)
    if (u.node >= 0 && static_cast<std::size_t>(u.node) < op.nodes.size())
      coarse_height[static_cast<std::size_t>(u.node)] = u.height;
  for (const RefinedUnit& u : fine->units)
    if (u.node >= 0 && static_cast<std::size_t>(u.node) < op.nodes.size() &&
        u.kind != UnitKind::Encoder)
      fine_height[static_cast<std::size_t>(u.node)] = u.height;
  // Every column is as wide as its widest cell, heading included (a plain node's "mean / p99"
  // cost, a long node name, "coarse H"), so each number stays under its heading; the name and
  // what it runs are left-aligned, the numbers right-aligned.
  std::vector<std::array<std::string, 6>> rows{
      {"node", "runs", "coarse H", "coarse d ms", "fine H", "fine d ms"}};
  for (std::size_t v = 0; v < op.nodes.size(); ++v) {
    const int ch = coarse_height[v];
    const int fh = fine_height[v];
    rows.push_back(
        {op.nodes[v].name, describe_node(s, op.nodes[v]), std::to_string(ch),
         fmt::format("{:.3f}", to_ms(coarse->static_offset[static_cast<std::size_t>(ch)])),
         std::to_string(fh),
         fmt::format("{:.3f}", to_ms(fine->static_offset[static_cast<std::size_t>(fh)]))});
  }
  std::array<std::size_t, 6> width{10, 24, 7, 12, 7, 12};  // the least, as the table always was
  for (const auto& row : rows)
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const auto& row = rows[r];
    const NodeSpec* node = r > 0 ? &op.nodes[r - 1] : nullptr;
    fmt::print("    {:<{}} {:<{}} {:>{}} {:>{}} {:>{}} {:>{}}{}\n", row[0], width[0], row[1],
               width[1], row[2], width[2], row[3], width[3], row[4], width[4], row[5], width[5],
               node && node->deadline
                   ? fmt::format("  (override {:.3f} ms)", to_ms(*node->deadline))
                   : "");
  }
  for (const EdgeSpec& e : op.edges)
    fmt::print("    edge {} -> {}\n", op.nodes[static_cast<std::size_t>(e.from)].name,
               op.nodes[static_cast<std::size_t>(e.to)].name);
}

/// What validate checked besides the workload (docs/MODELS.md, "What red validate checks").
void print_checks(const Scenario& s, const std::optional<ModelManifest>& m, const Profile& p,
                  const ProfileIdentity& id) {
  fmt::print("checked:\n");
  std::string heads;
  for (const std::string& h : s.model.heads) heads += (heads.empty() ? "" : ", ") + h;
  if (m) {
    fmt::print("  manifest {}: read, {} head(s)\n", m->file, m->heads.size());
    std::string files = "encoder " + m->encoder.path;
    for (const ManifestFile& f : m->heads) files += ", " + f.name + " " + f.path;
    fmt::print("  files: {} exist\n", files);
    fmt::print("  heads: {} in the manifest\n", heads);
    fmt::print("  input: {} {}\n", shape_label(s.model.input),
               s.model.input_line > 0 ? "equals the manifest's" : "taken from the manifest");
  } else if (!s.model.heads.empty()) {
    fmt::print("  model: built-in {}, heads {}, input {}\n", s.model.builtin, heads,
               shape_label(s.model.input));
  } else {
    fmt::print("  model: none (plain nodes only)\n");
  }
  fmt::print("  {}\n", id.checked);
  if (!s.model.heads.empty())
    fmt::print("  profile ({}): has the encoder and every head the scenario uses\n", p.source);
}

// The resolved workload: the scenario's settings, sensors, operations at t = 0 and each event's
// changes (print_operation adds to `warnings`).
void print_workload(const Scenario& s, const Profile& p, std::vector<std::string>& warnings) {
  const CostModel costs{&p, &s.model, s.scheduler.estimate};
  const CostModel mean{&p, &s.model, EstimateKind::Mean};
  fmt::print("scenario {} ({}): {:g} s, warm-up {:g} s, seed {}, {} lane(s)\n", s.name, s.file,
             to_s(s.duration), to_s(s.warmup), s.seed, s.device.lanes);
  fmt::print("profile: {} ({}); estimate {}; gamma {:.1f} ms; max batch {}\n", p.source, p.device,
             to_string(s.scheduler.estimate), to_ms(s.scheduler.gamma), s.scheduler.max_batch);
  if (!s.model.heads.empty()) {
    std::string heads;
    for (const std::string& h : s.model.heads) heads += (heads.empty() ? "" : ", ") + h;
    fmt::print("model: {} heads [{}]; encoder {:.3f} ms\n",
               s.model.manifest.empty() ? s.model.builtin : s.model.manifest, heads,
               to_ms(costs.encoder()));
  }
  for (const SensorSpec& sn : s.sensors)
    fmt::print("sensor {}: {:g} Hz, phase {:.3f} ms, jitter {:.3f} ms\n", sn.name, sn.rate_hz,
               to_ms(sn.phase), to_ms(sn.jitter));
  fmt::print("operations at t = 0:\n");
  for (int i = 0; i < s.operation_count(); ++i)
    if (s.initial[static_cast<std::size_t>(i)])
      print_operation(s, *s.initial[static_cast<std::size_t>(i)], i, costs, mean, "", warnings);
  for (std::size_t e = 0; e < s.events.size(); ++e) {
    const EventSpec& ev = s.events[e];
    fmt::print("event {} at {:g} s: {}\n", e, to_s(ev.at), ev.kind);
    for (const auto& [op, spec] : ev.changes) {
      if (spec)
        print_operation(s, *spec, op, costs, mean,
                        fmt::format(" from {:g} s (event {})", to_s(ev.at), e), warnings);
      else
        fmt::print("  operation {} leaves the workload\n", s.operation_name(op));
    }
    for (const auto& [sensor, rate] : ev.sensor_rates)
      fmt::print("  sensor {} now at {:g} Hz\n", s.sensors[static_cast<std::size_t>(sensor)].name,
                 rate);
  }
}

// `red validate`: load the scenario and its profile, print the resolved workload and the checks.
int run_validate(const ScenarioArgs& args) {
  // The manifest load() read (check_model()), to list the checks.
  std::optional<ModelManifest> manifest;
  auto s = load(args, &manifest);
  if (!s) {
    print_error(s.error());
    return kBadInput;
  }
  std::vector<std::string> warnings;
  auto p = resolve_profile(*s, args.profile, &warnings);
  if (!p) {
    print_error(p.error());
    return kBadInput;
  }
  for (const std::string& w : warnings) std::cerr << "red: warning: " << w << '\n';
  warn_suspect_profile(*p, args.profile.value_or(s->profile));
  print_workload(*s, *p, warnings);
  print_checks(*s, manifest, *p, check_profile_identity(*p, *s, args.profile));
  if (warnings.empty())
    fmt::print("ok\n");
  else
    fmt::print("ok, with {} warning(s) on stderr\n", warnings.size());
  return kOk;
}

}  // namespace

void register_validate(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ScenarioArgs>();
  CLI::App* cmd =
      app.add_subcommand("validate", "Check a scenario and print the resolved workload");
  cmd->add_option("scenario", args->path, "Scenario file (YAML)")->required();
  cmd->add_option("--profile", args->profile,
                  "Profile JSON (default: the scenario's, else built-in)");
  cmd->add_option("--set", args->sets, "Override key=value (deadline_scale, rate_scale, ...)");
  cmd->callback([args, &exit_code] { exit_code = run_validate(*args); });
}

}  // namespace red::cli
