// The Chrome/Perfetto timeline (trace.json): valid JSON, the expected tracks and events,
// slices that never overlap on a track, an instant per job release and deadline, marked
// misses, a ready-queue counter, and bounded memory.

#include "red/observe/trace.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "red/metrics/policy_run.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

using nlohmann::json;

Scenario load(const std::string& name) {
  auto s = load_scenario(std::string(RED_SOURCE_DIR) + "/scenarios/" + name);
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return std::move(s.value());
}

// Two lanes, two operations, one of them triggered at a high rate with max_inflight 3:
// several jobs of one operation in flight at once, units on both lanes.
constexpr const char* kTwoLanes = R"(
name: two-lanes
duration_s: 2
warmup_s: 0.2
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det], input: [3, 192, 384]}
sensors:
  front: {rate_hz: 40}
  rear: {rate_hz: 25, phase_ms: 7}
operations:
  - name: drive
    trigger: front
    deadline_ms: 45
    max_inflight: 3
    nodes:
      L: {head: lane, sensor: front}
      S: {head: seg, sensor: front}
      C: {head: steer, sensor: front}
    edges: [[L, C], [S, C]]
  - name: watch
    rate_hz: 20
    deadline_ms: 60
    nodes:
      D: {head: det, sensor: rear}
      P: {cost_ms: 2}
    edges: [[D, P]]
)";

Scenario two_lanes() {
  auto s = parse_scenario(kTwoLanes, "two-lanes.yaml");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().to_string());
  return std::move(s.value());
}

// Counts what the scheduler reported, to compare with the trace.
struct Counting final : Observer {
  std::vector<JobRecord> ended;
  int unit_starts = 0;
  void on_job_end(const JobRecord& j) override { ended.push_back(j); }
  void on_unit_start(const Dispatch&) override { ++unit_starts; }
};

struct Traced {
  json trace;
  Counting seen;
  bool truncated = false;
};

Traced run(const Scenario& s, const std::vector<std::string>& policies, TraceOptions options = {}) {
  Traced out;
  std::vector<std::unique_ptr<TraceObserver>> traces;
  std::vector<TraceProcess> processes;
  for (const std::string& p : policies) {
    traces.push_back(std::make_unique<TraceObserver>(s, options));
    std::vector<Observer*> extra{traces.back().get()};
    if (processes.empty()) extra.push_back(&out.seen);  // counts for the first policy only
    auto r = simulate_policy(s, default_profile(), p, s.seed, extra);
    EXPECT_TRUE(r.has_value());
    processes.push_back({"policy " + p, traces.back().get()});
    out.truncated = out.truncated || traces.back()->truncated();
  }
  const std::string text = chrome_trace_json(s, processes, {{"backend", "sim"}});
  out.trace = json::parse(text);  // throws (fails the test) if it is not JSON
  return out;
}

std::int64_t ns(const json& us) {
  return std::llround(us.get<double>() * 1000.0);
}

// For every (pid, tid): X slices sorted by start never overlap (nesting is not used).
void expect_no_overlap(const json& trace) {
  std::map<std::pair<int, int>, std::vector<std::pair<std::int64_t, std::int64_t>>> tracks;
  for (const json& e : trace.at("traceEvents"))
    if (e.at("ph") == "X") {
      ASSERT_GE(ns(e.at("dur")), 0) << e.dump();
      tracks[{e.at("pid").get<int>(), e.at("tid").get<int>()}].push_back(
          {ns(e.at("ts")), ns(e.at("dur"))});
    }
  ASSERT_FALSE(tracks.empty());
  for (auto& [track, slices] : tracks) {
    std::sort(slices.begin(), slices.end());
    for (std::size_t i = 1; i < slices.size(); ++i)
      ASSERT_LE(slices[i - 1].first + slices[i - 1].second, slices[i].first)
          << "overlap on pid " << track.first << " tid " << track.second << " at slice " << i;
  }
}

std::map<std::string, std::string> thread_names(const json& trace, int pid) {
  std::map<std::string, std::string> out;
  for (const json& e : trace.at("traceEvents"))
    if (e.at("ph") == "M" && e.at("name") == "thread_name" && e.at("pid") == pid)
      out[e.at("args").at("name").get<std::string>()] = std::to_string(e.at("tid").get<int>());
  return out;
}

TEST(Trace, ParsesAsJsonWithTheExpectedTracksAndEvents) {
  const Scenario s = load("case-dynamic.yaml");
  const Traced t = run(s, {"red"});
  const json& j = t.trace;
  EXPECT_EQ(j.at("displayTimeUnit"), "ms");
  EXPECT_EQ(j.at("otherData").at("scenario"), "case-dynamic");
  EXPECT_EQ(j.at("otherData").at("backend"), "sim");
  const auto names = thread_names(j, 1);
  EXPECT_TRUE(names.count("lane 0"));
  EXPECT_TRUE(names.count("navigate: release, deadline, misses"));
  EXPECT_TRUE(names.count("navigate: jobs"));
  std::map<std::string, int> kinds;
  int counters = 0, workload = 0, process_names = 0;
  for (const json& e : j.at("traceEvents")) {
    const std::string ph = e.at("ph");
    if (ph == "X" && e.at("cat") != "job" && e.at("cat") != "sync") {
      ++kinds[e.at("args").at("kind").get<std::string>()];
      const json& a = e.at("args");
      for (const char* key : {"kind", "batch", "members", "round_trip", "status", "job"})
        EXPECT_TRUE(a.contains(key)) << key << " in " << e.dump();
      EXPECT_EQ(a.at("members").size(), a.at("merged").get<std::size_t>());
      EXPECT_GE(a.at("batch").get<int>(), 1);
      if (a.at("kind") == "head") {
        EXPECT_TRUE(a.contains("head"));
      }
    }
    if (ph == "C" && e.at("name") == "ready queue") {
      ++counters;
      EXPECT_GE(e.at("args").at("length").get<int>(), 0);
    }
    if (ph == "i" && e.at("cat") == "workload") {
      ++workload;
      EXPECT_EQ(e.at("s"), "g");
    }
    if (ph == "M" && e.at("name") == "process_name") {
      ++process_names;
      EXPECT_EQ(e.at("args").at("name"), "policy red");
    }
  }
  // red runs the fine graph: encoders and heads; case-dynamic has two workload events.
  EXPECT_GT(kinds["encoder"], 0);
  EXPECT_GT(kinds["head"], 0);
  EXPECT_GT(counters, 0);
  EXPECT_EQ(workload, 2);
  EXPECT_EQ(process_names, 1);
}

TEST(Trace, EveryUnitExecutionIsOneSliceOnItsLane) {
  const Scenario s = two_lanes();
  const Traced t = run(s, {"red"});
  int slices = 0;
  std::set<int> lanes;
  const auto names = thread_names(t.trace, 1);
  for (const json& e : t.trace.at("traceEvents"))
    if (e.at("ph") == "X" && e.at("cat") != "job" && e.at("cat") != "sync") {
      ++slices;
      lanes.insert(e.at("tid").get<int>());
    }
  EXPECT_EQ(slices, t.seen.unit_starts);
  EXPECT_EQ(lanes.size(), 2u);  // both lanes used
  for (int tid : lanes) {
    bool named = false;
    for (const auto& [name, id] : names) named = named || id == std::to_string(tid);
    EXPECT_TRUE(named) << tid;
  }
}

TEST(Trace, SlicesNeverOverlapOnATrack) {
  for (const char* policy : {"fifo", "mono", "edf", "red-fg", "red"}) {
    SCOPED_TRACE(policy);
    expect_no_overlap(run(two_lanes(), {policy}).trace);
    expect_no_overlap(run(load("case-dynamic.yaml"), {policy}).trace);
  }
  // Several policies in one file: each is its own process with its own tracks.
  expect_no_overlap(run(load("case-async.yaml"), {"edf", "red"}).trace);
}

TEST(Trace, ReleaseAndDeadlineInstantsForEveryJob) {
  const Scenario s = two_lanes();
  const Traced t = run(s, {"edf"});
  std::map<std::string, std::int64_t> release, deadline;
  for (const json& e : t.trace.at("traceEvents"))
    if (e.at("ph") == "i" && e.at("cat") == "job") {
      const std::string job = e.at("args").at("job");
      (e.at("name") == "release" ? release : deadline)[job] = ns(e.at("ts"));
    }
  ASSERT_FALSE(t.seen.ended.empty());
  EXPECT_EQ(release.size(), t.seen.ended.size());
  for (const JobRecord& j : t.seen.ended) {
    const std::string name = s.operation_name(j.operation) + "#" + std::to_string(j.seq);
    ASSERT_TRUE(release.count(name)) << name;
    ASSERT_TRUE(deadline.count(name)) << name;
    EXPECT_EQ(release[name], j.release.count()) << name;
    EXPECT_EQ(deadline[name], j.deadline.count()) << name;
  }
}

TEST(Trace, MissesAndDropsAreMarkedWithTheirOutcome) {
  const Scenario s = load("case-dynamic.yaml");
  const Traced t = run(s, {"edf"});  // edf drops jobs once the third node joins
  std::map<std::string, int> expected;
  for (const JobRecord& j : t.seen.ended)
    if (j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished)
      ++expected[to_string(j.outcome)];
  ASSERT_GT(expected["dropped"], 0);
  std::map<std::string, int> marked;
  for (const json& e : t.trace.at("traceEvents"))
    if (e.at("ph") == "i" && e.at("cat") == "miss") {
      ++marked[e.at("args").at("outcome").get<std::string>()];
      std::string upper = e.at("args").at("outcome");
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      EXPECT_EQ(e.at("name"), upper);
    }
  EXPECT_EQ(marked, expected);
}

TEST(Trace, JobSlicesCarryTheOutcome) {
  const Traced t = run(load("case-dynamic.yaml"), {"fifo"});
  std::map<std::string, int> outcomes;
  for (const json& e : t.trace.at("traceEvents"))
    if (e.at("ph") == "X" && e.at("cat") == "job") {
      ++outcomes[e.at("args").at("outcome").get<std::string>()];
      EXPECT_NEAR(e.at("args").at("response_ms").get<double>(), e.at("dur").get<double>() / 1000,
                  1e-3);
    }
  EXPECT_GT(outcomes["met"], 0);
  EXPECT_GT(outcomes["missed"], 0);  // fifo completes late jobs
}

TEST(Trace, SamePlainRunGivesTheSameBytes) {
  // The trace holds only the times the scheduler passed: no wall clock leaks in.
  const Scenario s = load("case-async.yaml");
  EXPECT_EQ(run(s, {"red"}).trace.dump(), run(s, {"red"}).trace.dump());
}

TEST(Trace, StopsAtTheEventLimitAndSaysSo) {
  const Scenario s = load("minibench-tight.yaml");
  TraceOptions o;
  o.max_events = 800;
  TraceObserver trace(s, o);
  ASSERT_TRUE(simulate_policy(s, default_profile(), "red", s.seed, {&trace}).has_value());
  EXPECT_TRUE(trace.truncated());
  EXPECT_LE(trace.events(), o.max_events);
  EXPECT_GT(trace.truncated_at(), TimePoint{0});
  EXPECT_LT(trace.truncated_at(), s.duration);
  const json j = json::parse(chrome_trace_json(s, {{"policy red", &trace}}));
  EXPECT_TRUE(j.at("otherData").contains("truncated policy red"));
  // Nothing after the cut, apart from deadlines of jobs released before it.
  for (const json& e : j.at("traceEvents"))
    if (e.at("ph") == "X") {
      EXPECT_LE(ns(e.at("ts")), trace.truncated_at().count()) << e.dump();
    }
  EXPECT_LE(j.at("traceEvents").size(), o.max_events + 100);  // + metadata events
  expect_no_overlap(j);
}

TEST(Trace, EscapesTextForJson) {
  const Scenario s = load("case-async.yaml");
  TraceObserver trace(s);
  const std::string text = chrome_trace_json(s, {{"policy \"quoted\"\n", &trace}},
                                             {{"note", "back\\slash \"q\" \t tab \x01"}});
  const json j = json::parse(text);
  EXPECT_EQ(j.at("otherData").at("note"), "back\\slash \"q\" \t tab \x01");
}

}  // namespace
}  // namespace red
