#include "robot_description.h"

#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <vector>

namespace dqn_dovs {

namespace {

/// Pose of `link` in `ancestor` (3-D translation, yaw), walking parent joints; false when not below it.
bool poseInAncestor(const urdf::ModelInterface& model, const std::string& link, const std::string& ancestor,
                    urdf::Pose& out) {
  urdf::Pose acc;  // identity
  std::string current = link;
  for (int guard = 0; guard < 256 && current != ancestor; ++guard) {
    urdf::LinkConstSharedPtr l = model.getLink(current);
    if (!l || !l->parent_joint) return false;
    const urdf::Pose& j = l->parent_joint->parent_to_joint_origin_transform;
    urdf::Pose composed;
    composed.rotation = j.rotation * acc.rotation;
    const urdf::Vector3 rotated = j.rotation * acc.position;
    composed.position = urdf::Vector3(j.position.x + rotated.x, j.position.y + rotated.y, j.position.z + rotated.z);
    acc = composed;
    current = l->parent_joint->parent_link_name;
  }
  if (current != ancestor) return false;
  out = acc;
  return true;
}

}  // namespace

RobotGeometry readRobotGeometry(const std::string& urdf_xml, const std::string& base_frame,
                                const std::string& laser_frame) {
  if (urdf_xml.empty()) throw RobotDescriptionError("robot description is empty");
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model) throw RobotDescriptionError("robot description is not valid URDF XML");
  if (!model->getLink(base_frame)) throw RobotDescriptionError("robot description has no link '" + base_frame + "'");
  if (!model->getLink(laser_frame)) throw RobotDescriptionError("robot description has no link '" + laser_frame + "'");

  RobotGeometry g;
  // The footprint: the first collision cylinder at or below base_frame, breadth first.
  std::vector<urdf::LinkConstSharedPtr> frontier{model->getLink(base_frame)};
  while (!frontier.empty() && g.radius_m <= 0.0) {
    std::vector<urdf::LinkConstSharedPtr> next;
    for (const auto& l : frontier) {
      if (l->collision && l->collision->geometry && l->collision->geometry->type == urdf::Geometry::CYLINDER) {
        g.radius_m = std::static_pointer_cast<const urdf::Cylinder>(l->collision->geometry)->radius;
        break;
      }
      for (const auto& c : l->child_links) next.push_back(c);
    }
    frontier.swap(next);
  }
  if (!(g.radius_m > 0.0)) {
    throw RobotDescriptionError("robot description has no collision cylinder at or below '" + base_frame +
                                "' to take the robot radius from");
  }
  urdf::Pose laser;
  if (!poseInAncestor(*model, laser_frame, base_frame, laser)) {
    throw RobotDescriptionError("link '" + laser_frame + "' is not below '" + base_frame +
                                "' in the robot description");
  }
  double roll, pitch, yaw;
  laser.rotation.getRPY(roll, pitch, yaw);
  if (std::abs(roll) > 1e-3 && std::abs(std::abs(roll) - kPi) > 1e-3) {
    throw RobotDescriptionError("link '" + laser_frame + "' is rolled: the LIDAR must scan in the ground plane");
  }
  g.laser_mount = {laser.position.x, laser.position.y, yaw};
  g.laser_height_m = laser.position.z;
  return g;
}

}  // namespace dqn_dovs
