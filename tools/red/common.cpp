#include "common.hpp"

#include <cstdlib>

#include "red/report/report.hpp"
#include "red/scenario/loader.hpp"

namespace red::cli {

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c != ' ') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

Expected<Scenario> load(const ScenarioArgs& a) {
  auto s = load_scenario(a.path);
  if (!s) return s.error();
  for (const std::string& kv : a.sets) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) return Error{"", 0, "--set '" + kv + "': expected key=value"};
    const std::string key = kv.substr(0, eq);
    const std::string val = kv.substr(eq + 1);
    char* end = nullptr;
    const double v = std::strtod(val.c_str(), &end);
    if (val.empty() || end == nullptr || *end != '\0')
      return Error{"", 0, "--set " + key + ": '" + val + "' is not a number"};
    if (auto err = apply_override(s.value(), key, v)) return *err;
  }
  return s;
}

std::optional<Error> write_outputs(const std::string& dir, const Scenario& s, const Profile& p,
                                   const std::string& backend, std::uint64_t seed,
                                   const std::vector<PolicyRun>& runs) {
  std::vector<PolicyMetrics> metrics;
  std::vector<PolicyRows<JobRow>> jobs;
  std::vector<PolicyRows<UnitRow>> units;
  for (const PolicyRun& r : runs) {
    metrics.push_back(r.metrics);
    jobs.push_back({r.metrics.name, &r.jobs});
    units.push_back({r.metrics.name, &r.units});
  }
  apply_ratios(metrics, "edf");
  SummaryHeader h;
  h.scenario = s.name;
  h.backend = backend;
  h.seed = seed;
  h.profile_source = p.source;
  if (auto e = write_file(dir, "summary.json", summary_json(h, metrics))) return e;
  if (auto e = write_file(dir, "jobs.csv", jobs_csv(s, jobs))) return e;
  if (auto e = write_file(dir, "units.csv", units_csv(s, units))) return e;
  return std::nullopt;
}

}  // namespace red::cli
