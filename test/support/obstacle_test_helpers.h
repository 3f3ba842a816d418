// A disc obstacle for tests of the DOVS, the action shield and the planners (core and ROS unit tests).
#pragma once

#include "dqn_dovs/common/types.h"

namespace dqn_dovs::test {

/// A 0.2 m disc at (x, y), moving at `speed` along `heading` (static when speed is 0).
inline MovingObstacle movingDisc(double x, double y, double heading = 0.0, double speed = 0.0) {
  MovingObstacle o;
  o.center = {x, y};
  o.radius = 0.2;
  o.heading = heading;
  o.speed = speed;
  o.is_static = speed == 0.0;
  return o;
}

}  // namespace dqn_dovs::test
