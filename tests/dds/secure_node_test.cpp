// `red node` on a shared network (docs/ROS2.md, "Security" and "A bad link"): with DDS Security
// against a secure eProsima Fast DDS peer (frames in, results out), against peers it must
// refuse (no security, a certificate of another CA, no permission to publish the camera
// topic), its encrypted traffic captured on loopback; and over a link that loses packets or
// goes down, made with nftables in a network namespace of the test's own (root only).

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../support/cli.hpp"
#include "red/dds/messages.hpp"
#include "red/dds/ros.hpp"
#include "red/dds/security.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;

const std::string kRed = RED_CLI;
const std::string kScenario = RED_SOURCE_DIR "/tests/dds/data/node.yaml";

int sh(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return status != -1 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Runs a shell command on its own thread; its exit code when joined.
struct Command {
  std::atomic<bool> done{false};
  int code = -1;
  std::thread thread;
  explicit Command(const std::string& cmd)
      : thread([this, cmd] {
          code = sh(cmd);
          done = true;
        }) {}
  int join() {
    thread.join();
    return code;
  }
};

// The node's /diagnostics as a participant of this process sees them: the last value of each
// "status/key".
struct DiagnosticsWatch {
  dds_entity_t reader = 0;
  std::map<std::string, std::string> last;
  explicit DiagnosticsWatch(dds_entity_t pp) {
    const dds_entity_t t =
        dds_create_topic(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                         dds_topic_name("/diagnostics").c_str(), nullptr, nullptr);
    dds_qos_t* q = make_qos(EndpointQos{true, 50, false});
    reader = dds_create_reader(pp, t, q, nullptr);
    dds_delete_qos(q);
  }
  void drain() {
    void* samples[8] = {};
    dds_sample_info_t infos[8];
    for (;;) {
      std::fill(std::begin(samples), std::end(samples), nullptr);
      const dds_return_t n = dds_take(reader, samples, infos, 8, 8);
      if (n <= 0) return;
      for (dds_return_t i = 0; i < n; ++i) {
        if (!infos[i].valid_data) continue;
        const auto& m = *static_cast<const DiagnosticArray*>(samples[i]);
        for (std::uint32_t j = 0; j < m.status_._length; ++j) {
          const DiagnosticStatus& st = m.status_._buffer[j];
          for (std::uint32_t k = 0; k < st.values_._length; ++k)
            last[std::string(st.name_) + "/" + st.values_._buffer[k].key_] =
                st.values_._buffer[k].value_;
        }
      }
      dds_return_loan(reader, samples, n);
    }
  }
};

nlohmann::json read_json(const fs::path& p) {
  return nlohmann::json::parse(read_text(p), nullptr, false);
}

// Two keystores made by `red security`: A with the node's enclave (its scenario's grant), a
// camera's (every topic) and an intruder's (the node's grant: it may not publish frames);
// B, another CA, with a camera's enclave. The peers' enclave names are chosen so that the
// node initiates their handshakes: Fast DDS 2.9 and Cyclone DDS 0.10 complete a handshake
// only when Cyclone initiates (tests/dds/fastdds/peer.cpp; docs/ROS2.md, "Security"), and a
// participant's GUID, which decides who initiates, hashes its certificate's subject. And a
// governance for the intruder that turns its own access control off (signed by A's CA): otherwise
// Fast DDS would refuse to create the writer its permissions deny, and the node's side of access
// control would go untested.
class Keystores {
 public:
  static const Keystores& get() {
    static const Keystores k;
    return k;
  }
  fs::path dir, a, b, intruder_governance;
  std::string error;  // why they could not be made
  ~Keystores() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }

 private:
  Keystores() {
    dir = fs::temp_directory_path() / ("red_keystores_" + std::to_string(getpid()));
    a = dir / "a";
    b = dir / "b";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string node = " --scenario " + quote(kScenario);
    for (const std::string& args :
         {"create-keystore " + quote(a.string()), "create-keystore " + quote(b.string()),
          "create-enclave " + quote(a.string()) + " /red/node" + node,
          "create-enclave " + quote(a.string()) + " /cam4",
          "create-enclave " + quote(a.string()) + " /intruder1" + node,
          "create-enclave " + quote(b.string()) + " /cam4"}) {
      if (sh(quote(kRed) + " security " + args + " 2>>" + quote((dir / "err.txt").string())) != 0)
        error = "red security " + args + " failed: " + read_text(dir / "err.txt");
    }
    const fs::path xml = dir / "intruder_governance.xml";
    intruder_governance = dir / "intruder_governance.p7s";
    const std::string sign = "sed -E 's/(enable_(read|write)_access_control>)true/\\1false/' " +
                             quote((a / "enclaves/governance.xml").string()) + " > " +
                             quote(xml.string()) + " && openssl smime -sign -text -in " +
                             quote(xml.string()) + " -out " + quote(intruder_governance.string()) +
                             " -signer " + quote((a / "public/permissions_ca.cert.pem").string()) +
                             " -inkey " + quote((a / "private/permissions_ca.key.pem").string()) +
                             " 2>>" + quote((dir / "err.txt").string());
    if (error.empty() && sh(sign) != 0) error = "cannot sign the intruder's governance";
  }
};

bool secure_peer_skip(std::string& why) {
#ifndef RED_FASTDDS_PEER
  why = "built without Fast DDS (apt-get install libfastrtps-dev fastddsgen)";
  return true;
#else
  if (sh("openssl version >/dev/null 2>&1") != 0) {
    why = "the openssl program is not installed (apt-get install openssl)";
    return true;
  }
  return false;
#endif
}

// The environment of a secure node: ROS 2's variables on keystore A, Enforce.
std::string secure_env() {
  return "ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_KEYSTORE=" +
         quote(Keystores::get().a.string()) + " ";
}

// A secure node for `duration` seconds on `domain`, writing to `out`.
std::string node_command(const std::string& domain, double duration, const fs::path& out) {
  return secure_env() + quote(kRed) + " node " + quote(kScenario) +
         " --backend synthetic --security-enclave /red/node --duration " +
         std::to_string(duration) + " --domain " + domain + " --out " +
         quote((out / "run").string()) + " 2> " + quote((out / "node.err").string());
}

class DdsNodeSecure : public test::ScratchTest {
 protected:
  void SetUp() override {
    test::ScratchTest::SetUp();
    std::string why;
    if (secure_peer_skip(why)) GTEST_SKIP() << why;
    ASSERT_TRUE(Keystores::get().error.empty()) << Keystores::get().error;
  }
};

#ifdef RED_FASTDDS_PEER
const std::string kPeer = RED_FASTDDS_PEER;

TEST_F(DdsNodeSecure, ASecureFastDdsPeerExchangesFramesAndResults) {
  const std::string d = std::to_string(test_domain());
  Command node(node_command(d, 7, dir_));
  const fs::path out = dir_ / "peer.json";
  const int peer = sh(quote(kPeer) + " " + d + " 40 20 2 " +
                      quote((Keystores::get().a / "enclaves/cam4").string()) + " > " +
                      quote(out.string()) + " 2> " + quote((dir_ / "peer.err").string()));
  EXPECT_EQ(node.join(), 0) << read_text(dir_ / "node.err");
  EXPECT_EQ(peer, 0) << read_text(dir_ / "peer.err");
  EXPECT_NE(read_text(dir_ / "node.err").find("DDS Security with enclave /red/node"),
            std::string::npos)
      << read_text(dir_ / "node.err");
  const auto r = read_json(out);
  ASSERT_FALSE(r.is_discarded()) << read_text(out) << read_text(dir_ / "peer.err");
  ASSERT_TRUE(r["matched"].get<bool>()) << "the secure peer's writer never matched the node\n"
                                        << read_text(dir_ / "node.err");
  EXPECT_EQ(r["sent"], 40);
  for (const std::string t : {"/red/drive/L", "/red/drive/C/stamped", "/red/detect/O"}) {
    SCOPED_TRACE(t);
    EXPECT_GT(r["outputs"][t]["count"].get<int>(), 0) << r.dump();
    EXPECT_EQ(r["outputs"][t]["matched_stamps"], r["outputs"][t]["count"]) << r.dump();
  }
  EXPECT_GT(r["diagnostics"].get<int>(), 0) << r.dump();
  const auto nj = read_json(dir_ / "run/node.json");
  ASSERT_FALSE(nj.is_discarded());
  EXPECT_GT(nj["released"].get<int>(), 0) << nj.dump();
  EXPECT_EQ(nj["security"]["enclave"], "/red/node") << nj.dump();
  // The peer authenticated (it matched): nothing refused.
  EXPECT_EQ(nj["security"]["refused_participants"], 0) << nj.dump();
  EXPECT_EQ(nj["security"]["refused_endpoints"], 0) << nj.dump();
}

// Each peer the node must refuse writes 20 frames at it (unmatched: Fast DDS has no reader to
// send them to, the node no writer to take them from); the node releases none of them and
// counts the refusal: the participant without security or from another CA, the intruder's
// writer. A secure Cyclone participant of this test process (keystore A's camera enclave: any
// two Cyclone participants authenticate each other) watches the node's /diagnostics. The peer
// stays (LINGER 4 s) longer than the node's grace for an authentication (kAuthenticationGrace).
class DdsNodeSecureRefuses : public DdsNodeSecure,
                             public ::testing::WithParamInterface<std::string> {};

TEST_P(DdsNodeSecureRefuses, APeerTheNodeMustRefuse) {
  const std::string d = std::to_string(test_domain());
  const Keystores& k = Keystores::get();
  const std::string enclave = GetParam() == "unauthenticated" ? ""
                              : GetParam() == "other-ca"      ? (k.b / "enclaves/cam4").string()
                                                         : (k.a / "enclaves/intruder1").string();
  auto witness = resolve_security({k.a.string(), "", "true", "Enforce"}, "/cam4");
  ASSERT_TRUE(witness && witness->enclave);
  auto dom = Domain::open(test_domain(), "", false, &*witness->enclave);
  ASSERT_TRUE(dom.has_value()) << dom.error().to_string();
  DiagnosticsWatch diag((*dom)->participant());
  ASSERT_GT(diag.reader, 0);
  Command node(node_command(d, 8, dir_));
  const fs::path out = dir_ / "peer.json";
  Command peer("RED_PEER_FORCE=3 " +
               (GetParam() == "no-permission"
                    ? "RED_PEER_GOVERNANCE=" + quote(k.intruder_governance.string()) + " "
                    : std::string()) +
               quote(kPeer) + " " + d + " 20 20 4 " + (enclave.empty() ? "" : quote(enclave)) +
               " > " + quote(out.string()) + " 2> " + quote((dir_ / "peer.err").string()));
  while (!node.done || !peer.done) {
    diag.drain();
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
  }
  EXPECT_EQ(node.join(), 0) << read_text(dir_ / "node.err");
  EXPECT_EQ(peer.join(), 0) << read_text(dir_ / "peer.err");
  diag.drain();
  const auto r = read_json(out);
  ASSERT_FALSE(r.is_discarded()) << read_text(out) << read_text(dir_ / "peer.err");
  EXPECT_EQ(r["sent"], 20) << r.dump();
  EXPECT_FALSE(r["matched"].get<bool>()) << r.dump();
  for (const auto& [topic, o] : r["outputs"].items())
    EXPECT_EQ(o["count"], 0) << topic << ": a refused peer received results";
  EXPECT_EQ(r["diagnostics"], 0) << r.dump();
  const auto nj = read_json(dir_ / "run/node.json");
  ASSERT_FALSE(nj.is_discarded()) << read_text(dir_ / "node.err");
  EXPECT_EQ(nj["frames"], 0) << nj.dump();
  EXPECT_EQ(nj["released"], 0) << nj.dump();
  // The refusal, counted. The intruder authenticates, and its writer is refused for its
  // security attributes (its governance turned access control off): an endpoint, from
  // Cyclone's log. A participant without security, or whose certificate is of another CA (the
  // node initiates the handshake, which Fast DDS never answers), from Cyclone's discovery
  // trace: a participant.
  const auto& sec = nj["security"];
  const std::string kind =
      GetParam() == "no-permission" ? "refused_endpoints" : "refused_participants";
  EXPECT_GT(sec[kind].get<int>(), 0) << nj.dump() << "\n" << read_text(dir_ / "node.err");
  ASSERT_FALSE(diag.last.empty()) << "the witness saw no /diagnostics\n"
                                  << read_text(dir_ / "node.err");
  const std::string seen = diag.last["red: node/" + kind];
  EXPECT_GT(std::stoul(seen.empty() ? "0" : seen), 0U) << kind << " in /diagnostics: " << seen;
  EXPECT_EQ(diag.last["red: node/released"], "0");
  RecordProperty("refused_participants", sec["refused_participants"].dump());
  RecordProperty("refused_endpoints", sec["refused_endpoints"].dump());
  RecordProperty("diagnostics_refused_participants", diag.last["red: node/refused_participants"]);
}

INSTANTIATE_TEST_SUITE_P(DdsNodeSecure, DdsNodeSecureRefuses,
                         ::testing::Values("unauthenticated", "other-ca", "no-permission"),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           for (char& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });
#endif

// What a test in a network namespace needs: root, unshare and the tools it names.
bool netns_skip(const std::vector<std::string>& tools, std::string& why) {
  if (geteuid() != 0) {
    why = "needs root (a network namespace of its own)";
    return true;
  }
  if (sh("unshare --net true 2>/dev/null") != 0) {
    why = "cannot make a network namespace here (unshare --net failed)";
    return true;
  }
  for (const std::string& t : tools)
    if (sh("command -v " + t + " >/dev/null 2>&1") != 0) {
      why = t + " is not installed (scripts/deps.sh installs it)";
      return true;
    }
  return false;
}

// How many times `needle` occurs in the file `path`.
std::size_t occurrences(const fs::path& path, const std::string& needle) {
  const std::string hay = read_text(path);
  std::size_t n = 0;
  for (std::size_t at = hay.find(needle); at != std::string::npos; at = hay.find(needle, at + 1))
    ++n;
  return n;
}

#ifdef RED_FASTDDS_PEER
// The secure node and the secure peer on the loopback of a namespace of their own, captured
// with tcpdump: the frames' pixels (the peer's first row, bytes 0, 1, 2, ...), their
// encoding and frame_id, and the diagnostics' keys never appear in clear. The same exchange
// without security, captured the same way, holds all of them: the check can see them.
TEST_F(DdsNodeSecure, EncryptedTrafficHoldsNoPixelsOrResultsInClear) {
  std::string why;
  if (netns_skip({"tcpdump", "ip"}, why)) GTEST_SKIP() << why;
  const std::string d = std::to_string(test_domain());
  const auto capture = [&](bool secure) {
    const fs::path sub = dir_ / (secure ? "secure" : "open");
    fs::create_directories(sub);
    const fs::path pcap = sub / "lo.pcap";
    std::string node = node_command(d, 5, sub);
    std::string peer = quote(kPeer) + " " + d + " 20 20 1.5 ";
    if (secure) {
      peer += quote((Keystores::get().a / "enclaves/cam4").string());
    } else {
      node = "env -u ROS_SECURITY_ENABLE " + node.substr(node.find(quote(kRed)), std::string::npos);
      node.replace(node.find(" --security-enclave /red/node"), 29, "");
    }
    const std::string script = "ip link set lo up && (tcpdump -i lo -s 0 -U -w " +
                               quote(pcap.string()) + " udp 2>/dev/null & tp=$!; sleep 1; (" +
                               node + ") & np=$!; " + peer + " > " +
                               quote((sub / "peer.json").string()) +
                               " 2>/dev/null; wait $np; rc=$?; sleep 0.5; kill $tp; "
                               "wait $tp; exit $rc)";
    EXPECT_EQ(sh("unshare --net bash -c " + quote(script)), 0) << read_text(sub / "node.err");
    const auto r = read_json(sub / "peer.json");
    EXPECT_GT(r.value("outputs", nlohmann::json::object())
                  .value("/red/drive/L", nlohmann::json::object())
                  .value("count", 0),
              0)
        << (secure ? "secure" : "open") << ": no results came back\n"
        << read_text(sub / "node.err");
    return pcap;
  };
  std::string row;  // the first 48 bytes of every frame's first row
  for (int i = 0; i < 48; ++i) row += static_cast<char>(i);
  // Pixels, the image header's strings, the diagnostics' names and keys (results). Not topic
  // names: the node's permissions, which list them, cross in clear in the authentication
  // handshake (as DDS Security specifies: permissions are signed, not secret).
  const std::vector<std::string> secrets = {row,         "fastdds_camera", "bgr8",
                                            "red: node", "red: drive",     "latency_p99_ms"};
  const fs::path open = capture(false);
  for (const std::string& s : secrets)
    EXPECT_GT(occurrences(open, s), 0u) << "the open capture should hold it: " << s.substr(0, 14);
  const fs::path secure = capture(true);
  EXPECT_GT(fs::file_size(secure), 10000u) << "the secure capture holds (almost) nothing";
  for (const std::string& s : secrets)
    EXPECT_EQ(occurrences(secure, s), 0u) << "in clear on the wire: " << s.substr(0, 14);
}
#endif

// A bad link between `red camera` and `red node` (open, on the loopback of a namespace of
// the test's own): nftables drops a share of the domain's UDP packets, or all of them for
// 2 s, in the middle of the run (not at its start or end, where a lost frame cannot be told
// from one never sent). Every frame the camera published is taken by the node or counted
// lost (node.json), and results go on after an outage.
struct LinkCase {
  const char* name;
  int loss_percent;  // 100: an outage
  bool reliable;
};

class DdsNodeLink : public test::ScratchTest, public ::testing::WithParamInterface<LinkCase> {};

TEST_P(DdsNodeLink, EveryFrameIsReleasedOrCountedLost) {
  std::string why;
  if (netns_skip({"nft", "ip"}, why)) GTEST_SKIP() << why;
  const LinkCase c = GetParam();
  const int domain = test_domain();
  const std::string d = std::to_string(domain);
  const std::string ports =
      std::to_string(7400 + 250 * domain) + "-" + std::to_string(7400 + 250 * domain + 249);
  const fs::path qos = dir_ / "qos.yaml";
  std::ofstream(qos) << "input: {reliability: " << (c.reliable ? "reliable" : "best_effort")
                     << ", depth: 10}\n";
  const std::string drop = c.loss_percent >= 100
                               ? "udp dport " + ports + " drop"
                               : "udp dport " + ports + " numgen random mod 100 < " +
                                     std::to_string(c.loss_percent) + " drop";
  const std::string node = quote(kRed) + " node " + quote(kScenario) +
                           " --backend synthetic --duration 8 --domain " + d + " --qos-file " +
                           quote(qos.string()) + " --out " + quote((dir_ / "run").string()) +
                           " 2> " + quote((dir_ / "node.err").string());
  const std::string camera = quote(kRed) + " camera --size 64x48 --rate 20 --duration 5 --domain " +
                             d + " --qos-file " + quote(qos.string()) + " 2> " +
                             quote((dir_ / "camera.err").string());
  const std::string script =
      "ip link set lo up && nft add table inet red && nft add chain inet red c "
      "'{ type filter hook input priority 0; }' && (" +
      node + ") & sleep 1; (" + camera + ") & cp=$!; sleep 2; nft add rule inet red c \"" + drop +
      "\" || exit 3; sleep 2; nft flush chain inet red c; wait $cp; wait";
  EXPECT_EQ(sh("unshare --net bash -c " + quote(script)), 0);
  const std::string cam = read_text(dir_ / "camera.err");
  const auto at = cam.find("published ");
  ASSERT_NE(at, std::string::npos) << cam;
  const int sent = std::stoi(cam.substr(at + 10));
  const auto nj = read_json(dir_ / "run/node.json");
  ASSERT_FALSE(nj.is_discarded()) << read_text(dir_ / "node.err");
  const int frames = nj["frames"].get<int>();
  const int lost = nj["not_taken_by_reason"]["lost_in_transport"].get<int>();
  // Every frame is accounted for: taken, or counted lost. The node infers a best-effort
  // frame's loss from the gaps between header stamps (a sensor_msgs/Image has no sequence
  // number), so the count can be one short (the camera's first frame, sent before the node's
  // reader had matched its writer, leaves no gap) or over (a frame the camera sent more
  // than half a period late looks like a gap; seen on this loaded 2-core machine: docs/ROS2.md,
  // "A bad link"): what is asserted is that none goes unaccounted beyond that first one, and
  // that the node never takes more frames than were sent.
  const int accounted = frames + nj["not_taken"].get<int>();
  EXPECT_GE(accounted, sent - 1) << nj.dump() << "\n" << cam;
  EXPECT_LE(frames, sent) << nj.dump();
  RecordProperty("accounted_minus_sent", accounted - sent);
  // An outage loses frames whatever the QoS (a reliable writer keeps only its depth); a
  // random 5 % of some 40 frames may lose none, so only the accounting is asserted there.
  const bool outage = c.loss_percent >= 100;
  if (outage) {
    EXPECT_GT(lost, 0) << nj.dump();
  }
  EXPECT_GT(nj["released"].get<int>(), 0);
  RecordProperty("sent", sent);
  RecordProperty("frames", frames);
  RecordProperty("lost_in_transport", lost);
  // Results go on after the link comes back: the camera-triggered operation's releases
  // (jobs.csv), their largest gap the outage (or a burst of losses), and completed jobs after
  // it. The gap beyond the outage's 2 s is when results resumed: recorded, not asserted.
  std::istringstream jobs(read_text(dir_ / "run/jobs.csv"));
  std::string line;
  std::vector<std::pair<double, std::string>> drive;  // release_ms, outcome
  std::getline(jobs, line);
  ASSERT_EQ(line.rfind("policy,operation,job,release_ms,finish_ms,deadline_ms,outcome", 0), 0u)
      << line;
  while (std::getline(jobs, line)) {
    std::vector<std::string> f;
    std::istringstream row(line);
    for (std::string x; std::getline(row, x, ',');) f.push_back(x);
    if (f.size() > 6 && f[1] == "drive") drive.emplace_back(std::stod(f[3]), f[6]);
  }
  std::sort(drive.begin(), drive.end());
  ASSERT_GT(drive.size(), 10u);
  std::size_t after = 1;
  double gap = 0;
  for (std::size_t i = 1; i < drive.size(); ++i)
    if (drive[i].first - drive[i - 1].first > gap) {
      gap = drive[i].first - drive[i - 1].first;
      after = i;
    }
  const auto completed_after =
      std::count_if(drive.begin() + static_cast<std::ptrdiff_t>(after), drive.end(),
                    [](const auto& j) { return j.second == "met" || j.second == "missed"; });
  if (outage) {
    EXPECT_GE(completed_after, 5) << "results did not resume after the outage (" << gap << " ms)";
  }
  RecordProperty("largest_release_gap_ms", std::to_string(gap));
}

INSTANTIATE_TEST_SUITE_P(DdsNodeLink, DdsNodeLink,
                         ::testing::Values(LinkCase{"loss5_best_effort", 5, false},
                                           LinkCase{"loss20_reliable", 20, true},
                                           LinkCase{"outage_best_effort", 100, false},
                                           LinkCase{"outage_reliable", 100, true}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

}  // namespace
}  // namespace red::dds
