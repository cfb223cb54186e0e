// Scans released in arrival order; one that never settles is given up after the bound.

#include <gtest/gtest.h>

#include <vector>

#include "rrr_graphslam/ros/arrival_order.h"

namespace rrr_graphslam::ros_adapter {
namespace {

TEST(ArrivalOrder, ReleasesInArrivalOrderOnceEveryEarlierItemSettled) {
  ArrivalOrder<int, int> order;
  for (int k = 0; k < 4; ++k) order.arrived(k, 0.1 * k);
  EXPECT_TRUE(order.settle(2, 20));
  EXPECT_TRUE(order.release().empty());        // 0 and 1 still wait
  EXPECT_TRUE(order.settle(1, std::nullopt));  // dropped
  EXPECT_TRUE(order.settle(0, 0));
  EXPECT_EQ(order.release(), (std::vector<int>{0, 20}));
  EXPECT_EQ(order.waiting(), 1u);
  EXPECT_FALSE(order.settle(2, 21));  // released already
  EXPECT_FALSE(order.settle(9, 90));  // never arrived
}

TEST(ArrivalOrder, AnItemThatNeverSettlesIsGivenUpAfterTheBound) {
  ArrivalOrder<int, int> order;
  order.arrived(0, 10.0);  // its transform never comes
  for (int k = 1; k <= 100; ++k) {
    order.arrived(k, 10.0 + 0.01 * k);
    order.settle(k, k);
  }
  EXPECT_TRUE(order.release().empty());
  EXPECT_TRUE(order.expire(10.1, 0.2).empty());  // within the bound: still waits
  EXPECT_EQ(order.waiting(), 101u);
  const auto expired = order.expire(10.25, 0.2);
  ASSERT_EQ(expired.size(), 1u);
  EXPECT_EQ(expired[0].first, 0);
  EXPECT_EQ(order.release().size(), 100u);
  EXPECT_EQ(order.waiting(), 0u);
  // Late settling of the given-up item is refused, so the caller neither counts nor forwards it.
  EXPECT_FALSE(order.settle(0, 0));
}

TEST(ArrivalOrder, OnlyUnsettledItemsOlderThanTheBoundExpire) {
  ArrivalOrder<int, int> order;
  order.arrived(0, 0.0);
  order.arrived(1, 0.0);
  order.arrived(2, 5.0);
  order.settle(1, 1);
  const auto expired = order.expire(1.0, 0.5);
  ASSERT_EQ(expired.size(), 1u);  // 1 settled, 2 is young
  EXPECT_EQ(order.release(), std::vector<int>{1});
  EXPECT_EQ(order.waiting(), 1u);
}

}  // namespace
}  // namespace rrr_graphslam::ros_adapter
