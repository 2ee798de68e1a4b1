// The policy options of a scenario's `scheduler:` section: the scenario loader keeps them as the
// file writes them (key, value, lines), and check_policy_options() of the policy layer reads and
// checks them, with the messages and lines the loader gave when it checked them itself.

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "red/analysis/analyze.hpp"
#include "red/metrics/policy_run.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

// A scenario whose scheduler section is `section` (indented lines, from line 4 on).
Scenario with_section(const std::string& section) {
  const Expected<Scenario> s = parse_scenario(
      "name: o\nduration_s: 1\nscheduler:\n" + section +
          "operations:\n  - {name: a, rate_hz: 5, deadline_ms: 10, nodes: {X: {cost_ms: 1}}}\n",
      "o.yaml");
  EXPECT_TRUE(s.has_value()) << s.error().to_string();
  return s.has_value() ? *s : Scenario{};
}

// The message set_option gives for `key=value`.
std::string refusal(const std::string& key, const std::string& value) {
  PolicyOptions o;
  return set_option(o, key, value);
}

TEST(PolicyOptionsOfAScenario, GoodOptionsPassAndKeepTheirTextInFileOrder) {
  const Scenario s = with_section("  drop: hopeless\n  gamma_ms: 10\n  admission: shed\n");
  const std::optional<Error> e = check_policy_options(s);
  EXPECT_FALSE(e.has_value()) << e->to_string();
  EXPECT_EQ(s.scheduler.policy_with, "drop=hopeless,admission=shed");
  ASSERT_EQ(s.scheduler.policy_options.size(), 2u);
  EXPECT_EQ(s.scheduler.policy_options[0].key, "drop");
  EXPECT_EQ(s.scheduler.policy_options[0].line, 4);
  EXPECT_EQ(s.scheduler.policy_options[1].line, 6);
  PolicyOptions o;
  EXPECT_EQ(apply_options(o, s.scheduler.policy_with), "");
  EXPECT_EQ(o.drop, DropMode::Hopeless);
  EXPECT_EQ(o.admission, Admission::Shed);
}

TEST(PolicyOptionsOfAScenario, ABadValueIsNamedAtItsLine) {
  const Scenario s = with_section("  gamma_ms: 10\n  admission: sideways\n");
  const std::optional<Error> e = check_policy_options(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->file, "o.yaml");
  EXPECT_EQ(e->line, 5);
  EXPECT_EQ(e->message, "scheduler.admission: " + refusal("admission", "sideways"));
  EXPECT_NE(e->message.find("'sideways' is not one of: none, shed"), std::string::npos);
}

// The key's line, and every key the section takes: its own knobs, then the policy options.
TEST(PolicyOptionsOfAScenario, AnUnknownKeyIsNamedAtItsLineWithEveryKeyTheSectionTakes) {
  const Scenario s = with_section("  gamma_ms: 10\n  colour:\n    red\n");
  const std::optional<Error> e = check_policy_options(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->line, 5);
  std::string allowed;
  for (const std::vector<std::string>* keys : {&scheduler_keys(), &option_keys()})
    for (const std::string& k : *keys) allowed += (allowed.empty() ? "" : ", ") + k;
  EXPECT_EQ(e->message, "scheduler: unknown key 'colour' (allowed: " + allowed + ")");
}

TEST(PolicyOptionsOfAScenario, AValueThatIsNotTextIsNamedAtItsLine) {
  const Scenario s = with_section("  drop:\n    {a: 1}\n");
  const std::optional<Error> e = check_policy_options(s);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->line, 5);
  EXPECT_EQ(e->message, "scheduler.drop: must be a non-empty string, got a mapping");
}

// The loader's order: every key first, then the values in option_keys() order (a bad `graph`
// before a bad `drop`, whichever the file writes first).
TEST(PolicyOptionsOfAScenario, KeysAreCheckedBeforeValuesAndValuesInOptionOrder) {
  const Scenario unknown = with_section("  drop: sometimes\n  colour: red\n");
  const std::optional<Error> e1 = check_policy_options(unknown);
  ASSERT_TRUE(e1.has_value());
  EXPECT_NE(e1->message.find("unknown key 'colour'"), std::string::npos) << e1->message;
  const Scenario values = with_section("  drop: sometimes\n  graph: round\n");
  const std::optional<Error> e2 = check_policy_options(values);
  ASSERT_TRUE(e2.has_value());
  EXPECT_EQ(e2->line, 5);
  EXPECT_EQ(e2->message, "scheduler.graph: " + refusal("graph", "round"));
}

// A library caller that loads a scenario and goes straight to the simulator or the analysis
// (without check_policy_options) gets the same located error, not a run with the option
// silently left out.
TEST(PolicyOptionsOfAScenario, SimulateAndAnalyzeRefuseAScenarioWhoseOptionsWereNotChecked) {
  const Scenario bad = with_section("  gamma_ms: 10\n  admission: sideways\n");
  const Expected<PolicyRun> run = simulate_policy(bad, default_profile(), "red", 1);
  ASSERT_FALSE(run.has_value());
  EXPECT_EQ(run.error().file, "o.yaml");
  EXPECT_EQ(run.error().line, 5);
  EXPECT_EQ(run.error().message, "scheduler.admission: " + refusal("admission", "sideways"));
  const Expected<Analysis> a = analyze(bad, default_profile());
  ASSERT_FALSE(a.has_value());
  EXPECT_EQ(a.error().line, 5);
  EXPECT_EQ(a.error().message, run.error().message);

  const Scenario good = with_section("  admission: shed\n");
  const Expected<PolicyRun> ok = simulate_policy(good, default_profile(), "red", 1);
  ASSERT_TRUE(ok.has_value()) << ok.error().to_string();
  EXPECT_GT(ok->metrics.jobs, 0);
}

}  // namespace
}  // namespace red
