#pragma once
/// \file
/// A backend that spends each unit's profiled time instead of running a network: the
/// sampled execution time of the simulator (common random numbers), spent sleeping or
/// spinning on the lane's thread. It lets the real-time runtime run and be tested without
/// LibTorch, and injects failures and out-of-memory errors on request.

#include <atomic>
#include <cstdint>
#include <functional>

#include "red/runtime/backend.hpp"
#include "red/sim/cost_sampler.hpp"

namespace red {

class SyntheticBackend final : public Backend {
 public:
  struct Options {
    double time_scale = 1.0;  ///< multiplies every sampled time (0: return at once)
    bool spin = false;        ///< spin instead of sleeping (keeps a core busy like compute)
    /// Decides whether a dispatch fails: 0 ok, 1 throws std::runtime_error, 2 throws
    /// OutOfMemoryError, 3 hangs for `hang` before returning normally. Called on the
    /// lane's thread.
    std::function<int(const Dispatch&)> inject;
    Duration hang = std::chrono::seconds{1};  ///< how long an injected hang lasts
  };

  SyntheticBackend(const Scenario& s, const Profile& p, std::uint64_t seed, Options o);

  [[nodiscard]] std::string_view name() const noexcept override { return "synthetic"; }
  void run(int lane, const Dispatch& d) override;

  /// Units run so far (all lanes).
  [[nodiscard]] std::uint64_t runs() const noexcept { return runs_.load(); }

 private:
  CostSampler sampler_;
  Options options_;
  std::atomic<std::uint64_t> runs_{0};
};

}  // namespace red
