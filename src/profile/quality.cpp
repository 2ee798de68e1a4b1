/// \file
/// Profile quality (docs/CLI.md, "Profile quality"): judging a profile's figures and reading
/// the machine's CPU counters around the measuring.

#include "red/profile/quality.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "red/profile/profile.hpp"

namespace red {

namespace {

QualityFinding oversubscribed(const MachineState& m, double other, const char* source) {
  QualityFinding f;
  f.kind = "oversubscribed";
  f.figures = {{"threads", m.threads}, {"other_busy_cpus", other}, {"online_cpus", m.online_cpus}};
  f.message = fmt::format(
      "the machine was busier than the threads asked for: {} thread(s) + {:.1f} CPU(s) busy "
      "with other processes ({}) > {} online CPU(s); the units waited for a CPU and their "
      "times are too high",
      m.threads, other, source, m.online_cpus);
  const int free = default_profile_threads(m.online_cpus, other);
  f.advice = free < m.threads
                 ? fmt::format(
                       "measure again on a quiet machine, or with --threads {} (the "
                       "CPUs not busy)",
                       free)
                 : std::string("measure again on a quiet machine (stop the other work)");
  return f;
}

}  // namespace

std::vector<QualityFinding> judge_profile(const Profile& p, const MachineState* machine,
                                          const QualityThresholds& t) {
  std::vector<QualityFinding> out;
  if (machine != nullptr && machine->threads > 0 && machine->online_cpus > 0) {
    const bool direct = machine->other_busy_cpus >= 0;
    const double other = direct ? machine->other_busy_cpus : machine->load1_before;
    if (machine->threads + other > machine->online_cpus + t.oversubscribe_margin)
      out.push_back(oversubscribed(*machine, other,
                                   direct ? "while measuring" : "1-minute load before measuring"));
  }
  for (const auto& [name, unit] : p.units) {
    for (int b = 1; b <= unit.max_batch(); ++b) {
      const LatencyStats& s = unit.at(b);
      const double p50 = to_ms(s.p50);
      const double max = to_ms(s.max);
      if (p50 > 0 && max > t.spread_ratio * p50 && max - p50 >= t.spread_floor_ms) {
        QualityFinding f;
        f.unit = name;
        f.batch = b;
        f.kind = "spread";
        f.figures = {{"p50_ms", p50},
                     {"p99_ms", to_ms(s.p99)},
                     {"max_ms", max},
                     {"max_over_p50", max / p50}};
        f.message = fmt::format(
            "{} at batch {}: max {:.3f} ms is {:.1f}x its p50 {:.3f} ms; a run that slow was "
            "held up (another process, a page fault, a clock change), not the unit's own cost",
            name, b, max, max / p50, p50);
        f.advice =
            "measure again on a quiet machine (fewer --threads, nothing else running); "
            "deadlines checked against p99 or max would be too pessimistic";
        out.push_back(std::move(f));
      }
    }
    for (int b = 1; b < unit.max_batch(); ++b) {
      const double here = to_ms(unit.at(b).mean);
      const double next = to_ms(unit.at(b + 1).mean);
      if (here > 0 && next < (1.0 - t.batch_tolerance) * here) {
        QualityFinding f;
        f.unit = name;
        f.batch = b + 1;
        f.kind = "non_monotone";
        f.figures = {{"mean_ms_batch_b", here}, {"mean_ms_next_batch", next}};
        f.message = fmt::format(
            "{}: batch {} costs less in all ({:.3f} ms) than batch {} ({:.3f} ms); more frames "
            "cannot take less time, so batch {} was measured while the machine was slower",
            name, b + 1, next, b, here, b);
        f.advice = "measure again on a quiet machine (fewer --threads, nothing else running)";
        out.push_back(std::move(f));
      }
    }
  }
  return out;
}

Quality assess_quality(const Profile& p, const MachineState* machine, const QualityThresholds& t) {
  Quality q;
  if (machine != nullptr) {
    q.has_machine = true;
    q.machine = *machine;
  }
  q.findings = judge_profile(p, machine, t);
  q.verdict = q.findings.empty() ? "good" : "suspect";
  return q;
}

std::vector<std::string> quality_lines(const Quality& q, std::size_t cap) {
  std::vector<std::string> lines;
  for (const QualityFinding& f : q.findings) {
    if (lines.size() == cap) {
      lines.push_back(fmt::format("... and {} more finding(s) in the profile's quality field",
                                  q.findings.size() - cap));
      break;
    }
    lines.push_back(f.message + " (" + f.advice + ")");
  }
  return lines;
}

CpuSnapshot cpu_snapshot() {
  CpuSnapshot s;
  s.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) == 0)
    s.process_cpu_s = static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
                      static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
  {
    std::ifstream load("/proc/loadavg");
    load >> s.load1;
    if (!load) s.load1 = 0;
  }
  std::ifstream stat("/proc/stat");
  std::string line;
  if (!std::getline(stat, line) || line.rfind("cpu ", 0) != 0) return s;
  std::istringstream in(line.substr(4));
  // user nice system idle iowait irq softirq steal: busy is all but idle and iowait.
  double v[8] = {};
  for (double& x : v)
    if (!(in >> x)) return s;
  const long hz = sysconf(_SC_CLK_TCK);
  if (hz <= 0) return s;
  s.busy_cpu_s = (v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / static_cast<double>(hz);
  s.ok = true;
  return s;
}

int online_cpus() {
  const long n = sysconf(_SC_NPROCESSORS_ONLN);
  return n > 0 ? static_cast<int>(n) : 1;
}

std::string this_host() {
  std::array<char, 256> name{};
  std::string host = gethostname(name.data(), name.size() - 1) == 0 ? name.data() : "?";
  std::ifstream in("/proc/cpuinfo");
  std::string line, model;
  while (model.empty() && std::getline(in, line))
    if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos)
      model = line.substr(line.find(':') + 2);
  return host + ", " + (model.empty() ? "unknown CPU" : model) + ", " +
         std::to_string(online_cpus()) + " CPUs";
}

MachineState machine_between(const CpuSnapshot& before, const CpuSnapshot& after, int threads) {
  MachineState m;
  m.host = this_host();
  m.online_cpus = online_cpus();
  m.threads = threads;
  m.load1_before = before.load1;
  m.load1_after = after.load1;
  m.wall_s = std::max(0.0, after.wall_s - before.wall_s);
  m.process_cpu_s = std::max(0.0, after.process_cpu_s - before.process_cpu_s);
  if (before.ok && after.ok && m.wall_s > 0) {
    const double other = after.busy_cpu_s - before.busy_cpu_s - m.process_cpu_s;
    // Rounded to what the counters resolve (clock ticks over the window).
    m.other_busy_cpus = std::round(std::max(0.0, other / m.wall_s) * 100) / 100;
  }
  m.wall_s = std::round(m.wall_s * 1000) / 1000;
  m.process_cpu_s = std::round(m.process_cpu_s * 1000) / 1000;
  return m;
}

double other_busy_cpus_now(double window_s) {
  const CpuSnapshot a = cpu_snapshot();
  std::this_thread::sleep_for(std::chrono::duration<double>(window_s));
  const CpuSnapshot b = cpu_snapshot();
  const MachineState m = machine_between(a, b, 0);
  return m.other_busy_cpus >= 0 ? m.other_busy_cpus : a.load1;
}

int default_profile_threads(int online, double other_busy) {
  return std::max(1, online - static_cast<int>(std::lround(std::max(0.0, other_busy))));
}

}  // namespace red
