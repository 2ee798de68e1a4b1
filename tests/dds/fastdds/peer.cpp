// A ROS 2 Humble user's side of the wire, without ROS 2: an eProsima Fast DDS program whose
// types fastddsgen generated from RED's IDL (bridges/dds/idl). It publishes camera frames to
// `red node` over RTPS/UDP on loopback and receives every output type (docs/ROS2.md).
//
//     red_fastdds_peer DOMAIN FRAMES RATE_HZ LINGER_S [ENCLAVE_DIR]   -> JSON report on stdout
//
// With ENCLAVE_DIR (an SROS2 enclave: cert.pem, key.pem, identity_ca.cert.pem,
// permissions_ca.cert.pem, governance.p7s, permissions.p7s) the participant uses DDS Security
// with Fast DDS's built-in plugins, as rmw_fastrtps_cpp sets them up from ROS 2's keystore.

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <fastdds/dds/log/StdoutErrConsumer.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "diagnostic_msgsPubSubTypes.h"
#include "geometry_msgsPubSubTypes.h"
#include "sensor_msgsPubSubTypes.h"
#include "vision_msgsPubSubTypes.h"

using namespace eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::IPLocator;
using eprosima::fastrtps::rtps::Locator_t;

namespace {

using Stamp = std::pair<int32_t, uint32_t>;

struct Output {
  DataReader* reader = nullptr;
  std::function<bool(DataReader*, Stamp&, double&)> take;  // false when no sample
  std::uint64_t count = 0, matched_stamps = 0;
  std::vector<double> latency_ms;  // received (wall clock) - frame stamp
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

template <typename T>
std::function<bool(DataReader*, Stamp&, double&)> taker(std::function<Stamp(const T&)> stamp) {
  return [stamp](DataReader* r, Stamp& s, double& received_s) {
    T msg;
    SampleInfo info;
    if (r->take_next_sample(&msg, &info) != ReturnCode_t::RETCODE_OK) return false;
    s = info.valid_data ? stamp(msg) : Stamp{-1, 0};
    // When the sample arrived (wall clock), not when it was taken.
    received_s = info.reception_timestamp.seconds() + info.reception_timestamp.nanosec() * 1e-9;
    return true;
  };
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5 && argc != 6) {
    std::cerr << "usage: red_fastdds_peer DOMAIN FRAMES RATE_HZ LINGER_S [ENCLAVE_DIR]\n";
    return 2;
  }
  // Fast DDS's log (e.g. security errors) to stderr: stdout holds the JSON report only.
  Log::ClearConsumers();
  Log::RegisterConsumer(std::make_unique<StdoutErrConsumer>());
  const int domain = std::atoi(argv[1]);
  const int frames = std::atoi(argv[2]);
  const double rate = std::atof(argv[3]);
  const double linger = std::atof(argv[4]);

  // UDP on loopback only, unicast discovery to the RTPS ports of participants 0..31 on
  // 127.0.0.1 (where red node's loopback configuration listens), participant id 40.
  DomainParticipantQos pq;
  pq.name("red_fastdds_peer");
  pq.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back("127.0.0.1");
  pq.transport().user_transports.push_back(udp);
  pq.wire_protocol().participant_id = 40;
  if (argc == 6) {
    const std::string dir = std::string("file://") + argv[5] + "/";  // Fast DDS: file://
    const std::vector<std::pair<std::string, std::string>> props = {
        {"dds.sec.auth.plugin", "builtin.PKI-DH"},
        {"dds.sec.auth.builtin.PKI-DH.identity_ca", dir + "identity_ca.cert.pem"},
        {"dds.sec.auth.builtin.PKI-DH.identity_certificate", dir + "cert.pem"},
        {"dds.sec.auth.builtin.PKI-DH.private_key", dir + "key.pem"},
        {"dds.sec.access.plugin", "builtin.Access-Permissions"},
        {"dds.sec.access.builtin.Access-Permissions.permissions_ca",
         dir + "permissions_ca.cert.pem"},
        {"dds.sec.access.builtin.Access-Permissions.governance", dir + "governance.p7s"},
        {"dds.sec.access.builtin.Access-Permissions.permissions", dir + "permissions.p7s"},
        {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"}};
    for (const auto& [k, v] : props) pq.properties().properties().emplace_back(k, v);
    // The handshake's initiator picks the key agreement: Fast DDS 2.9 picks DH+MODP-2048-256,
    // whose public key Cyclone DDS 0.10 cannot read ("Failed to convert octet sequence to
    // ASN1 integer"; eProsima/Fast-DDS#3802, eclipse-cyclonedds/cyclonedds#701), Cyclone
    // picks ECDH (prime256v1), which both read. Cyclone initiates when this participant's
    // GUID is the higher; with security, a GUID's first 48 bits are a hash of the
    // certificate's subject, so the enclave's name decides (the tests pick names that work).
    // RED_PEER_GOVERNANCE=FILE: another governance for this peer (the test's intruder: one
    // whose own access control is off, so that it does write where its permissions say it
    // may not, and the node's side of access control is what refuses it).
    if (const char* g = std::getenv("RED_PEER_GOVERNANCE"))
      for (auto& p : pq.properties().properties())
        if (p.name() == "dds.sec.access.builtin.Access-Permissions.governance")
          p.value() = std::string("file://") + g;
  }
  for (int i = 0; i < 32; ++i) {
    Locator_t peer;
    IPLocator::setIPv4(peer, 127, 0, 0, 1);
    peer.port = static_cast<uint32_t>(7400 + 250 * domain + 10 + 2 * i);
    pq.wire_protocol().builtin.initialPeersList.push_back(peer);
  }
  DomainParticipant* pp = DomainParticipantFactory::get_instance()->create_participant(
      static_cast<DomainId_t>(domain), pq);
  if (pp == nullptr) {
    std::cerr << "red_fastdds_peer: cannot create a participant\n";
    return 1;
  }
  TypeSupport image(new sensor_msgs::msg::dds_::Image_PubSubType());
  TypeSupport twist(new geometry_msgs::msg::dds_::Twist_PubSubType());
  TypeSupport twist_stamped(new geometry_msgs::msg::dds_::TwistStamped_PubSubType());
  TypeSupport detections(new vision_msgs::msg::dds_::Detection2DArray_PubSubType());
  TypeSupport diagnostics(new diagnostic_msgs::msg::dds_::DiagnosticArray_PubSubType());
  for (TypeSupport* t : {&image, &twist, &twist_stamped, &detections, &diagnostics})
    t->register_type(pp);

  Publisher* pub = pp->create_publisher(PUBLISHER_QOS_DEFAULT);
  Subscriber* sub = pp->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
  Topic* camera = pp->create_topic("rt/camera/image_raw", image.get_type_name(), TOPIC_QOS_DEFAULT);
  DataWriterQos wq = DATAWRITER_QOS_DEFAULT;
  wq.reliability().kind = BEST_EFFORT_RELIABILITY_QOS;  // ROS 2's sensor-data profile
  wq.history().kind = KEEP_LAST_HISTORY_QOS;
  wq.history().depth = 5;
  wq.durability().kind = VOLATILE_DURABILITY_QOS;
  DataWriter* writer = pub->create_datawriter(camera, wq);
  if (writer == nullptr) {
    std::cerr << "red_fastdds_peer: cannot create the camera writer (not permitted?)\n";
    return 1;
  }

  DataReaderQos rq = DATAREADER_QOS_DEFAULT;
  rq.reliability().kind = RELIABLE_RELIABILITY_QOS;
  rq.history().kind = KEEP_LAST_HISTORY_QOS;
  rq.history().depth = 200;
  rq.durability().kind = VOLATILE_DURABILITY_QOS;
  std::map<std::string, Output> outputs;
  const auto reader = [&](const std::string& topic, TypeSupport& t) {
    Topic* tp = pp->create_topic("rt" + topic, t.get_type_name(), TOPIC_QOS_DEFAULT);
    DataReader* r = sub->create_datareader(tp, rq);
    if (r == nullptr) {
      std::cerr << "red_fastdds_peer: cannot create a reader of " << topic << "\n";
      std::exit(1);
    }
    return r;
  };
  const auto image_stamp = [](const sensor_msgs::msg::dds_::Image_& m) {
    return Stamp{m.header_().stamp_().sec_(), m.header_().stamp_().nanosec_()};
  };
  outputs["/red/drive/L"] = {reader("/red/drive/L", image),
                             taker<sensor_msgs::msg::dds_::Image_>(image_stamp)};
  outputs["/red/drive/S"] = {reader("/red/drive/S", image),
                             taker<sensor_msgs::msg::dds_::Image_>(image_stamp)};
  outputs["/red/drive/C"] = {
      reader("/red/drive/C", twist),
      taker<geometry_msgs::msg::dds_::Twist_>([](const geometry_msgs::msg::dds_::Twist_&) {
        return Stamp{-2, 0};  // no header
      })};
  outputs["/red/drive/C/stamped"] = {
      reader("/red/drive/C/stamped", twist_stamped),
      taker<geometry_msgs::msg::dds_::TwistStamped_>(
          [](const geometry_msgs::msg::dds_::TwistStamped_& m) {
            return Stamp{m.header_().stamp_().sec_(), m.header_().stamp_().nanosec_()};
          })};
  outputs["/red/detect/O"] = {
      reader("/red/detect/O", detections),
      taker<vision_msgs::msg::dds_::Detection2DArray_>(
          [](const vision_msgs::msg::dds_::Detection2DArray_& m) {
            return Stamp{m.header_().stamp_().sec_(), m.header_().stamp_().nanosec_()};
          })};
  DataReader* diag = reader("/diagnostics", diagnostics);
  nlohmann::json diag_values = nlohmann::json::object();
  std::uint64_t diag_count = 0;

  std::set<Stamp> sent;
  const auto poll = [&] {
    for (auto& [name, o] : outputs) {
      Stamp s;
      double received_s = 0;
      while (o.take(o.reader, s, received_s)) {
        if (s.first == -1) continue;
        ++o.count;
        if (sent.count(s) != 0) {
          ++o.matched_stamps;
          o.latency_ms.push_back((received_s - s.first - s.second * 1e-9) * 1e3);
        }
      }
    }
    diagnostic_msgs::msg::dds_::DiagnosticArray_ d;
    SampleInfo info;
    while (diag->take_next_sample(&d, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      ++diag_count;
      for (const auto& st : d.status_())
        for (const auto& kv : st.values_()) diag_values[st.name_() + "/" + kv.key_()] = kv.value_();
    }
  };

  // Wait for red node's reader of the camera topic, then publish.
  const auto t0 = std::chrono::steady_clock::now();
  PublicationMatchedStatus ms;
  bool matched = false;
  // RED_PEER_FORCE=S: wait S seconds at most, then write the frames even unmatched (a peer
  // the node must refuse: what it wrote is then "sent" and the node must release none).
  const char* force = std::getenv("RED_PEER_FORCE");
  const double wait_s = force != nullptr ? std::atof(force) : 20.0;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(wait_s)) {
    writer->get_publication_matched_status(ms);
    if (ms.current_count > 0) {
      matched = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  const uint32_t w = 64, h = 48;
  const auto period = std::chrono::nanoseconds{static_cast<int64_t>(1e9 / rate)};
  auto next = std::chrono::steady_clock::now();
  for (int k = 0; (matched || force != nullptr) && k < frames; ++k) {
    std::this_thread::sleep_until(next);
    next += period;
    sensor_msgs::msg::dds_::Image_ img;
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                        std::chrono::system_clock::now().time_since_epoch())
                        .count();
    img.header_().stamp_().sec_(static_cast<int32_t>(ns / 1000000000));
    img.header_().stamp_().nanosec_(static_cast<uint32_t>(ns % 1000000000));
    img.header_().frame_id_("fastdds_camera");
    img.height_(h);
    img.width_(w);
    img.encoding_("bgr8");
    img.step_(w * 3);
    std::vector<uint8_t> data(static_cast<size_t>(w * h * 3));
    for (size_t i = 0; i < data.size(); ++i)
      data[i] = static_cast<uint8_t>((i + static_cast<size_t>(k) * 3) % 251);
    img.data_(data);
    sent.insert({img.header_().stamp_().sec_(), img.header_().stamp_().nanosec_()});
    writer->write(&img);
    poll();
  }
  const auto end =
      std::chrono::steady_clock::now() +
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(linger));
  while (std::chrono::steady_clock::now() < end) {
    poll();
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }
  poll();
  nlohmann::json report = {{"matched", matched},
                           {"sent", sent.size()},
                           {"outputs", nlohmann::json::object()},
                           {"diagnostics", diag_count},
                           {"diagnostic_values", diag_values}};
  for (const auto& [name, o] : outputs)
    report["outputs"][name] = {{"count", o.count},
                               {"matched_stamps", o.matched_stamps},
                               {"latency_ms_p50", percentile(o.latency_ms, 0.5)},
                               {"latency_ms_p99", percentile(o.latency_ms, 0.99)}};
  std::cout << report.dump() << std::endl;
  pp->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(pp);
  return 0;
}
