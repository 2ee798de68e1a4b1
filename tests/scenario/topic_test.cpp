// `topic:` on sensors and inference nodes: the ROS 2 topics of `red node` (docs/ROS2.md).

#include <gtest/gtest.h>

#include "red/scenario/loader.hpp"

namespace red {
namespace {

std::string scenario(const std::string& sensor_topic, const std::string& node_topic) {
  return "name: t\nduration_s: 1\nmodel: {builtin: mimonet, heads: [lane]}\nsensors:\n"
         "  camera: {rate_hz: 10, topic: " +
         sensor_topic +
         "}\noperations:\n  - name: drive\n    trigger: camera\n    deadline_ms: 100\n"
         "    nodes:\n      L: {head: lane, sensor: camera, topic: " +
         node_topic + "}\n";
}

TEST(ScenarioTopics, SensorsAndNodesMayNameTheirTopics) {
  auto s = parse_scenario(scenario("/front/image_raw", "/perception/lanes"), "t.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  EXPECT_EQ(s->sensors[0].topic, "/front/image_raw");
  EXPECT_EQ(s->initial[0]->nodes[0].topic, "/perception/lanes");
}

TEST(ScenarioTopics, ABadTopicNamesTheLine) {
  for (const auto& [sensor, node, line] :
       {std::tuple{"front", "/ok", 5}, std::tuple{"/a//b", "/ok", 5},
        std::tuple{"/ok", "/lanes/", 11}, std::tuple{"/ok", "/1lanes", 11}}) {
    auto s = parse_scenario(scenario(sensor, node), "t.yaml");
    ASSERT_FALSE(s.has_value()) << sensor << " " << node;
    EXPECT_EQ(s.error().line, line) << s.error().to_string();
    EXPECT_NE(s.error().message.find("ROS 2 topic name"), std::string::npos);
  }
}

}  // namespace
}  // namespace red
