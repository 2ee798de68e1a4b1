/// \file
/// Stop signals: a flag and a self-pipe written by the handler, read by a watcher thread.

#include "signals.hpp"

#include "red/core/stop.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <mutex>
#include <utility>

namespace red::cli {

namespace {

static_assert(std::atomic<int>::is_always_lock_free, "the handler needs a lock-free atomic");

std::atomic<int> g_signal{0};
std::atomic<bool> g_quit{false};  // the StopWatch alive is ending
int g_pipe[2] = {-1, -1};         // [0] read by the watcher, [1] written by the handler

// Only async-signal-safe work: an atomic store and a write(2) that cannot block.
extern "C" void on_stop_signal(int sig) {
  int expected = 0;
  g_signal.compare_exchange_strong(expected, sig);
  red::request_stop();  // simulations and analyses in progress end early
  const int saved = errno;
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = write(g_pipe[1], &byte, 1);
  errno = saved;
}

void poke_watcher() {
  const char byte = 0;
  [[maybe_unused]] const ssize_t n = write(g_pipe[1], &byte, 1);
}

}  // namespace

void install_stop_signals() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (pipe2(g_pipe, O_CLOEXEC) != 0) return;  // no pipe: the signals keep their default
    fcntl(g_pipe[1], F_SETFL, fcntl(g_pipe[1], F_GETFL) | O_NONBLOCK);
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    // Interrupted system calls resume (a file being written stays whole); a second signal
    // of the same kind takes its default action and ends the process at once.
    sa.sa_flags = SA_RESTART | SA_RESETHAND;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
  });
}

int stop_signal() noexcept {
  return g_signal.load();
}

const char* stop_signal_name() noexcept {
  switch (g_signal.load()) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    default:
      return "";
  }
}

int stop_exit_code() noexcept {
  return 128 + g_signal.load();
}

StopWatch::StopWatch(std::function<void()> on_stop) : on_stop_(std::move(on_stop)) {
  if (g_pipe[0] < 0) return;  // install_stop_signals() not called, or it failed
  g_quit.store(false);
  thread_ = std::thread([this] {
    for (;;) {
      if (g_signal.load() != 0) {
        on_stop_();
        return;
      }
      if (g_quit.load()) return;
      pollfd p{g_pipe[0], POLLIN, 0};
      if (poll(&p, 1, -1) > 0 && (p.revents & POLLIN) != 0) {
        char buf[64];
        [[maybe_unused]] const ssize_t n = read(g_pipe[0], buf, sizeof buf);
      }
    }
  });
}

StopWatch::~StopWatch() {
  if (!thread_.joinable()) return;
  g_quit.store(true);
  poke_watcher();
  thread_.join();
}

}  // namespace red::cli
