/// \file
/// `red_bench`: the Google Benchmark programs of bench/ (docs/BENCHMARKS.md), plus one
/// mode of its own:
///
///     red_bench --decision-stats[=N]   N timed scheduling decisions per policy (default
///                                      200000): median, p90, p99, p99.9, max
///
/// Every other argument goes to Google Benchmark (--benchmark_filter=..., ...).

#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

namespace red::bench {
/// decision_bench.cpp.
int decision_stats_main(std::uint64_t decisions);
}  // namespace red::bench

int main(int argc, char** argv) {
  constexpr std::string_view kFlag = "--decision-stats";
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg.substr(0, kFlag.size()) != kFlag) continue;
    std::uint64_t n = 200'000;
    if (arg.size() > kFlag.size()) {
      if (arg[kFlag.size()] != '=') break;  // some other flag: leave it to the library
      char* end = nullptr;
      const char* text = argv[i] + kFlag.size() + 1;
      n = std::strtoull(text, &end, 10);
      if (*text == '\0' || *end != '\0' || n == 0) {
        std::fprintf(stderr, "red_bench: --decision-stats=N needs a positive integer\n");
        return 2;
      }
    }
    return red::bench::decision_stats_main(n);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
