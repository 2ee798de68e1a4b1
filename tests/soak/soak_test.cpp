// Overload soak in real time (label `integration`): the minibenchmark at 10 x its frame
// rate on the synthetic backend. Every released job is accounted for exactly once, no
// queue grows, and (without sanitizers, whose allocators keep freed memory) the resident
// set after warm-up stays flat. The 60 s and 10-minute soaks, on LibTorch too, are
// bench/soak.sh; their figures are in docs/BENCHMARKS.md.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define RED_SOAK_SANITIZED 1
#else
#define RED_SOAK_SANITIZED 0
#endif

namespace red {
namespace {

// Counts releases and ends by outcome without growing with the run (one byte per job).
struct Ledger final : Observer {
  std::int64_t released = 0;
  std::int64_t by_outcome[6] = {};
  std::int64_t twice = 0;
  std::int64_t never_released = 0;
  std::vector<std::uint8_t> state;  // by job id: 1 released, 2 ended
  Ledger() { state.reserve(1 << 16); }
  std::uint8_t& at(JobId id) {
    if (id >= state.size()) state.resize(static_cast<std::size_t>(id) + 1, 0);
    return state[static_cast<std::size_t>(id)];
  }
  void on_job_release(const JobRecord& j) override {
    ++released;
    at(j.id) = 1;
  }
  void on_job_end(const JobRecord& j) override {
    ++by_outcome[static_cast<int>(j.outcome)];
    std::uint8_t& s = at(j.id);
    if (s == 2) ++twice;
    if (s == 0) ++never_released;
    s = 2;
  }
  [[nodiscard]] std::int64_t ended() const {
    std::int64_t n = 0;
    for (std::int64_t k : by_outcome) n += k;
    return n;
  }
};

TEST(Soak, TenTimesTheMinibenchFrameRateAccountsForEveryJobAndStaysFlat) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/minibench-tight.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  ASSERT_FALSE(apply_override(*s, "rate_scale", 10).has_value());
  // RED_SOAK_SECONDS (bench/soak.sh) runs it longer than the scenario's 20 s.
  if (const char* secs = std::getenv("RED_SOAK_SECONDS")) {
    ASSERT_FALSE(apply_override(*s, "duration_s", std::atof(secs)).has_value());
  }
  const Profile p = default_profile();
  SyntheticBackend::Options bo;
  bo.spin = false;  // sleep: the overload is in the schedule, not on this machine's cores
  SyntheticBackend backend(*s, p, 1, bo);
  RuntimeOptions ro;
  ro.realtime = false;
  Runtime rt(*s, p, make_policy("red"), backend, ro);
  Ledger ledger;
  rt.add_observer(&ledger);
  const RuntimeReport r = rt.run();

  // released = met + missed + dropped + skipped + failed + unfinished, each job once.
  ASSERT_GT(ledger.released, 0);
  EXPECT_EQ(ledger.twice, 0);
  EXPECT_EQ(ledger.never_released, 0);
  EXPECT_EQ(ledger.ended(), ledger.released);
  EXPECT_GT(ledger.by_outcome[static_cast<int>(JobOutcome::Met)], 0);
  EXPECT_GT(ledger.by_outcome[static_cast<int>(JobOutcome::Skipped)] +
                ledger.by_outcome[static_cast<int>(JobOutcome::Dropped)],
            0)
      << "10 x the frame rate must overload one lane";

  // No queue grows: jobs in flight stay within max_inflight per operation, and ready units
  // within what those jobs hold (two units per node in the fine graph, the most nodes an
  // operation of this scenario has: four).
  ASSERT_GE(r.samples.size(), 10U);
  int inflight_cap = 0;
  for (const auto& op : s->initial) inflight_cap += op ? op->max_inflight : 0;
  for (const RuntimeSample& x : r.samples) {
    EXPECT_LE(x.in_flight, inflight_cap) << "at " << to_s(x.t) << " s";
    EXPECT_LE(x.ready, inflight_cap * 2 * 4) << "at " << to_s(x.t) << " s";
  }

  if (RED_SOAK_SANITIZED) {
    // A sanitizer's allocator holds freed memory (quarantine): the accounting above is
    // what is checked there.
    std::printf("soak: resident set not checked under a sanitizer\n");
    return;
  }
  // Flat after warm-up: from the sample a quarter into the run to the peak afterwards.
  const std::size_t from = r.samples.size() / 4;
  std::int64_t peak = 0;
  for (std::size_t i = from; i < r.samples.size(); ++i)
    peak = std::max(peak, r.samples[i].rss_bytes);
  const std::int64_t growth = peak - r.samples[from].rss_bytes;
  for (std::size_t i = 0; i < r.samples.size(); i += 60)
    std::printf("soak: t %.0f s RSS %.2f MB ready %d in flight %d\n", to_s(r.samples[i].t),
                static_cast<double>(r.samples[i].rss_bytes) / 1e6, r.samples[i].ready,
                r.samples[i].in_flight);
  std::printf(
      "soak: %zu samples, RSS %.2f MB at %.1f s, peak after it %.2f MB (growth %lld KB); "
      "%lld jobs released\n",
      r.samples.size(), static_cast<double>(r.samples[from].rss_bytes) / 1e6,
      to_s(r.samples[from].t), static_cast<double>(peak) / 1e6,
      static_cast<long long>(growth / 1024), static_cast<long long>(ledger.released));
  constexpr std::int64_t kBound = 4 << 20;  // 4 MiB
  EXPECT_LT(growth, kBound) << "RSS grew by " << growth << " bytes after warm-up";
}

}  // namespace
}  // namespace red
