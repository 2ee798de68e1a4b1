/// \file
/// WakeupLatencyHold (red/runtime/wakeup_latency.hpp): a PM QoS request on /dev/cpu_dma_latency.

#include "red/runtime/wakeup_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <utility>

namespace red {

namespace {
constexpr const char* kDevice = "/dev/cpu_dma_latency";
}  // namespace

WakeupLatencyHold WakeupLatencyHold::zero() {
  WakeupLatencyHold h;
  // The kernel reads one 32-bit value in microseconds and keeps it while the file is open.
  const int fd = ::open(kDevice, O_WRONLY | O_CLOEXEC);
  const std::int32_t zero = 0;
  if (fd >= 0 && ::write(fd, &zero, sizeof zero) == static_cast<ssize_t>(sizeof zero)) {
    h.fd_ = fd;
    h.report_ = std::string("CPU wake-up latency: held at 0 us (") + kDevice + ")";
    return h;
  }
  const int err = errno;
  if (fd >= 0) ::close(fd);
  h.report_ =
      std::string("CPU wake-up latency: not held (") + kDevice + ": " + std::strerror(err) + ")";
  return h;
}

WakeupLatencyHold::WakeupLatencyHold(WakeupLatencyHold&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), report_(std::move(other.report_)) {}

WakeupLatencyHold& WakeupLatencyHold::operator=(WakeupLatencyHold&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = std::exchange(other.fd_, -1);
    report_ = std::move(other.report_);
  }
  return *this;
}

WakeupLatencyHold::~WakeupLatencyHold() {
  release();
}

void WakeupLatencyHold::release() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

}  // namespace red
