// The shipped URDF and the robot configuration agree; bad descriptions give clear errors.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "robot_description.h"
#include "source_paths.h"

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(RobotDescription, ShippedUrdfGivesTheConfiguredRadiusAndLaserMount) {
  const std::string xml = readFile(std::string(DQN_DOVS_SOURCE_DIR) + "/urdf/turtlebot2.urdf");
  ASSERT_FALSE(xml.empty());
  const dqn_dovs::RobotGeometry g = dqn_dovs::readRobotGeometry(xml, "base_footprint", "laser");
  // config/robot.yaml: radius 0.2 m.
  const std::string yaml = readFile(std::string(DQN_DOVS_SOURCE_DIR) + "/config/robot.yaml");
  const auto pos = yaml.find("radius:");
  ASSERT_NE(pos, std::string::npos);
  const double configured = std::stod(yaml.substr(pos + 7));
  EXPECT_NEAR(g.radius_m, configured, 1e-9);
  EXPECT_NEAR(g.laser_mount.x, 0.0, 1e-9);
  EXPECT_NEAR(g.laser_mount.y, 0.0, 1e-9);
  EXPECT_NEAR(g.laser_mount.theta, 0.0, 1e-9);
  EXPECT_NEAR(g.laser_height_m, 0.0102 + 0.42, 1e-9);  // base_joint + laser_joint
}

TEST(RobotDescription, ComposesRotatedJoints) {
  const std::string xml = R"(<robot name="r">
    <link name="base_footprint"/>
    <joint name="j1" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
      <origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/></joint>
    <link name="base_link"><collision><geometry><cylinder radius="0.25" length="0.3"/></geometry></collision></link>
    <joint name="j2" type="fixed"><parent link="base_link"/><child link="laser"/>
      <origin xyz="0.2 0 0.3" rpy="0 0 0.5"/></joint>
    <link name="laser"/></robot>)";
  const dqn_dovs::RobotGeometry g = dqn_dovs::readRobotGeometry(xml, "base_footprint", "laser");
  EXPECT_NEAR(g.radius_m, 0.25, 1e-12);
  EXPECT_NEAR(g.laser_mount.x, 0.1, 1e-9);  // 0.2 along base_link's x, which points along +y
  EXPECT_NEAR(g.laser_mount.y, 0.2, 1e-9);
  EXPECT_NEAR(g.laser_mount.theta, 1.5707963267948966 + 0.5, 1e-9);
}

TEST(RobotDescription, ErrorsNameTheProblem) {
  auto message = [](const std::string& xml, const std::string& base, const std::string& laser) {
    try {
      dqn_dovs::readRobotGeometry(xml, base, laser);
    } catch (const dqn_dovs::RobotDescriptionError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("", "a", "b").find("empty"), std::string::npos);
  EXPECT_NE(message("<robot", "a", "b").find("not valid URDF"), std::string::npos);
  const std::string no_cyl = R"(<robot name="r"><link name="base_footprint"/>
    <joint name="j" type="fixed"><parent link="base_footprint"/><child link="laser"/></joint><link name="laser"/></robot>)";
  EXPECT_NE(message(no_cyl, "base_footprint", "laser").find("no collision cylinder"), std::string::npos);
  EXPECT_NE(message(no_cyl, "base_footprint", "lidar").find("no link 'lidar'"), std::string::npos);
}

}  // namespace
