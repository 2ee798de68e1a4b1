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
#include <chrono>
#include <cstdint>
#include <map>
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

/// What DDS Security refused (docs/ROS2.md, "What the node refuses, and what it counts").
/// Cyclone DDS 0.10 has no status or listener for it: the counts come from its log (warnings
/// and errors) and from its discovery trace.
struct SecurityRefusals {
  /// Remote participants not admitted, each counted once (by GUID prefix): one without
  /// security (when the governance allows no unauthenticated participant), one whose
  /// authentication failed (a handshake that failed, a "remote secure participant ... not
  /// allowed"), and one still not authenticated kAuthenticationGrace after its discovery (a
  /// certificate of another CA when the node initiates the handshake: the peer never answers),
  /// or that left unauthenticated after that long.
  std::uint64_t participants = 0;
  std::uint64_t endpoints = 0;  ///< remote endpoints access control refused (one per warning)
  std::string last;             ///< the last refusal, in words
};

/// What a line of Cyclone's log says about security: 0 nothing, 1 a participant refused, 2 an
/// endpoint refused.
int classify_security_log(std::string_view message) noexcept;

/// The GUID prefix ("a:b:c", hexadecimal, as Cyclone prints it) of the remote participant a
/// line of Cyclone's log or trace names: after "rguid=" in a handshake's line, else the
/// second of "(local --> remote)", else the first GUID in the line; empty when none.
std::string remote_guid_prefix(std::string_view line);

/// How long a secure remote participant may stay unauthenticated before it counts as refused
/// (Cyclone resends its handshake every second and gives up only after 100 s, with an error).
inline constexpr std::chrono::seconds kAuthenticationGrace{3};

/// The count of refused participants and endpoints from Cyclone's log and discovery trace
/// (not thread-safe; watch_security_log() holds one under a lock).
class RefusalCounter {
 public:
  using Clock = std::chrono::steady_clock;
  /// `count_unsecured`: whether a participant without security is refused (the governance
  /// does not allow unauthenticated participants, as SROS2's never does).
  explicit RefusalCounter(bool count_unsecured = true) : count_unsecured_(count_unsecured) {}
  void set_count_unsecured(bool on) { count_unsecured_ = on; }
  /// A line of Cyclone's log (warnings, errors).
  void log(std::string_view message, Clock::time_point now);
  /// A line of Cyclone's discovery trace: a new remote participant ("SPDP ST0 <guid> bes <x>
  /// [(secure)] NEW"), a handshake that succeeded ("handshake (lguid=.. rguid=<guid>)
  /// succeeded"), a remote participant deleted ("ddsi_delete_proxy_participant_by_guid(<guid>)
  /// - deleting").
  void trace(std::string_view line, Clock::time_point now);
  /// The refusals as of `now`.
  [[nodiscard]] SecurityRefusals refusals(Clock::time_point now) const;

 private:
  struct Remote {
    Clock::time_point seen, left_at;
    bool secure = false, authenticated = false, left = false, refused = false;
  };
  [[nodiscard]] bool counts(const Remote& r, Clock::time_point now) const;
  std::map<std::string, Remote> remotes_;  // by GUID prefix
  std::uint64_t endpoints_ = 0;
  std::string last_;
  bool count_unsecured_;
};

/// Watches Cyclone's log (warnings and errors; process-wide, idempotent) and counts the
/// refusals; every line still goes to stderr, as without it.
void watch_security_log();

/// A Cyclone configuration fragment (to append after a comma) that turns on the discovery
/// category of Cyclone's trace and nothing else (no data path), to /dev/null: the lines reach
/// the sink watch_security_trace() sets, not a file.
std::string security_trace_config();

/// Whether a Cyclone configuration has a Tracing element of its own (then the node leaves
/// the trace to it and does not count what only the trace shows).
bool configures_tracing(std::string_view config);

/// Whether the enclave's governance (governance.p7s, its XML signed in clear as SROS2 does)
/// allows unauthenticated participants in some domain rule.
bool governance_allows_unauthenticated(const Enclave& e);

/// Takes Cyclone's trace (process-wide, idempotent; with security_trace_config() only the
/// discovery category) into the refusal count; nothing of it is printed.
/// `count_unsecured` as in RefusalCounter.
void watch_security_trace(bool count_unsecured);

/// The refusals counted since watch_security_log() (thread-safe).
SecurityRefusals security_refusals();

}  // namespace red::dds
