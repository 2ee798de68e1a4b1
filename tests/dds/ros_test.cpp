// ROS 2 conventions on DDS (docs/ROS2.md): topic names, remapping, QoS files, the loopback config.

#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "red/dds/ros.hpp"

namespace red::dds {
namespace {

TEST(DdsRos, TopicNamesGetTheRtPrefix) {
  EXPECT_EQ(dds_topic_name("/camera/image_raw"), "rt/camera/image_raw");
  EXPECT_EQ(dds_topic_name("/diagnostics"), "rt/diagnostics");
  EXPECT_TRUE(valid_ros_topic("/a/b_1"));
  EXPECT_FALSE(valid_ros_topic("a/b"));
  EXPECT_FALSE(valid_ros_topic("/a//b"));
  EXPECT_FALSE(valid_ros_topic("/a/"));
  EXPECT_FALSE(valid_ros_topic("/a/1b"));
  EXPECT_FALSE(valid_ros_topic("/a-b"));
}

TEST(DdsRos, RemapsReplaceWholeNamesAndRejectBadRules) {
  Remaps r;
  ASSERT_TRUE(r.add("/camera/image_raw:=/front/image").has_value());
  EXPECT_EQ(r.apply("/camera/image_raw"), "/front/image");
  EXPECT_EQ(r.apply("/camera/image_raw2"), "/camera/image_raw2");
  auto bad = r.add("/camera/image_raw=/x");
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("from:=to"), std::string::npos);
  auto bad_name = r.add("/camera:=front");
  ASSERT_FALSE(bad_name.has_value());
  EXPECT_NE(bad_name.error().message.find("'front'"), std::string::npos);
}

TEST(DdsRos, QosDefaultsAreRos2sAndAFileOverridesThem) {
  const QosSettings d;
  EXPECT_FALSE(d.input.reliable);
  EXPECT_EQ(d.input.depth, 5);
  EXPECT_TRUE(d.output.reliable);
  EXPECT_EQ(d.output.depth, 10);
  EXPECT_FALSE(d.output.transient_local);
  const std::string path = ::testing::TempDir() + "qos.yaml";
  std::ofstream(path) << "input: {reliability: reliable, depth: 1}\noutput:\n  durability: "
                         "transient_local\n";
  auto q = load_qos_file(path);
  ASSERT_TRUE(q.has_value()) << q.error().to_string();
  EXPECT_TRUE(q->input.reliable);
  EXPECT_EQ(q->input.depth, 1);
  EXPECT_TRUE(q->output.transient_local);
  EXPECT_EQ(q->output.depth, 10);
}

TEST(DdsRos, BadQosFilesNameTheLineAndTheProblem) {
  const std::string path = ::testing::TempDir() + "bad_qos.yaml";
  std::ofstream(path) << "input:\n  reliability: sometimes\n";
  auto q = load_qos_file(path);
  ASSERT_FALSE(q.has_value());
  EXPECT_EQ(q.error().line, 2);
  EXPECT_NE(q.error().message.find("sometimes"), std::string::npos);
  std::ofstream(path) << "output: {depth: 0}\n";
  EXPECT_FALSE(load_qos_file(path).has_value());
  std::ofstream(path) << "outptu: {depth: 3}\n";
  auto typo = load_qos_file(path);
  ASSERT_FALSE(typo.has_value());
  EXPECT_NE(typo.error().message.find("outptu"), std::string::npos);
  EXPECT_FALSE(load_qos_file("/nonexistent/qos.yaml").has_value());
}

TEST(DdsRos, TheDefaultConfigurationStaysOnLoopback) {
  const std::string c = loopback_config();
  EXPECT_NE(c.find("name=\"lo\""), std::string::npos);
  EXPECT_NE(c.find("<AllowMulticast>false</AllowMulticast>"), std::string::npos);
  EXPECT_NE(c.find("127.0.0.1"), std::string::npos);
  EXPECT_FALSE(Domain::open(500, "").has_value()) << "domain ids above 232 are rejected";
}

// The large fragments are not only written but applied: Cyclone's own trace of the
// configuration it runs with (verbosity "config") shows them.
TEST(DdsRos, TheDefaultConfigurationsFragmentSizesTakeEffect) {
  const std::string trace =
      ::testing::TempDir() + "red_cyclone_config_" + std::to_string(getpid()) + ".log";
  std::string c = loopback_config();
  const auto end = c.find("</Domain>");
  ASSERT_NE(end, std::string::npos);
  c.insert(end, "<Tracing><Verbosity>config</Verbosity><OutputFile>" + trace +
                    "</OutputFile></Tracing>");
  const int domain = 200 + static_cast<int>(getpid() % 30);
  {
    auto d = Domain::open(domain, c);
    ASSERT_TRUE(d.has_value()) << d.error().to_string();
  }
  std::ifstream f(trace);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string log = ss.str();
  EXPECT_NE(log.find("General/FragmentSize/#text: 60000 B"), std::string::npos)
      << log.substr(0, 400);
  EXPECT_NE(log.find("General/MaxMessageSize/#text: 65000 B"), std::string::npos);
  std::remove(trace.c_str());
}

}  // namespace
}  // namespace red::dds
