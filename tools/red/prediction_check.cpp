/// \file
/// The check at the end of a real run (prediction_check.hpp, docs/FIDELITY.md).

#include "prediction_check.hpp"

#include <cmath>
#include <map>

#include <fmt/format.h>

#include "red/calibrate/calibrate.hpp"

namespace red::cli {

PredictionGap prediction_gap(double real_miss_pct, double real_mean_ms, double sim_miss_pct,
                             double sim_mean_ms) {
  PredictionGap g;
  g.miss_pts = sim_miss_pct - real_miss_pct;
  // A mean latency is of the jobs that completed: where the run or the prediction completed
  // none (a policy that misses nearly everything) there is no mean to compare, and only the
  // miss rate can be held to the target.
  if (real_mean_ms > 0.0 && sim_mean_ms > 0.0)
    g.mean_pct = 100.0 * (sim_mean_ms - real_mean_ms) / real_mean_ms;
  g.within = std::abs(g.miss_pts) <= kMissTargetPts &&
             (!g.mean_pct || std::abs(*g.mean_pct) <= kMeanTargetPct);
  return g;
}

namespace {

// The kind of a profile unit: "encoder", "head/seg" -> "heads", "coarse/…" -> "coarse", ...
std::string unit_kind(const std::string& unit) {
  const auto slash = unit.find('/');
  const std::string head = unit.substr(0, slash);
  return head == "head" ? "heads" : head;
}

std::string signed_figure(double v, const char* unit) {
  return fmt::format("{:+.1f}{}", v, unit);
}

std::string gap_cells(const PredictionGap& g) {
  return fmt::format("{} pts, {}", signed_figure(g.miss_pts, ""),
                     g.mean_pct ? signed_figure(*g.mean_pct, " %") : std::string("- %"));
}

nlohmann::ordered_json gap_json(const PredictionGap& g) {
  nlohmann::ordered_json j{{"miss_pts", g.miss_pts}};
  j["mean_pct"] = g.mean_pct ? nlohmann::ordered_json(*g.mean_pct) : nlohmann::ordered_json();
  j["within_target"] = g.within;
  return j;
}

}  // namespace

CostDrift cost_drift(const std::vector<const PolicyMetrics*>& runs) {
  // Per unit and batch size, the largest count seen over the policies would double-count a
  // unit two policies ran; every policy's runs count, each at its own mean.
  struct Sum {
    double run = 0.0, profile = 0.0;
  };
  Sum all;
  std::map<std::string, Sum> by_kind;
  std::vector<std::string> order;
  CostDrift d;
  for (const PolicyMetrics* m : runs)
    for (const UnitCostFigures& f : m->costs) {
      // Coarse units count through their own "coarse/<head>" figures; their model parts'
      // entries (encoder and head at batch 1) hold the same runs again only as ratios.
      if (f.runs <= 0 || f.profile_mean <= Duration{0}) continue;
      const double n = f.runs;
      const double run = n * static_cast<double>(f.run_mean.count());
      const double prof = n * static_cast<double>(f.profile_mean.count());
      const std::string kind = unit_kind(f.unit);
      if (!by_kind.contains(kind)) order.push_back(kind);
      by_kind[kind].run += run;
      by_kind[kind].profile += prof;
      all.run += run;
      all.profile += prof;
      d.runs += f.runs;
    }
  if (all.profile > 0.0) d.ratio = all.run / all.profile;
  for (const std::string& k : order) d.kinds.emplace_back(k, by_kind[k].run / by_kind[k].profile);
  return d;
}

std::string prediction_check(const std::vector<PredictionCheck>& checks, const CostDrift& drift,
                             std::vector<HtmlTable>& html, nlohmann::ordered_json& doc) {
  if (checks.empty()) return {};
  std::string out = fmt::format(
      "prediction check (simulated - real; target: miss rate within {:g} points, mean latency "
      "within {:g} %):\n",
      kMissTargetPts, kMeanTargetPct);
  out += fmt::format("{:<10} {:>26} {:>26} {:>16}\n", "policy", "ahead (this profile)",
                     "from the run's own costs", "units / profile");
  HtmlTable t{fmt::format("Prediction check: simulated minus real (target: miss rate within {:g} "
                          "points, mean latency within {:g} %; docs/FIDELITY.md)",
                          kMissTargetPts, kMeanTargetPct),
              {"policy", "ahead: miss pts, latency %", "within", "own costs: miss pts, latency %",
               "within", "units / profile"},
              {}};
  int ahead_in = 0, own_in = 0, owns = 0;
  for (const PredictionCheck& c : checks) {
    const std::string a = gap_cells(c.ahead) + (c.ahead.within ? "" : " *");
    const std::string o = c.own ? gap_cells(*c.own) + (c.own->within ? "" : " *") : "-";
    const std::string u = c.unit_ratio ? fmt::format("{:.2f}x", *c.unit_ratio) : "-";
    out += fmt::format("{:<10} {:>26} {:>26} {:>16}\n", c.policy, a, o, u);
    t.rows.push_back({c.policy, gap_cells(c.ahead), c.ahead.within ? "yes" : "no",
                      c.own ? gap_cells(*c.own) : "-", c.own ? (c.own->within ? "yes" : "no") : "-",
                      u});
    ahead_in += c.ahead.within ? 1 : 0;
    if (c.own) {
      ++owns;
      own_in += c.own->within ? 1 : 0;
    }
  }
  const int n = static_cast<int>(checks.size());
  out += fmt::format("within the target (* outside): ahead {} of {}", ahead_in, n);
  if (owns > 0) out += fmt::format(", from the run's own costs {} of {}", own_in, owns);
  out += "\n";
  std::string kinds;
  for (const auto& [k, r] : drift.kinds)
    kinds += fmt::format("{}{} {:.2f}x", kinds.empty() ? "" : ", ", k, r);
  if (drift.runs > 0)
    out += fmt::format(
        "units in this run against the profile (time-weighted means, every policy): {:.2f}x "
        "({})\n",
        drift.ratio, kinds);
  // What the two predictions together say (docs/FIDELITY.md, "The run's own costs").
  std::string reading;
  if (ahead_in == n) {
    reading = "the prediction made with this profile holds for this run";
  } else if (owns > 0 && own_in == owns) {
    std::string outside;
    for (const PredictionCheck& c : checks)
      if (!c.ahead.within)
        outside += (outside.empty() ? "" : ", ") + c.policy +
                   (c.unit_ratio ? fmt::format(" (its units {:.2f}x)", *c.unit_ratio) : "");
    reading = fmt::format(
        "the simulator's model holds (fed the run's own costs it is within the target), but the "
        "machine ran at another speed than the profile says for {}: calibrate closer to the run, "
        "or write this run's costs as the next profile (--write-profile)",
        outside);
  } else if (owns > 0) {
    std::string names;
    for (const PredictionCheck& c : checks)
      if (c.own && !c.own->within) names += (names.empty() ? "" : ", ") + c.policy;
    reading = fmt::format(
        "fed the run's own costs the simulator still misses {}: the run met something its model "
        "of the run leaves out (late releases or hand-offs: see the frames table and the "
        "runtime's lines; or scheduling, batching, drops) - a policy near its capacity turns a "
        "small error into many points; worth a report with the run's directory",
        names);
  } else {
    reading =
        "the prediction made with this profile misses; with --out the run also predicts from its "
        "own units' costs, which tells the machine's drift from the model's error";
  }
  out += "reading: " + reading + "\n";
  html.push_back(std::move(t));
  nlohmann::ordered_json check{{"miss_target_pts", kMissTargetPts},
                               {"mean_target_pct", kMeanTargetPct},
                               {"ahead_within", ahead_in},
                               {"policies", n}};
  check["own_within"] = owns > 0 ? nlohmann::ordered_json(own_in) : nlohmann::ordered_json();
  if (drift.runs > 0) {
    nlohmann::ordered_json k = nlohmann::ordered_json::object();
    for (const auto& [name, r] : drift.kinds) k[name] = r;
    check["unit_cost_ratio"] = drift.ratio;
    check["unit_cost_ratio_by_kind"] = std::move(k);
  }
  check["reading"] = reading;
  doc["check"] = std::move(check);
  if (doc.contains("policies"))
    for (auto& row : doc["policies"])
      for (const PredictionCheck& c : checks)
        if (row.value("policy", "") == c.policy) {
          nlohmann::ordered_json g{{"ahead", gap_json(c.ahead)}};
          if (c.own) g["own"] = gap_json(*c.own);
          if (c.unit_ratio) g["unit_cost_ratio"] = *c.unit_ratio;
          row["gap"] = std::move(g);
        }
  return out;
}

Expected<Profile> run_profile(const Scenario& s, const Profile& p,
                              const std::vector<PolicyRun>& runs,
                              const std::vector<Handoffs>& handoffs, std::optional<SyncMode> sync) {
  std::vector<CalibrationRun> cal;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const Handoffs none;
    const Handoffs& h = i < handoffs.size() ? handoffs[i] : none;
    CalibrationRun run =
        calibration_run(s, runs[i].metrics.name, runs[i].units, h.handoff_us, sync);
    run.queued_gap_us = h.queued_gap_us;
    if (!run.units.empty()) cal.push_back(std::move(run));
  }
  if (cal.empty())
    return Error{"", 0, "--write-profile: the run completed no unit after the warm-up to fit"};
  CalibrationOptions o;
  o.seconds_per_policy = to_s(s.duration - s.warmup);
  auto c = calibrate_profile(p, s, cal, o);
  if (!c) return Error{"", 0, "--write-profile: " + c.error().message};
  return c;
}

}  // namespace red::cli
