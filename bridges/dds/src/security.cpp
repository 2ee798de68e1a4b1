#include "red/dds/security.hpp"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "red/dds/ros.hpp"

namespace red::dds {

namespace {

std::string env_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v == nullptr ? std::string{} : std::string{v};
}

// An enclave name as ROS 2 has it: "/", or checked as a namespace is (rcl validates an
// enclave name with the namespace rules): absolute tokens of [A-Za-z0-9_], none starting
// with a digit, which are a topic name's rules too.
bool valid_enclave(const std::string& name) {
  return name == "/" || valid_ros_topic(name);
}

}  // namespace

SecurityEnv SecurityEnv::from_environment() {
  return {env_or_empty("ROS_SECURITY_KEYSTORE"), env_or_empty("ROS_SECURITY_ENCLAVE_OVERRIDE"),
          env_or_empty("ROS_SECURITY_ENABLE"), env_or_empty("ROS_SECURITY_STRATEGY")};
}

Expected<SecuritySettings> resolve_security(const SecurityEnv& env,
                                            const std::string& cli_enclave) {
  SecuritySettings s;
  if (!env.strategy.empty() && env.strategy != "Enforce" && env.strategy != "Permissive")
    return Error{"", 0,
                 "ROS_SECURITY_STRATEGY='" + env.strategy +
                     "': expected Enforce or Permissive (case matters, as in ROS 2)"};
  s.enforce = env.strategy == "Enforce";
  const bool on = env.enable == "true" || !cli_enclave.empty();
  if (!on) {
    if (s.enforce)
      s.warning =
          "ROS_SECURITY_STRATEGY=Enforce has no effect: security is off (set "
          "ROS_SECURITY_ENABLE=true or give --security-enclave), as in ROS 2";
    return s;
  }
  const std::string name = !env.enclave_override.empty() ? env.enclave_override
                           : !cli_enclave.empty()        ? cli_enclave
                                                         : std::string{"/"};
  const std::string origin =
      !env.enclave_override.empty() ? "ROS_SECURITY_ENCLAVE_OVERRIDE" : "--security-enclave";
  if (!valid_enclave(name))
    return Error{"", 0,
                 origin + " '" + name +
                     "': not an enclave name (absolute, like /red/node: letters, digits, _, no "
                     "token starting with a digit)"};
  std::string problem;
  namespace fs = std::filesystem;
  std::error_code ec;
  if (env.keystore.empty()) {
    problem = "ROS_SECURITY_KEYSTORE is not set (the keystore that holds enclave " + name + ")";
  } else {
    const fs::path dir =
        fs::absolute(fs::path(env.keystore) / "enclaves" / name.substr(1), ec).lexically_normal();
    std::string d = dir.string();
    while (d.size() > 1 && d.back() == '/') d.pop_back();
    if (!fs::is_directory(dir, ec)) {
      problem = "enclave " + name + ": no directory " + d;
    } else {
      Enclave e{name, d};
      for (std::size_t i = 0; i < kEnclaveFiles.size() && problem.empty(); ++i)
        if (!fs::is_regular_file(e.file(i), ec))  // follows SROS2's symbolic links
          problem = "enclave " + name + ": missing " + e.file(i);
      if (problem.empty()) s.enclave = std::move(e);
    }
  }
  if (problem.empty()) return s;
  if (s.enforce)
    return Error{"", 0,
                 problem +
                     "; ROS_SECURITY_STRATEGY=Enforce: refusing to start without security "
                     "(docs/ROS2.md, \"Security\")"};
  s.warning = problem + "; ROS_SECURITY_STRATEGY is Permissive: running WITHOUT security";
  return s;
}

std::vector<std::pair<std::string, std::string>> cyclone_security_properties(const Enclave& e) {
  const auto uri = [&](std::size_t i) { return "file:" + e.file(i); };
  return {{"dds.sec.auth.library.path", "dds_security_auth"},
          {"dds.sec.auth.library.init", "init_authentication"},
          {"dds.sec.auth.library.finalize", "finalize_authentication"},
          {"dds.sec.auth.identity_ca", uri(0)},
          {"dds.sec.auth.identity_certificate", uri(1)},
          {"dds.sec.auth.private_key", uri(2)},
          {"dds.sec.access.library.path", "dds_security_ac"},
          {"dds.sec.access.library.init", "init_access_control"},
          {"dds.sec.access.library.finalize", "finalize_access_control"},
          {"dds.sec.access.permissions_ca", uri(3)},
          {"dds.sec.access.governance", uri(4)},
          {"dds.sec.access.permissions", uri(5)},
          {"dds.sec.crypto.library.path", "dds_security_crypto"},
          {"dds.sec.crypto.library.init", "init_crypto"},
          {"dds.sec.crypto.library.finalize", "finalize_crypto"}};
}

dds_qos_t* make_security_qos(const Enclave& e) {
  dds_qos_t* q = dds_create_qos();
  for (const auto& [k, v] : cyclone_security_properties(e)) dds_qset_prop(q, k.c_str(), v.c_str());
  return q;
}

}  // namespace red::dds

namespace red::dds {

namespace {

std::string domains_xml(const std::string& indent) {
  return indent + "<domains>\n" + indent + "  <id_range>\n" + indent + "    <min>0</min>\n" +
         indent + "    <max>230</max>\n" + indent + "  </id_range>\n" + indent + "</domains>\n";
}

std::string topics_xml(const char* what, const std::vector<std::string>& topics) {
  if (topics.empty()) return {};
  std::string x = std::string("        <") + what + ">\n          <topics>\n";
  for (const std::string& t : topics) x += "            <topic>" + t + "</topic>\n";
  return x + "          </topics>\n        </" + what + ">\n";
}

}  // namespace

Grant node_grant(const std::vector<std::string>& sensors, const std::vector<std::string>& outputs,
                 const std::string& diagnostics) {
  Grant g;
  for (const std::string& s : sensors) g.subscribe.push_back(dds_topic_name(s));
  for (const std::string& o : outputs) g.publish.push_back(dds_topic_name(o));
  g.publish.push_back(dds_topic_name(diagnostics));
  return g;
}

Grant open_grant() {
  const std::vector<std::string> all = {"rt/*", "rq/*", "rr/*", "ros_discovery_info"};
  return {all, all};
}

std::string governance_xml() {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/"
         "omg_shared_ca_governance.xsd\">\n"
         "  <domain_access_rules>\n"
         "    <domain_rule>\n" +
         domains_xml("      ") +
         "      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
         "      <enable_join_access_control>true</enable_join_access_control>\n"
         "      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
         "      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
         "      <rtps_protection_kind>SIGN</rtps_protection_kind>\n"
         "      <topic_access_rules>\n"
         "        <topic_rule>\n"
         "          <topic_expression>*</topic_expression>\n"
         "          <enable_discovery_protection>true</enable_discovery_protection>\n"
         "          <enable_liveliness_protection>true</enable_liveliness_protection>\n"
         "          <enable_read_access_control>true</enable_read_access_control>\n"
         "          <enable_write_access_control>true</enable_write_access_control>\n"
         "          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>\n"
         "          <data_protection_kind>ENCRYPT</data_protection_kind>\n"
         "        </topic_rule>\n"
         "      </topic_access_rules>\n"
         "    </domain_rule>\n"
         "  </domain_access_rules>\n"
         "</dds>\n";
}

std::string permissions_xml(const std::string& enclave, const Grant& g,
                            const std::string& not_before, const std::string& not_after) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/"
         "omg_shared_ca_permissions.xsd\">\n"
         "  <permissions>\n"
         "    <grant name=\"" +
         enclave +
         "\">\n"
         "      <subject_name>CN=" +
         enclave +
         "</subject_name>\n"
         "      <validity>\n"
         "        <not_before>" +
         not_before +
         "</not_before>\n"
         "        <not_after>" +
         not_after +
         "</not_after>\n"
         "      </validity>\n"
         "      <allow_rule>\n" +
         domains_xml("        ") + topics_xml("publish", g.publish) +
         topics_xml("subscribe", g.subscribe) +
         "      </allow_rule>\n"
         "      <default>DENY</default>\n"
         "    </grant>\n"
         "  </permissions>\n"
         "</dds>\n";
}

}  // namespace red::dds

namespace red::dds {

namespace {

bool contains(std::string_view m, std::string_view what) {
  return m.find(what) != std::string_view::npos;
}

bool is_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

// The GUID ("a:b:c:d", hexadecimal) at `at` in `m`: its prefix "a:b:c" and its end; empty
// when there is none there.
std::pair<std::string, std::size_t> guid_at(std::string_view m, std::size_t at) {
  std::size_t i = at;
  std::size_t prefix_end = 0;
  for (int part = 0; part < 4; ++part) {
    const std::size_t b = i;
    while (i < m.size() && is_hex(m[i])) ++i;
    if (i == b || i - b > 8) return {{}, at};
    if (part == 2) prefix_end = i;
    if (part < 3) {
      if (i >= m.size() || m[i] != ':') return {{}, at};
      ++i;
    }
  }
  if (i < m.size() && (is_hex(m[i]) || m[i] == ':')) return {{}, at};
  return {std::string(m.substr(at, prefix_end - at)), i};
}

// The first GUID in `m` from `from` on.
std::pair<std::string, std::size_t> first_guid(std::string_view m, std::size_t from) {
  for (std::size_t i = from; i < m.size(); ++i) {
    if (!is_hex(m[i]) || (i > 0 && (is_hex(m[i - 1]) || m[i - 1] == ':'))) continue;
    auto g = guid_at(m, i);
    if (!g.first.empty()) return g;
  }
  return {{}, std::string_view::npos};
}

std::string trimmed(std::string_view m) {
  while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.remove_suffix(1);
  while (!m.empty() && m.front() == ' ') m.remove_prefix(1);
  return std::string(m);
}

}  // namespace

int classify_security_log(std::string_view m) noexcept {
  // Cyclone DDS 0.10's messages. An endpoint: "match_remote_writer ... security_attributes
  // mismatch", "Non secure remote writer ... is not allowed", "... not allowed by security",
  // access control's "... not permitted".
  if (contains(m, "match_remote_") || contains(m, "Non secure remote writer") ||
      contains(m, "Non secure remote reader") || contains(m, "not allowed by security") ||
      contains(m, "not permitted"))
    return 2;
  // A participant: "Remote secure participant ... not allowed" (its identity or permissions
  // failed validation), "handshake (lguid=... rguid=...) failed", "Begin handshake ... failed".
  if ((contains(m, "participant") && contains(m, "not allowed")) ||
      (contains(m, "andshake") && contains(m, "failed")))
    return 1;
  return 0;
}

std::string remote_guid_prefix(std::string_view m) {
  if (const auto r = m.find("rguid="); r != std::string_view::npos) return guid_at(m, r + 6).first;
  if (const auto arrow = m.find(" --> "); arrow != std::string_view::npos)
    return guid_at(m, arrow + 5).first;
  return first_guid(m, 0).first;
}

bool RefusalCounter::counts(const Remote& r, Clock::time_point now) const {
  if (r.refused) return true;
  if (!r.secure) return count_unsecured_;
  if (r.authenticated) return false;
  return (r.left ? r.left_at : now) - r.seen >= kAuthenticationGrace;
}

void RefusalCounter::log(std::string_view m, Clock::time_point now) {
  const int kind = classify_security_log(m);
  if (kind == 0) return;
  last_ = trimmed(m);
  if (kind == 2) {
    ++endpoints_;
    return;
  }
  // A participant: counted once by its GUID prefix. A line without one (the plugin's
  // "Begin handshake reply failed: ...") is followed by Cyclone's "handshake (lguid=...
  // rguid=...) failed", which has it.
  const std::string g = remote_guid_prefix(m);
  if (g.empty()) return;
  auto [it, added] = remotes_.try_emplace(g);
  if (added) it->second.seen = now;
  it->second.refused = true;
}

void RefusalCounter::trace(std::string_view m, Clock::time_point now) {
  if (const auto at = m.find("SPDP ST0 "); at != std::string_view::npos) {
    const auto [g, end] = guid_at(m, at + 9);
    if (g.empty() || m.substr(end, 5) != " bes ") return;
    std::size_t i = end + 5;
    while (i < m.size() && is_hex(m[i])) ++i;
    const std::string_view rest = m.substr(i);
    const bool secure = rest.starts_with(" (secure) NEW");
    if (!secure && !rest.starts_with(" NEW")) return;
    auto [it, added] = remotes_.try_emplace(g);
    Remote& r = it->second;
    if (!added && counts(r, now)) r.refused = true;  // back after it was refused: stays counted
    r.seen = now;
    r.secure = secure;
    r.authenticated = r.left = false;
    if (!secure && count_unsecured_ && !r.refused)
      last_ = "remote participant " + g + " has no security (the governance allows none)";
    return;
  }
  if (contains(m, "handshake (lguid=") &&
      (contains(m, ") succeeded") || contains(m, ") processed"))) {
    if (auto it = remotes_.find(remote_guid_prefix(m)); it != remotes_.end())
      it->second.authenticated = true;
    return;
  }
  if (const auto at = m.find("ddsi_delete_proxy_participant_by_guid(");
      at != std::string_view::npos && contains(m, "- deleting")) {
    auto it = remotes_.find(guid_at(m, at + 38).first);
    if (it == remotes_.end() || it->second.left) return;
    Remote& r = it->second;
    r.left = true;
    r.left_at = now;
    if (r.secure && !r.authenticated && counts(r, now) && !r.refused) {
      r.refused = true;
      last_ = "remote participant " + it->first + " left without authenticating";
    }
  }
}

SecurityRefusals RefusalCounter::refusals(Clock::time_point now) const {
  SecurityRefusals s;
  for (const auto& [g, r] : remotes_)
    if (counts(r, now)) ++s.participants;
  s.endpoints = endpoints_;
  s.last = last_;
  return s;
}

namespace {

std::mutex g_log_mu;
RefusalCounter g_counter;
bool g_watching = false;
bool g_tracing = false;

void on_log(void*, const dds_log_data_t* d) {
  const std::string_view m(d->message, d->size);
  {
    std::lock_guard lock(g_log_mu);
    g_counter.log(m, RefusalCounter::Clock::now());
  }
  std::fwrite(d->message, 1, d->size, stderr);
  if (d->size == 0 || d->message[d->size - 1] != '\n') std::fputc('\n', stderr);  // Cyclone's own
}

// Cyclone's trace: with security_trace_config(), the discovery category only, plus every log
// line (warnings and errors also reach the trace when it is on): those are on_log's.
void on_trace(void*, const dds_log_data_t* d) {
  if ((d->priority & DDS_LOG_MASK) != 0) return;
  std::lock_guard lock(g_log_mu);
  g_counter.trace(std::string_view(d->message, d->size), RefusalCounter::Clock::now());
}

}  // namespace

void watch_security_log() {
  std::lock_guard lock(g_log_mu);
  if (g_watching) return;
  g_watching = true;
  dds_set_log_sink(on_log, nullptr);
}

std::string security_trace_config() {
  return "<CycloneDDS><Domain Id=\"any\"><Tracing><Category>discovery</Category>"
         "<OutputFile>/dev/null</OutputFile></Tracing></Domain></CycloneDDS>";
}

bool configures_tracing(std::string_view config) {
  std::string lower(config);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return contains(lower, "<tracing") || contains(lower, "<cyclonedds:tracing");
}

bool governance_allows_unauthenticated(const Enclave& e) {
  std::ifstream f(e.file(4));
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  static constexpr std::string_view tag = "<allow_unauthenticated_participants>";
  for (std::size_t at = text.find(tag); at != std::string::npos; at = text.find(tag, at + 1)) {
    std::size_t i = at + tag.size();
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (text.compare(i, 4, "true") == 0 || text.compare(i, 1, "1") == 0) return true;
  }
  return false;
}

void watch_security_trace(bool count_unsecured) {
  std::lock_guard lock(g_log_mu);
  g_counter.set_count_unsecured(count_unsecured);
  if (g_tracing) return;
  g_tracing = true;
  dds_set_trace_sink(on_trace, nullptr);
}

SecurityRefusals security_refusals() {
  std::lock_guard lock(g_log_mu);
  return g_counter.refusals(RefusalCounter::Clock::now());
}

}  // namespace red::dds
