// The node's frame intake (docs/ROS2.md, issue 8's first target): a received frame is released
// before its pixels are converted; the conversion runs once, on the first thread that needs
// it, and no reader ever sees a half-converted frame; a frame no unit reads is never
// converted; bad frames are still rejected before the release and counted.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <latch>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "red/dds/image.hpp"
#include "red/dds/messages.hpp"
#include "red/dds/node.hpp"
#include "red/dds/ros.hpp"
#include "red/profile/profile.hpp"
#include "red/runtime/backend.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

// A frame whose conversion counts its calls and pauses half-way, so that a reader that did
// not wait for it would find half a frame; the first `failures` calls throw.
class CountingFrame final : public LazyFrame {
 public:
  explicit CountingFrame(int failures = 0) : LazyFrame(64, 32, 3), failures_(failures) {}
  mutable std::atomic<int> calls{0};

  static std::uint8_t expected(std::size_t i) { return static_cast<std::uint8_t>(i * 7U + 1U); }

 protected:
  void convert(std::uint8_t* out) const override {
    if (calls.fetch_add(1) < failures_) throw std::runtime_error("conversion failed");
    const std::size_t n = 64U * 32U * 3U;
    for (std::size_t i = 0; i < n; ++i) {
      out[i] = expected(i);
      if (i == n / 2) std::this_thread::sleep_for(std::chrono::milliseconds{5});
    }
  }

 private:
  int failures_;
};

TEST(DdsLazyFrame, ConcurrentReadersGetOneConversionAndAllOfIt) {
  CountingFrame frame;
  EXPECT_FALSE(frame.converted()) << "nothing is converted before someone asks";
  EXPECT_EQ(frame.calls.load(), 0);
  constexpr int kReaders = 8;
  std::latch start(kReaders);
  std::vector<int> wrong(kReaders, -1);
  std::vector<std::thread> readers;
  for (int r = 0; r < kReaders; ++r)
    readers.emplace_back([&, r] {
      start.arrive_and_wait();
      const FrameView px = frame.pixels();
      int bad = 0;
      const std::size_t n = static_cast<std::size_t>(px.width * px.height * px.channels);
      for (std::size_t i = 0; i < n; ++i)
        if (px.data[i] != CountingFrame::expected(i)) ++bad;
      wrong[static_cast<std::size_t>(r)] = bad;
    });
  for (std::thread& t : readers) t.join();
  EXPECT_EQ(frame.calls.load(), 1) << "converted exactly once";
  EXPECT_TRUE(frame.converted());
  for (int r = 0; r < kReaders; ++r) EXPECT_EQ(wrong[static_cast<std::size_t>(r)], 0) << r;
}

TEST(DdsLazyFrame, AFailedConversionConvertsNothingAndTheNextCallTriesAgain) {
  CountingFrame frame(1);
  EXPECT_THROW((void)frame.pixels(), std::runtime_error);
  EXPECT_FALSE(frame.converted());
  const FrameView px = frame.pixels();
  EXPECT_TRUE(frame.converted());
  EXPECT_EQ(frame.calls.load(), 2);
  EXPECT_EQ(px.data[5], CountingFrame::expected(5));
}

// A 640x480 rgb8 test image whose bytes depend on position.
std::vector<std::uint8_t> pattern(std::uint32_t w, std::uint32_t h) {
  std::vector<std::uint8_t> v(static_cast<std::size_t>(w) * h * 3U);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::uint8_t>((i * 31U) >> 3U);
  return v;
}

TEST(DdsIntake, ASamplesOwnBufferIsMovedNotCopiedAndLetGoOnceConverted) {
  const std::uint32_t w = 640, h = 480;
  const std::vector<std::uint8_t> bytes = pattern(w, h);
  const std::string encoding = "rgb8", frame_id = "cam";
  // As Cyclone leaves a received sample: the data sequence allocated with dds_alloc.
  Image img{};
  img.header_.stamp_.sec_ = 7;
  img.header_.frame_id_ = borrow(frame_id);
  img.encoding_ = borrow(encoding);
  img.width_ = w;
  img.height_ = h;
  img.step_ = w * 3;
  auto* buffer = static_cast<std::uint8_t*>(dds_alloc(bytes.size()));
  std::copy(bytes.begin(), bytes.end(), buffer);
  img.data_._buffer = buffer;
  img.data_._length = img.data_._maximum = static_cast<std::uint32_t>(bytes.size());
  img.data_._release = true;
  ASSERT_FALSE(check_image(img).has_value());

  std::shared_ptr<const ReceivedImage> received = ReceivedImage::take(img);
  EXPECT_TRUE(received->moved());
  EXPECT_EQ(img.data_._buffer, nullptr) << "the sample no longer owns (or frees) the pixels";
  EXPECT_FALSE(img.data_._release);
  EXPECT_EQ(received->view().data_._buffer, buffer) << "moved, not copied";
  EXPECT_EQ(received->header().sec, 7);
  EXPECT_EQ(received->header().frame_id, "cam");

  const std::weak_ptr<const ReceivedImage> source = received;
  auto rgb = std::make_shared<const ConvertedImage>(received, 384, 192, 3);
  auto gray = std::make_shared<const ConvertedImage>(received, 384, 192, 1);
  received.reset();
  EXPECT_FALSE(rgb->converted());
  EXPECT_FALSE(gray->converted());

  // The same pixels as the eager conversions of the same image.
  Image ref = img;
  ref.data_._buffer = const_cast<std::uint8_t*>(bytes.data());
  ref.data_._length = ref.data_._maximum = static_cast<std::uint32_t>(bytes.size());
  ref.data_._release = false;
  std::vector<std::uint8_t> want_rgb;
  GrayFrame want_gray;
  to_rgb(ref, 384, 192, want_rgb);
  to_gray(ref, 384, 192, want_gray);
  const FrameView px = rgb->pixels();
  ASSERT_EQ(px.channels, 3);
  EXPECT_TRUE(std::equal(want_rgb.begin(), want_rgb.end(), px.data));
  EXPECT_FALSE(source.expired()) << "the gray conversion still needs the received pixels";
  const FrameView g = gray->pixels();
  ASSERT_EQ(g.channels, 1);
  EXPECT_TRUE(std::equal(want_gray.pixels.begin(), want_gray.pixels.end(), g.data));
  EXPECT_TRUE(source.expired()) << "both conversions done: the 921 KB frame is freed";
}

TEST(DdsIntake, ABorrowedBufferIsCopied) {
  const std::vector<std::uint8_t> bytes = pattern(8, 4);
  const std::string encoding = "rgb8";
  Image img{};
  img.encoding_ = borrow(encoding);
  img.width_ = 8;
  img.height_ = 4;
  img.step_ = 24;
  std::vector<std::uint8_t> data = bytes;
  borrow(img.data_, data);
  const auto received = ReceivedImage::take(img);
  EXPECT_FALSE(received->moved());
  EXPECT_EQ(img.data_._buffer, data.data()) << "a borrowed buffer stays with its owner";
  const Image v = received->view();
  EXPECT_NE(v.data_._buffer, data.data());
  EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), v.data_._buffer));
}

// ---- in a running node (wall clock: label integration, as every DdsNode test) ----

constexpr std::uint32_t kW = 96, kH = 48;  // tests/dds/data/node.yaml's model input: no resize

// Frame k's pixels: every byte derived from k (byte 0 is k), so that a reader can tell a
// whole frame from a mixture.
std::uint8_t frame_byte(std::uint8_t k, std::size_t i) {
  return i == 0 ? k : static_cast<std::uint8_t>(k * 13U + i % 251U);
}

// A backend that records how each frame arrived and checks, at every encoder, that the
// frame it reads is whole.
class RecordingBackend final : public Backend {
 public:
  std::mutex mu;
  std::map<std::uint64_t, std::shared_ptr<const LazyFrame>> frames;
  int arrived_converted = 0;  // frames whose pixels were converted before their release
  int arrived_eager = 0;      // frames that came with pixels rather than a LazyFrame
  int encoded = 0, torn = 0;

  [[nodiscard]] std::string_view name() const noexcept override { return "recording"; }
  void on_external_frame(int, std::uint64_t frame, const FrameView& px) override {
    std::lock_guard lock(mu);
    frames[frame] = px.lazy;
    if (px.data != nullptr || !px.lazy) ++arrived_eager;
    if (px.lazy && px.lazy->converted()) ++arrived_converted;
  }
  void run(int, const Dispatch& d) override {
    if (d.kind != UnitKind::Encoder) return;
    for (const Member& m : d.members) {
      std::shared_ptr<const LazyFrame> f;
      {
        std::lock_guard lock(mu);
        f = frames[m.frame];
      }
      if (!f) continue;
      const FrameView px = f->pixels();
      const std::size_t n = static_cast<std::size_t>(px.width * px.height * px.channels);
      int bad = 0;
      for (std::size_t i = 0; i < n; ++i)
        if (px.data[i] != frame_byte(px.data[0], i)) ++bad;
      std::lock_guard lock(mu);
      ++encoded;
      if (bad > 0) ++torn;
    }
  }
};

// Publishes a frame; returns its stamp (sec, nanosec).
std::pair<std::int32_t, std::uint32_t> publish(dds_entity_t writer, const std::string& encoding,
                                               std::uint32_t w, std::uint32_t h, std::uint32_t step,
                                               std::vector<std::uint8_t>& data) {
  const std::string frame_id = "camera";
  Image img{};
  stamp_now(img.header_.stamp_.sec_, img.header_.stamp_.nanosec_);
  img.header_.frame_id_ = borrow(frame_id);
  img.encoding_ = borrow(encoding);
  img.width_ = w;
  img.height_ = h;
  img.step_ = step;
  borrow(img.data_, data);
  EXPECT_GE(dds_write(writer, &img), 0);
  return {img.header_.stamp_.sec_, img.header_.stamp_.nanosec_};
}

// A node's options for these tests: the test's own domain, no real-time settings, no watchdog.
NodeOptions test_node_options() {
  NodeOptions o;
  o.domain = test_domain();
  o.realtime = false;
  o.watchdog_x = 0;
  return o;
}

TEST(DdsNodeIntake, FramesAreReleasedUnconvertedConvertedOnceWholeAndBadOnesNeverReleased) {
  auto s = load_scenario(RED_SOURCE_DIR "/tests/dds/data/node.yaml");
  ASSERT_TRUE(s.has_value());
  auto profile = resolve_profile(*s, std::nullopt);  // as red node: the built-in one
  ASSERT_TRUE(profile.has_value());
  RecordingBackend backend;
  NodeOptions o = test_node_options();
  o.diagnostics_period = std::chrono::milliseconds{200};
  auto node = Node::make(*s, *profile, backend, o);
  ASSERT_TRUE(node.has_value()) << node.error().to_string();

  // The camera, in this process (the node's domain is reused).
  auto dom = Domain::open(o.domain, "");
  ASSERT_TRUE(dom.has_value());
  const dds_entity_t topic =
      dds_create_topic((*dom)->participant(), &sensor_msgs_msg_dds__Image__desc,
                       dds_topic_name((*node)->topics().sensors.front()).c_str(), nullptr, nullptr);
  dds_qos_t* qos = make_qos(QosSettings{}.input);
  const dds_entity_t writer = dds_create_writer((*dom)->participant(), topic, qos, nullptr);
  dds_delete_qos(qos);
  ASSERT_GT(writer, 0);
  for (int i = 0; i < 500; ++i) {
    dds_publication_matched_status_t st;
    if (dds_get_publication_matched_status(writer, &st) == DDS_RETCODE_OK && st.current_count > 0)
      break;
    std::this_thread::sleep_for(std::chrono::milliseconds{10});
  }
  RuntimeReport report;
  std::thread runner([&] { report = (*node)->run(); });
  const auto good = [&](int k) {
    std::vector<std::uint8_t> data(kW * kH * 3U);
    for (std::size_t i = 0; i < data.size(); ++i)
      data[i] = frame_byte(static_cast<std::uint8_t>(k), i);
    publish(writer, "rgb8", kW, kH, kW * 3U, data);
    return data;
  };
  // Until the node takes frames (its runtime started), so that no bad frame published below
  // waits in the reader's history (keep last 5) and is overwritten there uncounted.
  int sent = 0;
  for (int tries = 0; tries < 100 && (*node)->counters().frames == 0; ++tries) {
    good(sent++);
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
  }
  if ((*node)->counters().frames == 0) {
    (*node)->stop();
    runner.join();
    FAIL() << "the node took no frame";
  }
  const int kGood = sent + 24;
  int bad_size = 0, bad_encoding = 0;
  for (int k = sent; k < kGood; ++k) {
    std::vector<std::uint8_t> data = good(k);
    if (k % 4 == 1) {
      std::vector<std::uint8_t> short_data(kW * kH);  // a third of height * step
      publish(writer, "rgb8", kW, kH, kW * 3U, short_data);
      ++bad_size;
    }
    if (k % 4 == 3) {
      publish(writer, "yuv422", kW, kH, kW * 3U, data);
      ++bad_encoding;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds{30});
  }
  std::this_thread::sleep_for(std::chrono::milliseconds{400});  // the last jobs end
  (*node)->stop();
  runner.join();

  const NodeCounters c = (*node)->counters();
  EXPECT_EQ(c.rejected[static_cast<std::size_t>(Reject::DataSize)],
            static_cast<std::uint64_t>(bad_size));
  EXPECT_EQ(c.rejected[static_cast<std::size_t>(Reject::UnknownEncoding)],
            static_cast<std::uint64_t>(bad_encoding));
  EXPECT_GT(c.frames, 0U);
  EXPECT_LE(c.frames, static_cast<std::uint64_t>(kGood)) << "no bad frame was accepted";
  EXPECT_EQ(c.released, c.frames);
  std::lock_guard lock(backend.mu);
  EXPECT_EQ(backend.frames.size(), c.released) << "the backend saw the released frames only";
  EXPECT_EQ(backend.arrived_eager, 0) << "frames reach the backend as LazyFrames";
  EXPECT_EQ(backend.arrived_converted, 0) << "released before being converted";
  EXPECT_GT(backend.encoded, 0);
  EXPECT_EQ(backend.torn, 0) << "an encoder read a frame that was not whole";
  EXPECT_EQ(report.frame_release_us.size(), c.released);
  const Node::Timings t = (*node)->timings();
  EXPECT_EQ(t.released_intake_us.size(), c.released);
  // Received -> released, frame by frame: stamped at the release when the runtime released
  // the frame on the receiving thread (inside push_frame, so after the intake), else NaN.
  ASSERT_EQ(t.taken_released_us.size(), c.released);
  std::size_t direct = 0;
  for (std::size_t i = 0; i < t.taken_released_us.size(); ++i) {
    if (std::isnan(t.taken_released_us[i])) continue;
    ++direct;
    EXPECT_GE(t.taken_released_us[i], t.released_intake_us[i])
        << "released before pushed, frame " << i;
  }
  EXPECT_GT(direct, 0U)
      << "without the real-time knobs the receiving thread releases frames itself";
  EXPECT_EQ(t.after_release_us.size(), direct);
  // The publisher's wake-up is timed for the outputs it waited for, a job's first: at most
  // one per output it took, and some where any output was published.
  EXPECT_LE(t.publish_wake_us.size(), t.publish_us.size() + c.jobs_without_output);
  EXPECT_TRUE(t.publish_us.empty() || !t.publish_wake_us.empty());
  for (double us : t.publish_wake_us) EXPECT_GE(us, 0.0);
}

// What the node publishes for a frame, computed here from the frame's own luminance by the
// rules of docs/ROS2.md ("What the outputs contain"), independently of the node's code.
struct Expected {
  std::vector<std::uint8_t> lane, seg;
  double linear = 0, angular = 0;
  bool has_box = false;
  double cx = 0, cy = 0, sx = 0, sy = 0, score = 0;
};

Expected expected_outputs(const std::vector<std::uint8_t>& rgb, std::uint32_t w, std::uint32_t h) {
  const std::string encoding = "rgb8";
  Image img{};
  img.encoding_ = borrow(encoding);
  img.width_ = w;
  img.height_ = h;
  img.step_ = w * 3U;
  std::vector<std::uint8_t> data = rgb;
  borrow(img.data_, data);
  GrayFrame g;
  to_gray(img, static_cast<int>(w), static_cast<int>(h), g);  // the model input: no resize
  Expected e;
  double sum = 0, left = 0, right = 0;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const double v = g.pixels[y * w + x];
      sum += v;
      (x < w / 2 ? left : right) += v;
    }
  const double n = static_cast<double>(w * h), mean = sum / n;
  for (std::uint8_t v : g.pixels) {
    e.lane.push_back(v > mean ? 255 : 0);
    e.seg.push_back(static_cast<std::uint8_t>(v / 64));
  }
  e.linear = mean / 255.0;
  e.angular = (right - left) / (n / 2.0) / 255.0;
  const double bright = mean + (255.0 - mean) / 2.0;
  std::uint32_t x0 = w, y0 = h, x1 = 0, y1 = 0, count = 0;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      if (g.pixels[y * w + x] > bright) {
        x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
        ++count;
      }
  if (count > 0) {
    e.has_box = true;
    e.cx = (x0 + x1) / 2.0;
    e.cy = (y0 + y1) / 2.0;
    e.sx = x1 - x0 + 1;
    e.sy = y1 - y0 + 1;
    e.score = count / (e.sx * e.sy);
  }
  return e;
}

// A caller that loaded the scenario itself and did not check its policy options gets the
// located error from Node::make, before any DDS entity is made, not a node that left the
// option out.
TEST(DdsNodeIntake, ANodeRefusesAScenarioWithABadPolicyOption) {
  auto s = load_scenario(RED_SOURCE_DIR "/tests/dds/data/node.yaml");
  ASSERT_TRUE(s.has_value());
  s->scheduler.policy_options.push_back(
      OptionText{"admission", "scheduler.admission", "sideways", "", 7, 7});
  auto profile = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(profile.has_value());
  RecordingBackend backend;
  auto node = Node::make(*s, *profile, backend, test_node_options());
  ASSERT_FALSE(node.has_value());
  EXPECT_EQ(node.error().line, 7);
  EXPECT_NE(node.error().message.find("scheduler.admission: "), std::string::npos);
  EXPECT_NE(node.error().message.find("'sideways'"), std::string::npos);
}

TEST(DdsNodeIntake, EveryOutputIsItsFramesRuleWhateverTheOrderOfHeads) {
  auto s = load_scenario(RED_SOURCE_DIR "/tests/dds/data/node.yaml");
  ASSERT_TRUE(s.has_value());
  auto profile = resolve_profile(*s, std::nullopt);
  ASSERT_TRUE(profile.has_value());
  RecordingBackend backend;
  const NodeOptions o = test_node_options();
  auto node = Node::make(*s, *profile, backend, o);
  ASSERT_TRUE(node.has_value()) << node.error().to_string();
  auto dom = Domain::open(o.domain, "");
  ASSERT_TRUE(dom.has_value());
  const dds_entity_t pp = (*dom)->participant();
  const auto reader = [&](const dds_topic_descriptor_t* desc, const std::string& name) {
    const dds_entity_t t =
        dds_create_topic(pp, desc, dds_topic_name(name).c_str(), nullptr, nullptr);
    EndpointQos q = QosSettings{}.output;
    q.depth = 200;
    dds_qos_t* qos = make_qos(q);
    const dds_entity_t r = dds_create_reader(pp, t, qos, nullptr);
    dds_delete_qos(qos);
    return r;
  };
  const auto& nodes = (*node)->topics().nodes;
  const dds_entity_t lane = reader(&sensor_msgs_msg_dds__Image__desc, nodes.at({0, "L"}));
  const dds_entity_t seg = reader(&sensor_msgs_msg_dds__Image__desc, nodes.at({0, "S"}));
  const dds_entity_t steer =
      reader(&geometry_msgs_msg_dds__TwistStamped__desc, nodes.at({0, "C"}) + "/stamped");
  const dds_entity_t det = reader(&vision_msgs_msg_dds__Detection2DArray__desc, nodes.at({1, "O"}));
  ASSERT_GT(lane, 0);
  ASSERT_GT(det, 0);
  const dds_entity_t topic =
      dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                       dds_topic_name((*node)->topics().sensors.front()).c_str(), nullptr, nullptr);
  dds_qos_t* qos = make_qos(QosSettings{}.input);
  const dds_entity_t writer = dds_create_writer(pp, topic, qos, nullptr);
  dds_delete_qos(qos);
  ASSERT_GT(writer, 0);
  RuntimeReport report;
  std::thread runner([&] { report = (*node)->run(); });
  std::map<std::pair<std::int32_t, std::uint32_t>, std::vector<std::uint8_t>> sent;
  for (int k = 0; k < 40; ++k) {
    std::vector<std::uint8_t> data(kW * kH * 3U);
    // A bright square that moves, on a gradient: the box and the balance change per frame.
    for (std::uint32_t y = 0; y < kH; ++y)
      for (std::uint32_t x = 0; x < kW; ++x)
        for (std::uint32_t c = 0; c < 3; ++c) {
          const bool square = x >= static_cast<std::uint32_t>(k) &&
                              x < static_cast<std::uint32_t>(k) + 12 && y >= 10 && y < 20;
          data[(y * kW + x) * 3U + c] =
              square ? 250 : static_cast<std::uint8_t>((x + y * 2 + c * 7) % 160);
        }
    sent[publish(writer, "rgb8", kW, kH, kW * 3U, data)] = data;
    std::this_thread::sleep_for(std::chrono::milliseconds{40});
  }
  std::this_thread::sleep_for(std::chrono::milliseconds{500});
  (*node)->stop();
  runner.join();

  int checked[4] = {0, 0, 0, 0};
  const auto each = [](dds_entity_t r, const std::function<void(const void*)>& f) {
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    for (;;) {
      std::fill(std::begin(samples), std::end(samples), nullptr);
      const dds_return_t n = dds_take(r, samples, infos, 16, 16);
      if (n <= 0) return;
      for (dds_return_t i = 0; i < n; ++i)
        if (infos[i].valid_data) f(samples[i]);
      dds_return_loan(r, samples, n);
    }
  };
  const auto frame_of = [&](const Header& h) -> const std::vector<std::uint8_t>* {
    const auto it = sent.find({h.stamp_.sec_, h.stamp_.nanosec_});
    return it == sent.end() ? nullptr : &it->second;
  };
  for (const dds_entity_t r : {lane, seg}) {
    each(r, [&](const void* p) {
      const auto& m = *static_cast<const Image*>(p);
      const auto* f = frame_of(m.header_);
      ASSERT_NE(f, nullptr) << "a mask with a stamp no frame had";
      const Expected e = expected_outputs(*f, kW, kH);
      const std::vector<std::uint8_t>& want = r == lane ? e.lane : e.seg;
      ASSERT_EQ(m.data_._length, want.size());
      EXPECT_TRUE(std::equal(want.begin(), want.end(), m.data_._buffer))
          << (r == lane ? "lane" : "seg");
      ++checked[r == lane ? 0 : 1];
    });
  }
  each(steer, [&](const void* p) {
    const auto& t = *static_cast<const TwistStamped*>(p);
    const auto* f = frame_of(t.header_);
    ASSERT_NE(f, nullptr);
    const Expected e = expected_outputs(*f, kW, kH);
    EXPECT_NEAR(t.twist_.linear_.x_, e.linear, 1e-12);
    EXPECT_NEAR(t.twist_.angular_.z_, e.angular, 1e-12);
    ++checked[2];
  });
  each(det, [&](const void* p) {
    const auto& a = *static_cast<const Detection2DArray*>(p);
    const auto* f = frame_of(a.header_);
    ASSERT_NE(f, nullptr);
    const Expected e = expected_outputs(*f, kW, kH);
    ASSERT_EQ(a.detections_._length, e.has_box ? 1U : 0U);
    if (e.has_box) {
      const Detection2D& d = a.detections_._buffer[0];
      EXPECT_DOUBLE_EQ(d.bbox_.center_.position_.x_, e.cx);
      EXPECT_DOUBLE_EQ(d.bbox_.center_.position_.y_, e.cy);
      EXPECT_DOUBLE_EQ(d.bbox_.size_x_, e.sx);
      EXPECT_DOUBLE_EQ(d.bbox_.size_y_, e.sy);
      ASSERT_EQ(d.results_._length, 1U);
      EXPECT_NEAR(d.results_._buffer[0].hypothesis_.score_, e.score, 1e-12);
    }
    ++checked[3];
  });
  EXPECT_GT(checked[0], 0) << "lane masks";
  EXPECT_GT(checked[1], 0) << "seg masks";
  EXPECT_GT(checked[2], 0) << "steering";
  EXPECT_GT(checked[3], 0) << "detections";
}

}  // namespace
}  // namespace red::dds
