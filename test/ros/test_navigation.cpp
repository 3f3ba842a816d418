// Node-level test of the move_base side of planner_node with dovs_node (shipped model and configs), the test
// node playing the robot (fake_robot.h), a localisation publishing map -> odom, and the base's safety sensors:
//   - a move_base action goal in `map` is reached in position and heading, and succeeds; a 0.3 m jump of
//     map -> odom while driving moves the goal with it (it is re-transformed every control period), never the
//     obstacles (they stay in odom);
//   - cancel through the action and a goal on move_base_simple/goal preempt the action goal; a goal in a frame
//     tf does not know is aborted with a text naming the frame;
//   - wheels that do not turn (stall) start a recovery round, and the goal is aborted saying so once the rounds
//     are used up;
//   - a bumper contact drops the command to zero at once (not along the deceleration ramp); a cliff aborts;
//   - with a map on `map`, a goal behind a wall is reached along a route around the wall's end: the robot never
//     crosses the wall, and the route the planner publishes is longer than the straight line.
#include <actionlib/client/simple_action_client.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "dqn_dovs/BaseSafety.h"
#include "dqn_dovs/PlannerStatus.h"
#include "fake_robot.h"

namespace {

using dqn_dovs::BaseSafety;
using dqn_dovs::PlannerStatus;
using namespace dqn_dovs::test;
using Client = actionlib::SimpleActionClient<move_base_msgs::MoveBaseAction>;
using actionlib::SimpleClientGoalState;

/// map -> odom at 20 Hz, as a localisation would publish it; the offset can be changed while running.
class Localisation {
 public:
  Localisation() : thread_([this] { loop(); }) {}
  ~Localisation() {
    running_ = false;
    thread_.join();
  }
  void set(double x, double y) {
    std::lock_guard<std::mutex> l(mutex_);
    x_ = x;
    y_ = y;
  }
  dqn_dovs::Vec2 offset() {
    std::lock_guard<std::mutex> l(mutex_);
    return {x_, y_};
  }

 private:
  void loop() {
    ros::WallRate rate(20.0);
    while (running_ && ros::ok()) {
      geometry_msgs::TransformStamped t;
      t.header.stamp = ros::Time::now();
      t.header.frame_id = "map";
      t.child_frame_id = "odom";
      {
        std::lock_guard<std::mutex> l(mutex_);
        t.transform.translation.x = x_;
        t.transform.translation.y = y_;
      }
      t.transform.rotation.w = 1.0;
      tf_.sendTransform(t);
      rate.sleep();
    }
  }
  tf2_ros::TransformBroadcaster tf_;
  std::mutex mutex_;
  double x_ = 1.0, y_ = -0.5;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

class Navigation : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    FakeRobotOptions options;
    options.scan = narrowScan();
    options.publish_obstacles = true;
    h_ = new RobotHarness(options);
    localisation_ = new Localisation();
    safety_pub_ = new ros::Publisher(h_->nh.advertise<BaseSafety>("base_safety", 10, true));
    client_ = new Client(h_->nh, "move_base", false);
    // dovs_node takes the planner's local goal here, so the simple goal has one subscriber: the planner.
    ASSERT_TRUE(h_->waitUntilReadyFor(1, 1, 30.0));
    ASSERT_TRUE(client_->waitForServer(ros::Duration(30.0))) << "no move_base action server";
    h_->robot.start();
  }
  static void TearDownTestSuite() {
    h_->stop();
    delete client_;
    delete safety_pub_;
    delete localisation_;
    delete h_;
  }
  void TearDown() override {
    if (!finished()) {
      client_->cancelGoal();
      waitFor(finished, 5.0);
    }
    safety(false, false);
    h_->robot.stuck = false;
    waitFor([] { return h_->robot.lastCommand().v == 0.0 && h_->robot.lastCommand().w == 0.0; }, 5.0);
  }

  static FakeRobot& robot() { return h_->robot; }
  static void safety(bool bumper, bool cliff) {
    BaseSafety m;
    m.header.stamp = ros::Time::now();
    m.bumper = bumper;
    m.cliff = cliff;
    m.detail = bumper ? "front bumper" : (cliff ? "left cliff sensor" : "");
    safety_pub_->publish(m);
  }
  /// A goal `distance` ahead of the robot, in `map` (through the localisation's offset), heading `yaw`.
  static move_base_msgs::MoveBaseGoal goalAheadInMap(double distance, double yaw) {
    const dqn_dovs::Pose2 p = robot().pose();
    const dqn_dovs::Vec2 off = localisation_->offset();
    move_base_msgs::MoveBaseGoal g;
    g.target_pose.header.frame_id = "map";
    g.target_pose.header.stamp = ros::Time::now();
    g.target_pose.pose.position.x = p.x + distance * std::cos(p.theta) + off.x();
    g.target_pose.pose.position.y = p.y + distance * std::sin(p.theta) + off.y();
    g.target_pose.pose.orientation.z = std::sin(yaw / 2.0);
    g.target_pose.pose.orientation.w = std::cos(yaw / 2.0);
    return g;
  }
  static bool finished() { return client_->getState().isDone(); }
  /// Waits until the robot is commanded faster than `v`; the planner's last state and reason otherwise.
  static ::testing::AssertionResult drivesFasterThan(double v, double timeout_s) {
    if (waitFor([v] { return robot().lastCommand().v > v; }, timeout_s)) return ::testing::AssertionSuccess();
    const PlannerStatus s = h_->lastStatus();
    return ::testing::AssertionFailure() << "the robot does not drive faster than " << v << " m/s: planner state "
                                         << int(s.state) << " (" << s.reason << "), last v " << robot().lastCommand().v;
  }

  static RobotHarness* h_;
  static Localisation* localisation_;
  static ros::Publisher* safety_pub_;
  static Client* client_;
};
RobotHarness* Navigation::h_ = nullptr;
Localisation* Navigation::localisation_ = nullptr;
ros::Publisher* Navigation::safety_pub_ = nullptr;
Client* Navigation::client_ = nullptr;

TEST_F(Navigation, MapGoalIsReachedInPositionAndHeadingAndFollowsALocalisationJump) {
  const move_base_msgs::MoveBaseGoal goal = goalAheadInMap(2.0, 1.2);
  client_->sendGoal(goal);
  ASSERT_TRUE(drivesFasterThan(0.2, 20.0));
  // Localisation corrects map -> odom by 0.3 m sideways: the goal, fixed in map, moves 0.3 m in odom.
  localisation_->set(1.0, -0.8);
  ASSERT_TRUE(waitFor(finished, 60.0)) << "no result; planner says: " << h_->lastStatus().reason;
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::SUCCEEDED) << client_->getState().getText();
  const dqn_dovs::Pose2 p = robot().pose();
  const double gx = goal.target_pose.pose.position.x - 1.0, gy = goal.target_pose.pose.position.y + 0.8;
  EXPECT_LT(std::hypot(p.x - gx, p.y - gy), 0.2)
      << "robot at (" << p.x << ", " << p.y << ") in odom, goal at (" << gx << ", " << gy << ") after the correction";
  EXPECT_LT(std::abs(dqn_dovs::normalizeAngle(p.theta - 1.2)), 0.2) << "heading " << p.theta << ", goal 1.2";
  EXPECT_EQ(h_->lastStatus().state, PlannerStatus::REACHED);
  EXPECT_EQ(h_->lastStatus().goal_frame, "map");
  localisation_->set(1.0, -0.5);
}

TEST_F(Navigation, CancelAndASimpleGoalPreemptTheActionGoal) {
  client_->sendGoal(goalAheadInMap(4.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.2, 20.0));
  client_->cancelGoal();
  ASSERT_TRUE(waitFor(finished, 5.0));
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::PREEMPTED);
  EXPECT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 5.0)) << "cancel must stop the robot";

  client_->sendGoal(goalAheadInMap(4.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.2, 20.0));
  h_->goal_pub.publish(h_->goalAhead(3.0));
  ASSERT_TRUE(waitFor(finished, 5.0));
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::PREEMPTED);
  EXPECT_NE(client_->getState().getText().find("move_base_simple/goal"), std::string::npos)
      << client_->getState().getText();
  EXPECT_TRUE(waitFor([] { return h_->lastStatus().state == PlannerStatus::ACTIVE; }, 3.0))
      << "the simple goal must be pursued";
}

TEST_F(Navigation, GoalInAnUnknownFrameIsAbortedNamingIt) {
  move_base_msgs::MoveBaseGoal goal = goalAheadInMap(2.0, 0.0);
  goal.target_pose.header.frame_id = "no_such_frame";
  client_->sendGoal(goal);
  ASSERT_TRUE(waitFor(finished, 5.0));
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getState().getText().find("no_such_frame"), std::string::npos) << client_->getState().getText();
}

TEST_F(Navigation, StalledWheelsStartARecoveryRoundThenTheGoalIsAborted) {
  client_->sendGoal(goalAheadInMap(4.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.15, 20.0));
  robot().stuck = true;
  ASSERT_TRUE(waitFor([] { return !h_->lastStatus().recovery.empty(); }, 5.0)) << "no recovery after the stall";
  EXPECT_NE(h_->lastStatus().last_trigger.find("stalled"), std::string::npos) << h_->lastStatus().last_trigger;
  ASSERT_TRUE(waitFor(finished, 15.0)) << "the goal was never given up; planner: " << h_->lastStatus().reason;
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getState().getText().find("stalled"), std::string::npos) << client_->getState().getText();
  EXPECT_EQ(h_->lastStatus().state, PlannerStatus::ABORTED);
  EXPECT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 3.0));
}

TEST_F(Navigation, BumperStopsAtOnceAndACliffAborts) {
  client_->sendGoal(goalAheadInMap(6.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.3, 20.0));
  const double pressed = wallNow();
  safety(true, false);
  ASSERT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 1.0));
  // Zero within a few ramp periods, not after v / a_v (>= 0.6 s) of braking.
  EXPECT_LT(robot().lastCommand().wall - pressed, 0.3);
  EXPECT_TRUE(waitFor([] { return h_->lastStatus().last_trigger.find("bumper") != std::string::npos; }, 2.0))
      << h_->lastStatus().last_trigger;
  EXPECT_FALSE(finished()) << "a bumper contact starts a recovery round, it does not end the goal";
  safety(false, false);
  ASSERT_TRUE(drivesFasterThan(0.1, 10.0));
  safety(false, true);
  ASSERT_TRUE(waitFor(finished, 3.0));
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getState().getText().find("cliff"), std::string::npos) << client_->getState().getText();
  EXPECT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 0.5));
}

TEST_F(Navigation, GoalBehindAWallIsReachedAlongARouteOnTheMap) {
  // A 10 x 10 m grid aligned with the robot, the robot at (3, 5) in it, a wall 0.2 m thick across x = 4.5 from
  // y = 0 to 6.5 (so the way round is past its end, 1.5 m to the robot's left), the goal at (7, 5) behind it.
  const dqn_dovs::Pose2 r = robot().pose();
  const dqn_dovs::Vec2 off = localisation_->offset();
  const dqn_dovs::Pose2 robot_in_map{r.x + off.x(), r.y + off.y(), r.theta};
  const dqn_dovs::Pose2 grid_origin{robot_in_map.toWorld({-3.0, -5.0}).x(), robot_in_map.toWorld({-3.0, -5.0}).y(),
                                    r.theta};
  nav_msgs::OccupancyGrid map;
  map.header.frame_id = "map";
  map.header.stamp = ros::Time::now();
  map.info.resolution = 0.1f;
  map.info.width = 100;
  map.info.height = 100;
  map.info.origin.position.x = grid_origin.x;
  map.info.origin.position.y = grid_origin.y;
  map.info.origin.orientation.z = std::sin(r.theta / 2.0);
  map.info.origin.orientation.w = std::cos(r.theta / 2.0);
  map.data.assign(100 * 100, 0);
  for (int j = 0; j < 65; ++j) {
    for (int i = 44; i < 46; ++i) map.data[static_cast<size_t>(j * 100 + i)] = 100;
  }
  ros::Publisher map_pub = h_->nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  TopicLog<nav_msgs::Path> routes(h_->nh, "planner/route", 5);
  map_pub.publish(map);
  ros::WallDuration(1.0).sleep();  // the planner takes the map before the goal

  move_base_msgs::MoveBaseGoal goal;
  goal.target_pose.header.frame_id = "map";
  goal.target_pose.header.stamp = ros::Time::now();
  const dqn_dovs::Vec2 goal_in_map = grid_origin.toWorld({7.0, 5.0});
  goal.target_pose.pose.position.x = goal_in_map.x();
  goal.target_pose.pose.position.y = goal_in_map.y();
  goal.target_pose.pose.orientation.w = 1.0;
  client_->sendGoal(goal);
  double closest_to_wall = 1e9;
  const double deadline = wallNow() + 80.0;
  while (!finished() && wallNow() < deadline) {
    const dqn_dovs::Pose2 p = robot().pose();
    const dqn_dovs::Vec2 in_grid = grid_origin.toLocal({p.x + off.x(), p.y + off.y()});
    const double dy = std::max(0.0, in_grid.y() - 6.5);
    closest_to_wall = std::min(closest_to_wall, std::hypot(std::max(0.0, std::abs(in_grid.x() - 4.5) - 0.1), dy));
    ros::WallDuration(0.02).sleep();
  }
  ASSERT_TRUE(finished()) << "no result; planner says: " << h_->lastStatus().reason;
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::SUCCEEDED) << client_->getState().getText();
  // The robot's radius is 0.2 m; the map's cells are 0.1 m.
  EXPECT_GT(closest_to_wall, 0.15) << "the robot crossed or brushed the wall (the fake robot goes through walls)";
  ASSERT_TRUE(routes.any()) << "no route published on planner/route";
  const nav_msgs::Path route = routes.entries().front().msg;
  double length = 0.0;
  for (size_t k = 1; k < route.poses.size(); ++k) {
    length += std::hypot(route.poses[k].pose.position.x - route.poses[k - 1].pose.position.x,
                         route.poses[k].pose.position.y - route.poses[k - 1].pose.position.y);
  }
  EXPECT_GT(length, 4.5) << "the route must go round the wall (straight line 4 m)";
  EXPECT_EQ(route.header.frame_id, "map");
}

}  // namespace

int main(int argc, char** argv) { return runRostestNode(argc, argv, "test_navigation"); }
