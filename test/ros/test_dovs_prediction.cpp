// Node-level test: dovs_node with people_predictor. The test node plays the robot standing at the odom origin (tf,
// odom) and the tracker (one track at 10 Hz, a person walking a 0.6 rad/s turn ahead, reported at its present
// velocity as the tracker's filter gives it). Two dovs_nodes take the same messages: /plain without the prediction,
// /predicted with models/people_predictor_tracks.dqnp. Their velocity spaces of the same obstacles message must
// differ once the person has a history (the predicted arc is not the present velocity), and agree on what the
// prediction does not touch (the window, the actions).
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <map>
#include <mutex>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/TrackedObstacleArray.h"
#include "fake_robot.h"

namespace {

class DovsPrediction : public ::testing::Test {
 protected:
  void SetUp() override {
    plain_sub_ = nh_.subscribe<dqn_dovs::Dovs>("plain/dovs", 50, [this](const dqn_dovs::Dovs::ConstPtr& m) {
      std::lock_guard<std::mutex> l(mutex_);
      plain_[m->header.stamp.toNSec()] = *m;
    });
    predicted_sub_ = nh_.subscribe<dqn_dovs::Dovs>("predicted/dovs", 50, [this](const dqn_dovs::Dovs::ConstPtr& m) {
      std::lock_guard<std::mutex> l(mutex_);
      predicted_[m->header.stamp.toNSec()] = *m;
    });
    obstacles_pub_ = nh_.advertise<dqn_dovs::TrackedObstacleArray>("obstacles", 5);
    odom_pub_ = nh_.advertise<nav_msgs::Odometry>("odom", 5);
  }

  /// One scan period at time t (s from the start): tf, odom, and the person's track.
  void publish(const ros::Time& now, double t) {
    dqn_dovs::test::publishStandingRobot(tf_, odom_pub_, now);
    ros::WallDuration(0.02).sleep();
    // Walking at 1 m/s on a left turn of 0.6 rad/s, starting 1.2 m ahead and 1.6 m to the right, heading left.
    const double w = 0.6, speed = 1.0, heading0 = 1.2, heading = heading0 + w * t;
    dqn_dovs::ObstacleTrack p;
    p.id = 17;
    p.center.x = 1.2 + speed / w * (std::sin(heading) - std::sin(heading0));
    p.center.y = -1.6 - speed / w * (std::cos(heading) - std::cos(heading0));
    p.radius = 0.3;
    p.heading = heading;
    p.speed = speed;
    p.turn_rate = 0.0;  // the filter has not seen the turn yet: the present velocity is a straight line
    p.age = t;
    p.hits = static_cast<uint32_t>(t * 10.0) + 1;
    dqn_dovs::TrackedObstacleArray a;
    a.header.stamp = now;
    a.header.frame_id = "odom";
    a.obstacles.push_back(p);
    obstacles_pub_.publish(a);
  }

  ros::NodeHandle nh_;
  ros::Subscriber plain_sub_, predicted_sub_;
  ros::Publisher obstacles_pub_, odom_pub_;
  tf2_ros::TransformBroadcaster tf_;
  std::mutex mutex_;
  std::map<uint64_t, dqn_dovs::Dovs> plain_, predicted_;
};

TEST_F(DovsPrediction, APredictedTurnReachesTheVelocitySpace) {
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Wait for both nodes to listen.
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  while (ros::ok() && (obstacles_pub_.getNumSubscribers() < 2 || odom_pub_.getNumSubscribers() < 2) &&
         ros::WallTime::now() < deadline) {
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_EQ(obstacles_pub_.getNumSubscribers(), 2u) << "both dovs_nodes subscribe to /obstacles";
  const ros::Time start = ros::Time::now();
  for (int k = 0; k < 20 && ros::ok(); ++k) {
    publish(start + ros::Duration(0.1 * k), 0.1 * k);
    ros::WallDuration(0.08).sleep();
  }
  ros::WallDuration(0.5).sleep();
  spinner.stop();
  std::lock_guard<std::mutex> l(mutex_);
  int both = 0, differing = 0;
  for (const auto& [stamp, plain] : plain_) {
    const auto it = predicted_.find(stamp);
    if (it == predicted_.end()) continue;
    const dqn_dovs::Dovs& predicted = it->second;
    ++both;
    ASSERT_EQ(plain.state.size(), predicted.state.size());
    EXPECT_EQ(plain.action_v, predicted.action_v) << "the window does not depend on the prediction";
    EXPECT_EQ(plain.action_w, predicted.action_w);
    if (plain.interval_lo != predicted.interval_lo || plain.interval_hi != predicted.interval_hi) ++differing;
  }
  ASSERT_GE(both, 10) << "velocity spaces of the same obstacles from both nodes";
  EXPECT_GE(differing, both / 2) << "the predicted turn changes the unsafe intervals (" << differing << " of " << both
                                 << ")";
}

}  // namespace

int main(int argc, char** argv) { return dqn_dovs::test::runRostestNode(argc, argv, "test_dovs_prediction"); }
