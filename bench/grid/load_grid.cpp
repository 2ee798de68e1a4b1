/// \file
/// `red_load_grid`: the overload grid of docs/DESIGN.md, "Overload". Every preset on random DAG
/// task sets (chains, fork-joins, wide DAGs; plain and MIMONet nodes; 1, 2 and 4 lanes) and on the
/// bundled scenarios, each swept over rate_scale; beside each policy's on-time fraction, the work
/// bound and the wasted lane time. Prints the table; with --markdown FILE it rewrites the
/// section between `<!-- load-grid:begin -->` and `<!-- load-grid:end -->` of FILE and
/// draws docs/plots/load-grid.svg with gnuplot (when present); --points F writes every
/// point's on-time fractions, bound and waste to F (tab-separated), for diffs and lists.
///
///     red_load_grid [--seeds N] [--duration S] [--markdown docs/BENCHMARKS.md] [--points F]
///     red_load_grid --point plain|mimonet chain|fork-join|wide SEED LANES LOAD [--with K=V,…]
///     red_load_grid --robots N [--profile F] [--shared] [--with K=V,…] [--frames F]
///                   [--points FILE]
///     red_load_grid --robot SEED [--profile F] [--shared] [--frames F] --yaml
///
/// --shared uses the shared-encoder robot workloads (robot_workload.hpp,
/// Options::shared_encoder; issue 52): several operations on one sensor's encoder at their
/// own rates and deadlines, heads shared across operations, a critical operation that joins
/// and leaves. After its worst points, --robots prints per load each policy's mean on-time
/// fraction, the worst red-robust - red, the points within 2 points of red, and the most
/// critical operation's mean on-time fraction under red and red-robust (with --shared, the
/// figures of RobotWorkload.RedRobustGeneralizes for one profile).
///
/// --frames sets the robot workloads' length in frames of their fastest sensor (60, the
/// tests' length, by default): longer runs give each operation more jobs, so that a 0.5-point
/// difference is more than one job.
///
/// --point prints one grid point's diagnostics instead: per policy the on-time fraction,
/// drops by reason and wasted lane time, and the jobs edf or red met that red-robust did
/// not (with what became of them); --with sets red-robust's options (ablations); --yaml
/// prints the point's scenario at load 1 instead (run it with `red compare FILE --set
/// rate_scale=LOAD`).
///
/// A bad argument (an unknown option, a value that is not a number or out of range) exits 2
/// naming it; a --points or --markdown file that cannot be written exits 1
/// (bench/grid/cli_test.sh, ctest red_load_grid_cli).

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <type_traits>
#include <vector>

#include "load_grid.hpp"
#include "red/core/file.hpp"
#include "red/sim/run.hpp"
#include "robot_workload.hpp"

namespace {

using red::grid::Point;

const std::vector<std::string> kPolicies{"fifo",    "mono", "edf",       "red-fg",
                                         "red-ida", "red",  "red-robust"};
const std::vector<double> kLoads{0.5, 0.8, 1.0, 1.1, 1.3, 1.5, 2.0, 2.5};

struct Cell {
  double on_time = 0, wasted = 0;
  int n = 0;
};

struct Summary {
  // family (e.g. "plain, 2 lanes") -> load -> policy -> mean on-time / wasted
  std::map<std::string, std::map<double, std::map<std::string, Cell>>> table;
  std::map<std::string, std::map<double, Cell>> bound;
  // worst differences over every point
  double worst_vs_edf = 1e9, worst_vs_red = 1e9, worst_vs_bound = 1e9;
  std::string worst_vs_edf_at, worst_vs_red_at, worst_vs_bound_at;
  double wasted_15 = 0;
  int wasted_15_n = 0;
  int points = 0;
  // points that miss a docs/DESIGN.md, "Overload" target: below edf, below red − 0.005, below 0.9 ×
  // the bound past capacity (of `overloaded` points), over 10 % wasted at 1.5×
  int below_edf = 0, below_red = 0, below_bound = 0, overloaded = 0, over_waste_15 = 0;
  std::ostream* points_out = nullptr;  // --points: one line per point
};

void add_point(Summary& sum, const std::string& family, const std::string& label, double load,
               const std::map<std::string, Point>& pts, double bound) {
  ++sum.points;
  for (const auto& [pol, p] : pts) {
    Cell& c = sum.table[family][load][pol];
    c.on_time += p.on_time;
    c.wasted += p.wasted;
    ++c.n;
  }
  Cell& b = sum.bound[family][load];
  b.on_time += bound;
  ++b.n;
  const double robust = pts.at("red-robust").on_time;
  const std::string at = fmt::format("{} at {:.1f}x", label, load);
  if (robust - pts.at("edf").on_time < sum.worst_vs_edf) {
    sum.worst_vs_edf = robust - pts.at("edf").on_time;
    sum.worst_vs_edf_at = at;
  }
  if (robust - pts.at("red").on_time < sum.worst_vs_red) {
    sum.worst_vs_red = robust - pts.at("red").on_time;
    sum.worst_vs_red_at = at;
  }
  sum.below_edf += robust < pts.at("edf").on_time - 0.005 ? 1 : 0;
  sum.below_red += robust < pts.at("red").on_time - 0.005 ? 1 : 0;
  if (load > 1.05 && bound > 0) {
    ++sum.overloaded;
    sum.below_bound += robust < 0.9 * bound ? 1 : 0;
  }
  if (load == 1.5) sum.over_waste_15 += pts.at("red-robust").wasted > 0.10 ? 1 : 0;
  if (load > 1.05 && bound > 0 && robust / bound < sum.worst_vs_bound) {
    sum.worst_vs_bound = robust / bound;
    sum.worst_vs_bound_at = at;
  }
  if (load == 1.5) {
    sum.wasted_15 = std::max(sum.wasted_15, pts.at("red-robust").wasted);
    ++sum.wasted_15_n;
  }
  if (sum.points_out != nullptr) {
    *sum.points_out << fmt::format("{}\t{:.1f}", label, load);
    for (const std::string& p : kPolicies)
      *sum.points_out << fmt::format("\t{:.4f}", pts.at(p).on_time);
    *sum.points_out << fmt::format("\t{:.4f}\t{:.4f}\n", bound, pts.at("red-robust").wasted);
  }
}

std::string render(const Summary& sum, int seeds, double duration) {
  std::string out;
  out += fmt::format(
      "Mean on-time fraction (met / released) per family of task sets and load (rate_scale of "
      "the necessary work: 1.0 fills the lanes), {} seeds per (lanes, shape, nodes) cell, {} s "
      "simulated each; `bound` is the work bound ([Overload](DESIGN.md#overload)); `waste` is "
      "red-robust's wasted lane "
      "time.\n\n",
      seeds, duration);
  out += "| family | load |";
  for (const std::string& p : kPolicies) out += " " + p + " |";
  out += " bound | waste |\n|---|---|";
  for (std::size_t i = 0; i < kPolicies.size() + 2; ++i) out += "---|";
  out += "\n";
  for (const auto& [family, loads] : sum.table) {
    for (const auto& [load, pols] : loads) {
      out += fmt::format("| {} | {:.1f} |", family, load);
      for (const std::string& p : kPolicies) {
        const Cell& c = pols.at(p);
        out += fmt::format(" {:.3f} |", c.on_time / c.n);
      }
      const Cell& b = sum.bound.at(family).at(load);
      const Cell& r = pols.at("red-robust");
      out += fmt::format(" {:.3f} | {:.1f} % |\n", b.on_time / b.n, 100 * r.wasted / r.n);
    }
  }
  out += fmt::format(
      "\nOver all {} points: red-robust − edf ≥ {:+.4f} (worst: {}); red-robust − red ≥ "
      "{:+.4f} (worst: {}); past capacity red-robust ≥ {:.3f} × the bound (worst: {}); "
      "wasted lane time at 1.5× load ≤ {:.1f} %.\n",
      sum.points, sum.worst_vs_edf, sum.worst_vs_edf_at, sum.worst_vs_red, sum.worst_vs_red_at,
      sum.worst_vs_bound, sum.worst_vs_bound_at, 100 * sum.wasted_15);
  out += fmt::format(
      "Points that miss an [overload](DESIGN.md#overload) target: {} of {} below edf − 0.005; "
      "{} of {} below red − 0.005; "
      "{} of {} past capacity below 0.9 × the bound; {} of {} at 1.5× over 10 % wasted.\n",
      sum.below_edf, sum.points, sum.below_red, sum.points, sum.below_bound, sum.overloaded,
      sum.over_waste_15, sum.wasted_15_n);
  return out;
}

// gnuplot: on-time fraction vs load, one curve per policy, bound dashed; all sets pooled.
void plot(const Summary& sum, const std::string& svg) {
  std::map<double, std::map<std::string, Cell>> pooled;
  std::map<double, Cell> bound;
  for (const auto& [family, loads] : sum.table)
    for (const auto& [load, pols] : loads) {
      for (const auto& [p, c] : pols) {
        pooled[load][p].on_time += c.on_time;
        pooled[load][p].n += c.n;
      }
      bound[load].on_time += sum.bound.at(family).at(load).on_time;
      bound[load].n += sum.bound.at(family).at(load).n;
    }
  const std::string dat = svg + ".dat";
  std::ofstream d(dat);
  d << "load";
  for (const std::string& p : kPolicies) d << ' ' << p;
  d << " bound\n";
  for (const auto& [load, pols] : pooled) {
    d << load;
    for (const std::string& p : kPolicies) d << ' ' << pols.at(p).on_time / pols.at(p).n;
    d << ' ' << bound[load].on_time / bound[load].n << '\n';
  }
  d.close();
  std::string gp = fmt::format(
      "set terminal svg size 760,440 font 'sans,12' background '#ffffff'\nset output '{}'\n"
      "set title 'Overload grid: on-time fraction vs load (all task sets)'\n"
      "set xlabel 'load (necessary work / lane capacity)'\nset ylabel 'on-time fraction'\n"
      "set key outside right\nset grid\nset yrange [0:1.02]\n",
      svg);
  gp += "plot ";
  for (std::size_t i = 0; i < kPolicies.size(); ++i)
    gp +=
        fmt::format("'{}' using 1:{} with linespoints lw 2 title '{}', ", dat, i + 2, kPolicies[i]);
  gp += fmt::format("'{}' using 1:{} with lines dt 2 lw 2 lc 'black' title 'work bound'\n", dat,
                    kPolicies.size() + 2);
  const std::string script = svg + ".gp";
  std::ofstream(script) << gp;
  if (std::system(("gnuplot " + script + " 2>/dev/null").c_str()) != 0)
    std::cerr << "red_load_grid: gnuplot failed or is missing; no plot\n";
  std::filesystem::remove(dat);
  std::filesystem::remove(script);
}

int rewrite_section(const std::string& file, const std::string& body) {
  std::ifstream in(file);
  if (!in) {
    std::cerr << "red_load_grid: cannot read " << file << "\n";
    return 2;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string begin = "<!-- load-grid:begin -->", end = "<!-- load-grid:end -->";
  const auto b = text.find(begin), e = text.find(end);
  if (b == std::string::npos || e == std::string::npos || e < b) {
    std::cerr << "red_load_grid: " << file << " has no " << begin << " ... " << end << " section\n";
    return 2;
  }
  text = text.substr(0, b + begin.size()) + "\n" + body + text.substr(e);
  std::ofstream out(file);
  if (!(out << text).flush()) {
    std::cerr << "red_load_grid: cannot write " << file << "\n";
    return 1;
  }
  return 0;
}

// The scenario red-robust runs with --with set (ablations); other policies run it as is.
red::Scenario with_options(const red::Scenario& s, const std::string& policy,
                           const std::string& with) {
  red::Scenario out = s;
  if (policy == "red-robust" && !with.empty()) out.scheduler.policy_with = with;
  return out;
}

// --points: opens `path` (when given) and writes the header line; false, with a message, when
// it cannot be written.
bool open_tsv(std::ofstream& out, const std::string& path, const std::string& header) {
  if (path.empty()) return true;
  out.open(path);
  if (!out) {
    std::cerr << "red_load_grid: cannot write " << path << "\n";
    return false;
  }
  out << header << "\n";
  return true;
}

// --robots: edf, red and red-robust on N seeded robot workloads (robot_workload.hpp) at
// 0.5 to 2.5x load; the worst point of red-robust against each, and of every operation more
// critical than the workload's least against red (on-time fractions, after warm-up).
// With points_file, one TSV line per point: seed, load, the three on-time fractions and the
// number of more critical operations below red. Then per load: the mean on-time fractions,
// the worst red-robust - red, the points within 2 points of red, and the mean on-time
// fraction of the most critical operation (the first of the highest criticality) under red
// and red-robust over the points where it released jobs.
int robots(int n, const red::Profile& profile, const std::string& with,
           const std::string& points_file, const red::robot::Options& opt) {
  std::ofstream tsv;
  if (!open_tsv(tsv, points_file, "seed\tload\tedf\tred\tred_robust\tcritical_below_red")) return 1;
  const std::vector<double> loads{0.5, 1.0, 1.5, 2.0, 2.5};
  double worst_red = 1, worst_edf = 1, worst_crit = 1;
  std::string at_red, at_edf, at_crit;
  int points = 0, below_red = 0, below_edf = 0, crit_below = 0;
  struct PerLoad {
    double edf = 0, red = 0, robust = 0, worst = 1, crit_red = 0, crit_robust = 0;
    int points = 0, within2 = 0, crit_points = 0;
  };
  std::map<double, PerLoad> per_load;
  for (int seed = 1; seed <= n; ++seed)
    for (double load : loads) {
      const red::Scenario s =
          red::robot::workload(static_cast<std::uint64_t>(seed), profile, load, opt);
      std::map<std::string, std::vector<double>> op_on_time;
      std::map<std::string, double> on_time;
      for (const char* pol : {"edf", "red", "red-robust"}) {
        auto r = red::simulate_policy(with_options(s, pol, with), profile, pol, s.seed, {}, false);
        if (!r) {
          std::cerr << r.error().to_string() << "\n";
          return 1;
        }
        on_time[pol] = r->metrics.on_time;
        std::vector<int> jobs(static_cast<std::size_t>(s.operation_count()), 0), met(jobs);
        for (const red::JobRow& j : r->jobs) {
          if (j.release < red::TimePoint{} + s.warmup) continue;
          ++jobs[static_cast<std::size_t>(j.operation)];
          met[static_cast<std::size_t>(j.operation)] += j.outcome == red::JobOutcome::Met ? 1 : 0;
        }
        for (std::size_t i = 0; i < jobs.size(); ++i)
          op_on_time[pol].push_back(jobs[i] == 0 ? -1.0 : static_cast<double>(met[i]) / jobs[i]);
      }
      ++points;
      const std::string at = fmt::format("robot seed {} at {:.1f}x", seed, load);
      const double dr = on_time["red-robust"] - on_time["red"];
      const double de = on_time["red-robust"] - on_time["edf"];
      below_red += dr < -0.005 ? 1 : 0;
      below_edf += de < -0.005 ? 1 : 0;
      if (dr < worst_red) {
        worst_red = dr;
        at_red = at;
      }
      if (de < worst_edf) {
        worst_edf = de;
        at_edf = at;
      }
      auto crit = [&](int i) {
        if (const auto& o = s.initial[static_cast<std::size_t>(i)]) return o->criticality;
        for (const red::EventSpec& e : s.events)
          for (const auto& [k, snap] : e.changes)
            if (k == i && snap) return snap->criticality;
        return 0;
      };
      int least = 1 << 30, most = 0;
      for (int i = 0; i < s.operation_count(); ++i) {
        least = std::min(least, crit(i));
        if (crit(i) > crit(most)) most = i;
      }
      PerLoad& pl = per_load[load];
      ++pl.points;
      pl.edf += on_time["edf"];
      pl.red += on_time["red"];
      pl.robust += on_time["red-robust"];
      pl.worst = std::min(pl.worst, dr);
      pl.within2 += dr >= -0.02 ? 1 : 0;
      if (const auto mi = static_cast<std::size_t>(most);
          op_on_time["red"][mi] >= 0 && op_on_time["red-robust"][mi] >= 0) {
        ++pl.crit_points;
        pl.crit_red += op_on_time["red"][mi];
        pl.crit_robust += op_on_time["red-robust"][mi];
      }
      int point_crit_below = 0;
      for (int i = 0; i < s.operation_count(); ++i) {
        const auto ii = static_cast<std::size_t>(i);
        if (crit(i) <= least || op_on_time["red"][ii] < 0) continue;
        const double d = op_on_time["red-robust"][ii] - op_on_time["red"][ii];
        crit_below += d < -0.005 ? 1 : 0;
        point_crit_below += d < -0.005 ? 1 : 0;
        if (d < worst_crit) {
          worst_crit = d;
          at_crit = at + " " + s.operation_name(i);
        }
      }
      if (tsv.is_open())
        tsv << fmt::format("{}\t{:.1f}\t{:.4f}\t{:.4f}\t{:.4f}\t{}\n", seed, load, on_time["edf"],
                           on_time["red"], on_time["red-robust"], point_crit_below);
    }
  std::cout << fmt::format(
      "{} points ({} robot workloads x {} loads)\n"
      "red-robust - red:  worst {:+.4f} ({}), {} points below -0.005\n"
      "red-robust - edf:  worst {:+.4f} ({}), {} points below -0.005\n"
      "more critical operations, red-robust - red: worst {:+.4f} ({}), {} below -0.005\n",
      points, n, loads.size(), worst_red, at_red, below_red, worst_edf, at_edf, below_edf,
      worst_crit, at_crit, crit_below);
  std::cout
      << "load  edf     red     robust  worst gap  within 2  most critical: red  robust (n)\n";
  for (const auto& [load, pl] : per_load) {
    const int cn = std::max(pl.crit_points, 1);
    std::cout << fmt::format(
        "{:.1f}   {:.4f}  {:.4f}  {:.4f}  {:+.4f}    {:>4}/{:<4}            {:.4f}  {:.4f} ({})\n",
        load, pl.edf / pl.points, pl.red / pl.points, pl.robust / pl.points, pl.worst, pl.within2,
        pl.points, pl.crit_red / cn, pl.crit_robust / cn, pl.crit_points);
  }
  return 0;
}

// One point's diagnostics (--point): where red-robust loses jobs that edf or red keep.
int diagnose(const red::grid::SetSpec& spec, double load, const std::string& with) {
  const red::Profile profile = red::default_profile();
  red::Scenario s = red::grid::set_scenario(spec, profile, load);
  std::map<std::string, red::PolicyRun> runs;
  for (const std::string& p : kPolicies) {
    red::Scenario sp = s;
    if (p == "red-robust") sp.scheduler.policy_with = with;
    auto r = red::simulate_policy(sp, profile, p, s.seed, {}, false);
    if (!r) {
      std::cerr << r.error().to_string() << "\n";
      return 2;
    }
    const red::PolicyMetrics& m = r->metrics;
    std::cout << fmt::format("{:<11} on-time {:.4f} ({} of {})  wasted {:5.1f} %  unfinished {}", p,
                             m.on_time, m.met, m.jobs, 100 * m.wasted_lane_fraction, m.unfinished);
    for (const auto& [why, n] : m.drop_reasons) std::cout << fmt::format("  {}: {}", why, n);
    std::cout << "\n";
    runs.emplace(p, std::move(*r));
  }
  std::cout << fmt::format("work bound {:.4f}\n", red::grid::work_bound(s, profile));
  auto index = [](const red::PolicyRun& r) {
    std::map<std::pair<int, std::uint64_t>, const red::JobRow*> v;
    for (const red::JobRow& j : r.jobs) v[{j.operation, j.seq}] = &j;
    return v;
  };
  const auto robust = index(runs.at("red-robust"));
  for (const char* other : {"edf", "red"}) {
    std::map<std::string, int> lost;
    int gained = 0;
    for (const auto& [k, j] : index(runs.at(other))) {
      const auto it = robust.find(k);
      if (it == robust.end()) continue;
      const bool met_other = j->outcome == red::JobOutcome::Met;
      const bool met_robust = it->second->outcome == red::JobOutcome::Met;
      if (met_other && !met_robust)
        ++lost[std::string(to_string(it->second->outcome)) + " " + it->second->reason];
      if (!met_other && met_robust) ++gained;
    }
    std::cout << fmt::format("vs {}: red-robust meets {} jobs it does not; loses", other, gained);
    for (const auto& [why, n] : lost) std::cout << fmt::format(" [{}: {}]", why, n);
    std::cout << "\n";
  }
  return 0;
}

}  // namespace

// An option's value as a number, the whole of it, or exit 2 naming the option (a bad
// argument is not read as 0: `--robots x` would otherwise run the overload grid instead).
template <typename T>
T number(const std::string& option, const std::string& value) {
  T x{};
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), x);
  bool finite = true;
  if constexpr (std::is_floating_point_v<T>) finite = std::isfinite(x);  // not inf or nan
  if (value.empty() || ec != std::errc{} || end != value.data() + value.size() || !finite) {
    std::cerr << "red_load_grid: " << option << ": '" << value << "' is not a number\n";
    std::exit(2);
  }
  return x;
}

int main(int argc, char** argv) {
  int seeds = 3;
  double duration = 4.0;
  std::string markdown;
  std::string with;
  bool yaml = false;        // --point: print the point's scenario instead
  std::string points_file;  // every point's on-time fractions, bound and waste (TSV)
  std::optional<std::pair<red::grid::SetSpec, double>> point;
  int robot_count = 0;            // --robots N
  int robot_seed = 0;             // --robot SEED (with --yaml)
  red::robot::Options robot_opt;  // --frames F, --shared
  std::string profile_file;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "red_load_grid: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--seeds") {
      seeds = number<int>(a, next());
    } else if (a == "--duration") {
      duration = number<double>(a, next());
    } else if (a == "--markdown") {
      markdown = next();
    } else if (a == "--with") {
      with = next();
    } else if (a == "--points") {
      points_file = next();
    } else if (a == "--robots") {
      robot_count = number<int>(a, next());
      if (robot_count < 1) {
        std::cerr << "red_load_grid: --robots must be >= 1\n";
        return 2;
      }
    } else if (a == "--robot") {
      robot_seed = number<int>(a, next());
      if (robot_seed < 1) {
        std::cerr << "red_load_grid: --robot needs a SEED >= 1\n";
        return 2;
      }
    } else if (a == "--frames") {
      robot_opt.frames = number<double>(a, next());
    } else if (a == "--shared") {
      robot_opt.shared_encoder = true;
    } else if (a == "--profile") {
      profile_file = next();
    } else if (a == "--yaml") {
      yaml = true;
    } else if (a == "--point") {
      red::grid::SetSpec spec;
      const std::string nodes = next(), shape = next();
      spec.nodes = nodes == "mimonet" ? red::grid::Nodes::Mimonet : red::grid::Nodes::Plain;
      spec.shape = shape == "chain"       ? red::grid::Shape::Chain
                   : shape == "fork-join" ? red::grid::Shape::ForkJoin
                                          : red::grid::Shape::Wide;
      if ((nodes != "plain" && nodes != "mimonet") ||
          (shape != "chain" && shape != "fork-join" && shape != "wide")) {
        std::cerr << "red_load_grid: --point plain|mimonet chain|fork-join|wide SEED LANES LOAD\n";
        return 2;
      }
      spec.seed = number<std::uint64_t>(a, next());
      spec.lanes = number<int>(a, next());
      const double load = number<double>(a, next());
      if (spec.lanes < 1 || !(load > 0)) {
        std::cerr << "red_load_grid: --point needs LANES >= 1 and LOAD > 0\n";
        return 2;
      }
      point = std::pair{spec, load};
    } else {
      std::cerr << "usage: red_load_grid [--seeds N] [--duration S] [--markdown FILE] "
                   "[--points FILE]\n"
                   "       red_load_grid --point plain|mimonet chain|fork-join|wide SEED LANES "
                   "LOAD [--duration S] [--with K=V,...] [--yaml]\n"
                   "       red_load_grid --robots N [--profile F] [--shared] [--with K=V,...] "
                   "[--frames F] [--points FILE]\n"
                   "       red_load_grid --robot SEED [--profile F] [--shared] [--frames F] "
                   "--yaml\n";
      return 2;
    }
  }
  if (seeds < 1 || !(duration > 1.0)) {
    std::cerr << "red_load_grid: --seeds must be >= 1 and --duration > 1\n";
    return 2;
  }
  if (!(robot_opt.frames >= 1)) {
    std::cerr << "red_load_grid: --frames must be >= 1\n";
    return 2;
  }
  if (robot_count > 0 || robot_seed > 0) {
    red::Profile rp = red::default_profile();
    if (!profile_file.empty()) {
      auto p = red::load_profile(profile_file);
      if (!p) {
        std::cerr << p.error().to_string() << "\n";
        return 2;
      }
      rp = std::move(*p);
    }
    if (robot_seed > 0) {
      // The workload at load 1; `red compare FILE --set rate_scale=LOAD` runs a point.
      std::cout << red::robot::workload_yaml(static_cast<std::uint64_t>(robot_seed), rp, robot_opt);
      return 0;
    }
    return robots(robot_count, rp, with, points_file, robot_opt);
  }
  if (point) {
    point->first.duration_s = duration;
    if (std::string err =
            [&] {
              red::PolicyOptions o;
              return red::apply_options(o, with);
            }();
        !err.empty()) {
      std::cerr << "red_load_grid: --with: " << err << "\n";
      return 2;
    }
    if (yaml) {
      // The set at load 1; `red compare FILE --set rate_scale=LOAD` runs the point.
      std::cout << red::grid::set_yaml(point->first, red::default_profile());
      return 0;
    }
    return diagnose(point->first, point->second, with);
  }
  const auto t0 = std::chrono::steady_clock::now();
  const red::Profile profile = red::default_profile();
  Summary sum;
  std::ofstream points_out;
  std::string header = "point\tload";
  for (const std::string& p : kPolicies) header += "\t" + p;
  if (!open_tsv(points_out, points_file, header + "\tbound\twaste")) return 1;
  if (points_out.is_open()) sum.points_out = &points_out;
  for (const red::grid::SetSpec& spec : red::grid::grid_sets(seeds, duration)) {
    const std::string family = fmt::format("{}, {} lane{}", red::grid::to_string(spec.nodes),
                                           spec.lanes, spec.lanes > 1 ? "s" : "");
    const std::string label = fmt::format("{} {} seed {} on {} lane(s)", to_string(spec.nodes),
                                          to_string(spec.shape), spec.seed, spec.lanes);
    for (double load : kLoads) {
      const red::Scenario s = red::grid::set_scenario(spec, profile, load);
      std::map<std::string, Point> pts;
      for (const std::string& p : kPolicies)
        pts[p] = red::grid::evaluate(with_options(s, p, with), profile, p);
      add_point(sum, family, label, load, pts, red::grid::work_bound(s, profile));
    }
  }
  // The bundled scenarios, swept over the same loads (rate_scale of their own rates).
  for (const char* name : {"minibench-tight", "minibench-loose", "case-dynamic", "case-async"}) {
    auto base = red::load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name + ".yaml");
    if (!base) {
      std::cerr << base.error().to_string() << "\n";
      return 1;
    }
    auto p = red::resolve_profile(*base, std::nullopt);
    if (!p) return 1;
    for (double load : kLoads) {
      red::Scenario s = *base;
      if (auto err = red::apply_override(s, "rate_scale", load)) continue;
      std::map<std::string, Point> pts;
      for (const std::string& pol : kPolicies)
        pts[pol] = red::grid::evaluate(with_options(s, pol, with), *p, pol);
      add_point(sum, std::string("bundled ") + name, name, load, pts, red::grid::work_bound(s, *p));
    }
  }
  const std::string table = render(sum, seeds, duration);
  std::cout << table;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cerr << fmt::format("red_load_grid: {} points in {:.1f} s\n", sum.points, wall);
  if (!markdown.empty()) {
    const std::string dir = std::filesystem::path(markdown).parent_path().string();
    const std::string svg = (dir.empty() ? std::string(".") : dir) + "/plots/load-grid.svg";
    std::filesystem::create_directories(std::filesystem::path(svg).parent_path());
    plot(sum, svg);
    const std::string body = fmt::format(
        "Regenerate with `build/bench/red_load_grid --seeds {} --duration {} --markdown "
        "docs/BENCHMARKS.md` (simulator, built-in default profile; deterministic).\n\n"
        "![on-time fraction vs load](plots/load-grid.svg)\n\n{}",
        seeds, duration, table);
    return rewrite_section(markdown, body);
  }
  return 0;
}
