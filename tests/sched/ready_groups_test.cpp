// The ready set's groups (src/sched/ready_set.cpp) change what a decision costs, never a
// decision: every policy, on the load grid's random DAG sets,
// on robot workloads (events, criticality levels, depends_on, several sensors) and on many
// copies of one DAG released together, makes the same calls with groups formed at once
// (group_from 1) and with none (group_from INT_MAX): every release, dispatch, unit end,
// job outcome and round, in order, the same.

#include <gtest/gtest.h>

#include <fmt/format.h>

#include <limits>
#include <string>
#include <vector>

#include "../support/load_grid.hpp"
#include "../support/robot_workload.hpp"
#include "../support/size.hpp"
#include "red/profile/profile.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/simulator.hpp"

namespace red {
namespace {

// Writes every callback as one line.
class Log final : public Observer {
 public:
  std::vector<std::string> lines;
  void on_job_release(const JobRecord& j) override {
    lines.push_back(fmt::format("release {} op {} at {} due {} {}", j.id, j.operation,
                                j.release.count(), j.deadline.count(), to_string(j.outcome)));
  }
  void on_job_end(const JobRecord& j) override {
    lines.push_back(
        fmt::format("end {} {} at {} {}", j.id, to_string(j.outcome), j.finish.count(), j.reason));
  }
  void on_unit_start(const Dispatch& d) override {
    std::string m;
    for (const Member& x : d.members) m += fmt::format(" {}/{}", x.job, x.unit);
    lines.push_back(fmt::format("start {} lane {} at {} due {} batch {}:{}", d.id, d.lane,
                                d.start.count(), d.deadline.count(), d.batch, m));
  }
  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) override {
    lines.push_back(fmt::format("unit end {} at {} {}", d.id, end.count(), to_string(s)));
  }
  void on_merge_wait(int sensor, TimePoint now, TimePoint until) override {
    lines.push_back(fmt::format("wait {} {} {}", sensor, now.count(), until.count()));
  }
  void on_decision(TimePoint now, int ready, int idle, int waiting) override {
    lines.push_back(
        fmt::format("round {} ready {} idle {} waiting {}", now.count(), ready, idle, waiting));
  }
};

std::vector<std::string> run(const Scenario& s, const Profile& p, const std::string& policy,
                             int group_from) {
  SimOptions o;
  o.seed = s.seed;
  o.group_from = group_from;
  auto pol = make_policy(policy);
  EXPECT_TRUE(pol) << policy;
  Simulator sim(s, p, std::move(pol), o);
  Log log;
  sim.add_observer(&log);
  (void)sim.run();
  return std::move(log.lines);
}

// Every policy there is.
const std::vector<std::string>& kPolicies = known_policies();

// The first line the two runs differ at, or "" when they do not.
std::string first_difference(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (a[i] != b[i]) return fmt::format("line {}: grouped '{}', ungrouped '{}'", i, a[i], b[i]);
  if (a.size() != b.size()) return fmt::format("{} lines against {}", a.size(), b.size());
  return "";
}

void expect_same(const Scenario& s, const Profile& p, const std::string& what) {
  for (const std::string& policy : kPolicies) {
    const auto grouped = run(s, p, policy, 1);
    const auto ungrouped = run(s, p, policy, std::numeric_limits<int>::max());
    ASSERT_GT(grouped.size(), 10u) << what << ", " << policy;
    EXPECT_EQ(first_difference(grouped, ungrouped), "") << what << ", " << policy;
  }
}

TEST(ReadyGroups, DecideAsTheFullScanOnTheLoadGrid) {
  const Profile p = default_profile();
  // Under a sanitizer, one set of each lane count, shape and kind of node (size.hpp).
  for (const grid::SetSpec& spec : test::sized_subset(grid::grid_sets(1, 1.5), 5))
    for (double load : {0.8, 1.5, 2.5})
      expect_same(grid::set_scenario(spec, p, load), p,
                  fmt::format("grid set {} at {}", spec.seed, load));
}

TEST(ReadyGroups, DecideAsTheFullScanOnRobotWorkloads) {
  const Profile p = default_profile();
  for (std::uint64_t seed = 1; seed <= test::sized(12, 3); ++seed)
    for (double load : {1.0, 2.0})
      expect_same(robot::workload(seed, p, load), p, fmt::format("robot {} at {}", seed, load));
}

// N copies of a diamond with its own rate released at one instant, two heights' worth of
// deadlines (half the copies due sooner), on two lanes: hundreds of ready tasks, most of
// them in a few groups.
std::string copies_yaml(int n) {
  std::string y =
      "name: copies\nduration_s: 3\nwarmup_s: 0\nseed: 1\ndevice: {lanes: 2}\noperations:\n";
  for (int i = 0; i < n; ++i)
    y += fmt::format(
        "  - name: d{}\n    rate_hz: 1\n    deadline_ms: {}\n    nodes:\n"
        "      a: {{cost_ms: 0.2}}\n      b: {{cost_ms: 0.3}}\n      c: {{cost_ms: 0.1}}\n"
        "      e: {{cost_ms: 0.2}}\n    edges: [[a, b], [a, c], [b, e], [c, e]]\n",
        i, i % 2 == 0 ? 150 : 400);
  return y;
}

TEST(ReadyGroups, DecideAsTheFullScanOnCopiesReleasedTogether) {
  const Profile p = default_profile();
  for (int n : {60, test::sized(300, 120)}) {  // size.hpp
    auto s = parse_scenario(copies_yaml(n), "copies.yaml");
    ASSERT_TRUE(s) << s.error().to_string();
    expect_same(*s, p, fmt::format("{} copies", n));
  }
}

}  // namespace
}  // namespace red
