// Robot geometry read from the URDF (robot_description), so configuration cannot disagree with it.
#pragma once

#include <stdexcept>
#include <string>

#include "dqn_dovs/common/geometry.h"

namespace dqn_dovs {

class RobotDescriptionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct RobotGeometry {
  double radius_m = 0.0;  ///< radius of the first collision cylinder below base_frame (the footprint)
  Pose2 laser_mount;      ///< planar pose of laser_frame in base_frame
  double laser_height_m = 0.0;
};

/// Parses URDF XML with urdfdom. Throws RobotDescriptionError naming the link / joint and the reason
/// (unparsable XML, missing frames, no collision cylinder, laser not below base_frame).
RobotGeometry readRobotGeometry(const std::string& urdf_xml, const std::string& base_frame,
                                const std::string& laser_frame);

}  // namespace dqn_dovs
