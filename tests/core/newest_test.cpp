// keep_newest and newest_since: the "newest N values" window written once for the runtime's
// recent decision times and the ROS 2 node's timing windows, latencies and decision times.

#include "red/core/newest.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace red {
namespace {

TEST(NewestWindow, KeepsTheNewestCapacityValuesOverTheOldest) {
  std::vector<int> ring;
  std::uint64_t n = 0;
  for (int v = 0; v < 3; ++v) keep_newest(ring, n++, 4, v);
  EXPECT_EQ(ring, (std::vector<int>{0, 1, 2}));  // filling: appended in order
  for (int v = 3; v < 7; ++v) keep_newest(ring, n++, 4, v);
  // 3 fills the ring; 4, 5 and 6 go over the oldest, 0, 1 and 2.
  EXPECT_EQ(ring, (std::vector<int>{4, 5, 6, 3}));
}

TEST(NewestWindow, NewestSinceGivesWhatIsStillHeldOldestFirst) {
  std::vector<int> ring;
  std::uint64_t n = 0;
  for (int v = 0; v < 3; ++v) keep_newest(ring, n++, 4, v);
  EXPECT_EQ(newest_since(ring, n, 0), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(newest_since(ring, n, 2), (std::vector<int>{2}));
  EXPECT_TRUE(newest_since(ring, n, 3).empty());  // nothing new since the cursor
  for (int v = 3; v < 10; ++v) keep_newest(ring, n++, 4, v);
  // Ten values, four kept: a cursor older than the ring gets the four it still holds.
  EXPECT_EQ(newest_since(ring, n, 0), (std::vector<int>{6, 7, 8, 9}));
  EXPECT_EQ(newest_since(ring, n, 8), (std::vector<int>{8, 9}));
}

TEST(NewestWindow, AnEmptyRingAndAZeroCapacityHoldNothing) {
  std::vector<double> ring;
  EXPECT_TRUE(newest_since(ring, 0, 0).empty());
  keep_newest(ring, 0, 0, 1.5);
  EXPECT_TRUE(ring.empty());
  EXPECT_TRUE(newest_since(ring, 1, 0).empty());
}

}  // namespace
}  // namespace red
