/// \file
/// `red security` (docs/ROS2.md, "Security"): an SROS2 keystore where ROS 2 is not installed.
/// `create-keystore DIR` and `create-enclave DIR /name` make the files and links that
/// `ros2 security create-keystore` and `create-enclave` make, with the `openssl` program
/// (ECDSA P-256 keys, X.509 certificates, governance and permissions signed as S/MIME), so
/// that either tool's keystore works with the other's enclaves. With `--scenario`, an
/// enclave's permissions are those `red node` needs for that scenario and no more.
/// Built only with the DDS bridge (RED_HAVE_DDS).

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "red/dds/node.hpp"
#include "red/dds/security.hpp"

extern char** environ;

namespace red::cli {

namespace {

namespace fs = std::filesystem;

// Runs openssl with `args` (no shell); Error with its messages when it fails.
Expected<bool> openssl(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all{"openssl"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "openssl", &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0)
    return Error{"", 0,
                 std::string("cannot run openssl (") + std::strerror(rc) +
                     "): install it (apt-get install openssl)"};
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::ifstream f(log);
  std::stringstream ss;
  ss << f.rdbuf();
  std::error_code ec;
  fs::remove(log, ec);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return true;
  std::string cmd;
  for (std::size_t i = 0; i + 1 < argv.size(); ++i) cmd += (i ? " " : "") + all[i];
  return Error{"", 0, "`" + cmd + "` failed: " + ss.str()};
}

Expected<bool> write_text(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  if (!(f << text) || !(f.flush()))
    return Error{path.string(), 0, std::string("cannot write: ") + std::strerror(errno)};
  return true;
}

// A symbolic link `link` -> `target` (relative), replacing any there.
Expected<bool> make_link(const fs::path& target, const fs::path& link) {
  std::error_code ec;
  fs::remove(link, ec);
  fs::create_symlink(target, link, ec);
  if (ec) return Error{link.string(), 0, "cannot create a symbolic link: " + ec.message()};
  return true;
}

// An ECDSA P-256 private key (PKCS#8 PEM, unencrypted, as SROS2 writes it).
Expected<bool> new_key(const fs::path& key, const fs::path& log) {
  return openssl(
      {"genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", key.string()},
      log);
}

// Signs `xml` into `p7s` as S/MIME (text, detached), as SROS2 does.
Expected<bool> sign(const fs::path& xml, const fs::path& p7s, const fs::path& ks,
                    const fs::path& log) {
  return openssl({"smime", "-sign", "-text", "-in", xml.string(), "-out", p7s.string(), "-signer",
                  (ks / "public/permissions_ca.cert.pem").string(), "-inkey",
                  (ks / "private/permissions_ca.key.pem").string()},
                 log);
}

// UTC time `years` from now, as permissions.xml's validity has it.
std::string utc(int years) {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  tm.tm_year += years;
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

// An openssl configuration of our own, so that the system's openssl.cnf changes nothing.
constexpr const char* kOpensslConfig =
    "[req]\ndistinguished_name = dn\nprompt = no\n[dn]\n"
    "[ca]\nbasicConstraints = critical, CA:true\nsubjectKeyIdentifier = hash\n"
    "authorityKeyIdentifier = keyid:always\n"
    "[leaf]\nbasicConstraints = CA:false\nsubjectKeyIdentifier = hash\n"
    "authorityKeyIdentifier = keyid,issuer\n";

Expected<bool> create_keystore(const fs::path& ks) {
  std::error_code ec;
  for (const char* d : {"public", "private", "enclaves"}) {
    fs::create_directories(ks / d, ec);
    if (ec) return Error{(ks / d).string(), 0, "cannot create the directory: " + ec.message()};
  }
  const fs::path log = ks / "private/openssl.log", cnf = ks / "private/openssl.cnf";
  if (auto r = write_text(cnf, kOpensslConfig); !r) return r;
  const fs::path key = ks / "private/ca.key.pem", cert = ks / "public/ca.cert.pem";
  if (!fs::exists(key)) {
    if (auto r = new_key(key, log); !r) return r;
    fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write, ec);
    // One CA for identities and permissions, self-signed, 10 years: SROS2's "sros2testCA".
    if (auto r = openssl(
            {"req", "-config", cnf.string(), "-new", "-x509", "-sha256", "-days", "3650", "-key",
             key.string(), "-subj", "/CN=sros2testCA", "-extensions", "ca", "-out", cert.string()},
            log);
        !r)
      return r;
  }
  for (const char* n : {"identity_ca", "permissions_ca"}) {
    if (auto r = make_link("ca.cert.pem", ks / "public" / (std::string(n) + ".cert.pem")); !r)
      return r;
    if (auto r = make_link("ca.key.pem", ks / "private" / (std::string(n) + ".key.pem")); !r)
      return r;
  }
  const fs::path gov = ks / "enclaves/governance.xml";
  if (auto r = write_text(gov, dds::governance_xml()); !r) return r;
  return sign(gov, ks / "enclaves/governance.p7s", ks, log);
}

// The grant `red node` needs for a scenario (with the node's remaps).
Expected<dds::Grant> scenario_grant(const ScenarioArgs& sa,
                                    const std::vector<std::string>& remaps) {
  auto s = load(sa);
  if (!s) return s.error();
  dds::Remaps r;
  for (const std::string& rule : remaps)
    if (auto ok = r.add(rule); !ok) return ok.error();
  const dds::NodeTopics t = dds::node_topics(*s, r);
  std::vector<std::string> outputs;
  for (const auto& [key, topic] : t.nodes) {
    const int head = t.heads.at(key);
    if (head < 0) continue;
    outputs.push_back(topic);
    if (dds::output_kind(s->model.heads[static_cast<std::size_t>(head)]) ==
        dds::OutputKind::Velocity)
      outputs.push_back(topic + "/stamped");
  }
  return dds::node_grant(t.sensors, outputs, t.diagnostics);
}

// A new key and a certificate for enclave `name`, signed by the identity CA.
Expected<bool> new_identity(const fs::path& ks, const fs::path& dir, const std::string& name,
                            const fs::path& key, const fs::path& csr, const fs::path& cnf,
                            const fs::path& log) {
  std::error_code ec;
  if (auto r = new_key(key, log); !r) return r;
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write, ec);
  // The subject is the enclave's name (CN=/red/node): '/' is escaped for -subj.
  std::string cn;
  for (const char c : name) cn += c == '/' ? std::string("\\/") : std::string(1, c);
  if (auto r = openssl({"req", "-config", cnf.string(), "-new", "-key", key.string(), "-subj",
                        "/CN=" + cn, "-out", csr.string()},
                       log);
      !r)
    return r;
  if (auto r = openssl({"x509", "-req", "-in", csr.string(), "-CA",
                        (ks / "public/identity_ca.cert.pem").string(), "-CAkey",
                        (ks / "private/identity_ca.key.pem").string(), "-set_serial",
                        std::to_string(std::time(nullptr)) + std::to_string(getpid()), "-days",
                        "3650", "-sha256", "-extfile", cnf.string(), "-extensions", "leaf", "-out",
                        (dir / "cert.pem").string()},
                       log);
      !r)
    return r;
  fs::remove(csr, ec);
  return true;
}

Expected<bool> create_enclave(const fs::path& ks, const std::string& name, const dds::Grant& g) {
  std::error_code ec;
  for (const char* f : {"public/identity_ca.cert.pem", "private/identity_ca.key.pem",
                        "public/permissions_ca.cert.pem", "private/permissions_ca.key.pem",
                        "enclaves/governance.p7s"})
    if (!fs::exists(ks / f))
      return Error{(ks / f).string(), 0,
                   "not in the keystore: make it first with `red security create-keystore " +
                       ks.string() + "`"};
  const fs::path dir = ks / "enclaves" / name.substr(1);
  fs::create_directories(dir, ec);
  if (ec) return Error{dir.string(), 0, "cannot create the directory: " + ec.message()};
  const fs::path log = dir / "openssl.log", cnf = ks / "private/openssl.cnf";
  if (auto r = write_text(cnf, kOpensslConfig); !r) return r;
  // Links as SROS2 makes them, relative to the enclave's directory.
  const fs::path up = fs::relative(ks, dir, ec);
  if (auto r = make_link(up / "public/identity_ca.cert.pem", dir / "identity_ca.cert.pem"); !r)
    return r;
  if (auto r = make_link(up / "public/permissions_ca.cert.pem", dir / "permissions_ca.cert.pem");
      !r)
    return r;
  if (auto r = make_link(up / "enclaves/governance.p7s", dir / "governance.p7s"); !r) return r;
  // An enclave's existing key and certificate are kept (its permissions are rewritten).
  const fs::path key = dir / "key.pem", csr = dir / "req.csr";
  if (!fs::exists(key) || !fs::exists(dir / "cert.pem")) {
    if (auto r = new_identity(ks, dir, name, key, csr, cnf, log); !r) return r;
  }
  const fs::path perms = dir / "permissions.xml";
  if (auto r = write_text(perms, dds::permissions_xml(name, g, utc(0), utc(10))); !r) return r;
  return sign(perms, dir / "permissions.p7s", ks, log);
}

struct SecurityArgs {
  std::string keystore;
  std::string enclave;
  ScenarioArgs scenario;
  std::vector<std::string> remaps;
};

}  // namespace

void register_security(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<SecurityArgs>();
  CLI::App* cmd = app.add_subcommand(
      "security", "DDS Security keystores and enclaves, as `ros2 security` makes them (SROS2)");
  cmd->require_subcommand(1);
  CLI::App* ks = cmd->add_subcommand(
      "create-keystore", "Make a keystore: a CA, governance.p7s (ros2 security create-keystore)");
  ks->add_option("dir", a->keystore, "Keystore directory (created)")->required();
  ks->callback([a, &exit_code] {
    if (auto r = create_keystore(a->keystore); !r) {
      print_error(r.error());
      exit_code = kBadInput;
      return;
    }
    std::cerr << "red security: keystore " << a->keystore << '\n';
  });
  CLI::App* en = cmd->add_subcommand(
      "create-enclave",
      "Make an enclave: key, certificate, permissions.p7s (ros2 security create-enclave)");
  en->add_option("dir", a->keystore, "Keystore directory")->required();
  en->add_option("name", a->enclave, "Enclave name, e.g. /red/node")->required();
  en->add_option("--scenario", a->scenario.path,
                 "Grant only what `red node` needs for this scenario: subscribe to its sensors' "
                 "topics, publish its results and /diagnostics (default: every topic, as "
                 "SROS2 without a policy)");
  en->add_option("--set", a->scenario.sets, "Override a scenario value: key=value");
  en->add_option("--remap", a->remaps, "The node's topic renames, from:=to (repeatable)");
  en->callback([a, &exit_code] {
    auto checked = dds::resolve_security({a->keystore, "", "true", "Permissive"}, a->enclave);
    if (!checked) {  // only a malformed name fails here
      print_error(checked.error());
      exit_code = kBadInput;
      return;
    }
    auto grant = a->scenario.path.empty() ? Expected<dds::Grant>(dds::open_grant())
                                          : scenario_grant(a->scenario, a->remaps);
    if (!grant) {
      print_error(grant.error());
      exit_code = kBadInput;
      return;
    }
    if (auto r = create_enclave(fs::absolute(a->keystore), a->enclave, *grant); !r) {
      print_error(r.error());
      exit_code = kBadInput;
      return;
    }
    std::cerr << fmt::format("red security: enclave {} in {} (publish {} topic(s), subscribe {})\n",
                             a->enclave, a->keystore, grant->publish.size(),
                             grant->subscribe.size());
  });
}

}  // namespace red::cli
