#pragma once
/// \file
/// DDS Security the ROS 2 way (SROS2; docs/ROS2.md, "Security"): ROS 2's environment
/// (ROS_SECURITY_KEYSTORE, ROS_SECURITY_ENCLAVE_OVERRIDE, ROS_SECURITY_ENABLE,
/// ROS_SECURITY_STRATEGY) and an enclave name select a directory of an SROS2 keystore,
/// `<keystore>/enclaves/<enclave>/`, whose six files become Cyclone DDS's security properties
/// (authentication, access control, encryption) on the process's participant.
///
///     auto env = red::dds::SecurityEnv::from_environment();
///     auto s = red::dds::resolve_security(env, "/red/node");  // Error: Enforce, file missing
///     if (s && s->enclave) { /* Domain::open(..., &*s->enclave) */ }

#include <dds/dds.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"

namespace red::dds {

/// ROS 2's security variables, as read (unset: empty).
struct SecurityEnv {
  std::string keystore;          ///< ROS_SECURITY_KEYSTORE
  std::string enclave_override;  ///< ROS_SECURITY_ENCLAVE_OVERRIDE
  std::string enable;            ///< ROS_SECURITY_ENABLE ("true" turns security on)
  std::string strategy;          ///< ROS_SECURITY_STRATEGY (Enforce | Permissive)
  /// Reads the four variables of this process.
  static SecurityEnv from_environment();
};

/// The files of an SROS2 enclave that DDS Security needs, in the order of kEnclaveFiles.
inline constexpr std::array<const char*, 6> kEnclaveFiles = {
    "identity_ca.cert.pem",    "cert.pem",       "key.pem",
    "permissions_ca.cert.pem", "governance.p7s", "permissions.p7s"};

/// An enclave found complete on disk.
struct Enclave {
  std::string name;  ///< e.g. "/red/node"
  std::string dir;   ///< absolute: <keystore>/enclaves/red/node
  /// The file of kEnclaveFiles[i] in dir.
  [[nodiscard]] std::string file(std::size_t i) const { return dir + "/" + kEnclaveFiles[i]; }
};

/// What a process does about security.
struct SecuritySettings {
  std::optional<Enclave> enclave;  ///< none: an open (unsecured) participant
  bool enforce = false;            ///< ROS_SECURITY_STRATEGY=Enforce
  /// Permissive and no usable enclave, or Enforce without ROS_SECURITY_ENABLE: what to tell
  /// the user (empty: nothing to say).
  std::string warning;
};

/// Decides as ROS 2's rcl does: security is on when ROS_SECURITY_ENABLE is "true" or an
/// enclave was given (`--security-enclave`, `cli_enclave` non-empty). The enclave is
/// ROS_SECURITY_ENCLAVE_OVERRIDE, else `cli_enclave`, else "/"; its directory is
/// `<ROS_SECURITY_KEYSTORE>/enclaves<enclave>`. When that directory or one of its files is
/// missing: Enforce -> Error naming the missing file or variable (the caller refuses to start);
/// Permissive (the default, as in ROS 2) -> no enclave and a warning. Error as well for a
/// ROS_SECURITY_STRATEGY other than Enforce or Permissive, or a malformed enclave name.
Expected<SecuritySettings> resolve_security(const SecurityEnv& env, const std::string& cli_enclave);

/// Cyclone DDS's security properties for `e` (name, value): the built-in plugins (Debian
/// ships them with libddsc: dds_security_auth, dds_security_ac, dds_security_crypto) and
/// the enclave's files as file: URIs, as ROS 2's rmw_cyclonedds sets them.
std::vector<std::pair<std::string, std::string>> cyclone_security_properties(const Enclave& e);

/// A participant QoS with those properties (caller deletes it with dds_delete_qos).
dds_qos_t* make_security_qos(const Enclave& e);

}  // namespace red::dds

namespace red::dds {

/// What an enclave may do (DDS topic names, `*` wildcards allowed): its permissions.xml's
/// allow rule.
struct Grant {
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

/// The grant of `red node` for its topics (node_topics(), after remapping): subscribe to each
/// sensor's topic, publish each output (Twist outputs also `<topic>/stamped`) and the
/// diagnostics, nothing else (as DDS topics: rt/<name>).
Grant node_grant(const std::vector<std::string>& sensors, const std::vector<std::string>& outputs,
                 const std::string& diagnostics);

/// SROS2's grant for an enclave made without a policy: every ROS 2 topic, service and action
/// (rt/*, rq/*, rr/*) and ros_discovery_info, both ways.
Grant open_grant();

/// SROS2's governance.xml: domains 0..230, no unauthenticated participants, join access
/// control, discovery, liveliness, metadata and data encrypted, RTPS messages signed.
std::string governance_xml();

/// SROS2's permissions.xml for `enclave` (subject CN=<enclave>), valid from `not_before` to
/// `not_after` (UTC, "YYYY-MM-DDTHH:MM:SS"), default DENY.
std::string permissions_xml(const std::string& enclave, const Grant& g,
                            const std::string& not_before, const std::string& not_after);

}  // namespace red::dds

namespace red::dds {

/// What DDS Security refused, as Cyclone DDS's log reports it (Cyclone 0.10 has no status or
/// listener for it): remote participants that failed authentication (no security, a
/// certificate of another CA, a failed handshake) and remote endpoints that access control
/// did not allow (a writer on a topic its permissions do not grant).
struct SecurityRefusals {
  std::uint64_t participants = 0;  ///< authentication refused
  std::uint64_t endpoints = 0;     ///< access control refused
  std::string last;                ///< the last such message
};

/// What a line of Cyclone's log says about security: 0 nothing, 1 a participant refused, 2 an
/// endpoint refused.
int classify_security_log(std::string_view message) noexcept;

/// Watches Cyclone's log (warnings and errors; process-wide, idempotent) and counts the
/// refusals; every line still goes to stderr, as without it.
void watch_security_log();

/// The refusals counted since watch_security_log() (thread-safe).
SecurityRefusals security_refusals();

}  // namespace red::dds
