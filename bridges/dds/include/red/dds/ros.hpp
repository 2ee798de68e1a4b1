#pragma once
/// \file
/// ROS 2 conventions on plain DDS (docs/ROS2.md): topic names (`/a/b` is the DDS topic `rt/a/b`),
/// `--remap from:=to`, the QoS ROS 2 uses (sensor data in, reliable results out) and a
/// loopback-only Cyclone DDS configuration. The participant of a process lives in Domain.

#include <dds/dds.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "red/core/expected.hpp"

namespace red::dds {

/// The DDS topic of a ROS 2 topic: "/camera/image_raw" -> "rt/camera/image_raw".
std::string dds_topic_name(std::string_view ros_topic);

/// True for a valid absolute ROS 2 topic name ("/a/b_1"; no "//", no trailing "/").
bool valid_ros_topic(std::string_view name);

/// ROS 2-style remapping rules (`from:=to`), applied to full topic names.
class Remaps {
 public:
  /// Adds "from:=to"; Error names the rule when it is malformed or not a valid topic.
  Expected<bool> add(const std::string& rule);
  /// The topic `name` maps to (itself when no rule names it).
  [[nodiscard]] std::string apply(const std::string& name) const;

 private:
  std::map<std::string, std::string> rules_;
};

/// Reliability, history depth and durability of one kind of endpoint.
struct EndpointQos {
  bool reliable = true;
  int depth = 10;
  bool transient_local = false;
};

/// The QoS of the node's endpoints (docs/ROS2.md): inputs as ROS 2's sensor-data profile, outputs
/// reliable, keep last 10, volatile.
struct QosSettings {
  EndpointQos input{false, 5, false};
  EndpointQos output{true, 10, false};
};

/// Reads a QoS override file (YAML: `input:`/`output:` with `reliability: best_effort |
/// reliable`, `depth: N`, `durability: volatile | transient_local`); keys left out keep
/// their defaults. Errors name the file, the line and the problem.
Expected<QosSettings> load_qos_file(const std::string& path);

/// A new dds_qos_t for `q` (caller deletes it with dds_delete_qos).
dds_qos_t* make_qos(const EndpointQos& q);

/// The loopback-only Cyclone DDS configuration: interface `lo`, no multicast, unicast
/// discovery to 127.0.0.1, so that nothing leaves the machine; fragments of 60000 B in
/// datagrams of up to 65000 B (loopback's MTU is 64 KiB), so that a large image crosses in
/// few datagrams.
std::string loopback_config();

/// The Unix socket of iceoryx's daemon RouDi (iceoryx 2.0: one RouDi per host, at this
/// fixed path).
inline constexpr const char* kRoudiSocket = "/tmp/roudi";

/// Whether RouDi, the iceoryx daemon that Cyclone DDS's shared memory needs, is running:
/// its socket accepts a connection. Error says why not and how to start it. Cyclone does
/// not fail when RouDi is missing: iceoryx waits for it and then aborts the process, hence
/// this check before a domain with shared memory is opened.
Expected<bool> roudi_running();

/// A Cyclone DDS configuration fragment that turns on shared memory (iceoryx): appended to a
/// configuration (Cyclone reads a comma-separated list of XML sources, later ones override),
/// it makes every reader and writer whose QoS allows it (keep last, volatile or transient
/// local, no deadline, automatic liveliness) exchange samples with the other processes of
/// the host through RouDi's shared memory instead of UDP. Samples of types that are not of
/// fixed size (Image: strings, sequences) are serialized into the iceoryx chunk.
std::string shared_memory_config();

/// A process's DDS domain and participant. `config` is Cyclone DDS XML (or a file://
/// URI); empty means the loopback configuration. With `shared_memory`, shared_memory_config()
/// is added to it, after checking that RouDi runs (roudi_running()). With `enclave`, the
/// participant has DDS Security (security.hpp; not with shared memory). Not copyable.
struct Enclave;

class Domain {
 public:
  /// Error when RouDi is wanted and not running, or when the domain or the participant cannot
  /// be created (names the domain, and the enclave when DDS Security refused it).
  static Expected<std::unique_ptr<Domain>> open(int domain_id, const std::string& config,
                                                bool shared_memory = false,
                                                const Enclave* enclave = nullptr);
  ~Domain();
  Domain(const Domain&) = delete;
  Domain& operator=(const Domain&) = delete;

  [[nodiscard]] dds_entity_t participant() const noexcept { return participant_; }
  [[nodiscard]] int id() const noexcept { return id_; }

 private:
  Domain(int id, dds_entity_t domain, dds_entity_t participant)
      : id_(id), domain_(domain), participant_(participant) {}
  int id_;
  dds_entity_t domain_;
  dds_entity_t participant_;
};

/// The wall-clock time now as a ROS 2 stamp (seconds, nanoseconds).
void stamp_now(std::int32_t& sec, std::uint32_t& nanosec);

}  // namespace red::dds
