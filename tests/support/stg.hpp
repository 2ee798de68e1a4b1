#pragma once
/// \file
/// Test support: the Standard Task Graph Set (Kasahara Lab., Waseda University) — reading
/// `.stg` files and the published optimal schedule lengths, and turning a graph into a
/// one-shot scenario (YAML text for parse_scenario) of plain nodes on m lanes.

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace red::test {

/// One STG graph: tasks 0..n+1, where 0 and n+1 are the dummy entry and exit tasks.
struct StgGraph {
  int n = 0;                            ///< real tasks
  std::vector<std::int64_t> time;       ///< by task id, size n + 2
  std::vector<std::vector<int>> preds;  ///< by task id

  /// Σ processing times of the real tasks.
  [[nodiscard]] std::int64_t work() const {
    std::int64_t w = 0;
    for (int t = 1; t <= n; ++t) w += time[static_cast<std::size_t>(t)];
    return w;
  }

  /// Longest path (sum of processing times) through the graph.
  [[nodiscard]] std::int64_t critical_path() const {
    // STG numbers tasks in a topological order (every predecessor id is smaller).
    std::vector<std::int64_t> finish(time.size(), 0);
    std::int64_t best = 0;
    for (std::size_t t = 0; t < time.size(); ++t) {
      std::int64_t start = 0;
      for (int p : preds[t]) start = std::max(start, finish[static_cast<std::size_t>(p)]);
      finish[t] = start + time[t];
      best = std::max(best, finish[t]);
    }
    return best;
  }
};

/// Reads an .stg file; nullopt (and `error` set) when it is malformed.
inline std::optional<StgGraph> read_stg(const std::string& path, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = path + ": cannot open";
    return std::nullopt;
  }
  std::ostringstream body;  // everything but comment lines
  for (std::string line; std::getline(in, line);)
    if (line.find_first_not_of(" \t\r") != std::string::npos &&
        line[line.find_first_not_of(" \t\r")] != '#')
      body << line << '\n';
  std::istringstream tok(body.str());
  StgGraph g;
  if (!(tok >> g.n) || g.n <= 0) {
    error = path + ": bad task count";
    return std::nullopt;
  }
  const auto total = static_cast<std::size_t>(g.n + 2);
  g.time.assign(total, 0);
  g.preds.assign(total, {});
  for (std::size_t k = 0; k < total; ++k) {
    int id = -1;
    std::int64_t t = 0;
    int np = 0;
    if (!(tok >> id >> t >> np) || id != static_cast<int>(k) || t < 0 || np < 0) {
      error = fmt::format("{}: bad line for task {}", path, k);
      return std::nullopt;
    }
    g.time[k] = t;
    for (int i = 0; i < np; ++i) {
      int p = -1;
      if (!(tok >> p) || p < 0 || p >= id) {
        error = fmt::format("{}: task {} has a bad predecessor", path, k);
        return std::nullopt;
      }
      g.preds[k].push_back(p);
    }
  }
  return g;
}

/// Reads `Case50_{m}_OPT.csv` (`graph,m,optimal_length`): graph path -> optimum.
inline std::map<std::string, std::int64_t> read_stg_optima(const std::string& path) {
  std::map<std::string, std::int64_t> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    const auto c1 = line.find(',');
    const auto c2 = line.find(',', c1 == std::string::npos ? c1 : c1 + 1);
    if (c1 == std::string::npos || c2 == std::string::npos) continue;
    try {
      out[line.substr(0, c1)] = std::stoll(line.substr(c2 + 1));
    } catch (const std::exception&) {
      // header or malformed line: not an entry
    }
  }
  return out;
}

/// The graph as a one-shot scenario: one operation released once, a plain node `tK` per
/// real task (its time read as milliseconds), the real edges, m lanes and free
/// synchronization, and a deadline no schedule can miss.
inline std::string stg_scenario_yaml(const StgGraph& g, int lanes, const std::string& name) {
  std::string y;
  y += fmt::format("name: {}\n", name);
  y += "duration_s: 100000\n";
  y += fmt::format("device: {{lanes: {}, sync_cost_us: 0}}\n", lanes);
  y += "operations:\n";
  y += "  - name: dag\n";
  y += "    release: {count: 1}\n";
  y += "    deadline_ms: 1000000000\n";
  y += "    nodes:\n";
  for (int t = 1; t <= g.n; ++t)
    y += fmt::format("      t{}: {{cost_ms: {}}}\n", t, g.time[static_cast<std::size_t>(t)]);
  std::string edges;
  for (int t = 1; t <= g.n; ++t)
    for (int p : g.preds[static_cast<std::size_t>(t)])
      if (p != 0) edges += fmt::format("{}[t{}, t{}]", edges.empty() ? "" : ", ", p, t);
  if (!edges.empty()) y += "    edges: [" + edges + "]\n";
  return y;
}

}  // namespace red::test
