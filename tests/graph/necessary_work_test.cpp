// The model of necessary work (red/graph/necessary_work.hpp): encoder runs per frame, runs batched
// as the deadlines let them gather, at the profile's cost per batch size.

#include "red/graph/necessary_work.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "red/scenario/loader.hpp"

namespace red {
namespace {

using std::chrono::microseconds;

LatencyStats at_ms(double ms) {
  LatencyStats l;
  l.min = l.mean = l.p50 = l.p95 = l.p99 = l.max = Duration{static_cast<std::int64_t>(ms * 1e6)};
  return l;
}

// Encoder: a batch of 2 costs what one run costs (MobileNetV3-small shaped); heads 2 ms at any
// batch up to 4.
Profile cheap_batches() {
  Profile p;
  p.source = "test";
  p.units["encoder"].by_batch = {at_ms(10), at_ms(10), at_ms(18), at_ms(24)};
  for (const char* h : {"lane", "seg", "steer", "det"})
    p.units[std::string("head/") + h].by_batch = {at_ms(2), at_ms(2), at_ms(2), at_ms(2)};
  return p;
}

Scenario scenario(const std::string& yaml) {
  auto s = parse_scenario(yaml, "work.yaml");
  EXPECT_TRUE(s) << (s ? "" : s.error().to_string());
  return std::move(s).value();
}

WorkInput input(const Scenario& s) {
  WorkInput in;
  for (const SensorSpec& sn : s.sensors) in.sensor_hz.push_back(sn.rate_hz);
  for (const auto& op : s.initial) {
    WorkInput::Stream st;
    st.op = op.get();
    st.rate_hz = op->trigger_sensor >= 0
                     ? s.sensors[static_cast<std::size_t>(op->trigger_sensor)].rate_hz
                     : op->rate_hz;
    in.ops.push_back(st);
  }
  return in;
}

std::string one_camera(int hz, int deadline_ms, int inflight = 2) {
  return fmt::format(R"(
name: cam
duration_s: 4
model: {{builtin: mimonet, heads: [lane, seg, steer, det]}}
sensors:
  cam: {{rate_hz: {}}}
operations:
  - name: a
    trigger: cam
    deadline_ms: {}
    max_inflight: {}
    nodes: {{L: {{head: lane, sensor: cam}}}}
)",
                     hz, deadline_ms, inflight);
}

TEST(NecessaryWork, BatchOfTwoAtTheCostOfOneHalvesTheEncoderWorkWhereTwoFramesGather) {
  const Profile p = cheap_batches();
  // 20 Hz, 100 ms: the first frame can wait 50 ms for the next and still finish a batch of 2
  // (10 ms) and its head (2 ms) by its deadline.
  const Scenario s = scenario(one_camera(20, 100));
  const WorkModel m(p, s.model, EstimateKind::Mean, 4, 1);
  const WorkEstimate w = m.estimate(input(s));
  const UnitWork& enc = w.units[WorkModel::kEncoder];
  EXPECT_DOUBLE_EQ(enc.runs_hz, 20);
  EXPECT_EQ(enc.batch, 2);
  EXPECT_EQ(enc.serves, 2);
  EXPECT_EQ(enc.per_run[0], Duration{5'000'000});
  // Heads cost 2 ms at any batch: a batch of up to max_inflight (2) on time.
  EXPECT_EQ(w.units[WorkModel::head_slot(0)].per_run[0], Duration{1'000'000});
  EXPECT_NEAR(w.load, 20 * (0.005 + 0.001), 1e-12);
  EXPECT_NEAR(w.op_load[0], w.load, 1e-12);
  EXPECT_LE(m.floor_load(input(s)), w.load + 1e-12);
}

TEST(NecessaryWork, NoBatchWhereTheDeadlineDoesNotLetRunsGather) {
  const Profile p = cheap_batches();
  // 40 ms: the next frame comes 50 ms later, after the first job's deadline.
  const Scenario s = scenario(one_camera(20, 40));
  const WorkEstimate w = WorkModel(p, s.model, EstimateKind::Mean, 4, 1).estimate(input(s));
  EXPECT_EQ(w.units[WorkModel::kEncoder].batch, 1);
  EXPECT_EQ(w.units[WorkModel::kEncoder].per_run[0], Duration{10'000'000});
  EXPECT_NEAR(w.load, 20 * 0.012, 1e-12);
}

TEST(NecessaryWork, MaxInflightAndMaxBatchCapTheBatch) {
  const Profile p = cheap_batches();
  const Scenario one = scenario(one_camera(20, 100, 1));  // one job at a time
  EXPECT_EQ(WorkModel(p, one.model, EstimateKind::Mean, 4, 1)
                .estimate(input(one))
                .units[WorkModel::kEncoder]
                .per_run[0],
            Duration{10'000'000});
  const Scenario s = scenario(one_camera(20, 100));
  EXPECT_EQ(WorkModel(p, s.model, EstimateKind::Mean, 1, 1)  // no batching
                .estimate(input(s))
                .units[WorkModel::kEncoder]
                .per_run[0],
            Duration{10'000'000});
}

TEST(NecessaryWork, AFrameIsEncodedOnceForEveryOperationItTriggersAndHeadsBatchAcrossThem) {
  const Profile p = cheap_batches();
  const Scenario s = scenario(R"(
name: shared
duration_s: 4
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - {name: a, trigger: cam, deadline_ms: 30, nodes: {D: {head: det, sensor: cam}}}
  - {name: b, trigger: cam, deadline_ms: 30, nodes: {D: {head: det, sensor: cam}}}
  - {name: c, rate_hz: 5, deadline_ms: 30, nodes: {D: {head: det, sensor: cam}}}
)");
  const WorkEstimate w = WorkModel(p, s.model, EstimateKind::Mean, 4, 1).estimate(input(s));
  EXPECT_DOUBLE_EQ(w.units[WorkModel::kEncoder].runs_hz, 10);  // the camera's frames
  EXPECT_EQ(w.units[WorkModel::kEncoder].batch, 1);            // 100 ms apart, 30 ms deadlines
  const UnitWork& det = w.units[WorkModel::head_slot(3)];
  EXPECT_DOUBLE_EQ(det.runs_hz, 25);
  EXPECT_EQ(det.serves, 3);  // one run of each operation's job on the same frame
  EXPECT_EQ(det.per_run[0], Duration{2'000'000} / 3);
  // The encoder's work is shared by rate among its readers.
  EXPECT_NEAR(w.op_load[0], 10 * (0.010 * 10 / 25 + 0.002 / 3), 1e-7);
  EXPECT_NEAR(w.op_load[2], 5 * (0.010 * 10 / 25 + 0.002 / 3), 1e-7);
  EXPECT_NEAR(w.load, w.op_load[0] + w.op_load[1] + w.op_load[2], 1e-12);
}

TEST(NecessaryWork, OwnRateOperationsNeedAtMostTheCamerasFrames) {
  const Profile p = cheap_batches();
  const Scenario s = scenario(R"(
name: sampling
duration_s: 4
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  cam: {rate_hz: 10}
operations:
  - {name: fast, rate_hz: 40, deadline_ms: 20, nodes: {L: {head: lane, sensor: cam}}}
  - {name: slow, rate_hz: 4, deadline_ms: 20, nodes: {S: {head: seg, sensor: cam}}}
)");
  const WorkEstimate w = WorkModel(p, s.model, EstimateKind::Mean, 4, 1).estimate(input(s));
  EXPECT_DOUBLE_EQ(w.units[WorkModel::kEncoder].runs_hz, 10);
}

TEST(NecessaryWork, OverloadedPastCapacityByMoreThanTheLastJobsCanRunOn) {
  EXPECT_FALSE(WorkModel::overloaded(0.99, 10, 0.1));
  EXPECT_FALSE(WorkModel::overloaded(1.005, 10, 0.1));  // 50 ms of extra work, 100 ms after
  EXPECT_TRUE(WorkModel::overloaded(1.02, 10, 0.1));
  EXPECT_FALSE(WorkModel::overloaded(5, 0, 0.1));  // an empty span
}

}  // namespace
}  // namespace red
