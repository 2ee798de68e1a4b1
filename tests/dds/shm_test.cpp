// `red node --shm` (docs/ROS2.md, "Shared memory (iceoryx)"): `red camera` -> `red node`
// -> red_ros2_listener through iceoryx shared memory, with a RouDi of the test's own; and
// --shm without a RouDi exits 2 with how to start one.

#include <gtest/gtest.h>

#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <sys/statvfs.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "../support/cli.hpp"
#include "red/dds/ros.hpp"
#include "support.hpp"

extern char** environ;  // NOLINT: POSIX

namespace red::dds {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;

const std::string kRed = RED_CLI;
const std::string kScenario = RED_SOURCE_DIR "/tests/dds/data/node.yaml";

// The full path of `name` on PATH ("" when absent).
[[maybe_unused]] std::string find_program(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  for (std::size_t from = 0; from <= dirs.size();) {
    const std::size_t colon = std::min(dirs.find(':', from), dirs.size());
    const std::string p = dirs.substr(from, colon - from) + "/" + name;
    if (!p.empty() && access(p.c_str(), X_OK) == 0) return p;
    from = colon + 1;
  }
  return "";
}

// A child process: `sh -c 'exec CMD'`, so that its pid is CMD's own.
struct Child {
  pid_t pid = -1;
  Child() = default;
  explicit Child(const std::string& cmd) {
    const std::string line = "exec " + cmd;
    const char* argv[] = {"/bin/sh", "-c", line.c_str(), nullptr};
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) !=
        0)
      pid = -1;
  }
  // Its exit code once it ended (-1: killed by a signal, or not started); waits at most `limit`,
  // then kills it.
  int wait(std::chrono::seconds limit) {
    if (pid <= 0) return -1;
    const auto end = std::chrono::steady_clock::now() + limit;
    int status = 0;
    while (waitpid(pid, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > end) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds{20});
    }
    pid = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  [[nodiscard]] bool running() const {
    int status = 0;
    return pid > 0 && waitpid(pid, &status, WNOHANG) == 0;
  }
};

// A RouDi of the test's own (iceoryx 2.0 has one per host, at fixed paths), stopped with
// SIGINT at the end; what a crashed one would leave in /dev/shm and /tmp is removed then.
struct Roudi {
  Child child;
  std::string config, log;
  bool ready = false;  // seen running: the files at RouDi's fixed paths are this one's
  Roudi(const std::string& exe, const std::string& dir)
      : config(dir + "roudi.toml"), log(dir + "roudi.log") {
    // Pools for the test's 640x480 rgb8 frames (921 KB) and the node's small outputs.
    std::ofstream(config) << "[general]\nversion = 1\n\n[[segment]]\n\n"
                             "[[segment.mempool]]\nsize = 1024\ncount = 512\n\n"
                             "[[segment.mempool]]\nsize = 16384\ncount = 64\n\n"
                             "[[segment.mempool]]\nsize = 1048576\ncount = 24\n";
    child = Child(exe + " -c " + quote(config) + " -l warning > " + quote(log) + " 2>&1");
  }
  ~Roudi() {
    if (child.pid > 0) {
      kill(child.pid, SIGINT);
      child.wait(std::chrono::seconds{15});
    }
    std::error_code ec;
    if (ready) {
      const passwd* pw = getpwuid(geteuid());
      std::vector<std::string> left = {"/dev/shm/iceoryx_mgmt", "/tmp/roudi", "/tmp/roudi.lock",
                                       "/tmp/iox-unique-roudi.lock"};
      if (pw != nullptr) left.push_back(std::string("/dev/shm/") + pw->pw_name);
      for (const std::string& f : left) fs::remove(f, ec);
    }
    fs::remove(config, ec);
    fs::remove(log, ec);
  }
  Roudi(const Roudi&) = delete;
  Roudi& operator=(const Roudi&) = delete;
};

// Removes the IPC sockets iceoryx applications leave in /tmp when killed (named after their pid).
[[maybe_unused]] void remove_app_sockets(const std::vector<pid_t>& pids) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/tmp", ec))
    for (pid_t p : pids)
      if (e.path().filename().string().rfind("iceoryx_rt_" + std::to_string(p) + "_", 0) == 0)
        fs::remove(e.path(), ec);
}

[[maybe_unused]] std::size_t count_lines_with(const std::string& text, const std::string& a,
                                              const std::string& b) {
  std::size_t n = 0;
  std::size_t from = 0;
  while (from < text.size()) {
    const std::size_t end = std::min(text.find('\n', from), text.size());
    const std::string_view line(text.data() + from, end - from);
    if (line.find(a) != std::string_view::npos && line.find(b) != std::string_view::npos) ++n;
    from = end + 1;
  }
  return n;
}

TEST(DdsNodeShm, CameraToNodeToListenerThroughSharedMemoryWithARoudiOfItsOwn) {
#ifndef RED_ROS2_LISTENER
  GTEST_SKIP() << "built without the bench programs (RED_BUILD_BENCH=OFF): no red_ros2_listener";
#else
  const std::string roudi_exe = find_program("iox-roudi");
  if (roudi_exe.empty())
    GTEST_SKIP() << "iox-roudi not found (Debian package iceoryx, installed by scripts/deps.sh): "
                    "shared memory is not tested";
  if (roudi_running())
    GTEST_SKIP() << "a RouDi already runs on this host: iceoryx 2.0 has one per host (fixed "
                    "paths /tmp/roudi, /dev/shm/iceoryx_mgmt) and this test needs its own";
  struct statvfs vfs {};
  const double free_mb =
      statvfs("/dev/shm", &vfs) == 0
          ? static_cast<double>(vfs.f_bavail) * static_cast<double>(vfs.f_frsize) / 1e6
          : 0.0;
  // RouDi's management segment (66 MB with Debian's iceoryx 2.0.3) and the test's pools (33 MB).
  if (free_mb < 128)
    GTEST_SKIP() << "/dev/shm has " << free_mb
                 << " MB free; RouDi needs about 100 MB (a container's default is 64 MB: "
                    "docker run --shm-size=256m)";

  const std::string dir = ::testing::TempDir() + "red_shm_" + std::to_string(getpid()) + "_";
  const std::string d = " --domain " + std::to_string(test_domain());
  const std::string listener = RED_ROS2_LISTENER;

  // Without RouDi, --shm is refused with exit 2 and how to start it (iceoryx itself would
  // wait for RouDi and then abort the process).
  {
    const std::string err = dir + "noroudi.err";
    for (const std::string& cmd :
         {kRed + " node " + quote(kScenario) + " --backend synthetic --duration 1 --shm" + d,
          kRed + " camera --count 1 --shm" + d,
          listener + " --deadline-ms 100 --topic image:/x --timeout 1 --shm" + d}) {
      SCOPED_TRACE(cmd);
      Child c(cmd + " 2> " + quote(err));
      EXPECT_EQ(c.wait(std::chrono::seconds{60}), 2);
      const std::string text = read_text(err);
      EXPECT_NE(text.find("RouDi"), std::string::npos) << text;
      EXPECT_NE(text.find("iox-roudi"), std::string::npos) << text;
    }
    std::remove(err.c_str());
  }

  Roudi roudi(roudi_exe, dir);
  ASSERT_GT(roudi.child.pid, 0);
  const auto t0 = std::chrono::steady_clock::now();
  while (!roudi_running() && roudi.child.running() &&
         std::chrono::steady_clock::now() - t0 < std::chrono::seconds{20})
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
  ASSERT_TRUE(roudi_running() && roudi.child.running())
      << "RouDi did not start: " << read_text(roudi.log);
  roudi.ready = true;

  // The camera traces what Cyclone does (the loopback configuration plus a trace file): a
  // sample that goes over RTPS (UDP) is traced as write_sample, one through iceoryx is not.
  const std::string trace = dir + "camera.trace", camera_config = dir + "camera.xml";
  std::ofstream(camera_config) << loopback_config()
                               << ",<CycloneDDS><Domain Id=\"any\"><Tracing><Verbosity>finest"
                                  "</Verbosity><OutputFile>"
                               << trace << "</OutputFile></Tracing></Domain></CycloneDDS>";
  const std::string node_err = dir + "node.err", listener_out = dir + "listener.json",
                    listener_err = dir + "listener.err", camera_err = dir + "camera.err";
  Child node(kRed + " node " + quote(kScenario) + " --backend synthetic --shm" + d + " 2> " +
             quote(node_err));
  ASSERT_GT(node.pid, 0);
  const auto t1 = std::chrono::steady_clock::now();
  while (read_text(node_err).find("out /diagnostics") == std::string::npos && node.running() &&
         std::chrono::steady_clock::now() - t1 < std::chrono::seconds{30})
    std::this_thread::sleep_for(std::chrono::milliseconds{50});
  ASSERT_TRUE(node.running()) << read_text(node_err);
  Child probe(listener + " --deadline-ms 200 --warmup 0 --idle 2 --timeout 60 --shm" + d +
              " --camera-stamps /camera/stamps --topic image:/red/drive/L"
              " --topic image:/red/drive/S --topic twist_stamped:/red/drive/C/stamped"
              " --topic detections:/red/detect/O --topic twist:/red/drive/C"
              " --topic diagnostics:/diagnostics > " +
              quote(listener_out) + " 2> " + quote(listener_err));
  std::this_thread::sleep_for(std::chrono::milliseconds{500});
  Child camera(kRed + " camera --rate 20 --count 40 --size 640x480 --shm" + d +
               " --stamps-topic /camera/stamps --config " + quote(camera_config) + " 2> " +
               quote(camera_err));
  const std::vector<pid_t> pids = {node.pid, probe.pid, camera.pid};
  EXPECT_EQ(camera.wait(std::chrono::seconds{60}), 0) << read_text(camera_err);
  EXPECT_EQ(probe.wait(std::chrono::seconds{90}), 0) << read_text(listener_err);
  kill(node.pid, SIGINT);
  EXPECT_EQ(node.wait(std::chrono::seconds{30}), 0) << read_text(node_err);
  remove_app_sockets(pids);

  EXPECT_NE(read_text(node_err).find("shared memory"), std::string::npos) << read_text(node_err);
  const nlohmann::json out = nlohmann::json::parse(read_text(listener_out), nullptr, false);
  ASSERT_TRUE(out.is_object()) << read_text(listener_out) << read_text(listener_err);
  EXPECT_GT(out["camera_samples"].get<int>(), 0);
  // Every output type arrived, each stamped output with the header of a frame the camera
  // sent: the listener matches outputs to the camera's stamps. Outputs of the first frames,
  // sent before the probe's reader of the stamps was connected, cannot be checked (at most a
  // few).
  for (const std::string t :
       {"/red/drive/L", "/red/drive/S", "/red/drive/C/stamped", "/red/detect/O"}) {
    SCOPED_TRACE(t);
    EXPECT_GT(out["topics"][t]["samples"].get<int>(), 0) << out.dump();
    EXPECT_GT(out["topics"][t]["frames"].get<int>(), 0) << out.dump();
  }
  for (const std::string t : {"/red/drive/C", "/diagnostics"})
    EXPECT_GT(out["counted"][t].get<int>(), 0) << t << ": " << out.dump();
  EXPECT_GT(out["complete"].get<int>(), 0) << out.dump();
  EXPECT_LE(out["unknown_stamps"].get<int>(), 4) << out.dump();

  // The frames went through shared memory: the camera's image writer has an iceoryx
  // publisher and wrote no sample over RTPS.
  const std::string traced = read_text(trace);
  EXPECT_NE(traced.find("DDS:Cyclone:rt/camera/image_raw"), std::string::npos)
      << "no iceoryx publisher for the frames";
  EXPECT_EQ(count_lines_with(traced, "write_sample", "rt/camera/image_raw/"), 0U)
      << "frames went over RTPS (UDP)";
  for (const std::string& f :
       {trace, camera_config, node_err, listener_out, listener_err, camera_err})
    std::remove(f.c_str());
#endif
}

}  // namespace
}  // namespace red::dds
