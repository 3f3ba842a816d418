// TransformWaiter (src/ros/transform_wait.h): a lookup at a stamp whose transform has not arrived yet returns
// when it arrives, from another thread as the tf listener stores it; otherwise it fails after its timeout with
// tf2's own reason, and it stays usable after that.
#include <gtest/gtest.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>

#include <chrono>
#include <string>
#include <thread>

#include "transform_wait.h"

namespace dqn_dovs {
namespace {

geometry_msgs::TransformStamped odomToBase(double stamp_s, double x) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time(stamp_s);
  t.header.frame_id = "odom";
  t.child_frame_id = "base";
  t.transform.translation.x = x;
  t.transform.rotation.w = 1.0;
  return t;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

class TransformWaiterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(buffer_.setTransform(odomToBase(10.0, 1.0), "test"));
    ASSERT_TRUE(buffer_.setTransform(odomToBase(10.1, 2.0), "test"));
  }
  tf2::BufferCore buffer_;
};

TEST_F(TransformWaiterTest, AvailableTransformIsReturnedWithoutWaiting) {
  TransformWaiter waiter(buffer_);
  const auto t = waiter.lookup("odom", "base", ros::Time(10.05), 0.0);
  EXPECT_NEAR(t.transform.translation.x, 1.5, 1e-9);
  EXPECT_NEAR(waiter.lookup("odom", "base", ros::Time(10.1), 1.0).transform.translation.x, 2.0, 1e-9);
}

TEST_F(TransformWaiterTest, WaitEndsWhenTheTransformArrives) {
  TransformWaiter waiter(buffer_);
  // The stamp is past the newest transform; another thread (as the tf listener would) stores a later one. The
  // timeout is longer than the test may run: only the arrival can end this wait.
  const double timeout_s = 3600.0;
  std::thread listener([this] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    buffer_.setTransform(odomToBase(10.2, 3.0), "test");
  });
  geometry_msgs::TransformStamped t;
  EXPECT_NO_THROW(t = waiter.lookup("odom", "base", ros::Time(10.15), timeout_s));
  listener.join();
  EXPECT_NEAR(t.transform.translation.x, 2.5, 1e-9);
}

TEST_F(TransformWaiterTest, MissingTransformFailsAfterTheTimeoutWithTf2sReason) {
  TransformWaiter waiter(buffer_);
  const double timeout_s = 0.05;
  auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(waiter.lookup("odom", "base", ros::Time(10.5), timeout_s), tf2::ExtrapolationException);
  EXPECT_GE(secondsSince(start), timeout_s);
  // An unknown frame: tf2's lookup error names it.
  try {
    waiter.lookup("odom", "no_such_frame", ros::Time(10.05), timeout_s);
    ADD_FAILURE() << "no exception for an unknown frame";
  } catch (const tf2::TransformException& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_frame"), std::string::npos) << e.what();
  }
  // An empty frame is refused at once: with a wait longer than the test may run, anything else would hang it.
  EXPECT_THROW(waiter.lookup("odom", "", ros::Time(10.05), 3600.0), tf2::InvalidArgumentException);
}

TEST_F(TransformWaiterTest, StaysUsableAfterAWaitThatTimedOut) {
  TransformWaiter waiter(buffer_);
  EXPECT_THROW(waiter.lookup("odom", "base", ros::Time(10.3), 0.02), tf2::ExtrapolationException);
  // The abandoned request is cancelled: the transform arriving now answers only the next lookup.
  buffer_.setTransform(odomToBase(10.3, 4.0), "test");
  EXPECT_NEAR(waiter.lookup("odom", "base", ros::Time(10.3), 0.0).transform.translation.x, 4.0, 1e-9);
  std::thread listener([this] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    buffer_.setTransform(odomToBase(10.4, 5.0), "test");
  });
  EXPECT_NEAR(waiter.lookup("odom", "base", ros::Time(10.4), 20.0).transform.translation.x, 5.0, 1e-9);
  listener.join();
}

TEST_F(TransformWaiterTest, TwoWaitersOnOneBufferAreEachWoken) {
  // Each waiter registers its own callback on the buffer; two waiters on one buffer must not take each other's
  // answers.
  TransformWaiter a(buffer_), b(buffer_);
  double xa = 0.0, xb = 0.0;
  std::thread ta([&] { xa = a.lookup("odom", "base", ros::Time(10.25), 20.0).transform.translation.x; });
  std::thread tb([&] { xb = b.lookup("odom", "base", ros::Time(10.15), 20.0).transform.translation.x; });
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  buffer_.setTransform(odomToBase(10.3, 4.0), "test");
  ta.join();
  tb.join();
  EXPECT_NEAR(xa, 3.5, 1e-9);
  EXPECT_NEAR(xb, 2.5, 1e-9);
}

}  // namespace
}  // namespace dqn_dovs
