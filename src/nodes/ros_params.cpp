#include "ros_params.h"

#include <sstream>

namespace dqn_dovs {

double paramInRange(const ros::NodeHandle& pnh, const std::string& name, double fallback, double lo, double hi) {
  const double value = param<double>(pnh, name, fallback);
  if (value < lo || value > hi) {
    std::ostringstream os;
    os << "parameter '" << pnh.resolveName(name) << "' = " << value << " is outside [" << lo << ", " << hi << "]";
    throw ParameterError(os.str());
  }
  return value;
}

RobotLimits loadRobotLimits(const ros::NodeHandle& pnh) {
  RobotLimits limits;
  limits.v_max = param<double>(pnh, "robot/v_max", limits.v_max);
  limits.w_max = param<double>(pnh, "robot/w_max", limits.w_max);
  limits.a_v = param<double>(pnh, "robot/a_v", limits.a_v);
  limits.a_w = param<double>(pnh, "robot/a_w", limits.a_w);
  limits.dt = param<double>(pnh, "robot/dt", limits.dt);
  limits.radius = param<double>(pnh, "robot/radius", limits.radius);
  const std::string error = limits.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("robot") + ": " + error);
  return limits;
}

}  // namespace dqn_dovs

#include "robot_description.h"

namespace dqn_dovs {

bool checkRobotDescription(const ros::NodeHandle& nh, const RobotLimits& limits, const std::string& base_frame,
                           const std::string& laser_frame) {
  std::string xml;
  if (!nh.getParam("robot_description", xml)) return false;
  RobotGeometry g;
  try {
    g = readRobotGeometry(xml, base_frame, laser_frame);
  } catch (const RobotDescriptionError& e) {
    throw ParameterError(std::string("robot_description: ") + e.what());
  }
  if (std::abs(g.radius_m - limits.radius) > 1e-3) {
    std::ostringstream os;
    os << "robot radius " << limits.radius << " m (robot/radius) disagrees with the robot description's footprint "
       << g.radius_m << " m";
    throw ParameterError(os.str());
  }
  return true;
}

StaticSafetyConfig loadStaticSafetyConfig(const ros::NodeHandle& pnh) {
  StaticSafetyConfig c;
  c.enabled = param<bool>(pnh, "static_safety/enabled", c.enabled);
  c.latency_s = param<double>(pnh, "static_safety/latency", c.latency_s);
  c.braking_fraction = param<double>(pnh, "static_safety/braking_fraction", c.braking_fraction);
  c.margin_m = param<double>(pnh, "static_safety/margin", c.margin_m);
  c.step_s = param<double>(pnh, "static_safety/step", c.step_s);
  c.static_speed_mps = param<double>(pnh, "static_safety/static_speed", c.static_speed_mps);
  const std::string error = c.validate();
  if (!error.empty()) throw ParameterError(pnh.resolveName("static_safety") + ": " + error);
  return c;
}

}  // namespace dqn_dovs
