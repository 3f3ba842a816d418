// Node-level test of the move_base side of planner_node with dovs_node (shipped model and configs), the test
// node playing the robot (fake_robot.h), a localisation publishing map -> odom, and the base's safety sensors:
//   - a move_base action goal in `map` is reached in position and heading, and succeeds; a 0.3 m jump of
//     map -> odom while driving moves the goal with it (it is re-transformed every control period), never the
//     obstacles (they stay in odom);
//   - cancel through the action and a goal on move_base_simple/goal preempt the action goal; a goal in a frame
//     tf does not know is aborted with a text naming the frame;
//   - wheels that do not turn (stall) start a recovery round, and the goal is aborted saying so once the rounds
//     are used up;
//   - runtime tuning (dynamic_reconfigure): settings the supervisor refuses are put back as they were; accepted
//     ones act at once (no recovery round left: the first stall aborts);
//   - a bumper contact drops the command to zero at once (not along the deceleration ramp); a cliff aborts;
//   - with a map on `map`, a goal behind a wall is reached along a route around the wall's end: the robot never
//     crosses the wall, and the route the planner publishes is longer than the straight line; a panel the map does
//     not have, put on the route while the robot drives, is seen by the laser, and the route is planned again
//     around it (and never back through it), and the local goals lead round it.
#include <actionlib/client/simple_action_client.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/client.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <move_base_msgs/MoveBaseAction.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dqn_dovs/BaseSafety.h"
#include "dqn_dovs/PlannerConfig.h"
#include "dqn_dovs/PlannerRouteConfig.h"
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
    FakeRobotOptions options;  // full-turn scans: the route's blocked check sees what setWalls puts there
    options.publish_obstacles = true;
    h_ = new RobotHarness(options);
    localisation_ = new Localisation();
    safety_pub_ = new ros::Publisher(h_->nh.advertise<BaseSafety>("base_safety", 10, true));
    client_ = new Client(h_->nh, "move_base", false);
    diagnostics_ = new TopicLog<diagnostic_msgs::DiagnosticArray>(h_->nh, "/diagnostics", 20, 5);
    // dovs_node takes the planner's local goal here, so the simple goal has one subscriber: the planner.
    ASSERT_TRUE(h_->waitUntilReadyFor(1, 1, 30.0));
    ASSERT_TRUE(client_->waitForServer(ros::Duration(30.0))) << "no move_base action server";
    h_->robot.start();
  }
  static void TearDownTestSuite() {
    h_->stop();
    delete client_;
    delete diagnostics_;
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

  /// A map `cells` x `cells` of 0.1 m cells aligned with the robot, the robot at `at` in it (grid metres), free but
  /// for the cells `occupied` says; published latched on `map` in `map`. Returns the grid's pose in map.
  static dqn_dovs::Pose2 publishMapAroundRobot(ros::Publisher& pub, int cells, const dqn_dovs::Vec2& at,
                                               const std::function<bool(int, int)>& occupied) {
    const dqn_dovs::Pose2 r = robot().pose();
    const dqn_dovs::Vec2 off = localisation_->offset();
    const dqn_dovs::Pose2 robot_in_map{r.x + off.x(), r.y + off.y(), r.theta};
    const dqn_dovs::Vec2 corner = robot_in_map.toWorld(-at);
    const dqn_dovs::Pose2 origin{corner.x(), corner.y(), r.theta};
    nav_msgs::OccupancyGrid map;
    map.header.frame_id = "map";
    map.header.stamp = ros::Time::now();
    map.info.resolution = 0.1f;
    map.info.width = static_cast<uint32_t>(cells);
    map.info.height = static_cast<uint32_t>(cells);
    map.info.origin.position.x = origin.x;
    map.info.origin.position.y = origin.y;
    map.info.origin.orientation.z = std::sin(r.theta / 2.0);
    map.info.origin.orientation.w = std::cos(r.theta / 2.0);
    map.data.assign(static_cast<size_t>(cells * cells), 0);
    for (int j = 0; j < cells; ++j) {
      for (int i = 0; i < cells; ++i) map.data[static_cast<size_t>(j * cells + i)] = occupied(i, j) ? 100 : 0;
    }
    pub.publish(map);
    ros::WallDuration(1.0).sleep();  // the planner takes the map before the goal
    return origin;
  }

  /// An action goal at `p` (grid metres) of the grid at `origin` (map frame).
  static move_base_msgs::MoveBaseGoal goalInGrid(const dqn_dovs::Pose2& origin, const dqn_dovs::Vec2& p) {
    move_base_msgs::MoveBaseGoal goal;
    goal.target_pose.header.frame_id = "map";
    goal.target_pose.header.stamp = ros::Time::now();
    const dqn_dovs::Vec2 g = origin.toWorld(p);
    goal.target_pose.pose.position.x = g.x();
    goal.target_pose.pose.position.y = g.y();
    goal.target_pose.pose.orientation.w = 1.0;
    return goal;
  }

  static RobotHarness* h_;
  static Localisation* localisation_;
  static ros::Publisher* safety_pub_;
  static Client* client_;
  static TopicLog<diagnostic_msgs::DiagnosticArray>* diagnostics_;
};
RobotHarness* Navigation::h_ = nullptr;
Localisation* Navigation::localisation_ = nullptr;
ros::Publisher* Navigation::safety_pub_ = nullptr;
Client* Navigation::client_ = nullptr;
TopicLog<diagnostic_msgs::DiagnosticArray>* Navigation::diagnostics_ = nullptr;

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
  // The status topic may trail the action's result by a message: wait for it rather than read the last one at once.
  EXPECT_TRUE(waitFor([] { return h_->lastStatus().state == PlannerStatus::REACHED; }, 2.0))
      << "planner status " << static_cast<int>(h_->lastStatus().state) << ", expected REACHED";
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
  // /diagnostics says so too (1 Hz).
  EXPECT_TRUE(waitFor(
      [] {
        const diagnostic_msgs::DiagnosticArray a = diagnostics_->last();
        return !a.status.empty() && a.status[0].level == diagnostic_msgs::DiagnosticStatus::WARN &&
               a.status[0].message.find("stalled") != std::string::npos;
      },
      3.0))
      << "no WARN naming the stall on /diagnostics";
  ASSERT_TRUE(waitFor(finished, 15.0)) << "the goal was never given up; planner: " << h_->lastStatus().reason;
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getState().getText().find("stalled"), std::string::npos) << client_->getState().getText();
  EXPECT_EQ(h_->lastStatus().state, PlannerStatus::ABORTED);
  EXPECT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 3.0));
}

TEST_F(Navigation, ReconfigurationRefusesBadSettingsAndAppliesGoodOnesAtOnce) {
  dynamic_reconfigure::Client<dqn_dovs::PlannerConfig> reconfigure("/planner");
  dqn_dovs::PlannerConfig config;
  ASSERT_TRUE(reconfigure.getCurrentConfiguration(config, ros::Duration(5.0))) << "no configuration from the planner";
  EXPECT_DOUBLE_EQ(config.stall_time, 0.6) << "the server must start from the node's parameters";
  // A stall threshold above the command threshold is refused: the reply carries the settings in force.
  dqn_dovs::PlannerConfig bad = config;
  bad.stall_odom_speed = 0.5;
  ASSERT_TRUE(reconfigure.setConfiguration(bad));
  EXPECT_DOUBLE_EQ(bad.stall_odom_speed, config.stall_odom_speed);
  // No recovery round left: the first stall gives the goal up.
  dqn_dovs::PlannerConfig none = config;
  none.max_recovery_rounds = 0;
  ASSERT_TRUE(reconfigure.setConfiguration(none));
  EXPECT_EQ(none.max_recovery_rounds, 0);
  client_->sendGoal(goalAheadInMap(4.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.15, 20.0));
  robot().stuck = true;
  ASSERT_TRUE(waitFor(finished, 10.0)) << "the goal was never given up; planner: " << h_->lastStatus().reason;
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::ABORTED);
  EXPECT_NE(client_->getState().getText().find("gave up after 0 recovery rounds"), std::string::npos)
      << client_->getState().getText();
  ASSERT_TRUE(reconfigure.setConfiguration(config));  // as it was, for the tests after this one

  // The route's settings under the names of config/planner.yaml's route block (/planner/route/lookahead).
  dynamic_reconfigure::Client<dqn_dovs::PlannerRouteConfig> route("/planner/route");
  dqn_dovs::PlannerRouteConfig r;
  ASSERT_TRUE(route.getCurrentConfiguration(r, ros::Duration(5.0))) << "no route configuration from the planner";
  double loaded = 0.0;
  ASSERT_TRUE(ros::param::get("/planner/route/lookahead", loaded));
  EXPECT_DOUBLE_EQ(r.lookahead, loaded) << "the server must start from the node's parameters";
  dqn_dovs::PlannerRouteConfig shorter = r;
  shorter.lookahead = 2.5;
  ASSERT_TRUE(route.setConfiguration(shorter));
  EXPECT_DOUBLE_EQ(shorter.lookahead, 2.5);
  double now_in_force = 0.0;
  ASSERT_TRUE(ros::param::get("/planner/route/lookahead", now_in_force));
  EXPECT_DOUBLE_EQ(now_in_force, 2.5);
  ASSERT_TRUE(route.setConfiguration(r));
}

TEST_F(Navigation, BumperStopsAtOnceAndACliffAborts) {
  client_->sendGoal(goalAheadInMap(6.0, 0.0));
  ASSERT_TRUE(drivesFasterThan(0.3, 20.0));
  const size_t before = robot().commands().size();
  safety(true, false);
  ASSERT_TRUE(waitFor([] { return robot().lastCommand().v == 0.0; }, 10.0));
  // Zero within a few of the 50 Hz ramp's commands, not after v / a_v (>= 0.6 s: 30 or more) of braking. Counted in
  // commands, not seconds: a loaded machine sends fewer of them in a second, never more.
  const std::vector<Command> after = robot().commands();
  size_t moving = 0;
  for (size_t i = before; i < after.size() && after[i].v != 0.0; ++i) ++moving;
  EXPECT_LE(moving, 20u) << "commands still moving after the bumper press";
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

/// The length of a path message.
double pathLength(const nav_msgs::Path& path) {
  double length = 0.0;
  for (size_t k = 1; k < path.poses.size(); ++k) {
    length += std::hypot(path.poses[k].pose.position.x - path.poses[k - 1].pose.position.x,
                         path.poses[k].pose.position.y - path.poses[k - 1].pose.position.y);
  }
  return length;
}

TEST_F(Navigation, GoalBehindAWallIsReachedAlongARouteOnTheMap) {
  // A 10 x 10 m grid, the robot at (3, 5) in it, a wall 0.2 m thick across x = 4.5 from y = 0 to 6.5 (so the way
  // round is past its end, 1.5 m to the robot's left), the goal at (7, 5) behind it.
  const dqn_dovs::Vec2 off = localisation_->offset();
  ros::Publisher map_pub = h_->nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  TopicLog<nav_msgs::Path> routes(h_->nh, "planner/route", 5);
  const dqn_dovs::Pose2 grid_origin =
      publishMapAroundRobot(map_pub, 100, {3.0, 5.0}, [](int i, int j) { return j < 65 && (i == 44 || i == 45); });
  const move_base_msgs::MoveBaseGoal goal = goalInGrid(grid_origin, {7.0, 5.0});
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
  EXPECT_GT(pathLength(route), 4.5) << "the route must go round the wall (straight line 4 m)";
  EXPECT_EQ(route.header.frame_id, "map");
}

TEST_F(Navigation, APanelOnTheRouteIsSeenAndTheRouteIsPlannedAgainAroundIt) {
  // An empty 20 x 20 m map, the robot at (5, 10) in it, the goal 7 m ahead; once the robot drives, a 2 m panel
  // the map does not have appears across the way 4 m ahead of the start (the laser sees all of it).
  const dqn_dovs::Vec2 off = localisation_->offset();
  ros::Publisher map_pub = h_->nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  TopicLog<nav_msgs::Path> routes(h_->nh, "planner/route", 10);
  using Entry = TopicLog<nav_msgs::Path>::Entry;
  const dqn_dovs::Pose2 grid = publishMapAroundRobot(map_pub, 200, {5.0, 10.0}, [](int, int) { return false; });
  client_->sendGoal(goalInGrid(grid, {12.0, 10.0}));
  ASSERT_TRUE(drivesFasterThan(0.2, 20.0));
  auto odom = [&](double x, double y) { return dqn_dovs::Vec2(grid.toWorld({x, y}) - off); };
  const dqn_dovs::Segment panel{odom(9.0, 9.0), odom(9.0, 11.0)};
  robot().setWalls({panel});
  const double panel_from = wallNow();
  TopicLog<geometry_msgs::PoseStamped> local_goals(h_->nh, "planner/local_goal", 200);
  ASSERT_TRUE(waitFor(finished, 80.0)) << "no result; planner says: " << h_->lastStatus().reason;
  robot().setWalls({});
  EXPECT_EQ(client_->getState(), SimpleClientGoalState::SUCCEEDED) << client_->getState().getText();
  // The DOVS does not know the panel here (no tracker: the fake robot publishes the tracks), so where the robot
  // drives is the network's answer to its goal; what the planner must do is hand it the way round: a local goal
  // past one of the panel's ends.
  bool detour = false;
  for (const auto& e : local_goals.entries()) {
    const dqn_dovs::Vec2 g =
        grid.toLocal(dqn_dovs::Vec2(e.msg.pose.position.x + off.x(), e.msg.pose.position.y + off.y()));
    detour = detour || (e.wall > panel_from && (g.y() < 8.9 || g.y() > 11.1));
  }
  EXPECT_TRUE(detour) << "no local goal led round the panel";
  // The routes planned once the laser has seen the panel keep the robot's radius off it (the first, planned
  // before it stood there, goes through it), and none after leads back through it.
  auto clearance = [&](const nav_msgs::Path& path) {
    double c = 1e9;
    for (size_t i = 1; i < path.poses.size(); ++i) {
      const dqn_dovs::Vec2 a(path.poses[i - 1].pose.position.x - off.x(), path.poses[i - 1].pose.position.y - off.y());
      const dqn_dovs::Vec2 b(path.poses[i].pose.position.x - off.x(), path.poses[i].pose.position.y - off.y());
      for (double t = 0.0; t <= 1.0; t += 0.02) c = std::min(c, dqn_dovs::pointSegmentDistance(a + t * (b - a), panel));
    }
    return c;
  };
  const std::vector<Entry> all = routes.entries();
  size_t first_around = all.size();
  for (size_t k = 0; k < all.size() && first_around == all.size(); ++k) {
    if (all[k].wall > panel_from && clearance(all[k].msg) > 0.19) first_around = k;
  }
  ASSERT_LT(first_around, all.size()) << "no route was planned around the panel";
  for (size_t k = first_around; k < all.size(); ++k) {
    EXPECT_GT(clearance(all[k].msg), 0.19) << "route " << k << " leads back through the panel";
  }
}

}  // namespace

int main(int argc, char** argv) { return runRostestNode(argc, argv, "test_navigation"); }
