// red_host_probe: does this machine's speed hold still? Two loops run side by side for a while,
// each pinned to its own CPU: one bound to the core (a dependency chain over an array that
// stays in the first-level cache), one bound to memory (a stride over an array far larger
// than the caches, one cache line a step). Each times fixed chunks of work; per block of
// time it prints the median chunk over the median of the whole run.
//
// On a machine of its own both stay within a percent or two. Where the core-bound loop holds
// and the memory-bound one moves, what moves is the memory system the machine shares (a
// virtual machine's host: other guests on the same caches and memory bandwidth), which no
// calibration taken minutes before can know (docs/FIDELITY.md, "The host's memory system").

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <exception>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Chunk {
  double at_s;  ///< start, from the probe's start
  double ms;    ///< how long the chunk took
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// Keeps the compiler from dropping a loop whose result is otherwise unused.
void keep(double x) {
  asm volatile("" : : "g"(x) : "memory");
}

bool pin(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return pthread_setaffinity_np(pthread_self(), sizeof(set), &set) == 0;
}

// Times `chunk` (which returns a value to keep) back to back from now until `end`.
template <class F>
std::vector<Chunk> timed(Clock::time_point t0, Clock::time_point end, F chunk) {
  std::vector<Chunk> out;
  while (Clock::now() < end) {
    const auto s = Clock::now();
    keep(chunk());
    const auto e = Clock::now();
    out.push_back({std::chrono::duration<double>(s - t0).count(),
                   std::chrono::duration<double, std::milli>(e - s).count()});
  }
  return out;
}

// About 5 ms of a dependency chain over 64 KiB: the core's speed alone.
std::vector<Chunk> core_bound(Clock::time_point t0, Clock::time_point end) {
  std::vector<float> a(16384);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<float>(i) * 1e-3f;
  return timed(t0, end, [&] {
    double x = 1.0;
    for (int r = 0; r < 200; ++r)
      for (const float v : a) x = x * 0.9999999 + v;
    return x;
  });
}

// One pass over `mb` MiB, a cache line a step: the memory system's speed.
std::vector<Chunk> memory_bound(Clock::time_point t0, Clock::time_point end, std::size_t mb) {
  std::vector<double> a(mb * 1024 * 1024 / sizeof(double));
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<double>(i) * 1e-9;
  return timed(t0, end, [&] {
    double x = 0.0;
    for (std::size_t i = 0; i < a.size(); i += 8) x += a[i];
    return x;
  });
}

struct Blocks {
  double median_ms = 0.0;
  std::vector<double> ratios;  ///< per block: its median chunk over median_ms
};

Blocks blocks(const std::vector<Chunk>& chunks, double block_s) {
  Blocks b;
  std::vector<double> all;
  std::map<long, std::vector<double>> per;
  for (const Chunk& c : chunks) {
    all.push_back(c.ms);
    per[static_cast<long>(c.at_s / block_s)].push_back(c.ms);
  }
  b.median_ms = median(all);
  for (auto& [k, v] : per) b.ratios.push_back(b.median_ms > 0 ? median(v) / b.median_ms : 0.0);
  return b;
}

void print(const char* name, const Blocks& b, std::size_t chunks) {
  const auto [lo, hi] = std::minmax_element(b.ratios.begin(), b.ratios.end());
  std::printf("%-13s %6zu chunks, median %.3f ms; blocks %.2f-%.2f of it:", name, chunks,
              b.median_ms, b.ratios.empty() ? 0.0 : *lo, b.ratios.empty() ? 0.0 : *hi);
  for (const double r : b.ratios) std::printf(" %.2f", r);
  std::printf("\n");
}

// A finite number between lo and hi (a whole one where `whole`), else a message naming it.
CLI::Validator in_range(double lo, double hi, bool whole = false) {
  return CLI::Validator(
      [=](std::string& s) -> std::string {
        std::size_t used = 0;
        double v = 0;
        try {
          v = std::stod(s, &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used == 0 || used != s.size() || !std::isfinite(v) || (whole && v != std::floor(v)))
          return "'" + s + "' is not " + (whole ? "a whole number" : "a number");
        if (v < lo || v > hi) return "'" + s + "' is not between " + fmt(lo) + " and " + fmt(hi);
        return {};
      },
      whole ? "INT" : "NUMBER");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Runs a core-bound and a memory-bound loop side by side, each pinned to its own CPU, and "
      "prints per block of time each one's median chunk over its median for the whole run "
      "(docs/FIDELITY.md, \"The host's memory system\")"};
  double seconds = 120;
  double block_s = 5;
  std::size_t mb = 64;
  std::string csv;
  app.add_option("--seconds", seconds, "How long both loops run")->check(in_range(0.1, 86400));
  app.add_option("--block-s", block_s, "Length of a block of time, in seconds")
      ->check(in_range(0.01, 3600));
  app.add_option("--stream-mb", mb, "The memory-bound loop's array, in MiB (far above the caches)")
      ->check(in_range(1, 65536, true));
  app.add_option("--csv", csv, "Also write every chunk: probe,at_s,ms");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }

  // Opened before the probe, so that an unwritable path does not cost the run.
  std::ofstream f;
  if (!csv.empty()) {
    f.open(csv);
    if (!f) {
      std::fprintf(stderr, "red_host_probe: cannot write %s\n", csv.c_str());
      return 1;
    }
  }
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  const auto t0 = Clock::now();
  const auto end =
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::vector<Chunk> core;
  std::vector<Chunk> memory;
  std::atomic<bool> pinned{cpus >= 2};
  std::thread a([&] {
    if (pinned && !pin(0)) pinned = false;
    core = core_bound(t0, end);
  });
  std::thread b([&] {
    if (pinned && !pin(1)) pinned = false;
    memory = memory_bound(t0, end, mb);
  });
  a.join();
  b.join();

  std::printf("%.1f s, blocks of %.2f s, %s\n", seconds, block_s,
              pinned ? "the loops pinned to CPUs 0 and 1"
                     : "the loops not pinned (fewer than 2 CPUs, or pinning refused): they "
                       "share the CPUs and each other's time");
  print("core-bound", blocks(core, block_s), core.size());
  print("memory-bound", blocks(memory, block_s), memory.size());
  if (f.is_open()) {
    f << "probe,at_s,ms\n";
    for (const Chunk& c : core) f << "core," << c.at_s << ',' << c.ms << '\n';
    for (const Chunk& c : memory) f << "memory," << c.at_s << ',' << c.ms << '\n';
    if (!f) {
      std::fprintf(stderr, "red_host_probe: cannot write %s\n", csv.c_str());
      return 1;
    }
  }
  return 0;
}
