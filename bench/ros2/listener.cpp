/// \file
/// `red_ros2_listener`: the end-to-end probe of the ROS 2 case study (bench/ros2.sh,
/// docs/BENCHMARKS.md). It subscribes to the camera topic (to learn which frames were sent)
/// and to the output topics of one frame's work, and measures per frame the response time
/// as a subscriber sees it: header stamp (the camera's wall clock when sent) -> the last of
/// the frame's outputs received. A frame is met when every output topic delivered a sample
/// with its stamp within the deadline; missing or late, it is missed. Prints one JSON line:
/// frames, complete, met, miss_rate, response_ms, camera_samples, unknown_stamps (output
/// stamps the camera never sent), per matched topic its samples and frames, and the samples
/// of the topics only counted (kinds twist, diagnostics). --shm: through shared memory.
///
///     red_ros2_listener --domain 7 --deadline-ms 80 --warmup 1
///         --topic image:/red/perceive/L --topic detections:/red/perceive/O

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "red/dds/messages.hpp"
#include "red/dds/ros.hpp"

namespace {

using red::dds::Detection2DArray;
using red::dds::Header;
using red::dds::Image;
using red::dds::TwistStamped;

// A stamp as nanoseconds since the epoch (the key that matches outputs to frames).
std::int64_t stamp_ns(const Header& h) {
  return static_cast<std::int64_t>(h.stamp_.sec_) * 1'000'000'000 +
         static_cast<std::int64_t>(h.stamp_.nanosec_);
}

std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (pos - static_cast<double>(lo));
}

struct Topic {
  std::string name;
  const dds_topic_descriptor_t* desc = nullptr;
  dds_entity_t reader = 0;
  std::uint64_t samples = 0;
  bool sensor_qos = false;  // best effort, as the camera's frames (kind `frames`)
};

// The header of a sample of `desc` (every type here has one).
const Header& header_of(const dds_topic_descriptor_t* desc, const void* sample) {
  if (desc == &sensor_msgs_msg_dds__Image__desc) return static_cast<const Image*>(sample)->header_;
  if (desc == &std_msgs_msg_dds__Header__desc) return *static_cast<const Header*>(sample);
  if (desc == &geometry_msgs_msg_dds__TwistStamped__desc)
    return static_cast<const TwistStamped*>(sample)->header_;
  return static_cast<const Detection2DArray*>(sample)->header_;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"End-to-end probe of the ROS 2 case study: frame stamp -> outputs received"};
  int domain = 0;
  double deadline_ms = 0, warmup_s = 1.0, idle_s = 2.0, timeout_s = 600.0;
  std::string camera = "/camera/image_raw";
  std::string camera_stamps;
  std::string config_file;
  bool shm = false;
  std::vector<std::string> specs;
  app.add_option("--domain", domain, "DDS domain id")->check(CLI::Range(0, 232));
  app.add_option("--deadline-ms", deadline_ms, "A frame's deadline (ms after its stamp)")
      ->required()
      ->check(CLI::PositiveNumber);
  app.add_option("--warmup", warmup_s, "Leave out frames of the first seconds")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--camera", camera, "The camera topic (frames sent)");
  app.add_option("--camera-stamps", camera_stamps,
                 "Count the frames sent from this topic of their headers (red camera "
                 "--stamps-topic) instead of subscribing to the frames themselves");
  app.add_option("--topic", specs,
                 "KIND:/topic, KIND = image | twist_stamped | detections | frames (an Image "
                 "topic with the sensor-data QoS: the camera's own frames, to time the transport) "
                 "| twist | diagnostics (only counted)")
      ->required();
  app.add_option("--config", config_file, "Cyclone DDS XML configuration file (default: loopback)")
      ->check(CLI::ExistingFile);
  app.add_flag("--shm", shm,
               "Receive through iceoryx shared memory (needs a running iox-roudi; red node --shm)");
  app.add_option("--idle", idle_s, "Stop once the camera has been silent this long")
      ->check(CLI::PositiveNumber);
  app.add_option("--timeout", timeout_s, "Stop after this long in any case")
      ->check(CLI::PositiveNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return e.get_exit_code() == 0 ? 0 : 2;
  }
  std::vector<Topic> topics;   // one sample per frame, matched by stamp
  std::vector<Topic> counted;  // samples only counted
  for (const std::string& s : specs) {
    const auto colon = s.find(':');
    const std::string kind = s.substr(0, colon),
                      name = colon == std::string::npos ? "" : s.substr(colon + 1);
    Topic t{name, nullptr, 0, 0};
    if (kind == "image" || kind == "frames") t.desc = &sensor_msgs_msg_dds__Image__desc;
    t.sensor_qos = kind == "frames";
    if (kind == "twist_stamped") t.desc = &geometry_msgs_msg_dds__TwistStamped__desc;
    if (kind == "detections") t.desc = &vision_msgs_msg_dds__Detection2DArray__desc;
    // Types without a header (Twist) or not per frame (DiagnosticArray): only counted.
    const bool count_only = kind == "twist" || kind == "diagnostics";
    if (kind == "twist") t.desc = &geometry_msgs_msg_dds__Twist__desc;
    if (kind == "diagnostics") t.desc = &diagnostic_msgs_msg_dds__DiagnosticArray__desc;
    if (t.desc == nullptr || !red::dds::valid_ros_topic(name)) {
      std::cerr << "red_ros2_listener: --topic '" << s
                << "': expected image|twist_stamped|detections|frames|twist|diagnostics:"
                   "/absolute/topic\n";
      return 2;
    }
    (count_only ? counted : topics).push_back(t);
  }
  std::string config;
  if (!config_file.empty()) {
    std::ifstream f(config_file);
    std::stringstream ss;
    ss << f.rdbuf();
    config = ss.str();
  }
  if (shm) {
    if (auto up = red::dds::roudi_running(); !up) {
      std::cerr << "red_ros2_listener: " << up.error().to_string() << '\n';
      return 2;
    }
  }
  auto dom = red::dds::Domain::open(domain, config, shm);
  if (!dom) {
    std::cerr << "red_ros2_listener: " << dom.error().to_string() << '\n';
    return 1;
  }
  const dds_entity_t pp = (*dom)->participant();
  const auto reader = [pp](const dds_topic_descriptor_t* desc, const std::string& name,
                           red::dds::EndpointQos q) {
    q.depth = 1000;  // never lose a sample to history depth while measuring
    const dds_entity_t t =
        dds_create_topic(pp, desc, red::dds::dds_topic_name(name).c_str(), nullptr, nullptr);
    dds_qos_t* qos = red::dds::make_qos(q);
    const dds_entity_t r = t < 0 ? t : dds_create_reader(pp, t, qos, nullptr);
    dds_delete_qos(qos);
    return r;
  };
  const red::dds::QosSettings qos;
  Topic cam = camera_stamps.empty()
                  ? Topic{camera, &sensor_msgs_msg_dds__Image__desc,
                          reader(&sensor_msgs_msg_dds__Image__desc, camera, qos.input), 0}
                  : Topic{camera_stamps, &std_msgs_msg_dds__Header__desc,
                          reader(&std_msgs_msg_dds__Header__desc, camera_stamps, qos.output), 0};
  for (Topic& t : topics) t.reader = reader(t.desc, t.name, t.sensor_qos ? qos.input : qos.output);
  for (Topic& t : counted) t.reader = reader(t.desc, t.name, qos.output);
  const dds_entity_t ws = dds_create_waitset(pp);
  for (Topic* t : [&] {
         std::vector<Topic*> all{&cam};
         for (Topic& x : topics) all.push_back(&x);
         for (Topic& x : counted) all.push_back(&x);
         return all;
       }()) {
    if (t->reader < 0) {
      std::cerr << "red_ros2_listener: cannot subscribe to " << t->name << ": "
                << dds_strretcode(t->reader) << '\n';
      return 1;
    }
    dds_set_status_mask(t->reader, DDS_DATA_AVAILABLE_STATUS);
    dds_waitset_attach(ws, t->reader, 0);
  }

  // Per frame stamp: when each output topic delivered it (wall clock, ns).
  std::map<std::int64_t, std::vector<std::optional<std::int64_t>>> frames;
  std::set<std::int64_t> sent;  // stamps seen on the camera's topic
  std::optional<std::int64_t> first_frame;
  auto last_frame_at = std::chrono::steady_clock::now();
  const auto start = last_frame_at;
  void* samples[16] = {};
  dds_sample_info_t infos[16];
  const auto take = [&](Topic& t, int index) {
    for (;;) {
      std::fill(std::begin(samples), std::end(samples), nullptr);
      const dds_return_t n = dds_take(t.reader, samples, infos, 16, 16);
      if (n <= 0) return;
      const std::int64_t now = wall_ns();
      for (dds_return_t i = 0; i < n; ++i) {
        if (!infos[i].valid_data) continue;
        ++t.samples;
        const std::int64_t stamp = stamp_ns(header_of(t.desc, samples[i]));
        if (index < 0) {
          sent.insert(stamp);
          if (!first_frame) first_frame = stamp;
          frames.try_emplace(stamp, topics.size());
          last_frame_at = std::chrono::steady_clock::now();
        } else if (auto it = frames.find(stamp); it != frames.end()) {
          auto& at = it->second[static_cast<std::size_t>(index)];
          if (!at) at = now;
        } else {
          // The camera sample was lost to this probe (best effort) but the node got it.
          frames.try_emplace(stamp, topics.size()).first->second[static_cast<std::size_t>(index)] =
              now;
        }
      }
      dds_return_loan(t.reader, samples, n);
    }
  };
  for (;;) {
    dds_waitset_wait(ws, nullptr, 0, DDS_MSECS(50));
    take(cam, -1);
    for (std::size_t i = 0; i < topics.size(); ++i) take(topics[i], static_cast<int>(i));
    for (Topic& t : counted)
      for (dds_return_t n = 0;;) {
        std::fill(std::begin(samples), std::end(samples), nullptr);
        if ((n = dds_take(t.reader, samples, infos, 16, 16)) <= 0) break;
        for (dds_return_t i = 0; i < n; ++i) t.samples += infos[i].valid_data ? 1 : 0;
        dds_return_loan(t.reader, samples, n);
      }
    const auto now = std::chrono::steady_clock::now();
    if (first_frame && now - last_frame_at > std::chrono::duration<double>(idle_s)) break;
    if (now - start > std::chrono::duration<double>(timeout_s)) break;
  }

  const std::int64_t deadline = static_cast<std::int64_t>(deadline_ms * 1e6);
  const std::int64_t from = first_frame.value_or(0) + static_cast<std::int64_t>(warmup_s * 1e9);
  std::uint64_t frames_counted = 0, complete = 0, met = 0, unknown = 0;
  std::vector<double> response_ms;
  std::vector<std::uint64_t> per_topic(topics.size(), 0);
  for (const auto& [stamp, at] : frames) {
    // Outputs carrying a stamp the camera never sent (whatever the warm-up): a wrong header,
    // or a camera frame lost to this probe.
    if (sent.count(stamp) == 0) ++unknown;
    if (stamp < from) continue;
    ++frames_counted;
    std::int64_t last = 0;
    bool all = true;
    for (std::size_t i = 0; i < at.size(); ++i) {
      if (at[i]) {
        ++per_topic[i];
        last = std::max(last, *at[i]);
      } else {
        all = false;
      }
    }
    if (!all) continue;
    ++complete;
    response_ms.push_back(static_cast<double>(last - stamp) / 1e6);
    if (last - stamp <= deadline) ++met;
  }
  double mean = 0;
  for (double r : response_ms) mean += r;
  if (!response_ms.empty()) mean /= static_cast<double>(response_ms.size());
  nlohmann::json out = {
      {"frames", frames_counted},
      {"complete", complete},
      {"met", met},
      {"miss_rate", frames_counted == 0
                        ? 0.0
                        : 1.0 - static_cast<double>(met) / static_cast<double>(frames_counted)},
      {"response_ms",
       {{"mean", mean},
        {"p50", percentile(response_ms, 0.5)},
        {"p90", percentile(response_ms, 0.9)},
        {"p99", percentile(response_ms, 0.99)}}},
      {"camera_samples", cam.samples},
      {"unknown_stamps", unknown}};
  for (std::size_t i = 0; i < topics.size(); ++i)
    out["topics"][topics[i].name] = {{"samples", topics[i].samples}, {"frames", per_topic[i]}};
  for (const Topic& t : counted) out["counted"][t.name] = t.samples;
  std::cout << out.dump() << std::endl;
  dds_delete(ws);
  return 0;
}
