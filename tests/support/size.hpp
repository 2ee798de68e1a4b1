#pragma once
/// \file
/// How large a simulation-heavy property test runs (the load grid, the robot workloads, the
/// ready groups). In the plain build every test runs in full: that is where schedule quality
/// is checked. Under a sanitizer (RED_SANITIZED, set by tests/CMakeLists.txt when RED_SANITIZE
/// is on) the same tests run on a prefix of the same workloads: there they check memory and
/// undefined behaviour, which a few workloads show as well as a few hundred, at a tenth of the
/// time (docs/TESTING.md, "Sanitizers"). The simulator is deterministic, so a test's verdict on
/// that prefix is the same in every build.

#include <cstddef>
#include <vector>

namespace red::test {

#if defined(RED_SANITIZED)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

/// `full` in the plain build, `sanitized` under a sanitizer.
constexpr int sized(int full, int sanitized) {
  return kSanitized ? sanitized : full;
}

/// Every element in the plain build; under a sanitizer every `stride`-th from the first
/// (over the load grid's sets in their order, lanes x shape x nodes, a stride of 5 keeps one
/// set of each lane count, shape and kind of node).
template <class T>
std::vector<T> sized_subset(const std::vector<T>& v, std::size_t stride) {
  if (!kSanitized) return v;
  std::vector<T> out;
  for (std::size_t i = 0; i < v.size(); i += stride) out.push_back(v[i]);
  return out;
}

}  // namespace red::test
