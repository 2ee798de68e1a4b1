#include "red/analysis/headroom.hpp"

#include <chrono>
#include <cmath>

#include "red/analysis/workload.hpp"
#include "red/metrics/metrics.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/scenario/loader.hpp"

namespace red {

Expected<Trial> run_trial(const Scenario& s, const Profile& p, const std::string& policy,
                          double miss_limit) {
  auto r = simulate_policy(s, p, policy, s.seed, {}, false);
  if (!r) return r.error();
  const auto n = static_cast<std::size_t>(s.operation_count());
  std::vector<std::int64_t> decided(n, 0), missed(n, 0);
  for (const JobRow& j : r->jobs) {
    const auto i = static_cast<std::size_t>(j.operation);
    if (j.outcome == JobOutcome::Unfinished) continue;
    ++decided[i];
    if (j.outcome != JobOutcome::Met) ++missed[i];
  }
  Trial t;
  t.pass = true;
  for (std::size_t i = 0; i < n; ++i) {
    const double m =
        decided[i] > 0 ? static_cast<double>(missed[i]) / static_cast<double>(decided[i]) : 0.0;
    t.miss.push_back(m);
    if (m > miss_limit) t.pass = false;
  }
  return t;
}

namespace {

struct Searcher {
  const Scenario& s;
  const Profile& p;
  const std::string& policy;
  const HeadroomOptions& o;
  int runs = 0;

  Expected<Trial> at(const std::string& key, double scale) {
    Scenario v = s;
    if (auto e = apply_override(v, key, scale)) return *e;
    ++runs;
    auto t = run_trial(v, p, policy, o.miss_limit);
    if (t) t->scale = scale;
    return t;
  }

  void blame(ScaleSearch& r, const Trial& failed) const {
    double worst = -1;
    for (std::size_t i = 0; i < failed.miss.size(); ++i)
      if (failed.miss[i] > worst) {
        worst = failed.miss[i];
        r.first_to_fail = s.operation_name(static_cast<int>(i));
        r.first_miss = worst;
      }
  }

  // Bisection on a monotone property: `up` is the direction in which the load grows (rate:
  // larger scales; deadline: smaller scales). Finds pass/fail neighbours within tolerance.
  Expected<ScaleSearch> search(const std::string& key, bool load_grows_up, double lo_limit,
                               double hi_limit) {
    ScaleSearch r;
    auto first = at(key, 1.0);
    if (!first) return first.error();
    Trial good, bad;
    bool have_good = false, have_bad = false;
    (first->pass ? good : bad) = *first;
    (first->pass ? have_good : have_bad) = true;
    // Expand geometrically until the other side is found or the range ends.
    const double step = 2.0;
    while (!(have_good && have_bad)) {
      const double from = have_good ? good.scale : bad.scale;
      // Toward more load when passing, toward less when failing.
      const bool up = have_good == load_grows_up;
      const double next = up ? from * step : from / step;
      if (next > hi_limit * (1 + 1e-9) || next < lo_limit * (1 - 1e-9)) break;
      auto t = at(key, next);
      if (!t) return t.error();
      if (t->pass) {
        good = *t;
        have_good = true;
      } else {
        bad = *t;
        have_bad = true;
      }
    }
    if (!have_good) {  // fails even at the lightest load tried
      r.fail = bad.scale;
      blame(r, bad);
      return r;
    }
    if (!have_bad) {  // passes even at the heaviest load tried
      r.pass = good.scale;
      return r;
    }
    // Bisect in log space until the two are within tolerance.
    while (std::max(good.scale, bad.scale) / std::min(good.scale, bad.scale) > 1 + o.tolerance) {
      const double mid = std::sqrt(good.scale * bad.scale);
      auto t = at(key, mid);
      if (!t) return t.error();
      (t->pass ? good : bad) = *t;
    }
    r.pass = good.scale;
    r.fail = bad.scale;
    blame(r, bad);
    return r;
  }
};

}  // namespace

Expected<Headroom> search_headroom(const Scenario& s, const Profile& p, const std::string& policy,
                                   bool worst_case, const HeadroomOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Headroom h;
  h.policy = policy;
  h.costs = worst_case ? "worst-case" : "profiled";
  const Scenario ws = worst_case ? worst_case_scenario(s, p) : Scenario{};
  const Profile wp = worst_case ? worst_case_profile(p) : Profile{};
  Searcher sr{worst_case ? ws : s, worst_case ? wp : p, policy, o};
  auto rate = sr.search("rate_scale", true, o.min_rate_scale, o.max_rate_scale);
  if (!rate) return rate.error();
  h.rate = *rate;
  auto dl = sr.search("deadline_scale", false, o.min_deadline_scale, o.max_deadline_scale);
  if (!dl) return dl.error();
  h.deadline = *dl;
  h.simulations = sr.runs;
  h.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return h;
}

}  // namespace red
