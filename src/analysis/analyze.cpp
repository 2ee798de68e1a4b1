#include "red/analysis/analyze.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "red/analysis/bound.hpp"
#include "red/analysis/workload.hpp"
#include "red/core/stop.hpp"
#include "red/metrics/phases.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/scenario/estimate.hpp"
#include "red/sim/run.hpp"

namespace red {

const char* to_string(Verdict v) noexcept {
  switch (v) {
    case Verdict::Ok:
      return "ok";
    case Verdict::AtRisk:
      return "at risk";
    case Verdict::Overloaded:
      return "overloaded";
    case Verdict::Infeasible:
      return "infeasible";
  }
  return "?";
}

namespace {

const PhaseFigures* figures_of(const PhaseMetrics& pm, const std::string& name) {
  for (const auto& [n, f] : pm.operations)
    if (n == name) return &f;
  return nullptr;
}

// The verdict of one operation in one phase, and its reason (docs/ANALYSIS.md, "Verdicts").
// `span_s` is the phase's length and `deadline_s` its latest deadline: a load past capacity by more
// than the jobs released at its end can run on after it is overloaded (WorkModel::overloaded).
void judge(OperationAnalysis& oa, double phase_util, double limit, double span_s,
           double deadline_s) {
  const double d = to_ms(oa.deadline);
  if (oa.deadline < oa.alone_min) {
    oa.verdict = Verdict::Infeasible;
    oa.reason = fmt::format(
        "deadline {:.3f} ms is below {:.3f} ms, the shortest response alone on the device on "
        "best-case costs (critical path, own work over the lanes): every job misses",
        d, to_ms(oa.alone_min));
  } else if (oa.deadline < oa.alone_mean) {
    oa.verdict = Verdict::Infeasible;
    oa.reason = fmt::format(
        "deadline {:.3f} ms is below {:.3f} ms, the shortest response alone on the device on "
        "mean costs (critical path, own work over the lanes): most jobs miss even alone",
        d, to_ms(oa.alone_mean));
  } else if (WorkModel::overloaded(oa.utilization, span_s, deadline_s)) {
    oa.verdict = Verdict::Overloaded;
    oa.reason = fmt::format(
        "its own necessary work is {:.1f} % of the lanes' capacity (encoder runs shared, runs "
        "batched as its deadlines allow): no policy meets every deadline",
        100 * oa.utilization);
  } else if (WorkModel::overloaded(phase_util, span_s, deadline_s)) {
    oa.verdict = Verdict::Overloaded;
    oa.reason = fmt::format(
        "the device's necessary work in this phase is {:.1f} % of its capacity (encoder runs "
        "shared, runs batched as the deadlines allow): no policy meets every deadline",
        100 * phase_util);
  } else if (oa.jobs_profiled > 0 && oa.miss_profiled > limit) {
    oa.verdict = Verdict::AtRisk;
    oa.reason = fmt::format(
        "misses {:.1f} % of its jobs in simulation on profiled costs although the necessary "
        "work is {:.1f} % of capacity: this policy does not fit the work by the deadlines "
        "(another may; see the headroom and `red compare`)",
        100 * oa.miss_profiled, 100 * phase_util);
  } else if (oa.jobs_worst > 0 && oa.miss_worst > limit) {
    oa.verdict = Verdict::AtRisk;
    oa.reason = fmt::format(
        "meets in simulation on profiled costs ({:.1f} % misses) but misses {:.1f} % on "
        "worst-case (max) costs",
        100 * oa.miss_profiled, 100 * oa.miss_worst);
  } else {
    oa.verdict = Verdict::Ok;
    oa.reason = oa.jobs_profiled > 0
                    ? fmt::format("{:.1f} % misses on profiled costs, {:.1f} % on worst-case costs",
                                  100 * oa.miss_profiled, 100 * oa.miss_worst)
                    : std::string(
                          "fits (no job of it was released in this phase of the "
                          "simulation)");
  }
}

// What the analysis of every phase reads: the policy's options, the unit costs and the figures
// per phase of the simulations at profiled and at worst-case costs.
struct PhaseInputs {
  const Scenario& s;
  const PolicyOptions& opts;
  UnitCosts cmin, cmean, cest;
  CostModel est;
  WorkModel model;
  std::vector<PhaseMetrics> pm_prof, pm_worst;
};

// Operation i of phase k (`pw`): its deadline, critical paths, work and share of the lanes
// (`need`, with `merged` encoder runs per job), and its simulated figures.
OperationAnalysis analyze_operation(const PhaseInputs& in, const PhaseWorkload& pw, std::size_t k,
                                    std::size_t i, const std::vector<double>& merged,
                                    const WorkEstimate& need) {
  const Scenario& s = in.s;
  const PolicyOptions& opts = in.opts;
  const OperationSpec& op = *pw.ops[i];
  OperationAnalysis oa;
  oa.operation = static_cast<int>(i);
  oa.name = s.operation_name(oa.operation);
  oa.rate_hz = release_rate(op, pw, s);
  oa.deadline = resolve_deadline(op, in.est);
  oa.cp_coarse_mean = critical_path(op, GraphMode::Coarse, in.cmean);
  oa.cp_coarse_estimate = critical_path(op, GraphMode::Coarse, in.cest);
  oa.cp_fine_mean = critical_path(op, GraphMode::Fine, in.cmean);
  oa.cp_fine_estimate = critical_path(op, GraphMode::Fine, in.cest);
  // Alone on the device a job needs its critical path and its own work spread over the
  // lanes; its own encoder runs are shared only on the fine graph under DynamicMerge.
  auto alone = [&](const UnitCosts& c) {
    const Duration own =
        opts.graph == GraphMode::Coarse || (opts.graph == GraphMode::Fine && !opts.merge)
            ? work_coarse(op, c)
            : work_fine(op, c);
    return std::max(critical_path(op, opts.graph, c), own / s.device.lanes);
  };
  oa.alone_min = alone(in.cmin);
  oa.alone_mean = alone(in.cmean);
  oa.work_coarse = work_coarse(op, in.cmean);
  oa.work_fine = work_fine(op, in.cmean);
  oa.work_merged = work_merged(op, in.cmean, merged[i]);
  // What the policy runs: coarse units; a mono job (one encoder run per sensor); fine
  // units, whose encoder runs are shared only under DynamicMerge.
  oa.work_policy = opts.graph == GraphMode::Mono                 ? oa.work_fine
                   : opts.graph == GraphMode::Fine && opts.merge ? oa.work_merged
                                                                 : oa.work_coarse;
  oa.utilization = need.op_load[i];
  if (k < in.pm_prof.size())
    if (const PhaseFigures* f = figures_of(in.pm_prof[k], oa.name)) {
      oa.jobs_profiled = f->jobs;
      oa.miss_profiled = f->miss_rate;
    }
  if (k < in.pm_worst.size())
    if (const PhaseFigures* f = figures_of(in.pm_worst[k], oa.name)) {
      oa.jobs_worst = f->jobs;
      oa.miss_worst = f->miss_rate;
    }
  return oa;
}

// Phase k (`pw`): its necessary work, and each operation's figures and verdict.
PhaseAnalysis analyze_phase(const PhaseInputs& in, const PhaseWorkload& pw, std::size_t k,
                            double miss_limit) {
  PhaseAnalysis pa;
  pa.span = pw.span;
  pa.label = pw.label;
  const std::vector<double> merged = merged_encoder_runs(in.s, pw);
  const WorkEstimate need = in.model.estimate(work_input(in.s, pw));
  pa.utilization = need.load;
  Duration latest{0};
  for (std::size_t i = 0; i < pw.ops.size(); ++i) {
    if (!pw.ops[i]) continue;
    OperationAnalysis oa = analyze_operation(in, pw, k, i, merged, need);
    latest = std::max(latest, oa.deadline);
    pa.operations.push_back(std::move(oa));
  }
  for (OperationAnalysis& oa : pa.operations) {
    judge(oa, pa.utilization, miss_limit, to_s(pw.span.to - pw.span.from), to_s(latest));
    pa.verdict = std::max(pa.verdict, oa.verdict);
  }
  return pa;
}

}  // namespace

Expected<Analysis> analyze(const Scenario& s, const Profile& p, const AnalysisOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (auto e = check_policy_options(s)) return *e;
  const auto opts = policy_options(s, o.policy);
  if (!opts) return Error{"", 0, unknown_policy_message(o.policy)};
  Analysis a;
  a.scenario = s.name;
  a.policy = o.policy;
  a.profile = p.source;
  a.lanes = s.device.lanes;
  a.estimate = s.scheduler.estimate;
  a.slowdown = s.interference ? 1.0 + s.interference->intensity : 1.0;
  a.miss_limit = o.search.miss_limit;

  auto prof = simulate_policy(s, p, o.policy, s.seed, {}, false);
  if (!prof) return prof.error();
  const Scenario ws = worst_case_scenario(s, p);
  const Profile wp = worst_case_profile(p);
  auto worst = simulate_policy(ws, wp, o.policy, ws.seed, {}, false);
  if (!worst) return worst.error();
  a.on_time_profiled = prof->metrics.on_time;
  a.on_time_worst = worst->metrics.on_time;
  a.lane_busy = prof->metrics.lane_utilization;
  const TimePoint end = prof->result.end;
  const PhaseInputs in{s,
                       *opts,
                       UnitCosts(s, p, CostPoint::Min),
                       UnitCosts(s, p, CostPoint::Mean),
                       UnitCosts(s, p, CostPoint::Estimate),
                       CostModel{&p, &s.model, s.scheduler.estimate},
                       work_model(s, p),
                       phase_metrics(s, prof->jobs, end),
                       phase_metrics(ws, worst->jobs, end)};
  const auto phases = phase_workloads(s, end);
  for (std::size_t k = 0; k < phases.size(); ++k) {
    PhaseAnalysis pa = analyze_phase(in, phases[k], k, o.search.miss_limit);
    a.peak_utilization = std::max(a.peak_utilization, pa.utilization);
    a.verdict = std::max(a.verdict, pa.verdict);
    a.phases.push_back(std::move(pa));
  }
  if (stop_requested()) return Error{"", 0, kStoppedMessage};
  try {
    a.on_time_bound = work_bound(s, p);
  } catch (const std::runtime_error& e) {
    return Error{"", 0, e.what()};  // a stop request ends its simulation too
  }
  if (o.headroom) {
    std::vector<std::string> policies{o.policy};
    if (o.policy != "edf") policies.emplace_back("edf");
    for (const std::string& pol : policies)
      for (bool wc : {false, true}) {
        auto h = search_headroom(s, p, pol, wc, o.search);
        if (!h) return h.error();
        a.headroom.push_back(std::move(h).value());
      }
  }
  if (stop_requested()) return Error{"", 0, kStoppedMessage};
  a.response = response_bound(s, p, *opts);
  if (stop_requested()) return Error{"", 0, kStoppedMessage};
  a.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return a;
}

namespace {

std::string scale_text(const ScaleSearch& r, bool rate) {
  if (r.pass == 0) return fmt::format("fails even at {:g}", r.fail);
  if (r.fail == 0)
    return fmt::format("{}{:.3g} (limit of the search)", rate ? ">= " : "<= ", r.pass);
  // Three significant digits, or as many more as tell the two apart: a search that ends
  // between 1.2001 and 1.2004 printed "1.2 (fails at 1.2)".
  std::string pass, fail;
  for (int digits = 3; digits <= 12; ++digits) {
    pass = fmt::format("{:.{}g}", r.pass, digits);
    fail = fmt::format("{:.{}g}", r.fail, digits);
    if (pass != fail) break;
  }
  return pass + " (fails at " + fail + ")";
}

}  // namespace

std::string analysis_text(const Analysis& a) {
  std::string t = fmt::format(
      "red analyze: {} — policy {}, profile {}, {} lane{}, estimate {}{}\n", a.scenario, a.policy,
      a.profile, a.lanes, a.lanes == 1 ? "" : "s", to_string(a.estimate),
      a.slowdown != 1.0 ? fmt::format(", interference ×{:g}", a.slowdown) : std::string());
  t += "(times in ms; cp: critical path; work per job on mean costs; miss: simulated miss rate "
       "on profiled / worst-case costs)\n";
  // The operation column as wide as the longest name (a long name pushed its row's columns
  // right of the header's).
  std::size_t op_width = 12;
  for (const PhaseAnalysis& ph : a.phases)
    for (const OperationAnalysis& o : ph.operations) op_width = std::max(op_width, o.name.size());
  for (const PhaseAnalysis& ph : a.phases) {
    t += fmt::format("\nphase {} [{:.3f} s, {:.3f} s): device utilization {:.1f} %\n", ph.label,
                     to_s(ph.span.from), to_s(ph.span.to), 100 * ph.utilization);
    t += fmt::format("  {:<{}} {:>7} {:>9} {:>17} {:>17} {:>25} {:>7} {:>15}  {}\n", "operation",
                     op_width, "rate Hz", "deadline", "cp coarse mean/est", "cp fine mean/est",
                     "work coarse/fine/merged", "util %", "miss % prof/wc", "verdict");
    for (const OperationAnalysis& o : ph.operations) {
      t += fmt::format(
          "  {:<{}} {:>7.2f} {:>9.3f} {:>17} {:>17} {:>25} {:>7.1f} {:>15}  {}\n", o.name, op_width,
          o.rate_hz, to_ms(o.deadline),
          fmt::format("{:.2f}/{:.2f}", to_ms(o.cp_coarse_mean), to_ms(o.cp_coarse_estimate)),
          fmt::format("{:.2f}/{:.2f}", to_ms(o.cp_fine_mean), to_ms(o.cp_fine_estimate)),
          fmt::format("{:.2f}/{:.2f}/{:.2f}", to_ms(o.work_coarse), to_ms(o.work_fine),
                      to_ms(o.work_merged)),
          100 * o.utilization,
          fmt::format("{:.1f}/{:.1f}", 100 * o.miss_profiled, 100 * o.miss_worst),
          to_string(o.verdict));
      t += fmt::format("  {:<{}} └ {}\n", "", op_width, o.reason);
    }
  }
  t += fmt::format(
      "\ndevice: peak utilization {:.1f} % of {} lane{}; on-time fraction bound {:.3f} (work "
      "bound); {} simulated: {:.3f} on profiled costs, {:.3f} on worst-case costs\n",
      100 * a.peak_utilization, a.lanes, a.lanes == 1 ? "" : "s", a.on_time_bound, a.policy,
      a.on_time_profiled, a.on_time_worst);
  if (!a.lane_busy.empty()) {
    t += "lanes busy in the simulation on profiled costs:";
    for (double u : a.lane_busy) t += fmt::format(" {:.1f} %", 100 * u);
    t += "\n";
  }
  if (!a.headroom.empty()) {
    t += fmt::format(
        "\nheadroom (each operation's own miss rate <= {:g} %, not all jobs pooled as `red "
        "sweep`'s breakdown rate; bisection in the simulator):\n",
        100 * a.miss_limit);
    t += fmt::format("  {:<10} {:<11} {:<34} {:<34} {}\n", "policy", "costs", "rate_scale",
                     "deadline_scale", "first to fail as load grows");
    for (const Headroom& h : a.headroom)
      t += fmt::format(
          "  {:<10} {:<11} {:<34} {:<34} {}\n", h.policy, h.costs, scale_text(h.rate, true),
          scale_text(h.deadline, false),
          h.rate.first_to_fail.empty()
              ? std::string("-")
              : fmt::format("{} ({:.1f} % misses at rate_scale {:.3g})", h.rate.first_to_fail,
                            100 * h.rate.first_miss, h.rate.fail));
  }
  t += "\nresponse-time bound: ";
  if (!a.response.applies) {
    t += a.response.why_not + "\n";
  } else {
    t +=
        fmt::format("{}\n  busy period {:.3f} ms, utilization at max costs {:.1f} %\n",
                    a.response.method, to_ms(a.response.busy_period), 100 * a.response.utilization);
    for (const OperationBound& b : a.response.operations)
      t += fmt::format("  {:<12} R <= {:.3f} ms, deadline {:.3f} ms: {}\n", b.name, to_ms(b.bound),
                       to_ms(b.deadline), b.guaranteed() ? "guaranteed" : "not guaranteed");
  }
  t += fmt::format("\nverdict: {}\n", to_string(a.verdict));
  return t;
}

std::string analysis_json(const Analysis& a) {
  using nlohmann::ordered_json;
  ordered_json j;
  j["schema"] = 1;
  j["scenario"] = a.scenario;
  j["policy"] = a.policy;
  j["profile"] = a.profile;
  j["lanes"] = a.lanes;
  j["estimate"] = to_string(a.estimate);
  j["slowdown"] = a.slowdown;
  j["miss_limit"] = a.miss_limit;
  j["verdict"] = to_string(a.verdict);
  j["device"] = {{"peak_utilization", a.peak_utilization},
                 {"on_time_bound", a.on_time_bound},
                 {"on_time_profiled", a.on_time_profiled},
                 {"on_time_worst_case", a.on_time_worst},
                 {"lane_busy", a.lane_busy}};
  j["phases"] = ordered_json::array();
  for (const PhaseAnalysis& ph : a.phases) {
    ordered_json pj;
    pj["label"] = ph.label;
    pj["from_s"] = to_s(ph.span.from);
    pj["to_s"] = to_s(ph.span.to);
    pj["utilization"] = ph.utilization;
    pj["verdict"] = to_string(ph.verdict);
    pj["operations"] = ordered_json::array();
    for (const OperationAnalysis& o : ph.operations) {
      ordered_json oj;
      oj["name"] = o.name;
      oj["rate_hz"] = o.rate_hz;
      oj["deadline_ms"] = to_ms(o.deadline);
      oj["critical_path_ms"] = {
          {"coarse_mean", to_ms(o.cp_coarse_mean)},
          {"coarse_estimate", to_ms(o.cp_coarse_estimate)},
          {"fine_mean", to_ms(o.cp_fine_mean)},
          {"fine_estimate", to_ms(o.cp_fine_estimate)},
      };
      oj["alone_ms"] = {{"best_case", to_ms(o.alone_min)}, {"mean", to_ms(o.alone_mean)}};
      oj["work_ms"] = {{"coarse", to_ms(o.work_coarse)},
                       {"fine", to_ms(o.work_fine)},
                       {"merged", to_ms(o.work_merged)},
                       {"policy", to_ms(o.work_policy)}};
      oj["utilization"] = o.utilization;
      oj["simulated"] = {{"jobs_profiled", o.jobs_profiled},
                         {"miss_rate_profiled", o.miss_profiled},
                         {"jobs_worst_case", o.jobs_worst},
                         {"miss_rate_worst_case", o.miss_worst}};
      oj["verdict"] = to_string(o.verdict);
      oj["reason"] = o.reason;
      pj["operations"].push_back(oj);
    }
    j["phases"].push_back(pj);
  }
  j["headroom"] = ordered_json::array();
  auto scale = [](const ScaleSearch& r) {
    ordered_json sj;
    sj["pass"] = r.pass;
    sj["fail"] = r.fail;
    sj["first_to_fail"] = r.first_to_fail;
    sj["first_miss_rate"] = r.first_miss;
    return sj;
  };
  for (const Headroom& h : a.headroom) {
    ordered_json hj;
    hj["policy"] = h.policy;
    hj["costs"] = h.costs;
    hj["rate_scale"] = scale(h.rate);
    hj["deadline_scale"] = scale(h.deadline);
    hj["simulations"] = h.simulations;
    hj["wall_s"] = h.wall_s;
    j["headroom"].push_back(hj);
  }
  ordered_json rj;
  rj["applies"] = a.response.applies;
  if (!a.response.applies) {
    rj["why_not"] = a.response.why_not;
  } else {
    rj["method"] = a.response.method;
    rj["busy_period_ms"] = to_ms(a.response.busy_period);
    rj["utilization"] = a.response.utilization;
    rj["operations"] = ordered_json::array();
    for (const OperationBound& b : a.response.operations)
      rj["operations"].push_back({{"name", b.name},
                                  {"bound_ms", to_ms(b.bound)},
                                  {"deadline_ms", to_ms(b.deadline)},
                                  {"guaranteed", b.guaranteed()},
                                  {"job_cost_ms", to_ms(b.job_cost)},
                                  {"period_ms", to_ms(b.period)},
                                  {"jitter_ms", to_ms(b.jitter)}});
  }
  j["response_bound"] = rj;
  j["wall_s"] = a.wall_s;
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

HtmlTable verdict_html_table(const std::vector<Analysis>& per_policy) {
  HtmlTable t;
  if (per_policy.empty()) return t;
  t.caption = "Verdicts (red analyze, docs/ANALYSIS.md): will each operation keep its deadlines?";
  t.header = {"phase", "operation", "rate Hz", "deadline ms"};
  for (const Analysis& a : per_policy) t.header.push_back(a.policy);
  t.header.emplace_back("why");
  const Analysis& first = per_policy.front();
  for (std::size_t k = 0; k < first.phases.size(); ++k)
    for (std::size_t i = 0; i < first.phases[k].operations.size(); ++i) {
      const OperationAnalysis& op = first.phases[k].operations[i];
      std::vector<std::string> row{first.phases[k].label, op.name,
                                   fmt::format("{:.2f}", op.rate_hz),
                                   fmt::format("{:.3f}", to_ms(op.deadline))};
      // Every policy's reason; policies that give the same one share it.
      std::vector<std::pair<std::string, std::string>> why;  // (policies, reason)
      for (const Analysis& a : per_policy) {
        const bool same = k < a.phases.size() && i < a.phases[k].operations.size();
        row.emplace_back(same ? to_string(a.phases[k].operations[i].verdict) : "-");
        if (!same) continue;
        const std::string& reason = a.phases[k].operations[i].reason;
        auto it =
            std::find_if(why.begin(), why.end(), [&](const auto& w) { return w.second == reason; });
        if (it == why.end())
          why.emplace_back(a.policy, reason);
        else
          it->first += ", " + a.policy;
      }
      std::string text;
      for (const auto& [who, reason] : why)
        text += (text.empty() ? "" : "; ") +
                (why.size() == 1 && per_policy.size() > 1 ? "all: " : who + ": ") + reason;
      row.push_back(text);
      t.rows.push_back(std::move(row));
    }
  return t;
}

}  // namespace red
