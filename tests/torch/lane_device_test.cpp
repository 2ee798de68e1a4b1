// The LibTorch backend's asynchronous lanes as on a GPU, on a CPU stand-in of the device
// (a LaneDevice whose events complete late, hang or fail, and whose host clock moves only
// when the backend reads it or rests): unit times from the device's events, polling that
// rests, a hung unit abandoned, a lost device recognised, plain units timed on the host,
// streams per backend instance, cross-lane waits, the profiler's timing and the warm-up's
// settle rule. The model runs on the CPU; only the lanes' device is the stand-in. No real
// time is measured: every time here is the stand-in's.

#include <ATen/ATen.h>
#include <c10/util/Exception.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "device_lanes.hpp"
#include "red/graph/refine.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/scenario.hpp"
#include "red/torch/lane_device.hpp"
#include "red/torch/torch_backend.hpp"
#include "settle.hpp"
#include "unit_timer.hpp"

namespace red::torchb {
namespace {

using namespace std::chrono_literals;
using HostTime = LaneDevice::HostTime;

// The stand-in device. Streams are numbers; an event completes on the host's clock `delay`
// after it is recorded (never while `hang` says so, until finish()), at a device time taken
// from `device_ms` (else the device clock advanced by 1 ms); after fault() every call fails as a
// CUDA device does after an illegal memory access. Single-threaded, as the tests use it.
class FakeDevice final : public LaneDevice {
 public:
  struct Ev final : Event {
    explicit Ev(std::size_t i) : id(i) {}
    std::size_t id;
  };
  struct Record {
    StreamId stream;
    HostTime due;  // completes when the host's clock reaches it
    double ms;     // the device's clock when it completes
    bool fail_once = false;
  };

  // Settings.
  Duration delay{0};
  std::function<bool(std::size_t id, StreamId s)> hang;
  std::deque<double> device_ms;  // device times of the next events, in order
  bool timing = true;

  // What the backend did.
  std::vector<Record> records;
  std::vector<std::pair<StreamId, std::size_t>> blocks;  // stream, event
  int queries = 0;
  int pauses = 0;
  Duration paused{0};
  int host_buffers = 0;
  int copies = 0;
  StreamId current = 0;

  mutable HostTime host = HostTime{} + 1h;  // now() moves it

  void fault() { faulted_ = true; }
  void finish(std::size_t id) { records[id].due = host; }
  [[nodiscard]] static std::size_t id(const Event& e) { return static_cast<const Ev&>(e).id; }

  [[nodiscard]] c10::Device device() const override { return c10::Device(c10::kCPU); }
  StreamId new_stream() override {
    check();
    return ++streams_;
  }
  StreamId current_stream() override { return current; }
  StreamId exchange_stream(StreamId s) override {
    check();
    const StreamId was = current;
    current = s;
    return was;
  }
  std::unique_ptr<Event> record(StreamId s) override {
    check();
    const std::size_t i = records.size();
    double ms = clock_ms_ += 1.0;
    if (!device_ms.empty()) {
      ms = clock_ms_ = device_ms.front();
      device_ms.pop_front();
    }
    const bool hung = hang && hang(i, s);
    records.push_back({s, hung ? HostTime::max() : host + delay, ms});
    return std::make_unique<Ev>(i);
  }
  bool query(const Event& e) override {
    ++queries;
    check();
    Record& r = records[id(e)];
    if (r.fail_once) {
      r.fail_once = false;
      TORCH_CHECK(false, "CUDA error: an illegal instruction was encountered");
    }
    return host >= r.due;
  }
  [[nodiscard]] bool times() const noexcept override { return timing; }
  double elapsed_ms(const Event& from, const Event& to) override {
    check();
    return records[id(to)].ms - records[id(from)].ms;
  }
  void block(StreamId s, const Event& e) override {
    check();
    blocks.emplace_back(s, id(e));
  }
  at::Tensor host_buffer(const std::vector<std::int64_t>& shape) override {
    ++host_buffers;
    return at::empty(shape, at::TensorOptions().dtype(at::kByte));
  }
  at::Tensor to_device(const at::Tensor& h) override {
    check();
    ++copies;
    return h.clone();
  }
  [[nodiscard]] HostTime now() const override { return host += 1us; }
  void pause(std::chrono::nanoseconds d) override {
    ++pauses;
    paused += d;
    host += d;
  }

 private:
  void check() const {
    TORCH_CHECK(!faulted_, "CUDA error: an illegal memory access was encountered");
  }
  bool faulted_ = false;
  StreamId streams_ = 0;
  double clock_ms_ = 0.0;
};

Scenario small_scenario() {
  Scenario s;
  s.name = "lanes";
  s.model.heads = {"steer"};
  s.model.input = {1, 64, 96};
  s.scheduler.max_batch = 1;
  s.device.lanes = 2;
  SensorSpec cam;
  cam.name = "cam";
  cam.rate_hz = 10.0;
  s.sensors.push_back(cam);
  return s;
}

// Unit 0 the encoder on the camera's frame, unit 1 the head on its output, unit 2 a plain
// task of 2 ms after it.
RefinedGraph fine_graph() {
  auto spec = std::make_shared<OperationSpec>();
  NodeSpec infer;
  infer.name = "C";
  infer.head = 0;
  infer.sensor = 0;
  NodeSpec plain;
  plain.name = "P";
  plain.cost = PlainCost{2ms, 2ms};
  spec->nodes = {infer, plain};
  RefinedGraph g;
  g.mode = GraphMode::Fine;
  g.spec = spec;
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
  RefinedUnit post;
  post.kind = UnitKind::Plain;
  post.node = 1;
  post.preds = {1};
  post.produces = {1};
  g.units = {enc, head, post};
  return g;
}

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

std::unique_ptr<Backend> make(const Scenario& s, const std::shared_ptr<FakeDevice>& dev) {
  auto b = make_torch_backend(s, "cpu", 1, false, dev);
  if (!b) ADD_FAILURE() << b.error().to_string();
  return b ? std::move(*b) : nullptr;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// A backend on the stand-in device: each test's scenario, graph and device (a test may set the
// device up before it makes the backend).
class TorchLanesStandIn : public ::testing::Test {
 protected:
  const Scenario s = small_scenario();
  const RefinedGraph g = fine_graph();
  std::shared_ptr<FakeDevice> dev = std::make_shared<FakeDevice>();
};

TEST_F(TorchLanesStandIn, IsAsynchronousAndBindsOneStreamPerLane) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  EXPECT_TRUE(b->asynchronous());
  b->init_lane(0);
  b->init_lane(1);
  // Each lane's reference event, on a stream of its own.
  ASSERT_EQ(dev->records.size(), 2u);
  EXPECT_NE(dev->records[0].stream, dev->records[1].stream);
}

// Item 2: a unit's start and end are its events' device times placed on the host's clock by
// the lane's reference event, however late the host waits for it.
TEST_F(TorchLanesStandIn, UnitTimesAreTheEventsNotWhenTheHostWaited) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  dev->device_ms = {100.0};  // the reference event
  b->init_lane(0);
  b->on_frame(0, 1);
  dev->device_ms = {110.0, 125.0, 125.5, 130.0};  // encoder 10-25 ms after it, head 25.5-30
  b->enqueue(0, dispatch(g, 0, 1));
  b->enqueue(0, dispatch(g, 1, 1));
  dev->host += 5s;  // the handler comes back late
  const HostTime waited = dev->host;
  const UnitDone enc = b->wait(0);
  const UnitDone head = b->wait(0);
  ASSERT_EQ(enc.status, UnitStatus::Completed) << enc.reason;
  ASSERT_EQ(head.status, UnitStatus::Completed) << head.reason;
  EXPECT_EQ(enc.ended - enc.started, 15ms);
  EXPECT_EQ(head.started - enc.ended, 500us);
  EXPECT_EQ(head.ended - enc.started, 20ms);
  EXPECT_LT(head.ended + 4s, waited) << "stamped when waited for, not when the device ran it";
}

// The reference event is recorded again when the lane is idle and it is over a second old,
// and kept when the new one is not seen at once (the stream was not idle).
TEST_F(TorchLanesStandIn, TheReferenceEventIsRenewedOnlyOnAnIdleStream) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  dev->device_ms = {100.0};
  b->init_lane(0);
  for (std::uint64_t f = 1; f <= 3; ++f) b->on_frame(0, f);
  dev->device_ms = {110.0, 120.0};
  b->enqueue(0, dispatch(g, 0, 1));
  const UnitDone a = b->wait(0);
  dev->host += 2s;
  dev->delay = 1ms;  // the renewal is seen late: not adopted
  dev->device_ms = {3000.0, 3010.0, 3020.0};
  b->enqueue(0, dispatch(g, 0, 2));
  const UnitDone late = b->wait(0);
  EXPECT_EQ(late.started - a.started, 2900ms) << "placed by the old reference event";
  dev->host += 2s;
  dev->delay = 0ms;
  dev->device_ms = {9000.0, 9010.0, 9020.0};
  const HostTime enqueued = dev->host;
  b->enqueue(0, dispatch(g, 0, 3));
  const UnitDone renewed = b->wait(0);
  EXPECT_NE(renewed.started - a.started, 8900ms) << "the old reference event was kept";
  EXPECT_LT(renewed.started - (enqueued + 10ms), 100us);
  EXPECT_GT(renewed.started - (enqueued + 10ms), -100us);
}

TEST_F(TorchLanesStandIn, WithoutEventTimingTheEndIsWhenTheHostSawIt) {
  dev->timing = false;  // a LibTorch before 2.6
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  EXPECT_TRUE(dev->records.empty()) << "no reference event without event timing";
  b->on_frame(0, 1);
  b->enqueue(0, dispatch(g, 0, 1));
  const UnitDone done = b->wait(0);
  ASSERT_EQ(done.status, UnitStatus::Completed) << done.reason;
  EXPECT_EQ(done.started, HostTime{}) << "left to the runtime";
  EXPECT_NE(done.ended, HostTime{});
}

// Item 4: waiting polls the end event and rests between polls; ready() never waits.
TEST_F(TorchLanesStandIn, WaitingPollsAndRestsInsteadOfSpinning) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 1);
  dev->delay = 50ms;  // the device ends the unit 50 ms after it is queued
  b->enqueue(0, dispatch(g, 0, 1));
  const int pauses = dev->pauses;
  EXPECT_FALSE(b->ready(0));
  EXPECT_EQ(dev->pauses, pauses) << "ready() must not wait";
  const int queries = dev->queries;
  const UnitDone done = b->wait(0);
  EXPECT_EQ(done.status, UnitStatus::Completed) << done.reason;
  // 50 ms spent resting, in few polls: back to back only for the first 50 us.
  EXPECT_GE(dev->paused, 49ms);
  EXPECT_LT(dev->queries - queries, 200);
  EXPECT_TRUE(b->ready(0)) << "nothing left on the lane";
}

// Item 5: a unit the device never finishes is abandoned; its tensors go only when its event
// completes, and ending the run does not block on it.
TEST_F(TorchLanesStandIn, AHungUnitIsAbandonedAndLetGoWhenTheDeviceFinishesIt) {
  DeviceLanes lanes(dev);
  lanes.init(0);
  const at::Tensor t = at::zeros({4});
  DeviceLanes::Unit u;
  u.start = lanes.record(0);
  dev->hang = [](std::size_t, LaneDevice::StreamId) { return true; };
  u.end = lanes.record(0);
  const std::size_t end_id = FakeDevice::id(*u.end);
  u.keep = {t};
  lanes.push(0, std::move(u));
  const long held = t.use_count();
  EXPECT_FALSE(lanes.ready(0));
  lanes.abandon(0);
  EXPECT_TRUE(lanes.ready(0)) << "the lane goes on";
  EXPECT_EQ(lanes.abandoned(), 1u);
  lanes.sweep();
  EXPECT_EQ(t.use_count(), held) << "let go while its kernels may still run";
  const HostTime drained = dev->host;
  lanes.drain();  // gives up after DeviceLanes::kDrainLimit of the stand-in's time
  EXPECT_GE(dev->host - drained, DeviceLanes::kDrainLimit);
  EXPECT_EQ(lanes.abandoned(), 1u);
  dev->finish(end_id);
  lanes.sweep();
  EXPECT_EQ(lanes.abandoned(), 0u);
  EXPECT_EQ(t.use_count(), held - 1);
}

TEST_F(TorchLanesStandIn, TheBackendAbandonsAHungUnitAndEndsTheRun) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 1);
  dev->hang = [](std::size_t, LaneDevice::StreamId) { return true; };
  b->enqueue(0, dispatch(g, 0, 1));
  EXPECT_FALSE(b->ready(0));
  b->abandon(0);
  EXPECT_TRUE(b->ready(0));
  b->end_run();  // returns: the hung unit is left with the device
  for (std::size_t i = 0; i < dev->records.size(); ++i) dev->finish(i);
  dev->hang = nullptr;
  b->on_frame(0, 2);
  b->enqueue(0, dispatch(g, 0, 2));
  EXPECT_EQ(b->wait(0).status, UnitStatus::Completed);
  b->end_run();
}

// Item 6: a fault that sticks to the device is recognised as a lost device, named with the
// lane and unit that saw it first; every later unit says so without running.
TEST_F(TorchLanesStandIn, AStickyFaultIsADeviceLostFirstSeenByOneUnit) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->init_lane(1);
  b->on_frame(0, 1);
  b->on_frame(0, 2);
  b->enqueue(1, dispatch(g, 0, 2));
  dev->fault();  // a kernel faults: the context is broken for every later call
  const UnitDone done = b->wait(1);
  EXPECT_EQ(done.status, UnitStatus::Failed);
  EXPECT_TRUE(done.device_lost);
  EXPECT_TRUE(contains(done.reason, "device lost: LibTorch: CUDA error: an illegal memory access"))
      << done.reason;
  EXPECT_TRUE(contains(done.reason, "first seen on lane 1, encoder unit")) << done.reason;
  try {
    b->enqueue(0, dispatch(g, 0, 1));
    ADD_FAILURE() << "enqueue on a lost device did not throw";
  } catch (const DeviceLostError& e) {
    EXPECT_TRUE(contains(e.what(), "first seen on lane 1")) << e.what();
  }
}

TEST_F(TorchLanesStandIn, AFailureThatDoesNotStickFailsOnlyItsUnit) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 1);
  b->on_frame(0, 2);
  b->enqueue(0, dispatch(g, 0, 1));
  dev->records.back().fail_once = true;  // its end event reports an error once
  b->enqueue(0, dispatch(g, 0, 2));
  const UnitDone failed = b->wait(0);
  EXPECT_EQ(failed.status, UnitStatus::Failed);
  EXPECT_FALSE(failed.device_lost);
  EXPECT_TRUE(contains(failed.reason, "illegal instruction")) << failed.reason;
  const UnitDone next = b->wait(0);
  EXPECT_EQ(next.status, UnitStatus::Completed) << next.reason;
  // A failure of the backend's own (an input not there) leaves the device working too.
  try {
    b->enqueue(0, dispatch(g, 1, 9));
    ADD_FAILURE() << "a head without its encoder output did not throw";
  } catch (const DeviceLostError& e) {
    ADD_FAILURE() << e.what();
  } catch (const std::runtime_error& e) {
    EXPECT_TRUE(contains(e.what(), "encoder output of frame 9")) << e.what();
  }
}

// Item 7: a plain (CPU) unit queued behind device work is run and timed on the host once
// the units before it have ended; it records no device event.
TEST_F(TorchLanesStandIn, PlainUnitsAreTimedOnTheHost) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->on_frame(0, 1);
  b->enqueue(0, dispatch(g, 0, 1));
  b->enqueue(0, dispatch(g, 1, 1));
  const std::size_t events = dev->records.size();
  b->enqueue(0, dispatch(g, 2, 1));
  EXPECT_EQ(dev->records.size(), events) << "a plain unit has no device events";
  EXPECT_EQ(b->wait(0).status, UnitStatus::Completed);
  EXPECT_EQ(b->wait(0).status, UnitStatus::Completed);
  const HostTime asked = dev->host;
  const UnitDone plain = b->wait(0);
  ASSERT_EQ(plain.status, UnitStatus::Completed) << plain.reason;
  EXPECT_GE(plain.started, asked) << "after the units before it ended";
  EXPECT_GE(plain.ended - plain.started, 2ms) << "its cost, spent on the host";
}

// Item 9: the lane's stream belongs to the backend instance, not to the thread; a backend
// whose lane was never initialised still queues on a stream of its own and run() waits.
TEST_F(TorchLanesStandIn, TwoBackendsOnOneThreadKeepTheirOwnStreams) {
  auto a = make(s, dev);
  auto c = make(s, dev);
  ASSERT_TRUE(a && c);
  a->init_lane(0);
  const LaneDevice::StreamId a_stream = dev->records.back().stream;
  c->init_lane(0);
  const LaneDevice::StreamId c_stream = dev->records.back().stream;
  EXPECT_NE(a_stream, c_stream);
  a->on_frame(0, 1);
  a->enqueue(0, dispatch(g, 0, 1));
  EXPECT_EQ(dev->records.back().stream, a_stream) << "a's unit went on c's stream";
  EXPECT_EQ(dev->current, 0) << "the thread's stream is given back after each call";
  EXPECT_EQ(a->wait(0).status, UnitStatus::Completed);
}

TEST_F(TorchLanesStandIn, RunWithoutInitLaneWaitsForTheDevice) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->on_frame(0, 1);
  dev->delay = 5ms;
  b->run(0, dispatch(g, 0, 1));  // no init_lane(): the lane gets its stream on first use
  ASSERT_FALSE(dev->records.empty());
  const FakeDevice::Record& end = dev->records.back();
  EXPECT_NE(end.stream, 0) << "not the default stream";
  EXPECT_GE(dev->host, end.due) << "run() returned before the device had run the unit";
}

// Items 1 and 10: a received frame is copied to the device by the unit that first reads it,
// from host memory, before its start event; an input made on another lane's stream (a
// converted frame, an encoder output) is waited for by the reading lane's stream.
TEST_F(TorchLanesStandIn, FramesAndOutputsFromAnotherLaneAreWaitedForOnTheDevice) {
  auto b = make(s, dev);
  ASSERT_TRUE(b);
  b->init_lane(0);
  b->init_lane(1);
  const LaneDevice::StreamId lane0 = dev->records[0].stream;
  const LaneDevice::StreamId lane1 = dev->records[1].stream;
  std::vector<std::uint8_t> pixels(64 * 96, 128);
  FrameView px;
  px.width = 96;
  px.height = 64;
  px.channels = 1;
  px.data = pixels.data();
  b->on_external_frame(0, 5, px);
  EXPECT_EQ(dev->host_buffers, 1);
  EXPECT_EQ(dev->copies, 0) << "no copy to the device on the thread that brought the frame";
  const std::size_t before = dev->records.size();
  b->enqueue(0, dispatch(g, 0, 5));
  EXPECT_EQ(dev->copies, 1);
  // The frame's ready event, then the unit's start and end events.
  ASSERT_EQ(dev->records.size(), before + 3);
  const std::size_t ready = before;
  const std::size_t encoder_end = before + 2;
  EXPECT_EQ(dev->records[ready].stream, lane0);
  b->enqueue(1, dispatch(g, 1, 5));  // the head on the other lane
  b->enqueue(1, dispatch(g, 0, 5));  // and the same frame's encoder again there
  bool waits_encoder = false;
  bool waits_frame = false;
  for (const auto& [stream, event] : dev->blocks) {
    waits_encoder = waits_encoder || (stream == lane1 && event == encoder_end);
    waits_frame = waits_frame || (stream == lane1 && event == ready);
  }
  EXPECT_TRUE(waits_encoder);
  EXPECT_TRUE(waits_frame);
  EXPECT_EQ(dev->copies, 1) << "converted once";
  b->enqueue(0, dispatch(g, 1, 5));  // on its own lane: the stream's order suffices
  for (const auto& [stream, event] : dev->blocks) EXPECT_NE(stream, lane0);
  for (int lane : {0, 0, 1, 1}) EXPECT_EQ(b->wait(lane).status, UnitStatus::Completed);
}

// Item 8: on a device the profiler times a second call, queued behind an untimed first.
TEST_F(TorchLanesStandIn, TheProfilerTimesASecondCallBehindAnUntimedFirst) {
  const UnitTimer timer(dev);
  std::vector<std::size_t> events_at_call;
  dev->device_ms = {3.0, 7.5};
  const Duration t = timer.time([&] { events_at_call.push_back(dev->records.size()); });
  ASSERT_EQ(events_at_call.size(), 2u);
  EXPECT_EQ(events_at_call[0], 0u) << "the first call is not timed";
  EXPECT_EQ(events_at_call[1], 1u) << "the second follows the start event";
  EXPECT_EQ(t, Duration{4'500'000});
  EXPECT_EQ(std::string(timer.method()), "device events, each timed call after an untimed one");
}

// Item 3: warm-up calls a unit until its time settles.
TEST(TorchWarmUp, SettlesAfterTheSlowCallsOfAnOptimizingExecutor) {
  const SettleRule rule;
  const auto ms = [](std::initializer_list<int> v) {
    std::vector<Duration> out;
    for (int x : v) out.emplace_back(std::chrono::milliseconds{x});
    return out;
  };
  EXPECT_FALSE(settled(ms({10, 10}), rule)) << "at least three calls";
  EXPECT_TRUE(settled(ms({10, 10, 10}), rule));
  // Profiled, then optimizing (slow), then optimized: not settled until two fast calls.
  EXPECT_FALSE(settled(ms({40, 90, 10}), rule));
  EXPECT_TRUE(settled(ms({40, 90, 10, 10}), rule));
  EXPECT_FALSE(settled(ms({40, 90, 10, 10, 30}), rule)) << "a slow call after the fast ones";
  std::vector<Duration> falling;  // each call half the one before: never settled
  for (int i = 0; i < rule.max_calls; ++i)
    falling.emplace_back(Duration{std::int64_t{1} << (40 - i)});
  EXPECT_FALSE(settled({falling.begin(), falling.end() - 1}, rule));
  EXPECT_TRUE(settled(falling, rule)) << "at most max_calls";
  int calls = 0;
  const std::vector<Duration> seq = ms({40, 90, 10, 11});
  const auto times =
      warm_until_settled([&] { return seq[static_cast<std::size_t>(calls++)]; }, rule);
  EXPECT_EQ(calls, 4);
  EXPECT_EQ(times.size(), 4u);
}

}  // namespace
}  // namespace red::torchb
