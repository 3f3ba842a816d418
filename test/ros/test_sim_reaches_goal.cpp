// Node-level test: the shipped pipeline in simulation reaches the scenario's goal and holds there,
// and every cmd_vel respects the acceleration limits (with ~expect_publisher: the pipeline's topics are published
// by that node, e.g. the nodelet manager).
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cmath>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "dqn_dovs/Dovs.h"
#include "dqn_dovs/PlannerStatus.h"
#include "dqn_dovs/SimStatus.h"

namespace {

// The nodes that publish `topic`, from the master's system state.
std::set<std::string> publishersOf(const std::string& topic) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  std::set<std::string> out;
  if (!ros::master::execute("getSystemState", args, result, payload, true)) return out;
  XmlRpc::XmlRpcValue& publishers = payload[0];
  for (int i = 0; i < publishers.size(); ++i) {
    if (static_cast<std::string>(publishers[i][0]) != topic) continue;
    for (int j = 0; j < publishers[i][1].size(); ++j) out.insert(static_cast<std::string>(publishers[i][1][j]));
  }
  return out;
}

struct Watch {
  std::mutex mutex;
  dqn_dovs::SimStatus sim;
  dqn_dovs::PlannerStatus planner;
  bool have_sim = false, have_planner = false, reached = false;
  double reached_at = 0.0;
  int commands = 0;
  std::set<std::string> dovs_planners;          // the `planner` field of every Dovs message
  int planner_commands = 0;                     // Dovs messages carrying a finite command of that planner
  double max_dv_step = 0.0, max_dw_step = 0.0;  // largest change between consecutive commands
  geometry_msgs::Twist last_cmd;
  void onSim(const dqn_dovs::SimStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    sim = *m;
    have_sim = true;
  }
  void onPlanner(const dqn_dovs::PlannerStatus::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    planner = *m;
    have_planner = true;
    if (m->state == dqn_dovs::PlannerStatus::REACHED && !reached) {
      reached = true;
      reached_at = m->header.stamp.toSec();
    }
  }
  void onDovs(const dqn_dovs::Dovs::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    dovs_planners.insert(m->planner);
    planner_commands += std::isfinite(m->planner_v) && std::isfinite(m->planner_w) && !m->planner_note.empty();
  }
  void onCmd(const geometry_msgs::Twist::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex);
    if (commands > 0) {
      max_dv_step = std::max(max_dv_step, std::abs(m->linear.x - last_cmd.linear.x));
      max_dw_step = std::max(max_dw_step, std::abs(m->angular.z - last_cmd.angular.z));
    }
    last_cmd = *m;
    ++commands;
  }
};

TEST(SimLaunch, ReachesTheGoalAndStops) {
  ros::NodeHandle nh, pnh("~");
  const double limit = pnh.param("sim_time_limit", 100.0);
  Watch w;
  auto s1 = nh.subscribe("sim/status", 20, &Watch::onSim, &w);
  auto s2 = nh.subscribe("planner/status", 20, &Watch::onPlanner, &w);
  auto s3 = nh.subscribe("cmd_vel", 100, &Watch::onCmd, &w);
  // Only with expect_planner: a subscriber off the nodelet manager makes dovs_node serialise every Dovs message.
  const std::string planner = pnh.param<std::string>("expect_planner", "");
  ros::Subscriber s4;
  if (!planner.empty()) s4 = nh.subscribe("dovs", 20, &Watch::onDovs, &w);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(ros::Time::waitForValid(ros::WallDuration(30.0))) << "no /clock";
  const ros::WallTime wall_deadline = ros::WallTime::now() + ros::WallDuration(140.0);
  bool settled = false;
  while (ros::ok() && ros::WallTime::now() < wall_deadline) {
    {
      std::lock_guard<std::mutex> l(w.mutex);
      if (w.have_sim && (w.sim.collided || w.sim.episode_time > limit)) break;
      // Held on the goal for 2 s after reaching it.
      if (w.reached && ros::Time::now().toSec() - w.reached_at > 2.0) {
        settled = true;
        break;
      }
    }
    ros::WallDuration(0.05).sleep();
  }
  spinner.stop();
  // With expect_publisher (e.g. the nodelet manager), the pipeline's topics come from that node: the nodes
  // really run where the launch file says.
  const std::string expected = pnh.param<std::string>("expect_publisher", "");
  if (!expected.empty()) {
    for (const char* topic : {"/obstacles", "/dovs", "/cmd_vel"}) {
      const std::set<std::string> pubs = publishersOf(topic);
      EXPECT_EQ(pubs, std::set<std::string>{expected}) << topic;
    }
  }
  std::lock_guard<std::mutex> l(w.mutex);
  // With expect_planner (planner:=s_dovs, say), every velocity space was decided by that planner in dovs_node, and
  // planner_node drove on its commands.
  if (!planner.empty()) {
    EXPECT_EQ(w.dovs_planners, std::set<std::string>{planner});
    if (planner != "dqn_dovs") {
      EXPECT_GT(w.planner_commands, 20);
    }
  }
  ASSERT_TRUE(w.have_sim && w.have_planner) << "no status from simulator_node / planner_node";
  EXPECT_FALSE(w.sim.collided) << "collision at t = " << w.sim.episode_time;
  ASSERT_TRUE(settled) << "goal not reached: planner state " << int(w.planner.state) << " (" << w.planner.reason
                       << "), goal distance " << w.sim.goal_distance << " m at t = " << w.sim.episode_time;
  EXPECT_LT(w.sim.goal_distance, 0.15);
  EXPECT_LT(std::abs(w.sim.speed), 0.05) << "the robot must hold still on the goal";
  EXPECT_GT(w.commands, 100);
  // The ramp: each 50 Hz command moves by a * elapsed, elapsed capped at 0.1 s, so no command may jump by
  // more than a_v * 0.1 = 0.05 m/s or a_w * 0.1 = 0.2 rad/s (a dynamic-window jump is twice that).
  EXPECT_LE(w.max_dv_step, 0.05 + 1e-9);
  EXPECT_LE(w.max_dw_step, 0.2 + 1e-9);
  EXPECT_GT(w.max_dv_step, 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_reaches_goal");
  return RUN_ALL_TESTS();
}
