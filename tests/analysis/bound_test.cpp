// The work bound (red/analysis/bound.hpp, docs/DESIGN.md, "Overload") is an upper bound: no
// policy's on-time fraction exceeds it, on the bundled scenarios (shared and batched encoder runs
// of MIMONet workloads, own-rate operations merged within γ, events) and on seeded random task
// sets, below and past capacity. And it is no looser than it must be where the answer is
// known by hand.

#include "red/analysis/bound.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "../support/load_grid.hpp"
#include "../support/size.hpp"
#include "red/scenario/builder.hpp"
#include "red/scenario/loader.hpp"
#include "red/sched/policy.hpp"

namespace red {
namespace {

using std::chrono::milliseconds;

// Draws of the unit costs around their means let a policy that drops the unlucky jobs beat
// a bound on mean costs by a little (one job of 87 at one point of the random sets); more
// than that is a bound that is too low.
constexpr double kDrawSlack = 0.015;

void expect_above_every_policy(const Scenario& s, const Profile& p, const std::string& what) {
  const double bound = work_bound(s, p);
  EXPECT_GE(bound, 0.0);
  EXPECT_LE(bound, 1.0);
  for (const std::string& policy : known_policies()) {
    const grid::Point pt = grid::evaluate(s, p, policy);
    EXPECT_LE(pt.on_time, bound + kDrawSlack)
        << what << ": " << policy << " met " << pt.met << " of " << pt.released
        << ", more than the bound " << bound;
  }
}

// A unit's mean cost in the profile, in ms, at batch size b.
double mean_ms(const Profile& p, const std::string& unit, int b = 1) {
  return to_ms(p.find(unit)->at(b).mean);
}

// The shape of the hand-worked cases below: 2 s on one lane from time 0, one camera "cam"
// at `hz`, MIMONet's four heads, batches of at most `max_batch`.
ScenarioBuilder one_camera(std::string name, double hz, int max_batch) {
  ScenarioBuilder b(std::move(name));
  b.duration(std::chrono::seconds{2}).warmup(milliseconds{0}).seed(1).lanes(1);
  b.heads({"lane", "seg", "steer", "det"}).max_batch(max_batch);
  b.sensor("cam", hz);
  return b;
}

// An operation each frame of "cam" triggers, with up to 4 jobs in flight.
OperationBuilder& on_camera(ScenarioBuilder& b, std::string name, Duration deadline) {
  return b.operation(std::move(name)).trigger("cam").deadline(deadline).max_inflight(4);
}

TEST(WorkBound, AboveEveryPolicyOnTheBundledScenarios) {
  const std::string dir = std::string(RED_SOURCE_DIR) + "/scenarios";
  const Profile p = default_profile();
  int seen = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    auto loaded = load_scenario(entry.path().string());
    ASSERT_TRUE(loaded) << loaded.error().to_string();
    for (double load : {1.0, 1.6, 2.5}) {
      Scenario s = *loaded;
      ASSERT_FALSE(apply_override(s, "rate_scale", load).has_value());
      // 3 s of it, or up to a second past its last event.
      double seconds = 3.0;
      for (const EventSpec& e : s.events) seconds = std::max(seconds, to_s(e.at) + 1.0);
      if (seconds < to_s(s.duration)) {
        ASSERT_FALSE(apply_override(s, "duration_s", seconds).has_value());
      }
      expect_above_every_policy(
          s, p, entry.path().filename().string() + " at load " + std::to_string(load));
      ++seen;
    }
  }
  EXPECT_GE(seen, 9 * 3);
}

TEST(WorkBound, AboveEveryPolicyOnSeededRandomSets) {
  const Profile p = default_profile();
  // Under a sanitizer, one set of each lane count, shape and kind of node (size.hpp).
  for (const grid::SetSpec& spec : test::sized_subset(grid::grid_sets(1, 2.0), 5))
    for (double load : {0.8, 1.5, 2.5}) {
      const Scenario s = grid::set_scenario(spec, p, load);
      expect_above_every_policy(s, p, s.name + " at load " + std::to_string(load));
    }
}

// Two own-rate operations sampling one camera's newest frame, released 1 ms apart: one
// encoder run may serve both (DynamicMerge: the same newest frame, or releases within γ),
// so the bound charges each job half of it; on two cameras each job pays a whole run.
TEST(WorkBound, SharesAnEncoderRunBetweenOperationsThatMayMerge) {
  const Profile p = default_profile();
  const double enc = mean_ms(p, "encoder");
  const double steer = mean_ms(p, "head/steer");
  ASSERT_LT(steer, enc);
  auto build = [&](bool one_camera) {
    ScenarioBuilder b("merged");
    b.duration(std::chrono::seconds{2}).warmup(milliseconds{0}).seed(1).lanes(1);
    b.heads({"lane", "seg", "steer", "det"}).gamma(milliseconds{5}).max_batch(1);
    b.sensor("cam1", 200).sensor("cam2", 200);
    // Alone, each job needs enc + steer; both operations together 2 (enc + steer) per
    // 1.5 (enc + steer): more than the lane has, unless one encoder run serves both
    // (enc + 2 steer < 1.5 (enc + steer) when steer < enc).
    const double hz = 1000.0 / (1.5 * (enc + steer));
    b.operation("a")
        .rate(hz)
        .deadline(milliseconds{500})
        .max_inflight(1)
        .inference("A", "steer", "cam1");
    b.operation("b")
        .rate(hz)
        .phase(milliseconds{1})
        .deadline(milliseconds{500})
        .max_inflight(1)
        .inference("B", "steer", one_camera ? "cam1" : "cam2");
    auto s = b.build();
    EXPECT_TRUE(s) << (s ? "" : s.error().to_string());
    return std::move(s).value();
  };
  EXPECT_DOUBLE_EQ(work_bound(build(true), p), 1.0);
  const double apart = work_bound(build(false), p);
  EXPECT_GT(apart, 0.70);
  EXPECT_LT(apart, 0.80);  // 1.5 / 2 of the jobs fit
}

// One camera at 100 Hz triggers two operations that read it through the steer head: one
// with a 500 ms deadline, one with 14 ms. A merged encoder run of a frame serves both
// (12 ms for 2 jobs: 6 ms a job). Batching two frames' encoder runs (18.6 ms) would be
// 4.65 ms a job if it served four jobs, but it ends 18.6 ms after the later frame at the
// earliest, too late for the tight operation's jobs (18.6 + 0.6 > 14): it serves two on
// time, 9.3 ms a job. So each job is charged 6 ms of encoder, and 0.93 / 2 ms of steer (two
// of them, from one frame, fit a batch of two). 10 ms of lane a frame holds 10 / 12.93 of
// its two jobs.
TEST(WorkBound, ChargesAnEncoderBatchOnlyToTheJobsItCanServeOnTime) {
  const Profile p = default_profile();
  const double enc1 = mean_ms(p, "encoder");
  const double enc2 = mean_ms(p, "encoder", 2);
  const double steer1 = mean_ms(p, "head/steer");
  const double steer2 = mean_ms(p, "head/steer", 2);
  ASSERT_GT(enc2 + steer1, 14.0);  // a two-frame encoder batch is too late for "tight"
  ASSERT_LE(enc1 + steer2, 14.0);  // one frame's encoder, then both steer heads, is not
  ScenarioBuilder b = one_camera("windows", 100, 2);
  on_camera(b, "loose", milliseconds{500}).inference("A", "steer", "cam");
  on_camera(b, "tight", milliseconds{14}).inference("B", "steer", "cam");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  // 2000 ms of lane fit 2000 / per_job of the 400 jobs; releases stop at 2 s, and of the
  // jobs due after it, the 4 + 4 in flight then may still finish on time.
  const double per_job = enc1 / 2 + steer2 / 2;
  EXPECT_NEAR(work_bound(*s, p), (2000.0 / per_job + 8) / 400, 0.01);
  expect_above_every_policy(*s, p, "two operations on one camera, 14 and 500 ms");
}

// One camera triggers a cheap operation (the steer head) and a heavy one (det, seg, lane
// and steer in a chain), on one lane with no batching: 14 ms of lane a frame. Split evenly,
// a frame's 12 ms encoder run charges each job 6 ms, and a frame holds the cheap job (6.6)
// and 7.4 / 18.1 of the heavy one: 0.70 of the jobs. But a frame whose heavy job is not on
// time pays the whole run for the cheap one: serving m jobs of a frame costs at least the
// run and the m cheapest jobs' heads, and the most jobs per lane time come from serving
// both (2 per 24.7 ms, against 1 per 12.6), 12.35 ms a job: 14 / 12.35 of a frame's two.
TEST(WorkBound, ChargesAFramesEncoderRunToTheJobsOnTimeOfThatFrame) {
  const Profile p = default_profile();
  const double enc = mean_ms(p, "encoder");
  double heavy = 0;
  for (const char* h : {"det", "seg", "lane", "steer"})
    heavy += mean_ms(p, std::string("head/") + h);
  const double steer = mean_ms(p, "head/steer");
  ASSERT_GT(2.0 / (enc + steer + heavy), 1.0 / (enc + steer));  // both beat the cheap alone
  ScenarioBuilder b = one_camera("a frame's jobs", 1000.0 / 14.0, 1);
  on_camera(b, "cheap", milliseconds{30}).inference("S", "steer", "cam");
  on_camera(b, "heavy", milliseconds{200})
      .inference("D", "det", "cam")
      .inference("G", "seg", "cam")
      .inference("L", "lane", "cam")
      .inference("T", "steer", "cam")
      .edge("D", "G")
      .edge("G", "L")
      .edge("L", "T");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const double per_job = (enc + steer + heavy) / 2;
  const double released = 2 * 143.0;  // frames at 0, 14, ..., 1988 ms
  const double bound = work_bound(*s, p);
  EXPECT_NEAR(bound, (2000.0 / per_job + 8) / released, 0.01);
  EXPECT_LT(bound, 0.62);  // the even split's 0.70 and more
  expect_above_every_policy(*s, p, "a cheap and a heavy operation on one camera");
}

// The same split where batches could help: the steer and det heads on one camera, a frame
// every 14 ms, deadlines of 26 and 32 ms. A frame's encoder run and both heads take 17.1 ms,
// more than the 14 ms a frame has: 14 / 17.1 of the jobs. A batch of two frames 14 ms
// apart, of encoder runs (18.6 ms) or of heads, ends too late for the earlier frame's job,
// though both frames fall within one run's window: a frame with an on-time job pays a whole
// encoder run and its heads.
TEST(WorkBound, ChargesAWholeRunWhereNoBatchOfFramesIsOnTime) {
  const Profile p = default_profile();
  const double enc1 = mean_ms(p, "encoder");
  const double enc2 = mean_ms(p, "encoder", 2);
  const double steer = mean_ms(p, "head/steer");
  const double det = mean_ms(p, "head/det");
  const double steer2 = mean_ms(p, "head/steer", 2);
  const double det2 = mean_ms(p, "head/det", 2);
  ASSERT_GT(14.0 + enc2 + steer, 26.0);  // no batch of two frames for either operation
  ASSERT_GT(14.0 + enc2 + det, 32.0);
  ASSERT_GT(14.0 + enc1 + steer2, 26.0);
  ASSERT_GT(14.0 + enc1 + det2, 32.0);
  ASSERT_LE(14.0 + enc1 + det, 32.0);  // though two frames fit in the window of one run
  ScenarioBuilder b = one_camera("no batch on time", 1000.0 / 14.0, 2);
  on_camera(b, "steer", milliseconds{26}).inference("S", "steer", "cam");
  on_camera(b, "det", milliseconds{32}).inference("D", "det", "cam");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_NEAR(work_bound(*s, p), 14.0 / (enc1 + steer + det), 0.01);
  expect_above_every_policy(*s, p, "the steer and det heads on one camera");
}

// A batch of two frames 14 ms apart ends too late for the earlier frame's steer job (26 ms
// deadline) but not for its det-then-seg job (45 ms): in such a batch only the newer frame
// carries both jobs. Charging each frame a whole run C(1) = 12 ms, split as the per-frame way
// splits it, is then still valid, since a batch of two frames carries no more than
// C(1) + (charge - own) of the older frame's det job, less than C(2); while the half batch
// (9.3 ms) the third way charges assumes that both frames of every batch may carry both jobs.
// The heads batch across frames at their cheapest: det and seg at C(2) / 2.
TEST(WorkBound, ChargesAWholeRunWhereTheOlderFrameOfABatchCarriesFewerJobs) {
  const Profile p = default_profile();
  const double enc1 = mean_ms(p, "encoder");
  const double enc2 = mean_ms(p, "encoder", 2);
  const double enc3 = mean_ms(p, "encoder", 3);
  const double steer = mean_ms(p, "head/steer");
  const double det = mean_ms(p, "head/det");
  const double seg = mean_ms(p, "head/seg");
  const double det2 = mean_ms(p, "head/det", 2);
  const double seg2 = mean_ms(p, "head/seg", 2);
  ASSERT_GT(14.0 + enc2 + steer, 26.0);       // the steer job: one frame of a batch
  ASSERT_LE(14.0 + enc2 + det + seg, 45.0);   // the det-seg job: two frames of a batch of two,
  ASSERT_GT(14.0 + enc3 + det + seg, 45.0);   // but one of a batch of three
  ASSERT_LE(14.0 + enc1 + det2 + seg, 45.0);  // its heads batch across two frames
  ASSERT_LE(14.0 + enc1 + det + seg2, 45.0);
  const double own = steer + det2 / 2 + seg2 / 2;  // both jobs' heads
  const double charge = (enc1 + own) / 2;
  ASSERT_LE(enc1 + (charge - det2 / 2 - seg2 / 2), enc2);  // the way is valid
  ScenarioBuilder b = one_camera("older frames carry fewer jobs", 1000.0 / 14.0, 2);
  on_camera(b, "steer", milliseconds{26}).inference("S", "steer", "cam");
  on_camera(b, "detseg", milliseconds{45})
      .inference("D", "det", "cam")
      .inference("G", "seg", "cam")
      .edge("D", "G");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  const double released = 2 * 143.0;  // frames at 0, 14, ..., 1988 ms
  // Due after the run's 2 s, in flight when releases stop: one steer job and three det-seg.
  const double bound = work_bound(*s, p);
  EXPECT_NEAR(bound, (2000.0 / charge + 4) / released, 0.01);
  expect_above_every_policy(*s, p, "a steer and a det-seg operation on one camera");
}

// On one lane the work after a unit takes at least its lane time, not only its longest
// path: three heads side by side on a frame every 20 ms, deadline 45 ms. A batch of two
// frames' encoder runs (18.6 ms) leaves the older frame 45 - 20 - 18.6 = 6.4 ms, enough for
// its longest head (4.5 ms) but not for the three (11.5 ms, more side by side in batches):
// no batch of frames is on time, and each job pays a whole run and its heads (batched
// across frames at their cheapest, which the heads' own windows allow).
TEST(WorkBound, CountsTheLaneTimeAfterAnEncoderBatchOnOneLane) {
  const Profile p = default_profile();
  auto ms = [&p](const char* unit, int b) { return mean_ms(p, unit, b); };
  const double heads = ms("head/lane", 1) + ms("head/seg", 1) + ms("head/det", 1);
  ASSERT_LE(20.0 + ms("encoder", 2) + ms("head/det", 1), 45.0);  // the longest path fits
  ASSERT_GT(20.0 + ms("encoder", 2) + heads, 45.0);              // the lane time does not
  for (const char* h : {"head/lane", "head/seg", "head/det"})
    ASSERT_LE(20.0 + ms("encoder", 1) + ms(h, 2), 45.0);  // each head batches two frames
  const double per_job =
      ms("encoder", 1) + (ms("head/lane", 2) + ms("head/seg", 2) + ms("head/det", 2)) / 2;
  ASSERT_GT(per_job, 20.0);                                            // more than a frame's 20 ms,
  ASSERT_LT(per_job - ms("encoder", 1) + ms("encoder", 2) / 2, 20.0);  // a half batch less
  ScenarioBuilder b = one_camera("lane time after the encoder", 50.0, 2);
  on_camera(b, "three", milliseconds{45})
      .inference("L", "lane", "cam")
      .inference("G", "seg", "cam")
      .inference("D", "det", "cam");
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  // 100 frames (0, 20, ..., 1980 ms). By the deadline of frame i, 20 i + 45 ms, at most
  // (20 i + 45) / per_job of its i + 1 jobs fit, the later ones counted on time; at the
  // run's end 2000 / per_job, and the last two frames, due after it.
  double fit = std::floor(2000.0 / per_job) + 2;
  for (int i = 0; i < 98; ++i)
    fit = std::min(fit, std::min(i + 1.0, std::floor((20.0 * i + 45) / per_job)) + 99 - i);
  EXPECT_NEAR(work_bound(*s, p), fit / 100.0, 1e-9);
  expect_above_every_policy(*s, p, "three heads side by side on one lane");
}

// One operation at 100 Hz for 1 s, 10.1 ms of work a job, 50 ms deadline: the work of the
// 100 jobs is 1010 ms, more than the run's 1000 ms, yet every job can be on time, the last
// ones finishing after releases stop (EDF does it). The bound counts the lane time up to each
// deadline, and the jobs in flight when releases stop, so it is 1 here, not 99 / 100.
TEST(WorkBound, CountsTheJobsThatFinishAfterReleasesStop) {
  const Profile p = default_profile();
  ScenarioBuilder b("past the end");
  b.duration(std::chrono::seconds{1}).warmup(milliseconds{0}).seed(1).lanes(1);
  b.sync_cost(Duration{0});
  b.operation("a")
      .rate(100)
      .deadline(milliseconds{50})
      .plain("P", std::chrono::microseconds{10100});
  auto s = b.build();
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_DOUBLE_EQ(work_bound(*s, p), 1.0);
  EXPECT_DOUBLE_EQ(grid::evaluate(*s, p, "edf").on_time, 1.0);
  // At 11 ms a job, 1000 ms hold 90 jobs; of the 100 released, the 2 in flight when releases
  // stop (max_inflight) may also be on time, and at the last deadline (1040 ms) 94 fit.
  ScenarioBuilder c("past the end, overloaded");
  c.duration(std::chrono::seconds{1}).warmup(milliseconds{0}).seed(1).lanes(1);
  c.sync_cost(Duration{0});
  c.operation("a").rate(100).deadline(milliseconds{50}).plain("P", milliseconds{11});
  auto t = c.build();
  ASSERT_TRUE(t) << t.error().to_string();
  EXPECT_DOUBLE_EQ(work_bound(*t, p), 92.0 / 100);
  expect_above_every_policy(*t, p, "11 ms jobs every 10 ms");
}

}  // namespace
}  // namespace red
