// `red node` and `red camera` end to end over DDS on loopback (docs/ROS2.md): the camera's frames
// are the node's releases, every output type arrives with the header of a frame the camera
// sent, bad images are rejected, counted and reported, and bad command lines exit 2.

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "../support/cli.hpp"
#include "red/dds/messages.hpp"
#include "red/dds/ros.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

const std::string kRed = RED_CLI;
const std::string kScenario = RED_SOURCE_DIR "/tests/dds/data/node.yaml";

int exit_code(int status) {
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Runs a shell command on its own thread; its exit code when joined.
struct Command {
  std::thread thread;
  int code = -1;
  explicit Command(const std::string& cmd)
      : thread([this, cmd] { code = exit_code(std::system(cmd.c_str())); }) {}
  int join() {
    thread.join();
    return code;
  }
};

using Stamp = std::pair<std::int32_t, std::uint32_t>;

// A reader of one topic that keeps what the test needs from each sample.
struct Listener {
  dds_entity_t reader = 0;
  std::function<void(const void*)> on_sample;
  std::uint64_t samples = 0;
};

dds_entity_t make_reader(dds_entity_t pp, const dds_topic_descriptor_t* desc,
                         const std::string& topic, bool reliable) {
  const dds_entity_t t =
      dds_create_topic(pp, desc, dds_topic_name(topic).c_str(), nullptr, nullptr);
  EndpointQos q;
  q.reliable = reliable;
  q.depth = 200;
  dds_qos_t* qos = make_qos(q);
  const dds_entity_t r = dds_create_reader(pp, t, qos, nullptr);
  dds_delete_qos(qos);
  return r;
}

void drain(Listener& l) {
  void* samples[16] = {};
  dds_sample_info_t infos[16];
  for (;;) {
    std::fill(std::begin(samples), std::end(samples), nullptr);
    const dds_return_t n = dds_take(l.reader, samples, infos, 16, 16);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i)
      if (infos[i].valid_data) {
        ++l.samples;
        l.on_sample(samples[i]);
      }
    dds_return_loan(l.reader, samples, n);
  }
}

// Publishes an image on `writer` with the given (possibly bad) layout.
void publish_image(dds_entity_t writer, const std::string& encoding, std::uint32_t w,
                   std::uint32_t h, std::uint32_t step, std::size_t bytes) {
  std::vector<std::uint8_t> data(bytes, 100);
  const std::string frame = "bad";
  Image img{};
  img.header_.frame_id_ = borrow(frame);
  img.encoding_ = borrow(encoding);
  img.width_ = w;
  img.height_ = h;
  img.step_ = step;
  borrow(img.data_, data);
  ASSERT_GE(dds_write(writer, &img), 0);
}

TEST(DdsNode, CameraToNodeToListenersWithMatchingStampsAndDiagnostics) {
  const int domain = test_domain();
  auto dom = Domain::open(domain, "");
  ASSERT_TRUE(dom.has_value()) << dom.error().to_string();
  const dds_entity_t pp = (*dom)->participant();

  std::set<Stamp> sent;
  std::map<std::string, std::vector<Stamp>> stamps;  // by output topic
  std::map<std::string, std::string> last_diag;      // "status/key" -> value
  std::uint64_t bad_masks = 0, empty_stamped = 0;
  std::vector<Listener> ls;
  // The frames the camera sent: their headers, which `red camera --stamps-topic` also
  // publishes reliably (a best-effort reader of the frames themselves lost one under CI's
  // load, and every output of that frame then looked like a new stamp).
  ls.push_back({make_reader(pp, &std_msgs_msg_dds__Header__desc, "/camera/stamps", true),
                [&](const void* p) {
                  const auto& h = *static_cast<const Header*>(p);
                  if (std::string(h.frame_id_) == "camera")
                    sent.insert({h.stamp_.sec_, h.stamp_.nanosec_});
                }});
  for (const std::string t : {"/red/drive/L", "/red/drive/S"})
    ls.push_back(
        {make_reader(pp, &sensor_msgs_msg_dds__Image__desc, t, true), [&, t](const void* p) {
           const auto& m = *static_cast<const Image*>(p);
           stamps[t].push_back({m.header_.stamp_.sec_, m.header_.stamp_.nanosec_});
           // The model input of the scenario is 48 x 96: masks come at that size.
           if (std::string(m.encoding_) != "mono8" || m.height_ != 48 || m.width_ != 96 ||
               m.step_ != 96 || m.data_._length != 48U * 96U)
             ++bad_masks;
         }});
  ls.push_back(
      {make_reader(pp, &geometry_msgs_msg_dds__TwistStamped__desc, "/red/drive/C/stamped", true),
       [&](const void* p) {
         const auto& m = *static_cast<const TwistStamped*>(p);
         stamps["/red/drive/C/stamped"].push_back(
             {m.header_.stamp_.sec_, m.header_.stamp_.nanosec_});
         if (m.twist_.linear_.x_ <= 0) ++empty_stamped;  // mean luminance of a frame
       }});
  ls.push_back({make_reader(pp, &geometry_msgs_msg_dds__Twist__desc, "/red/drive/C", true),
                [&](const void*) { stamps["/red/drive/C"]; }});
  ls.push_back(
      {make_reader(pp, &vision_msgs_msg_dds__Detection2DArray__desc, "/red/detect/O", true),
       [&](const void* p) {
         const auto& m = *static_cast<const Detection2DArray*>(p);
         stamps["/red/detect/O"].push_back({m.header_.stamp_.sec_, m.header_.stamp_.nanosec_});
         for (std::uint32_t i = 0; i < m.detections_._length; ++i)
           EXPECT_EQ(HeaderValue::from(m.detections_._buffer[i].header_),
                     HeaderValue::from(m.header_));
       }});
  ls.push_back(
      {make_reader(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, "/diagnostics", true),
       [&](const void* p) {
         const auto& m = *static_cast<const DiagnosticArray*>(p);
         for (std::uint32_t i = 0; i < m.status_._length; ++i) {
           const DiagnosticStatus& s = m.status_._buffer[i];
           for (std::uint32_t k = 0; k < s.values_._length; ++k)
             last_diag[std::string(s.name_) + "/" + s.values_._buffer[k].key_] =
                 s.values_._buffer[k].value_;
         }
       }});
  for (const Listener& l : ls) ASSERT_GT(l.reader, 0);

  // Bad images come from a writer of the test's own.
  const dds_entity_t bad_topic =
      dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                       dds_topic_name("/camera/image_raw").c_str(), nullptr, nullptr);
  dds_qos_t* rq = make_qos(EndpointQos{true, 10, false});
  const dds_entity_t bad = dds_create_writer(pp, bad_topic, rq, nullptr);
  dds_delete_qos(rq);
  ASSERT_GT(bad, 0);

  const std::string d = " --domain " + std::to_string(domain);
  Command node(kRed + " node '" + kScenario + "' --backend synthetic --duration 5" + d + " 2> '" +
               ::testing::TempDir() + "node.err'");
  // The node's reader is there when the bad writer matches it (the test reads the camera's
  // headers, not the camera topic: the only reader to match is the node's).
  const auto t0 = std::chrono::steady_clock::now();
  dds_publication_matched_status_t st{};
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds{20}) {
    dds_get_publication_matched_status(bad, &st);
    if (st.current_count >= 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  ASSERT_GE(st.current_count, 1U) << "red node never subscribed to /camera/image_raw";
  Command camera(kRed + " camera --rate 20 --count 40 --size 64x48 --stamps-topic /camera/stamps" +
                 d + " 2>/dev/null");
  // The bad images go out once the node demonstrably takes frames (an output came back):
  // matching is seen from the writer's side first, and a sample the node's best-effort
  // reader gets before it has matched this writer is lost, which made the counts flaky.
  bool bad_sent = false;
  const auto poll = [&] {
    for (Listener& l : ls) drain(l);
    if (bad_sent || stamps["/red/drive/L"].empty()) return;
    publish_image(bad, "yuv422", 4, 4, 8, 32);           // unknown encoding
    publish_image(bad, "rgb8", 4, 4, 12, 47);            // data != height * step
    publish_image(bad, "mono8", 100000, 2, 100000, 16);  // absurd width
    publish_image(bad, "rgb8", 8, 2, 8, 16);             // step < width * 3
    bad_sent = true;
  };
  std::atomic<bool> camera_done{false};
  std::thread waiter([&] {
    camera.join();
    camera_done.store(true);
  });
  while (!camera_done.load() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds{60}) {
    poll();
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  waiter.join();
  EXPECT_EQ(camera.code, 0);
  const int node_code = node.join();
  std::this_thread::sleep_for(std::chrono::milliseconds{300});
  poll();
  EXPECT_EQ(node_code, 0) << test::read_text(::testing::TempDir() + "node.err");

  ASSERT_FALSE(sent.empty());
  for (const std::string t :
       {"/red/drive/L", "/red/drive/S", "/red/drive/C/stamped", "/red/detect/O"}) {
    SCOPED_TRACE(t);
    ASSERT_FALSE(stamps[t].empty()) << "no output on " << t;
    // Each output carries the header of a frame the camera sent, never a new stamp. The
    // test's probe may match the camera after the node did (discovery of the
    // camera's participant is not simultaneous): an output of a frame older than the first
    // one the probe saw cannot be checked against it, and there can be only a few.
    std::size_t before_probe = 0;
    for (const Stamp& s : stamps[t]) {
      if (s < *sent.begin()) {
        ++before_probe;
        continue;
      }
      EXPECT_EQ(sent.count(s), 1U) << s.first << "." << s.second;
    }
    EXPECT_LE(before_probe, 4U) << "outputs of frames sent before the probe matched";
    EXPECT_LT(before_probe, stamps[t].size());
  }
  EXPECT_EQ(stamps["/red/drive/L"].size(), stamps["/red/drive/S"].size());
  EXPECT_EQ(bad_masks, 0U);
  EXPECT_EQ(empty_stamped, 0U);
  ASSERT_FALSE(last_diag.empty()) << "no diagnostics";
  EXPECT_GT(std::stoi(last_diag["red: drive/jobs"]), 0);
  EXPECT_GT(std::stoi(last_diag["red: detect/jobs"]), 0);
  for (const std::string k :
       {"miss_rate", "drop_rate", "qoe", "latency_p50_ms", "latency_p99_ms", "not_met"})
    EXPECT_EQ(last_diag.count("red: drive/" + k), 1U) << k;
  // The jobs not met by cause add up to the misses the rate counts.
  for (const std::string op : {"drive", "detect"}) {
    const std::string text = last_diag["red: " + op + "/not_met"];
    std::uint64_t counted = 0;
    for (std::size_t at = 0; at < text.size();) {
      const std::size_t end = std::min(text.find(", ", at), text.size());
      const std::string part = text.substr(at, end - at);
      counted += std::stoull(part.substr(part.rfind(' ') + 1));
      at = end + 2;
    }
    const double jobs = std::stod(last_diag["red: " + op + "/jobs"]);
    const double rate = std::stod(last_diag["red: " + op + "/miss_rate"]);
    EXPECT_NEAR(static_cast<double>(counted), jobs * rate, 0.5) << op << ": " << text;
  }
  EXPECT_EQ(last_diag.count("red: node/decision_p99_us"), 1U);
  ASSERT_TRUE(bad_sent) << "the node produced no output, so no bad image was sent";
  EXPECT_EQ(last_diag["red: node/rejected_unknown_encoding"], "1");
  EXPECT_EQ(last_diag["red: node/rejected_data_size"], "1");
  EXPECT_EQ(last_diag["red: node/rejected_absurd_size"], "1");
  EXPECT_EQ(last_diag["red: node/rejected_bad_step"], "1");
  // Every good frame the node received was accepted: bad ones cost nothing else.
  EXPECT_EQ(last_diag["red: node/frames"], last_diag["red: node/released"]);
  // Camera topics are best effort (ROS 2's sensor-data QoS): a loaded machine may lose a few.
  EXPECT_GE(std::stoul(last_diag["red: node/frames"]), sent.size() / 2);
}

TEST(DdsNode, ASilentCameraIsReportedTheNodeResumesAndSigtermStopsItCleanly) {
  const int domain = test_domain();
  auto dom = Domain::open(domain, "");
  ASSERT_TRUE(dom.has_value()) << dom.error().to_string();
  const dds_entity_t pp = (*dom)->participant();
  struct Diag {
    std::uint64_t frames = 0;
    std::string silent;
  };
  std::vector<Diag> diags;
  std::uint64_t lanes = 0;
  std::vector<Listener> ls;
  ls.push_back(
      {make_reader(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, "/diagnostics", true),
       [&](const void* p) {
         const auto& m = *static_cast<const DiagnosticArray*>(p);
         Diag d;
         for (std::uint32_t i = 0; i < m.status_._length; ++i)
           for (std::uint32_t k = 0; k < m.status_._buffer[i].values_._length; ++k) {
             const KeyValue& kv = m.status_._buffer[i].values_._buffer[k];
             if (std::string(kv.key_) == "frames") d.frames = std::stoull(kv.value_);
             if (std::string(kv.key_) == "silent_sensors") d.silent = kv.value_;
           }
         diags.push_back(d);
       }});
  ls.push_back({make_reader(pp, &sensor_msgs_msg_dds__Image__desc, "/red/drive/L", true),
                [&](const void*) { ++lanes; }});
  const auto poll_for = [&](std::chrono::milliseconds how_long) {
    const auto end = std::chrono::steady_clock::now() + how_long;
    while (std::chrono::steady_clock::now() < end) {
      for (Listener& l : ls) drain(l);
      std::this_thread::sleep_for(std::chrono::milliseconds{20});
    }
  };
  const std::string dir = ::testing::TempDir() + "red_node_out_" + std::to_string(domain);
  const std::string pid = dir + ".pid", rc = dir + ".rc", err = dir + ".err";
  std::remove(rc.c_str());
  const std::string d = " --domain " + std::to_string(domain);
  // No --duration: the node runs until a signal.
  Command node("sh -c \"" + kRed + " node '" + kScenario + "' --backend synthetic --out '" + dir +
               "'" + d + " 2> '" + err + "' & echo \\$! > '" + pid + "'; wait \\$!; echo \\$? > '" +
               rc + "'\"");
  const std::string camera =
      kRed + " camera --rate 20 --count 20 --size 32x24" + d + " 2>/dev/null";
  ASSERT_EQ(exit_code(std::system(camera.c_str())), 0);
  poll_for(std::chrono::milliseconds{2500});  // > 3 periods of silence, > 1 diagnostics period
  const std::uint64_t lanes_before = lanes;
  ASSERT_FALSE(diags.empty()) << test::read_text(err);
  EXPECT_GT(diags.back().frames, 0U);
  EXPECT_EQ(diags.back().silent, "camera") << "a camera that stopped is reported silent";
  const std::uint64_t frames_before = diags.back().frames;
  // The camera comes back: releases and outputs resume.
  ASSERT_EQ(exit_code(std::system(camera.c_str())), 0);
  poll_for(std::chrono::milliseconds{1500});
  EXPECT_GT(lanes, lanes_before);
  EXPECT_GT(diags.back().frames, frames_before);
  const pid_t p = static_cast<pid_t>(std::stol(test::read_text(pid)));
  ASSERT_GT(p, 0);
  ASSERT_EQ(kill(p, SIGTERM), 0);
  EXPECT_EQ(node.join(), 0);
  EXPECT_EQ(test::read_text(rc), "0\n") << test::read_text(err);
  EXPECT_NE(test::read_text(err).find("red node: "), std::string::npos);
  EXPECT_NE(test::read_text(dir + "/summary.json").find("\"jobs\""), std::string::npos)
      << "SIGTERM still writes the summary";
  EXPECT_FALSE(test::read_text(dir + "/jobs.csv").empty());
}

TEST(DdsNode, WritersOfAnotherTypeOrIncompatibleQosAreCountedAndNoFrameIsLost) {
  const int domain = test_domain();
  auto dom = Domain::open(domain, "");
  ASSERT_TRUE(dom.has_value()) << dom.error().to_string();
  const dds_entity_t pp = (*dom)->participant();
  std::map<std::string, std::string> last_diag;  // "status/key" -> value
  Listener diag{
      make_reader(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, "/diagnostics", true),
      [&](const void* p) {
        const auto& m = *static_cast<const DiagnosticArray*>(p);
        for (std::uint32_t i = 0; i < m.status_._length; ++i) {
          const DiagnosticStatus& s = m.status_._buffer[i];
          for (std::uint32_t k = 0; k < s.values_._length; ++k)
            last_diag[std::string(s.name_) + "/" + s.values_._buffer[k].key_] =
                s.values_._buffer[k].value_;
        }
      }};
  ASSERT_GT(diag.reader, 0);
  // A geometry_msgs/Twist writer on the camera's topic (the wrong type: DDS never matches
  // it with the node's Image reader), and an Image writer whose exclusive ownership the
  // node's reader (shared ownership) cannot accept.
  const std::string camera_topic = dds_topic_name("/camera/image_raw");
  const dds_entity_t twist_topic = dds_create_topic(pp, &geometry_msgs_msg_dds__Twist__desc,
                                                    camera_topic.c_str(), nullptr, nullptr);
  ASSERT_GT(twist_topic, 0);
  const dds_entity_t twist = dds_create_writer(pp, twist_topic, nullptr, nullptr);
  ASSERT_GT(twist, 0);
  const dds_entity_t image_topic = dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                                                    camera_topic.c_str(), nullptr, nullptr);
  dds_qos_t* q = make_qos(EndpointQos{true, 10, false});
  dds_qset_ownership(q, DDS_OWNERSHIP_EXCLUSIVE);
  const dds_entity_t exclusive = dds_create_writer(pp, image_topic, q, nullptr);
  dds_delete_qos(q);
  ASSERT_GT(exclusive, 0);

  const std::string d = " --domain " + std::to_string(domain);
  const std::string err = ::testing::TempDir() + "wrong_type_" + std::to_string(domain) + ".err";
  Command node(kRed + " node '" + kScenario + "' --backend synthetic --duration 4" + d + " 2> '" +
               err + "'");
  Command camera(kRed + " camera --rate 20 --count 40 --size 32x24" + d + " 2>/dev/null");
  const auto t0 = std::chrono::steady_clock::now();
  bool wrote = false;
  while (last_diag["red: node/frames"].empty() || last_diag["red: node/frames"] == "0") {
    drain(diag);
    if (!wrote && !last_diag.empty()) {
      // Sent once the node is up; neither sample may reach it.
      Twist t{};
      t.linear_.x_ = 1.0;
      EXPECT_GE(dds_write(twist, &t), 0);
      wrote = true;
    }
    if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds{30}) break;
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  EXPECT_EQ(camera.join(), 0);
  EXPECT_EQ(node.join(), 0) << test::read_text(err);
  std::this_thread::sleep_for(std::chrono::milliseconds{300});
  drain(diag);
  ASSERT_FALSE(last_diag.empty()) << "no diagnostics; " << test::read_text(err);
  EXPECT_EQ(last_diag["red: node/rejected_wrong_type"], "1") << test::read_text(err);
  EXPECT_EQ(last_diag["red: node/rejected_incompatible_qos"], "1") << test::read_text(err);
  // The frames of the good camera are all released, as if the bad writers were not there.
  EXPECT_GT(std::stoul(last_diag["red: node/frames"]), 0U);
  EXPECT_EQ(last_diag["red: node/frames"], last_diag["red: node/released"]);
  const std::string text = test::read_text(err);
  EXPECT_NE(text.find("wrong_type"), std::string::npos) << text;
  EXPECT_NE(text.find("incompatible_qos"), std::string::npos) << text;
}

int run(const std::string& args) {
  return exit_code(std::system((kRed + " " + args + " >/dev/null 2>&1").c_str()));
}

// Frames a link loses are counted: the camera leaves out every fifth frame (8 of 40) and the
// node infers them from the gaps in the stamps (all but the first, which comes before it
// knows the stream's period), in its end line and node.json. 10 frames/s: a period long
// against the stamps' jitter on a loaded machine.
TEST(DdsNodeCli, FramesLostOnTheWayAreCounted) {
  const int domain = test_domain();
  const std::string d = " --domain " + std::to_string(domain);
  const std::string tag = std::to_string(domain);
  const std::string out = ::testing::TempDir() + "lost_" + tag;
  const std::string err = ::testing::TempDir() + "lost_" + tag + ".err";
  const std::string cam_err = ::testing::TempDir() + "lost_camera_" + tag + ".err";
  Command node(kRed + " node '" + kScenario + "' --backend synthetic --duration 7" + d +
               " --out '" + out + "' 2> '" + err + "'");
  std::this_thread::sleep_for(std::chrono::milliseconds{500});
  Command camera(kRed + " camera --rate 10 --count 40 --size 32x24 --skip-every 5" + d + " 2> '" +
                 cam_err + "'");
  EXPECT_EQ(camera.join(), 0) << test::read_text(cam_err);
  EXPECT_EQ(node.join(), 0) << test::read_text(err);
  EXPECT_NE(test::read_text(cam_err).find("published 32 frames on /camera/image_raw (8 left out)"),
            std::string::npos)
      << test::read_text(cam_err);
  std::ifstream f(out + "/node.json");
  ASSERT_TRUE(f.good()) << test::read_text(err);
  const nlohmann::json j = nlohmann::json::parse(f);
  const auto frames = j.at("frames").get<std::uint64_t>();
  const auto lost = j.at("not_taken_by_reason").at("lost_in_transport").get<std::uint64_t>();
  // Best effort on loopback may lose a frame of its own, and a stamp late by half a period
  // on a loaded machine hides a gap; none is counted twice.
  EXPECT_GE(lost, 6U) << test::read_text(err);
  EXPECT_LE(frames + lost, 40U);
  EXPECT_GE(frames, 28U);
  EXPECT_EQ(j.at("not_taken").get<std::uint64_t>(), lost);
  const std::string text = test::read_text(err);
  EXPECT_NE(text.find("lost in transport"), std::string::npos) << text;
  EXPECT_NE(text.find("not delivered by DDS lost_in_transport"), std::string::npos) << text;
}

// A 640x480 rgb8 frame (921 KB) crosses from `red camera` to another process with the
// default loopback configuration, whose 60000 B fragments travel in 16 datagrams of up to
// 65000 B (best effort: some of the frames suffice).
TEST(DdsNodeCli, LargeFramesCrossTheDefaultLoopbackConfigurationWhole) {
  const int domain = test_domain();
  auto dom = Domain::open(domain, "");
  ASSERT_TRUE(dom.has_value()) << dom.error().to_string();
  Listener frames;
  frames.reader = make_reader((*dom)->participant(), &sensor_msgs_msg_dds__Image__desc,
                              "/camera/image_raw", false);
  ASSERT_GT(frames.reader, 0);
  std::uint64_t whole = 0, broken = 0;
  frames.on_sample = [&](const void* p) {
    const auto& img = *static_cast<const Image*>(p);
    const bool ok = img.width_ == 640 && img.height_ == 480 && img.step_ == 640 * 3 &&
                    img.data_._length == 640U * 480U * 3U;
    (ok ? whole : broken) += 1;
  };
  Command camera(kRed + " camera --rate 20 --count 10 --size 640x480 --domain " +
                 std::to_string(domain) + " 2>/dev/null");
  std::atomic<bool> done{false};
  std::thread waiter([&] {
    camera.join();
    done.store(true);
  });
  const auto t0 = std::chrono::steady_clock::now();
  while (!done.load() && std::chrono::steady_clock::now() - t0 < std::chrono::seconds{30}) {
    drain(frames);
    std::this_thread::sleep_for(std::chrono::milliseconds{10});
  }
  waiter.join();
  std::this_thread::sleep_for(std::chrono::milliseconds{200});
  drain(frames);
  EXPECT_EQ(camera.code, 0);
  EXPECT_GT(whole, 0U) << "no 640x480 frame arrived";
  EXPECT_EQ(broken, 0U);
}

TEST(DdsNodeCli, BadInputExitsTwo) {
  const std::string s = "'" + kScenario + "' --backend synthetic --duration 0.1 --domain " +
                        std::to_string(test_domain());
  EXPECT_EQ(run("node /nonexistent.yaml"), 2);
  EXPECT_EQ(run("node " + s + " --policy nope"), 2);
  EXPECT_EQ(run("node " + s + " --remap /camera/image_raw=/x"), 2);
  EXPECT_EQ(run("node " + s + " --remap /camera/image_raw:=x"), 2);
  EXPECT_EQ(run("node " + s + " --qos-file /nonexistent.yaml"), 2);
  EXPECT_EQ(run("node " + s + " --config /nonexistent.xml"), 2);
  EXPECT_EQ(run("node " + s + " --domain 500"), 2);
  EXPECT_EQ(run("node " + s + " --backend magic"), 2);
  EXPECT_EQ(run("node " + s + " --duration -1"), 2);
  EXPECT_EQ(run("node " + s + " --watchdog-x -1"), 2);
  EXPECT_EQ(run("camera --size 10by10 --count 1"), 2);
  EXPECT_EQ(run("camera --encoding yuv422 --count 1"), 2);
  EXPECT_EQ(run("camera --rate 0 --count 1"), 2);
  EXPECT_EQ(run("camera --topic no_slash --count 1"), 2);
  EXPECT_EQ(run("camera --stamps-topic no_slash --count 1"), 2);
}

TEST(DdsNodeCli, RemapsAndQosFilesAreUsed) {
  const std::string qos = ::testing::TempDir() + "node_qos.yaml";
  std::ofstream(qos) << "input: {reliability: reliable, depth: 2}\n";
  const std::string err = ::testing::TempDir() + "remap.err";
  const int code = exit_code(std::system(
      (kRed + " node '" + kScenario + "' --backend synthetic --duration 0.2 --domain " +
       std::to_string(test_domain()) + " --qos-file '" + qos +
       "' --remap /camera/image_raw:=/front/image --remap /red/drive/L:=/lanes 2> '" + err + "'")
          .c_str()));
  EXPECT_EQ(code, 0) << test::read_text(err);
  const std::string text = test::read_text(err);
  EXPECT_NE(text.find("in  /front/image"), std::string::npos) << text;
  EXPECT_NE(text.find("out /lanes"), std::string::npos) << text;
  EXPECT_EQ(text.find("/camera/image_raw"), std::string::npos) << text;
}

TEST(DdsNodeCli, ScenarioTopicsAreUsedAndRemapsStillApply) {
  const std::string path = ::testing::TempDir() + "topics.yaml";
  std::ofstream(path) << "name: topics\nduration_s: 1\nmodel: {builtin: mimonet, heads: [lane, "
                         "steer]}\nsensors:\n  front: {rate_hz: 10, topic: /front/image}\n"
                         "operations:\n  - name: drive\n    trigger: front\n    deadline_ms: "
                         "100\n    nodes:\n      L: {head: lane, sensor: front, topic: /lanes}\n"
                         "      C: {head: steer, sensor: front}\n";
  const std::string err = ::testing::TempDir() + "topics.err";
  const int code = exit_code(
      std::system((kRed + " node '" + path + "' --backend synthetic --duration 0.2 --domain " +
                   std::to_string(test_domain()) + " --remap /lanes:=/lane_mask 2> '" + err + "'")
                      .c_str()));
  const std::string text = test::read_text(err);
  EXPECT_EQ(code, 0) << text;
  EXPECT_NE(text.find("in  /front/image (sensor front"), std::string::npos) << text;
  EXPECT_NE(text.find("out /lane_mask ("), std::string::npos) << text;
  EXPECT_NE(text.find("out /red/drive/C ("), std::string::npos) << text;
}

}  // namespace
}  // namespace red::dds
