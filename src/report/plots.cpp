#include "red/report/plots.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>

#include <sys/wait.h>

#include "red/core/output_file.hpp"
#include "red/report/report.hpp"

namespace red {

namespace {

namespace fs = std::filesystem;

// Quoting for the shell (single quotes) and for gnuplot strings (single quotes, doubled).
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string gq(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

// Data files quote policy names for gnuplot's xtic() and titles.
std::string dq(const std::string& s) {
  std::string out = "\"";
  for (char c : s)
    if (c != '"' && c != '\n') out += c;
  return out + "\"";
}

// One color per policy, the same in every plot.
// Open markers growing with the policy's index: where the curves of several policies
// coincide, their markers nest instead of hiding one another.
std::string marker(std::size_t index) {
  static const int types[] = {6, 4, 8, 10, 12, 14, 1, 2};
  return fmt::format("pt {} ps {:.2f}", types[index % 8], 0.8 + 0.35 * static_cast<double>(index));
}

int color_int(const std::string& hex) {
  return static_cast<int>(std::strtol(hex.c_str() + 1, nullptr, 16));
}

// A "nice" step (1, 2, 2.5 or 5 × 10^k) at least `raw`.
double nice_step(double raw) {
  if (!(raw > 0)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

bool completed(const JobRow& j) {
  return j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
}
bool decided(const JobRow& j) {
  return j.outcome != JobOutcome::Unfinished;
}

// Distinct relative deadlines (ms) of the jobs, to mark on latency axes.
std::vector<double> deadlines_ms(const std::vector<PlotRun>& runs) {
  std::set<long long> us;
  for (const PlotRun& r : runs)
    for (const JobRow& j : *r.jobs) us.insert(std::llround(to_ms(j.deadline - j.release) * 1e3));
  std::vector<double> out;
  for (long long v : us) out.push_back(static_cast<double>(v) / 1e3);
  if (out.size() > 3) out = {out.front(), out.back()};  // more would clutter: show the range
  return out;
}

// Dashed vertical lines at the deadlines and one label for all of them, placed on the
// side of the lines where the plot has room (`xmax`: right end of the x axis).
std::string deadline_marks(const std::vector<double>& d, const char* axis_end, double xmax) {
  if (d.empty()) return {};
  std::string out;
  int n = 1;
  std::string values;
  for (double v : d) {
    out += fmt::format(
        "set arrow {} from {:g}, graph 0 to {:g}, graph 1 nohead back dt 2 lw 1.5 lc rgb "
        "'#333333'\n",
        n, v, v);
    values += fmt::format("{}{:g}", values.empty() ? "" : ", ", std::round(v * 10) / 10);
    ++n;
  }
  const std::string text = (d.size() == 1 ? "deadline " : "deadlines ") + values + " ms";
  // Inside the panel: after the last line when there is room to its right, else before the
  // first when there is room to its left, else centred (a label that starts at a line near
  // the right edge ran out of the panel).
  const auto [lo, hi] = std::minmax_element(d.begin(), d.end());
  if (*hi <= 0.6 * xmax)
    out += fmt::format("set label 1 {} at {:g}, graph {} left offset 0.6,0 font ',9'\n", gq(text),
                       *hi, axis_end);
  else if (*lo >= 0.4 * xmax)
    out += fmt::format("set label 1 {} at {:g}, graph {} right offset -0.6,0 font ',9'\n", gq(text),
                       *lo, axis_end);
  else
    out +=
        fmt::format("set label 1 {} at graph 0.5, graph {} center font ',9'\n", gq(text), axis_end);
  return out;
}

struct Script {
  std::string name;
  std::string title;
  int width = 1000;
  int height = 600;
  std::string data;  // written to NAME.dat
  std::string body;  // gnuplot commands after the terminal is set
};

class Plotter {
 public:
  Plotter(const std::string& dir, const PlotOptions& o) : dir_(dir), o_(o) {
    path_ = (fs::path(dir) / o.subdir).string();
    if (!o.gnuplot.empty()) terminal_ = gnuplot_png_terminal(o.gnuplot);
    if (o.gnuplot.empty())
      note("plots: no gnuplot command given; wrote data and scripts only");
    else if (terminal_.empty())
      note("plots skipped: gnuplot not found ('" + o.gnuplot +
           "'; apt-get install gnuplot-nox); data and scripts are in " + path_);
  }

  void make(const Script& s) {
    const std::string terminal_png =
        terminal_ == "pngcairo"
            ? fmt::format("set terminal pngcairo noenhanced size {},{} font 'Sans,11'", s.width,
                          s.height)
            : fmt::format("set terminal png noenhanced size {},{} font 'Sans,10'", s.width,
                          s.height);
    // The script as kept (it draws NAME.png and NAME.svg), and as run now: it draws them
    // under their .partial names, renamed into place once gnuplot has finished them.
    auto script = [&](const std::string& png, const std::string& svg) {
      std::string gp = fmt::format(
          "# {} (written by red; edit and run `gnuplot {}.gp` to redraw)\n"
          "# data: {}.dat\n{}\nset output '{}'\n{}unset output\n",
          s.title, s.name, s.name, terminal_png, png, s.body);
      if (o_.svg)
        gp += fmt::format(
            "set terminal svg noenhanced size {},{} dynamic font 'Sans,11' background rgb "
            "'white'\nset output '{}'\n{}unset output\n",
            s.width, s.height, svg, s.body);
      return gp;
    };
    const std::string png_name = s.name + ".png", svg_name = s.name + ".svg";
    if (auto e = write_file(path_, s.name + ".dat", s.data)) return lost(*e);
    report_.files.push_back(o_.subdir + "/" + s.name + ".dat");
    if (auto e = write_file(path_, s.name + ".gp", script(png_name, svg_name))) return lost(*e);
    report_.files.push_back(o_.subdir + "/" + s.name + ".gp");
    if (terminal_.empty()) return;
    const std::string run = partial_path(s.name + ".gp");
    if (auto e = write_file(path_, run, script(partial_path(png_name), partial_path(svg_name))))
      return lost(*e);
    const std::string log = s.name + ".log";
    const std::string cmd = "cd " + shell_quote(path_) + " && " + shell_quote(o_.gnuplot) + " " +
                            shell_quote(run) + " > " + shell_quote(log) + " 2>&1";
    const int rc = std::system(cmd.c_str());
    std::error_code ec;
    fs::remove(fs::path(path_) / run, ec);
    const fs::path png = fs::path(path_) / partial_path(png_name);
    const fs::path svg = fs::path(path_) / partial_path(svg_name);
    const bool ok = rc == 0 && fs::exists(png, ec) && fs::file_size(png, ec) > 0 &&
                    (!o_.svg || (fs::exists(svg, ec) && fs::file_size(svg, ec) > 0));
    if (ok) fs::rename(png, fs::path(path_) / png_name, ec);
    if (ok && !ec && o_.svg) fs::rename(svg, fs::path(path_) / svg_name, ec);
    if (!ok || ec) {
      const std::string why = ok ? "cannot be renamed into place: " + ec.message()
                                 : gnuplot_complaint(rc, fs::path(path_) / log);
      fs::remove(png, ec);
      fs::remove(svg, ec);
      lost(Error{(fs::path(path_) / png_name).string(), 0,
                 "not drawn: " + why + " (the script is " + o_.subdir + "/" + s.name +
                     ".gp, gnuplot's output " + o_.subdir + "/" + log + ")"});
      return;
    }
    fs::remove(fs::path(path_) / log, ec);
    PlotFile f;
    f.name = s.name;
    f.title = s.title;
    f.png = o_.subdir + "/" + s.name + ".png";
    if (o_.svg) f.svg = o_.subdir + "/" + s.name + ".svg";
    report_.plots.push_back(std::move(f));
  }

  PlotReport done() { return std::move(report_); }

 private:
  void note(const std::string& n) {
    if (report_.note.empty()) report_.note = n;  // the first problem explains the rest
  }

  void lost(Error e) { report_.errors.push_back(std::move(e)); }

  // Why gnuplot made no image: its exit status and the first line it printed.
  static std::string gnuplot_complaint(int rc, const fs::path& log) {
    std::string why = rc == 0 ? "gnuplot exited 0 but wrote no image"
                      : WIFEXITED(rc) != 0
                          ? fmt::format("gnuplot failed (exit {})", WEXITSTATUS(rc))
                          : "gnuplot did not finish";
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line))
      if (line.find_first_not_of(" \t^") != std::string::npos) {
        if (line.size() > 200) line = line.substr(0, 200) + "...";
        return why + ": " + line;
      }
    return why;
  }

  std::string dir_;
  PlotOptions o_;
  std::string path_;
  std::string terminal_;
  PlotReport report_;
};

// ---- run plots -----------------------------------------------------------------------------

Script response_hist(const Scenario& s, const std::vector<PlotRun>& runs,
                     const std::vector<double>& dl) {
  double xmax = 0;
  for (const PlotRun& r : runs)
    for (const JobRow& j : *r.jobs)
      if (completed(j)) xmax = std::max(xmax, to_ms(j.finish - j.release));
  for (double d : dl) xmax = std::max(xmax, d * 1.05);
  const double bin = nice_step(std::max(xmax, 1.0) / 40.0);
  const auto bins = static_cast<std::size_t>(std::ceil(std::max(xmax, 1.0) / bin)) + 1;
  Script sc;
  sc.name = "response_hist";
  sc.title = "Response time per policy";
  const std::size_t n = runs.size();
  const std::size_t cols = n <= 1 ? 1 : n <= 4 ? 2 : 3;
  const std::size_t rows = (n + cols - 1) / cols;
  sc.width = static_cast<int>(cols == 1 ? 900 : 560 * cols);
  sc.height = static_cast<int>(rows == 1 ? 520 : 330 * rows + 60);
  sc.body = fmt::format(
      "reset\nset encoding utf8\n"
      "set multiplot layout {},{} title {} font ',13'\n"
      "set style fill solid 0.8 border -1\nset boxwidth {:g} absolute\n"
      "set xrange [0:{:g}]\n"
      "set xlabel 'response time (ms)'\nset ylabel 'jobs'\n"
      "set grid ytics lc rgb '#dddddd'\nset key top right opaque font ',9'\n",
      rows, cols,
      gq(fmt::format("Response time per policy: {} ({:g} ms bins; dropped jobs have none)", s.name,
                     bin)),
      bin * 0.9, static_cast<double>(bins) * bin);
  // The y range leaves the top quarter free for the key and the deadline label.
  sc.body += deadline_marks(dl, "0.78", static_cast<double>(bins) * bin);
  // Every panel on the same axes, so their heights compare.
  std::vector<std::vector<std::int64_t>> hist(n, std::vector<std::int64_t>(bins, 0));
  std::int64_t ymax = 1;
  for (std::size_t i = 0; i < n; ++i)
    for (const JobRow& j : *runs[i].jobs)
      if (completed(j)) {
        auto& c = hist[i][std::min(bins - 1,
                                   static_cast<std::size_t>(to_ms(j.finish - j.release) / bin))];
        ymax = std::max(ymax, ++c);
      }
  sc.body += fmt::format("set yrange [0:{:.0f}]\n", std::ceil(static_cast<double>(ymax) * 1.35));
  sc.data = fmt::format("# response-time histogram: bin centre (ms), completed jobs\n");
  for (std::size_t i = 0; i < n; ++i) {
    const PlotRun& r = runs[i];
    const std::vector<std::int64_t>& h = hist[i];
    sc.data += fmt::format("{}# {}\n", i == 0 ? "" : "\n\n", r.policy);
    for (std::size_t b = 0; b < bins; ++b)
      sc.data += fmt::format("{:g} {}\n", (static_cast<double>(b) + 0.5) * bin, h[b]);
    const PolicyMetrics& m = *r.metrics;
    sc.body += fmt::format("set title {}\n",
                           gq(fmt::format("{}: {} completed, {} missed (of which {} dropped)",
                                          r.policy, m.completed, m.missed, m.dropped)));
    sc.body += fmt::format(
        "plot 'response_hist.dat' index {} using 1:2 with boxes lc rgb '{}' title {}{}\n", i,
        policy_color(r.policy, i), gq(r.policy + ": completed jobs"),
        dl.empty() ? "" : ", NaN with lines dt 2 lw 1.5 lc rgb '#333333' title 'deadline'");
  }
  sc.body += "unset multiplot\n";
  return sc;
}

Script response_cdf(const Scenario& s, const std::vector<PlotRun>& runs,
                    const std::vector<double>& dl) {
  Script sc;
  sc.name = "response_cdf";
  sc.title = "Response-time distribution (CDF)";
  sc.width = 1000;
  sc.height = 600;
  sc.data = "# response time (ms), jobs finished within it (% of decided jobs)\n";
  std::string plot;
  double xmax = 1.0;
  for (double d : dl) xmax = std::max(xmax, d * 1.05);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    std::vector<double> lat;
    std::size_t n = 0;
    for (const JobRow& j : *runs[i].jobs) {
      if (decided(j)) ++n;
      if (completed(j)) lat.push_back(to_ms(j.finish - j.release));
    }
    std::sort(lat.begin(), lat.end());
    if (!lat.empty()) xmax = std::max(xmax, lat.back() * 1.02);
    sc.data += fmt::format("{}# {}\n0 0\n", i == 0 ? "" : "\n\n", runs[i].policy);
    // At most ~2000 points per policy: enough for a smooth curve, small files.
    const std::size_t step = std::max<std::size_t>(1, lat.size() / 2000);
    for (std::size_t k = 0; k < lat.size(); ++k)
      if (k % step == 0 || k + 1 == lat.size())
        sc.data += fmt::format("{:.4f} {:.4f}\n", lat[k],
                               100.0 * static_cast<double>(k + 1) / static_cast<double>(n));
    plot += fmt::format(
        "{}'response_cdf.dat' index {} using 1:2 with steps lw 2 lc rgb '{}' title {}",
        i == 0 ? "plot " : ", \\\n     ", i, policy_color(runs[i].policy, i), gq(runs[i].policy));
  }
  if (!dl.empty()) plot += ", NaN with lines dt 2 lw 1.5 lc rgb '#333333' title 'deadline'";
  sc.body = fmt::format(
      "reset\nset encoding utf8\nset title {} font ',13'\n"
      "set xlabel 'response time (ms)'\nset ylabel 'jobs finished within that time (%)'\n"
      "set yrange [0:100]\nset xrange [0:{:g}]\nset grid lc rgb '#dddddd'\n"
      "set key outside right top\n",
      gq(fmt::format("Response-time CDF: {} (a curve that stops below 100%: jobs dropped)",
                     s.name)),
      xmax);
  sc.body += deadline_marks(dl, "0.05", xmax);
  sc.body += plot + "\n";
  return sc;
}

Script metrics_bars(const Scenario& s, const std::vector<PlotRun>& runs) {
  Script sc;
  sc.name = "metrics_bars";
  sc.title = "Miss rate, latency and QoE per policy";
  sc.width = std::max(1350, static_cast<int>(runs.size()) * 3 * 90);
  sc.height = 520;
  sc.data = "# index policy miss_rate_% latency_mean_ms latency_p99_ms qoe color drop_rate_%\n";
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const PolicyMetrics& m = *runs[i].metrics;
    sc.data += fmt::format("{} {} {:.4f} {:.4f} {:.4f} {:.4f} {} {:.4f}\n", i, dq(runs[i].policy),
                           100.0 * m.miss_rate, m.latency.mean, m.latency.p99, m.qoe,
                           color_int(policy_color(runs[i].policy, i)), 100.0 * m.drop_rate);
  }
  const double lo = -0.6;
  const double hi = static_cast<double>(runs.size()) - 0.4;
  sc.body = fmt::format(
      "reset\nset encoding utf8\n"
      "set multiplot layout 1,3 title {} font ',13'\n"
      "set style fill solid 0.8 border -1\nset boxwidth 0.6\n"
      "set xrange [{:g}:{:g}]\nset xtics nomirror\nset grid ytics lc rgb '#dddddd'\n"
      "set xlabel 'policy'\nset key top left font ',9'\n"
      "set offsets 0,0,graph 0.15,0\nset yrange [0:*]\n",
      gq(runs.size() == 1
             ? fmt::format("Results: {} ({})", s.name, runs.front().policy)
             : fmt::format("Per-policy results: {} (the same workload for every policy)", s.name)),
      lo, hi);
  sc.body +=
      "set title 'Deadline miss rate'\nset ylabel 'miss rate (%)'\n"
      "plot 'metrics_bars.dat' using 1:3:7:xtic(2) with boxes lc rgb variable "
      "title 'missed (late or dropped)', \\\n"
      "     '' using 1:8:(0.25) with boxes fill pattern 4 lc rgb '#222222' title 'of which "
      "dropped', "
      "\\\n     '' using 1:3:(sprintf('%.1f%%', $3)) with labels offset 0,0.8 font ',9' notitle\n";
  sc.body +=
      "set title 'Response time (completed jobs)'\nset ylabel 'latency (ms)'\n"
      "plot 'metrics_bars.dat' using 1:4:7:xtic(2) with boxes lc rgb variable title 'mean', \\\n"
      "     '' using 1:5 with points pt 9 ps 1.4 lc rgb '#222222' title 'p99', \\\n"
      "     '' using 1:($4/2):(sprintf('%.1f', $4)) with labels font ',9' notitle, \\\n"
      "     '' using 1:5:(sprintf('%.1f', $5)) with labels offset 0,1 font ',9' notitle\n";
  sc.body +=
      "set title 'Quality of experience'\nset ylabel 'QoE (mean per job, 0 to 1)'\n"
      "set yrange [0:1.15]\nset offsets 0,0,0,0\n"
      "plot 'metrics_bars.dat' using 1:6:7:xtic(2) with boxes lc rgb variable title 'QoE', \\\n"
      "     '' using 1:6:(sprintf('%.3f', $6)) with labels offset 0,0.8 font ',9' notitle\n"
      "unset multiplot\n";
  return sc;
}

Script miss_over_time(const Scenario& s, const std::vector<PlotRun>& runs) {
  Script sc;
  sc.name = "miss_over_time";
  sc.title = "Miss rate over time";
  sc.width = 1200;
  sc.height = 600;
  const double dur = to_s(s.duration);
  // 0.5 s bins (the paper's Fig. 1 resolution), wider on long runs to keep ~120 bins.
  const double bin = std::max(0.5, nice_step(dur / 120.0));
  const auto bins = static_cast<std::size_t>(std::ceil(dur / bin));
  sc.data = "# bin centre (s), miss rate (%), decided jobs released in the bin\n";
  std::string plot;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    std::vector<std::int64_t> n(bins + 1, 0), miss(bins + 1, 0);
    for (const JobRow& j : *runs[i].jobs) {
      if (!decided(j)) continue;
      const auto b = std::min(bins, static_cast<std::size_t>(std::max(0.0, to_s(j.release)) / bin));
      ++n[b];
      if (j.outcome != JobOutcome::Met) ++miss[b];
    }
    sc.data += fmt::format("{}# {}\n", i == 0 ? "" : "\n\n", runs[i].policy);
    bool any = false;
    for (std::size_t b = 0; b <= bins; ++b) {
      if (n[b] == 0) continue;
      any = true;
      sc.data +=
          fmt::format("{:g} {:.3f} {}\n", (static_cast<double>(b) + 0.5) * bin,
                      100.0 * static_cast<double>(miss[b]) / static_cast<double>(n[b]), n[b]);
    }
    if (!any) sc.data += "NaN NaN 0\n";  // an empty block would stop gnuplot
    plot += fmt::format(
        "{}'miss_over_time.dat' index {} using 1:2 with linespoints lw 2 {} lc rgb '{}' title {}",
        i == 0 ? "plot " : ", \\\n     ", i, marker(i), policy_color(runs[i].policy, i),
        gq(runs[i].policy));
  }
  plot += ", NaN with lines dt 2 lw 1.5 lc rgb '#555555' title 'workload event'\n";
  sc.body = fmt::format(
      "reset\nset encoding utf8\nset title {} font ',13'\n"
      "set xlabel 'time (s), jobs binned by release'\nset ylabel 'miss rate (%)'\n"
      "set xrange [0:{:g}]\nset yrange [0:112]\nset ytics 0,20,100\nset grid lc rgb '#dddddd'\n"
      "set key outside right top\n",
      gq(fmt::format("Deadline miss rate over time: {} ({:g} s bins)", s.name, bin)), dur);
  if (s.warmup > Duration{0})
    sc.body += fmt::format(
        "set object 1 rect from 0, graph 0 to {:g}, graph 1 fc rgb '#eeeeee' fs solid "
        "noborder behind\nset label 1 'warm-up' at {:g}, graph 0.5 center rotate by 90 font "
        "',9' tc rgb '#777777'\n",
        to_s(s.warmup), to_s(s.warmup) / 2);
  const bool labels = s.events.size() <= 8;
  int k = 2;
  for (const EventSpec& e : s.events) {
    const double t = to_s(e.at);
    sc.body += fmt::format(
        "set arrow {} from {:g}, graph 0 to {:g}, graph 1 nohead dt 2 lw 1.5 lc rgb '#555555'\n", k,
        t, t);
    if (labels)
      sc.body += fmt::format("set label {} {} at {:g}, graph 0.965 left offset 0.4,0 font ',9'\n",
                             k, gq(e.kind), t);
    ++k;
  }
  sc.body += plot;
  return sc;
}

}  // namespace

std::string policy_color(const std::string& policy, std::size_t index) {
  // Every preset has its own colour (known_policies(); tests/report/plots_test.cpp checks it),
  // the same in every plot and command; other names take the palette by their place in the run.
  static const std::map<std::string, std::string> known = {
      {"fifo", "#7f7f7f"},    {"mono", "#8c564b"}, {"edf", "#1f77b4"},        {"red-fg", "#ff7f0e"},
      {"red-ida", "#2ca02c"}, {"red", "#d62728"},  {"red-robust", "#9e0142"}, {"lst", "#9467bd"}};
  static const char* const palette[] = {"#17becf", "#bcbd22", "#e377c2", "#393b79",
                                        "#637939", "#8c6d31", "#843c39", "#7b4173"};
  if (auto it = known.find(policy); it != known.end()) return it->second;
  return palette[index % (sizeof(palette) / sizeof(palette[0]))];
}

std::string gnuplot_png_terminal(const std::string& gnuplot) {
  static std::mutex mu;
  static std::map<std::string, std::string> cache;
  const std::lock_guard<std::mutex> lock(mu);
  if (auto it = cache.find(gnuplot); it != cache.end()) return it->second;
  std::string found;
  for (const char* t : {"pngcairo", "png"}) {
    const std::string cmd = shell_quote(gnuplot) + " -e " +
                            shell_quote(std::string("set terminal ") + t) + " > /dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) {
      found = t;
      break;
    }
  }
  cache[gnuplot] = found;
  return found;
}

PlotReport write_run_plots(const std::string& dir, const Scenario& s,
                           const std::vector<PlotRun>& runs, const PlotOptions& options) {
  Plotter p(dir, options);
  std::vector<PlotRun> usable;
  for (const PlotRun& r : runs)
    if (r.metrics != nullptr && r.jobs != nullptr) usable.push_back(r);
  if (usable.empty()) return p.done();
  const std::vector<double> dl = deadlines_ms(usable);
  p.make(response_hist(s, usable, dl));
  p.make(response_cdf(s, usable, dl));
  p.make(metrics_bars(s, usable));
  if (!s.events.empty()) p.make(miss_over_time(s, usable));
  return p.done();
}

std::string parameter_label(const std::string& parameter) {
  static const std::map<std::string, std::string> labels = {
      {"deadline_scale", "deadline scale (x the scenario's deadlines)"},
      {"rate_scale", "rate scale (x the scenario's rates)"},
      {"qoe_lambda", "QoE lambda (log scale)"},
      {"gamma_ms", "DynamicMerge window gamma (ms)"},
      {"lanes", "lanes"},
      {"duration_s", "duration (s)"},
      {"seed", "seed"}};
  if (auto it = labels.find(parameter); it != labels.end()) return it->second;
  return parameter;
}

PlotReport write_sweep_plots(const std::string& dir, const std::string& scenario,
                             const std::string& parameter, const std::vector<double>& values,
                             const std::vector<SweepSeries>& series, const PlotOptions& options) {
  Plotter p(dir, options);
  if (values.empty() || series.empty()) return p.done();
  const double lo = *std::min_element(values.begin(), values.end());
  const double hi = *std::max_element(values.begin(), values.end());
  const bool logx = lo > 0 && hi / lo >= 100.0;
  std::string data = fmt::format(
      "# {} miss_rate_% latency_mean_ms latency_p99_ms qoe drop_rate_%, one block per policy\n",
      parameter);
  for (std::size_t i = 0; i < series.size(); ++i) {
    data += fmt::format("{}# {}\n", i == 0 ? "" : "\n\n", series[i].policy);
    for (std::size_t k = 0; k < values.size() && k < series[i].points.size(); ++k) {
      const PolicyMetrics& m = series[i].points[k];
      data +=
          fmt::format("{:g} {:.4f} {:.4f} {:.4f} {:.4f} {:.4f}\n", values[k], 100.0 * m.miss_rate,
                      m.latency.mean, m.latency.p99, m.qoe, 100.0 * m.drop_rate);
    }
  }
  const std::string xlabel = parameter_label(parameter);
  struct Curve {
    const char* name;
    const char* title;
    const char* ylabel;
    int column;
    const char* yrange;
  };
  const Curve curves[] = {
      {"sweep_miss_rate", "Deadline miss rate", "miss rate (%)", 2, "[0:*]"},
      {"sweep_latency", "Mean response time", "latency (ms, completed jobs)", 3, "[0:*]"},
      {"sweep_qoe", "Quality of experience", "QoE (mean per job, 0 to 1)", 5, "[0:1.05]"},
  };
  for (const Curve& c : curves) {
    Script sc;
    sc.name = c.name;
    sc.title = fmt::format("{} vs {}", c.title, parameter);
    sc.width = 1000;
    sc.height = 600;
    // Every curve reads the same data; each script names its own copy so it stands alone.
    sc.data = data;
    std::string plot;
    for (std::size_t i = 0; i < series.size(); ++i)
      plot += fmt::format(
          "{}'{}.dat' index {} using 1:{} with linespoints lw 2 {} lc rgb '{}' title {}",
          i == 0 ? "plot " : ", \\\n     ", c.name, i, c.column, marker(i),
          policy_color(series[i].policy, i), gq(series[i].policy));
    sc.body = fmt::format(
        "reset\nset encoding utf8\nset title {} font ',13'\nset xlabel {}\nset ylabel {}\n"
        "set yrange {}\nset grid lc rgb '#dddddd'\nset key outside right top\n{}"
        "set offsets graph 0.03, graph 0.03, 0, 0\n{}\n",
        gq(fmt::format("{} vs {}: {}", c.title, parameter, scenario)), gq(xlabel), gq(c.ylabel),
        c.yrange, logx ? "set logscale x\n" : "", plot);
    p.make(sc);
  }
  return p.done();
}

}  // namespace red
