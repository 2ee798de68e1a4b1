#include "red/dds/ros.hpp"

#include "red/dds/security.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

namespace red::dds {

std::string dds_topic_name(std::string_view ros_topic) {
  std::string_view t = ros_topic;
  if (!t.empty() && t.front() == '/') t.remove_prefix(1);
  return "rt/" + std::string(t);
}

bool valid_ros_topic(std::string_view name) {
  if (name.size() < 2 || name.front() != '/' || name.back() == '/') return false;
  char prev = '/';
  for (std::size_t i = 1; i < name.size(); ++i) {
    const char c = name[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '/';
    if (!ok || (c == '/' && prev == '/')) return false;
    // A token never starts with a digit (ROS 2 name rules).
    if (prev == '/' && c >= '0' && c <= '9') return false;
    prev = c;
  }
  return true;
}

Expected<bool> Remaps::add(const std::string& rule) {
  const auto sep = rule.find(":=");
  if (sep == std::string::npos)
    return Error{"", 0, "--remap '" + rule + "': expected from:=to (e.g. /camera:=/front/image)"};
  const std::string from = rule.substr(0, sep), to = rule.substr(sep + 2);
  for (const std::string& t : {from, to})
    if (!valid_ros_topic(t))
      return Error{"", 0,
                   "--remap '" + rule + "': '" + t +
                       "' is not an absolute ROS 2 topic name (like /camera/image_raw)"};
  rules_[from] = to;
  return true;
}

std::string Remaps::apply(const std::string& name) const {
  const auto it = rules_.find(name);
  return it == rules_.end() ? name : it->second;
}

namespace {

Expected<bool> read_endpoint(const YAML::Node& n, const std::string& path, EndpointQos& q) {
  const auto line = [&](const YAML::Node& x) { return x.Mark().line + 1; };
  if (!n.IsMap()) return Error{path, line(n), "expected a map of reliability, depth, durability"};
  for (const auto& kv : n) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    if (key == "reliability") {
      const std::string s = v.as<std::string>();
      if (s != "reliable" && s != "best_effort")
        return Error{path, line(v), "reliability must be reliable or best_effort, not '" + s + "'"};
      q.reliable = s == "reliable";
    } else if (key == "depth") {
      int d = 0;
      try {
        d = v.as<int>();
      } catch (const YAML::Exception&) {
        d = 0;
      }
      if (d < 1 || d > 10000)
        return Error{path, line(v), "depth must be an integer from 1 to 10000"};
      q.depth = d;
    } else if (key == "durability") {
      const std::string s = v.as<std::string>();
      if (s != "volatile" && s != "transient_local")
        return Error{path, line(v),
                     "durability must be volatile or transient_local, not '" + s + "'"};
      q.transient_local = s == "transient_local";
    } else {
      return Error{path, line(kv.first),
                   "unknown key '" + key + "' (known: reliability, depth, durability)"};
    }
  }
  return true;
}

}  // namespace

Expected<QosSettings> load_qos_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) return Error{path, 0, "cannot open the QoS file"};
  QosSettings q;
  try {
    const YAML::Node root = YAML::Load(f);
    if (!root.IsMap()) return Error{path, 1, "expected a map with input: and/or output:"};
    for (const auto& kv : root) {
      const std::string key = kv.first.as<std::string>();
      EndpointQos* e = key == "input" ? &q.input : key == "output" ? &q.output : nullptr;
      if (e == nullptr)
        return Error{path, kv.first.Mark().line + 1,
                     "unknown key '" + key + "' (known: input, output)"};
      if (auto r = read_endpoint(kv.second, path, *e); !r) return r.error();
    }
  } catch (const YAML::Exception& e) {
    return Error{path, e.mark.line + 1, e.msg};
  }
  return q;
}

dds_qos_t* make_qos(const EndpointQos& q) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, q.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.depth);
  dds_qset_durability(qos,
                      q.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  // XCDR1, ROS 2's data representation (docs/ROS2.md).
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
  return qos;
}

std::string loopback_config() {
  // Large fragments: a 640x480 rgb8 frame (921 KB) goes in 16 datagrams of up to 65000 B
  // instead of Cyclone's default 63 of 14720 B (fragments of 1344 B), which halves its
  // transport on loopback (docs/journal/ros2-node.md, "Measured where it happens, and larger
  // fragments"). Any RTPS reader reassembles fragments of any size; loopback's MTU (65536)
  // carries them unfragmented.
  return "<CycloneDDS><Domain Id=\"any\">"
         "<General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
         "<AllowMulticast>false</AllowMulticast>"
         "<FragmentSize>60000B</FragmentSize><MaxMessageSize>65000B</MaxMessageSize></General>"
         "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
         "<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>"
         "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
         "</Domain></CycloneDDS>";
}

Expected<bool> roudi_running() {
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return Error{"", 0, std::string("shared memory: socket(): ") + std::strerror(errno)};
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, kRoudiSocket, sizeof(addr.sun_path) - 1);
  // A datagram socket's connect() sends nothing: it only checks that a socket is bound there.
  const int rc = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  const int err = errno;
  ::close(fd);
  if (rc == 0) return true;
  return Error{"", 0,
               std::string("shared memory needs iceoryx's daemon RouDi, which is not running (") +
                   kRoudiSocket + ": " + std::strerror(err) +
                   "): start it first, e.g. `iox-roudi -c bench/ros2/roudi.toml` (Debian package "
                   "iceoryx; docs/ROS2.md, \"Shared memory\")"};
}

std::string shared_memory_config() {
  // LogLevel warn: iceoryx's info lines (one per process) stay out of the node's log.
  return "<CycloneDDS><Domain Id=\"any\"><SharedMemory><Enable>true</Enable>"
         "<LogLevel>warn</LogLevel></SharedMemory></Domain></CycloneDDS>";
}

Expected<std::unique_ptr<Domain>> Domain::open(int domain_id, const std::string& config,
                                               bool shared_memory, const Enclave* enclave) {
  if (domain_id < 0 || domain_id > 232)
    return Error{"", 0, "--domain " + std::to_string(domain_id) + ": must be 0..232"};
  // Samples through iceoryx's shared memory bypass DDS Security's encryption and access
  // control: never both.
  if (shared_memory && enclave != nullptr)
    return Error{"", 0,
                 "--shm and DDS Security together: shared memory would bypass the enclave's "
                 "access control and encryption; use one or the other"};
  std::string xml = config.empty() ? loopback_config() : config;
  if (shared_memory) {
    if (auto up = roudi_running(); !up) return up.error();
    xml += "," + shared_memory_config();
  }
  const auto id = static_cast<dds_domainid_t>(domain_id);
  dds_entity_t dom = dds_create_domain(id, xml.c_str());
  // An already-open domain in this process (e.g. a test beside a node) is reused as is.
  if (dom < 0 && dom != DDS_RETCODE_PRECONDITION_NOT_MET)
    return Error{"", 0,
                 "cannot create DDS domain " + std::to_string(domain_id) + " (" +
                     dds_strretcode(dom) + "): check the Cyclone DDS configuration"};
  dds_qos_t* qos = enclave != nullptr ? make_security_qos(*enclave) : nullptr;
  const dds_entity_t p = dds_create_participant(id, qos, nullptr);
  if (qos != nullptr) dds_delete_qos(qos);
  if (p < 0) {
    if (dom > 0) dds_delete(dom);
    return Error{
        "", 0,
        "cannot create a DDS participant on domain " + std::to_string(domain_id) + " (" +
            dds_strretcode(p) + ")" +
            (enclave != nullptr
                 ? ": DDS Security refused enclave " + enclave->name + " (" + enclave->dir +
                       "): check that its certificates are valid, signed by its CAs, "
                       "and that permissions.p7s grants this domain"
                 : std::string{})};
  }
  return std::unique_ptr<Domain>(new Domain(domain_id, dom > 0 ? dom : 0, p));
}

Domain::~Domain() {
  dds_delete(participant_);
  if (domain_ > 0) dds_delete(domain_);
}

void stamp_now(std::int32_t& sec, std::uint32_t& nanosec) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  sec = static_cast<std::int32_t>(ns / 1'000'000'000);
  nanosec = static_cast<std::uint32_t>(ns % 1'000'000'000);
}

}  // namespace red::dds
