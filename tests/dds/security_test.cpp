// DDS Security the ROS 2 way (docs/ROS2.md, "Security"): ROS 2's security environment read into
// an enclave, the refusal to start under Enforce without one, the permissions `red security`
// writes, and a keystore made with the `openssl` program in SROS2's layout.

#include "red/dds/security.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include "../support/cli.hpp"
#include "red/dds/ros.hpp"

namespace red::dds {
namespace {

namespace fs = std::filesystem;

// An enclave directory holding the six files (empty: resolve_security checks presence only).
void make_enclave(const fs::path& dir, const std::string& left_out = "") {
  fs::create_directories(dir);
  for (const char* f : kEnclaveFiles)
    if (f != left_out) std::ofstream(dir / f) << "x";
}

class DdsSecurity : public test::ScratchTest {};

TEST_F(DdsSecurity, OffUnlessEnabledOrAnEnclaveIsGiven) {
  auto s = resolve_security({dir_.string(), "", "", "Enforce"}, "");
  ASSERT_TRUE(s) << s.error().to_string();
  EXPECT_FALSE(s->enclave);
  // As in ROS 2, the strategy alone turns nothing on, but the user hears about it.
  EXPECT_NE(s->warning.find("ROS_SECURITY_ENABLE"), std::string::npos) << s->warning;
  // Only the exact word "true" enables it (rcl compares it so).
  s = resolve_security({dir_.string(), "", "True", ""}, "");
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->enclave);
  EXPECT_TRUE(s->warning.empty());
}

TEST_F(DdsSecurity, TheEnclaveComesFromTheOverrideThenTheOptionThenTheRoot) {
  make_enclave(dir_ / "enclaves");  // the root enclave "/"
  make_enclave(dir_ / "enclaves/red/node");
  make_enclave(dir_ / "enclaves/other");
  auto s = resolve_security({dir_.string(), "", "true", "Enforce"}, "");
  ASSERT_TRUE(s) << s.error().to_string();
  ASSERT_TRUE(s->enclave);
  EXPECT_EQ(s->enclave->name, "/");
  EXPECT_EQ(s->enclave->dir, (dir_ / "enclaves").string());
  s = resolve_security({dir_.string(), "", "", "Enforce"}, "/red/node");  // the option enables
  ASSERT_TRUE(s) << s.error().to_string();
  ASSERT_TRUE(s->enclave);
  EXPECT_EQ(s->enclave->dir, (dir_ / "enclaves/red/node").string());
  s = resolve_security({dir_.string(), "/other", "true", "Enforce"}, "/red/node");
  ASSERT_TRUE(s) << s.error().to_string();
  ASSERT_TRUE(s->enclave);
  EXPECT_EQ(s->enclave->name, "/other");
}

// An enclave name follows ROS 2's namespace rules: absolute, tokens of letters, digits and _,
// none starting with a digit, no empty token.
TEST_F(DdsSecurity, AnEnclaveNameFollowsRos2sNamespaceRules) {
  make_enclave(dir_ / "enclaves/cam4");
  auto ok = resolve_security({dir_.string(), "", "true", "Enforce"}, "/cam4");
  ASSERT_TRUE(ok) << ok.error().to_string();
  for (const char* bad :
       {"red/node", "/red//node", "/red/node/", "/4cam", "/red/2nd", "/red-node"}) {
    SCOPED_TRACE(bad);
    auto s = resolve_security({dir_.string(), "", "true", "Enforce"}, bad);
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("not an enclave name"), std::string::npos)
        << s.error().to_string();
  }
}

TEST_F(DdsSecurity, EnforceWithoutAUsableEnclaveNamesWhatIsMissing) {
  auto s = resolve_security({"", "", "true", "Enforce"}, "/red/node");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("ROS_SECURITY_KEYSTORE is not set"), std::string::npos)
      << s.error().to_string();
  s = resolve_security({dir_.string(), "", "true", "Enforce"}, "/red/node");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("no directory " + (dir_ / "enclaves/red/node").string()),
            std::string::npos)
      << s.error().to_string();
  for (const char* f : kEnclaveFiles) {
    SCOPED_TRACE(f);
    fs::remove_all(dir_ / "enclaves");
    make_enclave(dir_ / "enclaves/red/node", f);
    s = resolve_security({dir_.string(), "", "true", "Enforce"}, "/red/node");
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("missing " + (dir_ / "enclaves/red/node" / f).string()),
              std::string::npos)
        << s.error().to_string();
    EXPECT_NE(s.error().message.find("refusing to start"), std::string::npos);
  }
}

TEST_F(DdsSecurity, PermissiveWithoutAUsableEnclaveWarnsAndRunsOpen) {
  make_enclave(dir_ / "enclaves/red/node", "permissions.p7s");
  for (const std::string strategy : {"Permissive", ""}) {  // Permissive is ROS 2's default
    auto s = resolve_security({dir_.string(), "", "true", strategy}, "/red/node");
    ASSERT_TRUE(s) << s.error().to_string();
    EXPECT_FALSE(s->enclave);
    EXPECT_NE(s->warning.find("missing " + (dir_ / "enclaves/red/node/permissions.p7s").string()),
              std::string::npos)
        << s->warning;
    EXPECT_NE(s->warning.find("WITHOUT security"), std::string::npos) << s->warning;
  }
}

TEST_F(DdsSecurity, BadStrategiesAndEnclaveNamesAreErrors) {
  auto s = resolve_security({dir_.string(), "", "true", "enforce"}, "/red/node");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("ROS_SECURITY_STRATEGY='enforce'"), std::string::npos);
  for (const std::string bad : {"red/node", "/red/", "/red//node", "/../etc", "/red node"}) {
    s = resolve_security({dir_.string(), "", "true", "Enforce"}, bad);
    ASSERT_FALSE(s) << bad;
    EXPECT_NE(s.error().message.find("'" + bad + "'"), std::string::npos) << s.error().to_string();
  }
}

TEST_F(DdsSecurity, CycloneGetsTheEnclavesFilesAndTheBuiltinPlugins) {
  const Enclave e{"/red/node", "/k/enclaves/red/node"};
  const auto props = cyclone_security_properties(e);
  const auto value = [&](const std::string& key) {
    const auto it =
        std::find_if(props.begin(), props.end(), [&](const auto& kv) { return kv.first == key; });
    return it == props.end() ? std::string("(absent)") : it->second;
  };
  EXPECT_EQ(value("dds.sec.auth.identity_ca"), "file:/k/enclaves/red/node/identity_ca.cert.pem");
  EXPECT_EQ(value("dds.sec.auth.identity_certificate"), "file:/k/enclaves/red/node/cert.pem");
  EXPECT_EQ(value("dds.sec.auth.private_key"), "file:/k/enclaves/red/node/key.pem");
  EXPECT_EQ(value("dds.sec.access.permissions_ca"),
            "file:/k/enclaves/red/node/permissions_ca.cert.pem");
  EXPECT_EQ(value("dds.sec.access.governance"), "file:/k/enclaves/red/node/governance.p7s");
  EXPECT_EQ(value("dds.sec.access.permissions"), "file:/k/enclaves/red/node/permissions.p7s");
  EXPECT_EQ(value("dds.sec.auth.library.path"), "dds_security_auth");
  EXPECT_EQ(value("dds.sec.access.library.path"), "dds_security_ac");
  EXPECT_EQ(value("dds.sec.crypto.library.path"), "dds_security_crypto");
}

TEST(DdsSecurityXml, TheNodeMaySubscribeToItsSensorsAndPublishItsResultsOnly) {
  const Grant g =
      node_grant({"/camera/image_raw"}, {"/red/drive/L", "/red/drive/C/stamped"}, "/diagnostics");
  const std::string x =
      permissions_xml("/red/node", g, "2026-01-01T00:00:00", "2036-01-01T00:00:00");
  const auto pub = x.find("<publish>"), sub = x.find("<subscribe>");
  ASSERT_NE(pub, std::string::npos) << x;
  ASSERT_NE(sub, std::string::npos) << x;
  ASSERT_LT(pub, sub);
  const std::string publish = x.substr(pub, sub - pub), subscribe = x.substr(sub);
  EXPECT_NE(subscribe.find("<topic>rt/camera/image_raw</topic>"), std::string::npos) << x;
  EXPECT_EQ(publish.find("rt/camera/image_raw"), std::string::npos) << x;
  for (const char* t : {"rt/red/drive/L", "rt/red/drive/C/stamped", "rt/diagnostics"}) {
    EXPECT_NE(publish.find(std::string("<topic>") + t + "</topic>"), std::string::npos) << t;
    EXPECT_EQ(subscribe.find(t), std::string::npos) << t;
  }
  EXPECT_EQ(x.find('*'), std::string::npos) << "no wildcard in a node's grant\n" << x;
  EXPECT_NE(x.find("<subject_name>CN=/red/node</subject_name>"), std::string::npos);
  EXPECT_NE(x.find("<not_before>2026-01-01T00:00:00</not_before>"), std::string::npos);
  EXPECT_NE(x.find("<default>DENY</default>"), std::string::npos);
}

// Cyclone DDS 0.10's log lines as the node counts them (seen in the secure tests' runs).
TEST(DdsSecurityLog, CyclonesRefusalsAreCountedByKind) {
  EXPECT_EQ(classify_security_log("Remote secure participant fce7bc83:1b53702d:f56deb7f:1c1 not "
                                  "allowed"),
            1);
  EXPECT_EQ(classify_security_log("fsm: Begin handshake reply failed: Failed to convert octet "
                                  "sequence to ASN1 integer"),
            1);
  EXPECT_EQ(classify_security_log("match_remote_writer f51efec2:47b30f4c:a0929860:103 with reader "
                                  "e92bded0:767448c4:933b7298:204 security_attributes mismatch"),
            2);
  EXPECT_EQ(classify_security_log("Non secure remote writer 1:2:3:4 is not allowed."), 2);
  EXPECT_EQ(classify_security_log("ddsi_udp_conn_write to udp/127.0.0.1:7410 failed"), 0);
}

// Refused participants, each once by its GUID prefix, from Cyclone DDS 0.10's own lines: its
// discovery trace ("SPDP ST0 ... NEW", "handshake ... succeeded", "ddsi_delete_proxy_...") and
// its log (warnings and errors).
TEST(DdsSecurityLog, GuidPrefixesAreTakenFromTheRemoteSide) {
  EXPECT_EQ(remote_guid_prefix("handshake (lguid=e92bded0:767448c4:933b7298:1c1 "
                               "rguid=fce7bc83:1b53702d:f56deb7f:1c1) failed: (3) Failed"),
            "fce7bc83:1b53702d:f56deb7f");
  EXPECT_EQ(remote_guid_prefix("received handshake message (1:2:3:1c1 --> a:b:c:1c1) does not "
                               "contain a handshake message token"),
            "a:b:c");
  EXPECT_EQ(remote_guid_prefix("Remote secure participant fce7bc83:1b53702d:f56deb7f:1c1 not "
                               "allowed"),
            "fce7bc83:1b53702d:f56deb7f");
  EXPECT_EQ(remote_guid_prefix("fsm: Begin handshake reply failed: Failed to convert"), "");
  EXPECT_EQ(remote_guid_prefix("udp/127.0.0.1:7410 failed"), "");
}

using Clock = RefusalCounter::Clock;
const std::string kNew = "SPDP ST0 1f0c1a2b:3c4d5e6f:708192a3:1c1 bes fc03";
const std::string kGuid = "1f0c1a2b:3c4d5e6f:708192a3";

TEST(DdsSecurityLog, AParticipantWithoutSecurityIsRefusedOnceUnlessTheGovernanceAllowsIt) {
  const Clock::time_point t0{};
  RefusalCounter c;
  c.trace(kNew + " NEW (data udp/127.0.0.1:7412) QOS={}", t0);
  EXPECT_EQ(c.refusals(t0).participants, 1U);
  // Announced again (an update, or a new lease): the same participant.
  c.trace(kNew + " NEW QOS={}", t0 + std::chrono::seconds{1});
  c.trace("SPDP ST0 1f0c1a2b:3c4d5e6f:708192a3:1c1 (update)", t0 + std::chrono::seconds{2});
  EXPECT_EQ(c.refusals(t0 + std::chrono::seconds{2}).participants, 1U);
  EXPECT_NE(c.refusals(t0).last.find(kGuid), std::string::npos);
  RefusalCounter allowed(false);
  allowed.trace(kNew + " NEW QOS={}", t0);
  EXPECT_EQ(allowed.refusals(t0 + std::chrono::seconds{60}).participants, 0U);
}

TEST(DdsSecurityLog, ASecureParticipantCountsWhenNotAuthenticatedInTime) {
  const Clock::time_point t0{};
  const auto later = t0 + kAuthenticationGrace;
  RefusalCounter c;
  c.trace(kNew + " (secure) NEW QOS={}", t0);
  EXPECT_EQ(c.refusals(t0).participants, 0U) << "its handshake has just begun";
  EXPECT_EQ(c.refusals(later).participants, 1U) << "still not authenticated";
  c.trace("handshake (lguid=e92bded0:767448c4:933b7298:1c1 rguid=" + kGuid + ":1c1) succeeded",
          later + std::chrono::seconds{1});
  EXPECT_EQ(c.refusals(later + std::chrono::seconds{2}).participants, 0U) << "authenticated late";
  // One that leaves unauthenticated: counted if it stayed the grace, not if it left sooner.
  RefusalCounter stayed, blinked;
  stayed.trace(kNew + " (secure) NEW QOS={}", t0);
  blinked.trace(kNew + " (secure) NEW QOS={}", t0);
  const std::string gone = "ddsi_delete_proxy_participant_by_guid(" + kGuid + ":1c1) - deleting";
  stayed.trace(gone, later);
  blinked.trace(gone, t0 + std::chrono::milliseconds{500});
  EXPECT_EQ(stayed.refusals(later + std::chrono::hours{1}).participants, 1U);
  EXPECT_EQ(blinked.refusals(later + std::chrono::hours{1}).participants, 0U);
  // Back with the same GUID prefix: still one participant, counted.
  stayed.trace(kNew + " (secure) NEW QOS={}", later + std::chrono::seconds{5});
  stayed.trace("handshake (lguid=1:2:3:1c1 rguid=" + kGuid + ":1c1) succeeded",
               later + std::chrono::seconds{6});
  EXPECT_EQ(stayed.refusals(later + std::chrono::seconds{7}).participants, 1U);
}

TEST(DdsSecurityLog, TheLogsRefusalsOfOneParticipantCountOnce) {
  const Clock::time_point t0{};
  RefusalCounter c;
  c.trace(kNew + " (secure) NEW QOS={}", t0);
  c.log("fsm: Begin handshake reply failed: Failed to convert octet sequence", t0);
  EXPECT_EQ(c.refusals(t0).participants, 0U) << "no GUID: the next line names it";
  c.log("handshake (lguid=1:2:3:1c1 rguid=" + kGuid + ":1c1) failed: (3) Failed", t0);
  c.log("Remote secure participant " + kGuid + ":1c1 not allowed", t0);
  EXPECT_EQ(c.refusals(t0).participants, 1U);
  c.log(
      "match_remote_writer f51efec2:47b30f4c:a0929860:103 with reader "
      "e92bded0:767448c4:933b7298:204 security_attributes mismatch",
      t0);
  const SecurityRefusals r = c.refusals(t0);
  EXPECT_EQ(r.participants, 1U);
  EXPECT_EQ(r.endpoints, 1U);
  EXPECT_NE(r.last.find("match_remote_writer"), std::string::npos) << r.last;
  // Lines that are none of these change nothing.
  c.trace("SPDP ST0 1:2:3:1c1 (local)", t0);
  c.log("ddsi_udp_conn_write to udp/127.0.0.1:7410 failed", t0);
  EXPECT_EQ(c.refusals(t0).participants, 1U);
}

TEST_F(DdsSecurity, TheNodesTraceIsDiscoveryOnlyAndTheGovernanceIsRead) {
  const std::string t = security_trace_config();
  EXPECT_NE(t.find("<Category>discovery</Category>"), std::string::npos) << t;
  EXPECT_EQ(t.find("trace<"), std::string::npos) << t;
  EXPECT_TRUE(configures_tracing(t));
  EXPECT_TRUE(configures_tracing("<CycloneDDS><Domain><tracing><Verbosity>fine</Verbosity>"));
  EXPECT_FALSE(configures_tracing(loopback_config()));
  make_enclave(dir_ / "e");
  const Enclave e{"/e", (dir_ / "e").string()};
  std::ofstream(e.file(4)) << "Content-Type: text/plain\n\n" << governance_xml();
  EXPECT_FALSE(governance_allows_unauthenticated(e));
  std::string open = governance_xml();
  const std::string f = "<allow_unauthenticated_participants>false";
  open.replace(open.find(f), f.size(), "<allow_unauthenticated_participants>true");
  std::ofstream(e.file(4)) << open;
  EXPECT_TRUE(governance_allows_unauthenticated(e));
}

// The keystore tool: `red security` with openssl, in SROS2's layout, its signatures checked by
// openssl against the keystore's CA, the node's grant drawn from the scenario.
TEST_F(DdsSecurity, TheKeystoreToolMakesSros2sLayoutSignedByItsCa) {
  if (std::system("openssl version >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "the openssl program is not installed (apt-get install openssl)";
  const fs::path ks = dir_ / "keystore";
  auto r = test::run_red("security create-keystore " + test::quote(ks.string()), dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  r = test::run_red("security create-enclave " + test::quote(ks.string()) +
                        " /red/node --scenario '" RED_SOURCE_DIR "/tests/dds/data/node.yaml'",
                    dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f :
       {"public/ca.cert.pem", "public/identity_ca.cert.pem", "public/permissions_ca.cert.pem",
        "private/ca.key.pem", "private/identity_ca.key.pem", "private/permissions_ca.key.pem",
        "enclaves/governance.xml", "enclaves/governance.p7s"})
    EXPECT_TRUE(fs::is_regular_file(ks / f)) << f;
  const fs::path e = ks / "enclaves/red/node";
  for (const char* f : kEnclaveFiles) EXPECT_TRUE(fs::is_regular_file(e / f)) << f;
  // SROS2's links, relative, so that a keystore can be moved.
  EXPECT_EQ(fs::read_symlink(e / "governance.p7s"), "../../../enclaves/governance.p7s");
  EXPECT_EQ(fs::read_symlink(e / "identity_ca.cert.pem"), "../../../public/identity_ca.cert.pem");
  const std::string ca = test::quote((ks / "public/permissions_ca.cert.pem").string());
  for (const fs::path& p7s : {e / "permissions.p7s", ks / "enclaves/governance.p7s"}) {
    const std::string verify = "openssl smime -verify -in " + test::quote(p7s.string()) +
                               " -CAfile " + ca + " >/dev/null 2>&1";
    EXPECT_EQ(std::system(verify.c_str()), 0) << p7s;
  }
  const std::string cert = test::quote((e / "cert.pem").string());
  EXPECT_EQ(std::system(("openssl verify -CAfile " + ca + " " + cert + " >/dev/null 2>&1").c_str()),
            0);
  const std::string subject = dir_.string() + "/subject.txt";
  ASSERT_EQ(std::system(("openssl x509 -in " + cert + " -noout -subject -nameopt RFC2253 > " +
                         test::quote(subject))
                            .c_str()),
            0);
  EXPECT_NE(test::read_text(subject).find("CN=/red/node"), std::string::npos)
      << test::read_text(subject);
  const std::string x = test::read_text(e / "permissions.xml");
  const std::string subscribe = x.substr(x.find("<subscribe>"));
  EXPECT_NE(subscribe.find("rt/camera/image_raw"), std::string::npos) << x;
  for (const char* t : {"rt/red/drive/L", "rt/red/drive/S", "rt/red/drive/C",
                        "rt/red/drive/C/stamped", "rt/red/detect/O", "rt/diagnostics"})
    EXPECT_NE(x.find(std::string("<topic>") + t + "</topic>"), std::string::npos) << t << x;
}

// `red security`'s bad input: exit 2, the problem named.
TEST_F(DdsSecurity, TheKeystoreToolNamesWhatIsWrong) {
  const std::string ks = test::quote((dir_ / "none").string());
  auto r = test::run_red("security create-enclave " + ks + " /red/node", dir_);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("make it first with `red security create-keystore"), std::string::npos)
      << r.err;
  r = test::run_red("security create-enclave " + ks + " red/node", dir_);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("'red/node': not an enclave name"), std::string::npos) << r.err;
  r = test::run_red("security create-enclave " + ks + " /red/node --scenario " +
                        test::quote((dir_ / "missing.yaml").string()),
                    dir_);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("missing.yaml"), std::string::npos) << r.err;
}

// `red node` and `red camera` under Enforce with no usable enclave: exit 2 before any DDS
// participant exists, the missing file named.
TEST_F(DdsSecurity, EnforceRefusesToStartTheNodeAndTheCamera) {
  make_enclave(dir_ / "enclaves/red/node", "key.pem");
  const std::string env =
      "ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce "
      "ROS_SECURITY_KEYSTORE=" +
      test::quote(dir_.string());
  const std::string missing = (dir_ / "enclaves/red/node/key.pem").string();
  auto r = test::run_red("node '" RED_SOURCE_DIR
                         "/tests/dds/data/node.yaml' --backend synthetic --duration 1 "
                         "--security-enclave /red/node",
                         dir_, env);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("missing " + missing), std::string::npos) << r.err;
  r = test::run_red("camera --count 1 --security-enclave /red/node", dir_, env);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("missing " + missing), std::string::npos) << r.err;
  r = test::run_red("camera --count 1", dir_,
                    "ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce "
                    "ROS_SECURITY_KEYSTORE= ROS_SECURITY_ENCLAVE_OVERRIDE=");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("ROS_SECURITY_KEYSTORE is not set"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace red::dds
