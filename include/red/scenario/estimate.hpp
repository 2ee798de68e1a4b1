#pragma once
/// \file
/// The names of the estimate kinds (EstimateKind, red/scenario/scenario.hpp): the one
/// spelling used by scenario files (`estimate`), the `drop_estimate` policy option and the
/// reports (`red analyze`, `red validate`).

#include <array>
#include <utility>

#include "red/scenario/scenario.hpp"

namespace red {

/// Every estimate kind with its name, in the order of EstimateKind.
inline constexpr std::array<std::pair<const char*, EstimateKind>, 4> kEstimateKinds{
    {{"mean", EstimateKind::Mean},
     {"p95", EstimateKind::P95},
     {"p99", EstimateKind::P99},
     {"max", EstimateKind::Max}}};

/// "mean", "p95", "p99" or "max" (kEstimateKinds).
inline const char* to_string(EstimateKind k) noexcept {
  for (const auto& [name, kind] : kEstimateKinds)
    if (kind == k) return name;
  return "?";
}

}  // namespace red
