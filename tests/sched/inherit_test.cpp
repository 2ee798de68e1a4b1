// Deadline inheritance across operations (PolicyOptions::inherit, docs/DESIGN.md,
// "Overload"): a job that a job of another operation waits on (depends_on) is planned to
// that job's deadline less the path from its waiting units, so a lax operation does not
// hold back a tight one that waits for it.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/metrics/tally.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

// One lane, every 100 ms: `plan` (two 8 ms nodes, 200 ms) at 0, `steer` (4 ms, 25 ms,
// waits for the newest `plan` job) at 1 ms, `log` (10 ms, 40 ms) at 2 ms. `plan`'s first
// node starts at once; after it, by its own deadlines `log` (due 42 ms) goes before `plan`'s
// second node (due about 200 ms), and `steer` can start only at 26 ms, its deadline. Planned
// to `steer`'s deadline less its 4 ms, `plan`'s second node is due by 22 ms: it goes first,
// then `steer`, then `log`, all on time.
constexpr const char* kScenario = R"(
name: inherit
duration_s: 3
seed: 3
device: {lanes: 1, sync_cost_us: 0}
sensors:
  camera: {rate_hz: 10}
operations:
  - name: plan
    rate_hz: 10
    phase_ms: 0
    deadline_ms: 200
    max_inflight: 3
    nodes:
      A: {cost: {mean_ms: 8, p99_ms: 8.2}}
      B: {cost: {mean_ms: 8, p99_ms: 8.2}}
    edges: [[A, B]]
  - name: steer
    rate_hz: 10
    phase_ms: 1
    deadline_ms: 25
    depends_on: {operation: plan, use: latest}
    nodes:
      C: {cost: {mean_ms: 4, p99_ms: 4.1}}
  - name: log
    rate_hz: 10
    phase_ms: 2
    deadline_ms: 40
    nodes:
      D: {cost: {mean_ms: 10, p99_ms: 10.2}}
)";

// Each operation's tally of ended jobs under `policy` with `with` (policy options).
std::vector<OutcomeTally> run(const std::string& policy, const std::string& with) {
  auto s = parse_scenario(kScenario, "inherit.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  if (!s) return {};
  s->scheduler.policy_with = with;
  auto r = simulate_policy(*s, default_profile(), policy, s->seed, {}, false);
  EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().to_string());
  if (!r) return {};
  std::vector<OutcomeTally> c(static_cast<std::size_t>(s->operation_count()));
  for (const JobRow& j : r->jobs) c[static_cast<std::size_t>(j.operation)].add(j.outcome, j.qoe);
  return c;
}

TEST(Inherit, AJobWaitedOnIsPlannedToItsDependentsDeadline) {
  const std::vector<OutcomeTally> with = run("red-robust", "");
  const std::vector<OutcomeTally> without = run("red-robust", "inherit=no");
  const std::vector<OutcomeTally> red = run("red", "");
  ASSERT_EQ(with.size(), 3u);
  ASSERT_EQ(without.size(), 3u);
  ASSERT_EQ(red.size(), 3u);
  // 30 periods: every job of every operation on time with inheritance.
  for (const OutcomeTally& c : with) {
    EXPECT_GE(c.decided(), 29);
    EXPECT_EQ(c.met, c.decided());
  }
  // Without it, `steer` (operation 1) waits behind `log` and misses, under red-robust and red.
  EXPECT_LT(without[1].met, without[1].decided() / 2);
  EXPECT_LT(red[1].met, red[1].decided() / 2);
}

}  // namespace
}  // namespace red
