// Parameter loading shared by the nodes: one place that reads, checks and reports.
#pragma once

#include <ros/ros.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "dqn_dovs/common/robot_model.h"
#include "dqn_dovs/dovs/dovs.h"
#include "dqn_dovs/policy/action_shield.h"
#include "dqn_dovs/policy/static_safety.h"

namespace dqn_dovs {

/// Thrown when a node's parameter is missing a valid value; the message names the parameter and the reason.
class ParameterError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Notes `name` (relative to `pnh`) as a parameter the node reads. Every reader below notes what it reads, so that
/// refuseUnknownParameters can tell a misspelt key from a real one.
void noteParameter(const ros::NodeHandle& pnh, const std::string& name);

/// Throws ParameterError naming every parameter set under `pnh`'s namespace that the node has not read (noted by
/// noteParameter) - a misspelt or unknown key that would otherwise be silently ignored - with the nearest name the
/// node reads. `also_known` names parameters the node owns but reads only later or elsewhere (relative names; a name
/// ending in '/' stands for every parameter under it). Nodes call it once their parameters are read.
void refuseUnknownParameters(const ros::NodeHandle& pnh, const std::vector<std::string>& also_known = {});

/// Reads `name` from the private handle, falling back to `fallback`; numbers must be finite.
template <typename T>
T param(const ros::NodeHandle& pnh, const std::string& name, const T& fallback) {
  noteParameter(pnh, name);
  T value = fallback;
  if (pnh.hasParam(name) && !pnh.getParam(name, value)) {
    throw ParameterError("parameter '" + pnh.resolveName(name) + "' has the wrong type");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) throw ParameterError("parameter '" + pnh.resolveName(name) + "' is not finite");
  }
  return value;
}

/// A parameter's value as text, for the name-driven setters of the core (setShieldParameter, setTrackerParameter);
/// false when it is not set. A list or map is a ParameterError naming it.
bool paramText(const ros::NodeHandle& pnh, const std::string& name, std::string& out);

/// Reads a number and checks lo <= value <= hi.
double paramInRange(const ros::NodeHandle& pnh, const std::string& name, double fallback, double lo, double hi);

/// Reads the robot limits from `robot/*` (config/robot.yaml) and validates them.
RobotLimits loadRobotLimits(const ros::NodeHandle& pnh);

/// Reads the static braking rule from `static_safety/*` (config/static_safety.yaml, loaded by dovs_node and
/// planner_node) and validates it.
StaticSafetyConfig loadStaticSafetyConfig(const ros::NodeHandle& pnh);

/// Reads `dovs/*` parameters (config/dovs.yaml, loaded by dovs_node and planner_node) over the defaults and
/// validates them.
DovsConfig loadDovsConfig(const ros::NodeHandle& pnh);

/// Reads every action shield parameter (shieldParameterNames(): `action_shield/*` of config/dovs.yaml and
/// `static_safety/*` of config/static_safety.yaml) over the defaults and validates them.
ActionShieldConfig loadActionShieldConfig(const ros::NodeHandle& pnh);

}  // namespace dqn_dovs

#include <optional>

#include "robot_description.h"

namespace dqn_dovs {
/// What differs between the configured robot radius and the robot description's footprint ("" when they agree
/// within 1 mm), and what to change.
std::string robotRadiusMismatch(double configured_m, double described_m);
/// The robot geometry of `robot_description` when it is on the parameter server, std::nullopt when there is
/// none. Throws ParameterError when the description cannot be read or its footprint is larger than limits.radius
/// (running would plan for a smaller robot than the real one); a smaller footprint is a warning saying what to
/// change.
std::optional<RobotGeometry> loadRobotDescription(const ros::NodeHandle& nh, const RobotLimits& limits,
                                                  const std::string& base_frame, const std::string& laser_frame);
/// When `robot_description` is on the parameter server, checks its footprint against limits.radius as
/// loadRobotDescription does. Returns false when there is none.
bool checkRobotDescription(const ros::NodeHandle& nh, const RobotLimits& limits, const std::string& base_frame,
                           const std::string& laser_frame);
}  // namespace dqn_dovs
