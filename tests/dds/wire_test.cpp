// ROS 2 wire format, byte for byte (docs/ROS2.md): every message type RED speaks, serialized by
// Cyclone DDS from RED's IDL, equals what an independent ROS 2 serializer writes (npm
// @foxglove/rosmsg2-serialization, run by node), and each side decodes the other's bytes.

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "red/dds/cdr.hpp"
#include "red/dds/messages.hpp"
#include "red/dds/ros.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

using nlohmann::json;

// Owns what the C messages built from JSON borrow.
struct Arena {
  std::deque<std::string> strings;
  std::deque<std::vector<std::uint8_t>> bytes;
  std::deque<std::vector<Detection2D>> detections;
  std::deque<std::vector<ObjectHypothesisWithPose>> results;
  std::deque<std::vector<DiagnosticStatus>> statuses;
  std::deque<std::vector<KeyValue>> values;
  char* str(const json& j) { return borrow(strings.emplace_back(j.get<std::string>())); }
};

void fill(Arena& a, const json& j, Header& h) {
  h.stamp_.sec_ = j["stamp"]["sec"].get<std::int32_t>();
  h.stamp_.nanosec_ = j["stamp"]["nanosec"].get<std::uint32_t>();
  h.frame_id_ = a.str(j["frame_id"]);
}
void fill(const json& j, Vector3& v) {
  v.x_ = j["x"].get<double>();
  v.y_ = j["y"].get<double>();
  v.z_ = j["z"].get<double>();
}
void fill(Arena& a, const json& j, Image& m) {
  fill(a, j["header"], m.header_);
  m.height_ = j["height"].get<std::uint32_t>();
  m.width_ = j["width"].get<std::uint32_t>();
  m.encoding_ = a.str(j["encoding"]);
  m.is_bigendian_ = j["is_bigendian"].get<std::uint8_t>();
  m.step_ = j["step"].get<std::uint32_t>();
  borrow(m.data_, a.bytes.emplace_back(j["data"].get<std::vector<std::uint8_t>>()));
}
void fill(Arena&, const json& j, Twist& m) {
  fill(j["linear"], m.linear_);
  fill(j["angular"], m.angular_);
}
void fill(Arena& a, const json& j, TwistStamped& m) {
  fill(a, j["header"], m.header_);
  fill(a, j["twist"], m.twist_);
}
void fill(Arena& a, const json& j, Detection2DArray& m) {
  fill(a, j["header"], m.header_);
  auto& dets = a.detections.emplace_back(j["detections"].size());
  for (std::size_t i = 0; i < dets.size(); ++i) {
    const json& jd = j["detections"][i];
    Detection2D& d = dets[i];
    fill(a, jd["header"], d.header_);
    auto& res = a.results.emplace_back(jd["results"].size());
    for (std::size_t k = 0; k < res.size(); ++k) {
      const json& jr = jd["results"][k];
      res[k].hypothesis_.class_id_ = a.str(jr["hypothesis"]["class_id"]);
      res[k].hypothesis_.score_ = jr["hypothesis"]["score"].get<double>();
      const json& jp = jr["pose"]["pose"];
      res[k].pose_.pose_.position_ = {jp["position"]["x"], jp["position"]["y"],
                                      jp["position"]["z"]};
      res[k].pose_.pose_.orientation_ = {jp["orientation"]["x"], jp["orientation"]["y"],
                                         jp["orientation"]["z"], jp["orientation"]["w"]};
      for (std::size_t c = 0; c < 36; ++c)
        res[k].pose_.covariance_[c] = jr["pose"]["covariance"][c].get<double>();
    }
    borrow(d.results_, res);
    d.bbox_.center_.position_.x_ = jd["bbox"]["center"]["position"]["x"];
    d.bbox_.center_.position_.y_ = jd["bbox"]["center"]["position"]["y"];
    d.bbox_.center_.theta_ = jd["bbox"]["center"]["theta"];
    d.bbox_.size_x_ = jd["bbox"]["size_x"];
    d.bbox_.size_y_ = jd["bbox"]["size_y"];
    d.id_ = a.str(jd["id"]);
  }
  borrow(m.detections_, dets);
}
void fill(Arena& a, const json& j, DiagnosticArray& m) {
  fill(a, j["header"], m.header_);
  auto& st = a.statuses.emplace_back(j["status"].size());
  for (std::size_t i = 0; i < st.size(); ++i) {
    const json& js = j["status"][i];
    st[i].level_ = js["level"].get<std::uint8_t>();
    st[i].name_ = a.str(js["name"]);
    st[i].message_ = a.str(js["message"]);
    st[i].hardware_id_ = a.str(js["hardware_id"]);
    auto& kv = a.values.emplace_back(js["values"].size());
    for (std::size_t k = 0; k < kv.size(); ++k) {
      kv[k].key_ = a.str(js["values"][k]["key"]);
      kv[k].value_ = a.str(js["values"][k]["value"]);
    }
    borrow(st[i].values_, kv);
  }
  borrow(m.status_, st);
}

json header(int sec, unsigned nanosec, const std::string& frame) {
  return {{"stamp", {{"sec", sec}, {"nanosec", nanosec}}}, {"frame_id", frame}};
}

json hypothesis(const std::string& cls, double score, double x) {
  json cov = json::array();
  for (int c = 0; c < 36; ++c) cov.push_back(c % 7 == 0 ? 0.25 * (c + 1) : 0.0);
  return {{"hypothesis", {{"class_id", cls}, {"score", score}}},
          {"pose",
           {{"pose",
             {{"position", {{"x", x}, {"y", -x}, {"z", 0.5}}},
              {"orientation", {{"x", 0.0}, {"y", 0.0}, {"z", 0.0}, {"w", 1.0}}}}},
            {"covariance", cov}}}};
}

// Sample messages of every type, with odd string lengths and empty sequences so that
// alignment and padding are exercised.
std::vector<std::pair<std::string, json>> samples() {
  std::vector<std::pair<std::string, json>> s;
  std::vector<int> rgb;
  for (int i = 0; i < 2 * 3 * 3; ++i) rgb.push_back((i * 37) % 256);
  s.push_back({"sensor_msgs/Image",
               {{"header", header(1700000000, 123456789, "camera_optical")},
                {"height", 2},
                {"width", 3},
                {"encoding", "rgb8"},
                {"is_bigendian", 0},
                {"step", 9},
                {"data", rgb}}});
  s.push_back({"sensor_msgs/Image",
               {{"header", header(-3, 0, "")},
                {"height", 0},
                {"width", 0},
                {"encoding", "mono8"},
                {"is_bigendian", 1},
                {"step", 0},
                {"data", json::array()}}});
  s.push_back({"geometry_msgs/Twist",
               {{"linear", {{"x", 1.5}, {"y", -0.0}, {"z", 1e-300}}},
                {"angular", {{"x", 0.0}, {"y", 3.25}, {"z", -0.125}}}}});
  s.push_back({"geometry_msgs/TwistStamped",
               {{"header", header(7, 999999999, "base_link")},
                {"twist",
                 {{"linear", {{"x", 0.5}, {"y", 0.0}, {"z", 0.0}}},
                  {"angular", {{"x", 0.0}, {"y", 0.0}, {"z", 0.75}}}}}}});
  s.push_back({"vision_msgs/Detection2DArray",
               {{"header", header(12, 34, "cam")},
                {"detections",
                 {{{"header", header(12, 34, "cam")},
                   {"results", {hypothesis("car", 0.75, 1.0), hypothesis("pedestrian", 0.5, 2.0)}},
                   {"bbox",
                    {{"center", {{"position", {{"x", 10.5}, {"y", 20.25}}}, {"theta", 0.1}}},
                     {"size_x", 4.0},
                     {"size_y", 8.0}}},
                   {"id", "7"}},
                  {{"header", header(0, 1, "a")},
                   {"results", json::array()},
                   {"bbox",
                    {{"center", {{"position", {{"x", 0.0}, {"y", 0.0}}}, {"theta", 0.0}}},
                     {"size_x", 0.0},
                     {"size_y", 0.0}}},
                   {"id", ""}}}}}});
  s.push_back({"vision_msgs/Detection2DArray",
               {{"header", header(5, 6, "empty")}, {"detections", json::array()}}});
  s.push_back({"diagnostic_msgs/DiagnosticArray",
               {{"header", header(99, 1000, "red")},
                {"status",
                 {{{"level", 0},
                   {"name", "red: drive"},
                   {"message", "ok"},
                   {"hardware_id", "red"},
                   {"values",
                    {{{"key", "jobs"}, {"value", "120"}}, {{"key", "miss_rate"}, {"value", "0"}}}}},
                  {{"level", 2},
                   {"name", "red: node"},
                   {"message", "sensor silent"},
                   {"hardware_id", ""},
                   {"values", json::array()}}}}}});
  return s;
}

const dds_topic_descriptor_t* descriptor(const std::string& type) {
  if (type == "sensor_msgs/Image") return &sensor_msgs_msg_dds__Image__desc;
  if (type == "geometry_msgs/Twist") return &geometry_msgs_msg_dds__Twist__desc;
  if (type == "geometry_msgs/TwistStamped") return &geometry_msgs_msg_dds__TwistStamped__desc;
  if (type == "vision_msgs/Detection2DArray") return &vision_msgs_msg_dds__Detection2DArray__desc;
  if (type == "diagnostic_msgs/DiagnosticArray")
    return &diagnostic_msgs_msg_dds__DiagnosticArray__desc;
  return nullptr;
}

// Fills a sample of `type` from `j` into `storage` (zeroed, large enough).
void fill_any(Arena& a, const std::string& type, const json& j, void* storage) {
  if (type == "sensor_msgs/Image") fill(a, j, *static_cast<Image*>(storage));
  if (type == "geometry_msgs/Twist") fill(a, j, *static_cast<Twist*>(storage));
  if (type == "geometry_msgs/TwistStamped") fill(a, j, *static_cast<TwistStamped*>(storage));
  if (type == "vision_msgs/Detection2DArray") fill(a, j, *static_cast<Detection2DArray*>(storage));
  if (type == "diagnostic_msgs/DiagnosticArray")
    fill(a, j, *static_cast<DiagnosticArray*>(storage));
}

std::string to_hex(const std::vector<std::uint8_t>& b) {
  static const char* d = "0123456789abcdef";
  std::string s;
  for (std::uint8_t x : b) {
    s += d[x >> 4];
    s += d[x & 15];
  }
  return s;
}

std::vector<std::uint8_t> from_hex(const std::string& s) {
  std::vector<std::uint8_t> b;
  for (std::size_t i = 0; i + 1 < s.size(); i += 2)
    b.push_back(static_cast<std::uint8_t>(std::stoi(s.substr(i, 2), nullptr, 16)));
  return b;
}

// Cyclone pads a serialized sample to a multiple of 4 and records the pad count in the
// encapsulation options (XTypes 7.6.3.1.2); both are allowed to differ from a serializer
// that does not pad. Returns the body without that padding.
std::vector<std::uint8_t> unpadded(const std::vector<std::uint8_t>& b) {
  if (b.size() < 4) return b;
  const std::size_t pad = b[3] & 3U;
  std::vector<std::uint8_t> body(b.begin() + 4, b.end() - static_cast<std::ptrdiff_t>(pad));
  body.insert(body.begin(), {b[0], b[1], 0, 0});
  return body;
}

TEST(DdsWire, EveryTypeMatchesTheIndependentRos2SerializerBothWays) {
  if (std::system("command -v node >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "node is not installed: the independent serializer cannot run";
  const std::string npm = RED_NPM_DIR;
  ASSERT_TRUE(std::ifstream(npm + "/@foxglove/rosmsg2-serialization/package.json").good())
      << "the npm oracle is not installed in " << npm << ": run scripts/npm-oracle.sh";

  auto domain = Domain::open(test_domain(), "");
  ASSERT_TRUE(domain.has_value()) << domain.error().to_string();
  const auto cases = samples();
  std::vector<std::vector<std::uint8_t>> ours;
  std::vector<std::unique_ptr<CdrCodec>> codecs;
  Arena arena;
  json request = {{"cases", json::array()}};
  for (const auto& [type, msg] : cases) {
    auto codec = CdrCodec::make((*domain)->participant(), descriptor(type));
    ASSERT_TRUE(codec.has_value()) << codec.error().to_string();
    std::vector<std::uint8_t> storage(descriptor(type)->m_size, 0);
    fill_any(arena, type, msg, storage.data());
    auto bytes = (*codec)->serialize(storage.data());
    ASSERT_TRUE(bytes.has_value()) << bytes.error().to_string();
    ours.push_back(*bytes);
    codecs.push_back(std::move(*codec));
    request["cases"].push_back({{"type", type}, {"msg", msg}, {"cdr", to_hex(*bytes)}});
  }
  const json reply = run_node_json(RED_SOURCE_DIR "/tests/dds/oracle.js", npm, request);
  ASSERT_EQ(reply["results"].size(), cases.size()) << reply.dump();
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto& [type, msg] = cases[i];
    SCOPED_TRACE(type + " #" + std::to_string(i));
    const std::vector<std::uint8_t> theirs = from_hex(reply["results"][i]["cdr"]);
    // 1. Our bytes are theirs (CDR little endian, encapsulation 0x0001).
    ASSERT_GE(ours[i].size(), 4U);
    EXPECT_EQ(ours[i][0], 0x00);
    EXPECT_EQ(ours[i][1], 0x01);
    EXPECT_EQ(to_hex(unpadded(ours[i])), to_hex(unpadded(theirs)));
    // 2. They decode our bytes to the message we meant.
    EXPECT_EQ(reply["results"][i]["decoded"], msg) << reply["results"][i]["decoded"].dump();
    // 3. We decode their bytes to the same message: re-serialized, it is our bytes again.
    std::vector<std::uint8_t> decoded(descriptor(type)->m_size, 0);
    auto ok = codecs[i]->deserialize(theirs, decoded.data());
    ASSERT_TRUE(ok.has_value()) << ok.error().to_string();
    auto again = codecs[i]->serialize(decoded.data());
    ASSERT_TRUE(again.has_value());
    EXPECT_EQ(to_hex(*again), to_hex(ours[i]));
    if (type == "sensor_msgs/Image") {
      const auto& img = *reinterpret_cast<const Image*>(decoded.data());
      EXPECT_EQ(img.height_, msg["height"].get<std::uint32_t>());
      EXPECT_STREQ(img.encoding_, msg["encoding"].get<std::string>().c_str());
      EXPECT_EQ(HeaderValue::from(img.header_).frame_id, msg["header"]["frame_id"]);
      EXPECT_EQ(img.data_._length, msg["data"].size());
    }
    dds_sample_free(decoded.data(), descriptor(type), DDS_FREE_CONTENTS);
  }
}

}  // namespace
}  // namespace red::dds
