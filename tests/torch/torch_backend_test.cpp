// The LibTorch backend's asynchronous lanes (Backend::enqueue() and wait()), through the CPU
// stand-in that make_torch_backend(..., asynchronous = true) makes: units run on enqueue
// and wait() reports each one in order, failures included. The built-in MIMONet on small
// inputs; no timing beyond the order of the reported times.

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "red/graph/refine.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/torch/torch_backend.hpp"

namespace red::torchb {
namespace {

/// One camera, one head on a small input (a forward pass takes milliseconds).
Scenario small_scenario() {
  Scenario s;
  s.name = "async";
  s.model.heads = {"steer"};
  s.model.input = {1, 64, 96};
  s.scheduler.max_batch = 1;
  SensorSpec cam;
  cam.name = "cam";
  cam.rate_hz = 10.0;
  s.sensors.push_back(cam);
  return s;
}

/// A fine graph of one inference node: unit 0 the encoder on the camera's frame, unit 1
/// the head on its output.
RefinedGraph fine_graph() {
  RefinedGraph g;
  g.mode = GraphMode::Fine;
  RefinedUnit enc;
  enc.kind = UnitKind::Encoder;
  enc.node = 0;
  enc.sensor = 0;
  enc.succs = {1};
  RefinedUnit head;
  head.kind = UnitKind::Head;
  head.node = 0;
  head.head = 0;
  head.sensor = 0;
  head.preds = {0};
  head.produces = {0};
  g.units = {enc, head};
  return g;
}

/// A dispatch of one task: `graph`'s unit `unit` on frame `frame`.
Dispatch dispatch(const RefinedGraph& graph, int unit, std::uint64_t frame) {
  const RefinedUnit& u = graph.units[static_cast<std::size_t>(unit)];
  Dispatch d;
  d.kind = u.kind;
  d.head = u.head;
  d.sensor = u.sensor;
  Member m;
  m.unit = unit;
  m.node = u.node;
  m.frame = frame;
  m.graph = &graph;
  d.members = {m};
  d.task_begin = {0, 1};
  return d;
}

std::unique_ptr<Backend> make(const Scenario& s, bool asynchronous) {
  auto b = make_torch_backend(s, "cpu", 1, asynchronous);
  if (!b) ADD_FAILURE() << b.error().to_string();
  return b ? std::move(*b) : nullptr;
}

TEST(TorchBackendAsync, OnlyWhenAskedOnTheCpu) {
  const Scenario s = small_scenario();
  auto plain = make(s, false);
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->asynchronous());
  auto standin = make(s, true);
  ASSERT_TRUE(standin);
  EXPECT_TRUE(standin->asynchronous());
  EXPECT_EQ(standin->name(), "torch cpu");
}

TEST(TorchBackendAsync, UnitsEndInEnqueueOrder) {
  const Scenario s = small_scenario();
  const RefinedGraph g = fine_graph();
  auto b = make(s, true);
  ASSERT_TRUE(b);
  b->init_lane(0);
  for (std::uint64_t f = 0; f < 3; ++f) b->on_frame(0, f);
  // Encoders of three frames, then the heads of two: what a lane queues behind its first.
  for (std::uint64_t f = 0; f < 3; ++f) b->enqueue(0, dispatch(g, 0, f));
  for (std::uint64_t f = 0; f < 2; ++f) b->enqueue(0, dispatch(g, 1, f));
  std::chrono::steady_clock::time_point last{};
  for (int i = 0; i < 5; ++i) {
    const UnitDone done = b->wait(0);
    EXPECT_EQ(done.status, UnitStatus::Completed) << i << ": " << done.reason;
    EXPECT_TRUE(done.reason.empty()) << i;
    EXPECT_NE(done.started, std::chrono::steady_clock::time_point{}) << i;
    EXPECT_LE(done.started, done.ended) << i;
    EXPECT_LE(last, done.started) << i;  // one after the other, in order
    last = done.ended;
  }
  b->end_run();
}

TEST(TorchBackendAsync, FailureIsReportedByWaitAndTheNextUnitRuns) {
  const Scenario s = small_scenario();
  const RefinedGraph g = fine_graph();
  auto b = make(s, true);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 7);
  // The head of frame 7 before its encoder ran, and an encoder on a frame never captured:
  // run() throws for both; the stand-in queues them and wait() reports them.
  EXPECT_NO_THROW(b->enqueue(0, dispatch(g, 1, 7)));
  EXPECT_NO_THROW(b->enqueue(0, dispatch(g, 0, 99)));
  b->enqueue(0, dispatch(g, 0, 7));
  b->enqueue(0, dispatch(g, 1, 7));

  UnitDone done = b->wait(0);
  EXPECT_EQ(done.status, UnitStatus::Failed);
  EXPECT_NE(done.reason.find("encoder output of frame 7 is not available"), std::string::npos)
      << done.reason;
  EXPECT_LE(done.started, done.ended);
  done = b->wait(0);
  EXPECT_EQ(done.status, UnitStatus::Failed);
  EXPECT_NE(done.reason.find("frame 99 of sensor cam is no longer in memory"), std::string::npos)
      << done.reason;
  for (int i = 0; i < 2; ++i) {
    done = b->wait(0);
    EXPECT_EQ(done.status, UnitStatus::Completed) << i << ": " << done.reason;
  }

  // The same failure from the synchronous backend is thrown, with the same reason.
  auto sync = make(s, false);
  ASSERT_TRUE(sync);
  sync->init_lane(0);
  sync->on_frame(0, 7);
  try {
    sync->run(0, dispatch(g, 1, 7));
    ADD_FAILURE() << "run() did not throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("encoder output of frame 7 is not available"),
              std::string::npos)
        << e.what();
  }
}

TEST(TorchBackendAsync, EndRunDropsUnitsNotWaitedFor) {
  const Scenario s = small_scenario();
  const RefinedGraph g = fine_graph();
  auto b = make(s, true);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 1);
  b->enqueue(0, dispatch(g, 1, 1));  // fails: no encoder output yet
  b->enqueue(0, dispatch(g, 0, 1));
  b->end_run();  // neither was waited for: the next run must not see them
  b->on_frame(0, 2);
  b->enqueue(0, dispatch(g, 0, 2));
  const UnitDone done = b->wait(0);
  EXPECT_EQ(done.status, UnitStatus::Completed) << done.reason;
  b->end_run();
}

TEST(TorchBackendAsync, LanesQueueApart) {
  const Scenario s = small_scenario();
  const RefinedGraph g = fine_graph();
  auto b = make(s, true);
  ASSERT_TRUE(b);
  for (std::uint64_t f = 0; f < 4; ++f) b->on_frame(0, f);
  // Two lanes, each on its own thread as the runtime's handlers are: lane 0 queues a unit
  // that fails and one that runs, lane 1 two that run; each sees only its own, in order.
  std::vector<UnitDone> ends[2];
  std::thread lanes[2];
  for (int lane = 0; lane < 2; ++lane)
    lanes[lane] = std::thread([&, lane] {
      b->init_lane(lane);
      const auto first = static_cast<std::uint64_t>(2 * lane);
      b->enqueue(lane, dispatch(g, lane == 0 ? 1 : 0, first));
      b->enqueue(lane, dispatch(g, 0, first + 1));
      for (int i = 0; i < 2; ++i) ends[lane].push_back(b->wait(lane));
    });
  for (std::thread& t : lanes) t.join();
  ASSERT_EQ(ends[0].size(), 2u);
  ASSERT_EQ(ends[1].size(), 2u);
  EXPECT_EQ(ends[0][0].status, UnitStatus::Failed);
  EXPECT_EQ(ends[0][1].status, UnitStatus::Completed) << ends[0][1].reason;
  EXPECT_EQ(ends[1][0].status, UnitStatus::Completed) << ends[1][0].reason;
  EXPECT_EQ(ends[1][1].status, UnitStatus::Completed) << ends[1][1].reason;
  b->end_run();
}

}  // namespace
}  // namespace red::torchb
